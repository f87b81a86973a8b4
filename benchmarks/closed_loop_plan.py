"""The user's path, closed in the loop: ``tognet.plan`` on a depth image from a camera unlike the simulator's,
carried out in the simulator, against the evaluation's planner of the same method on the same scenes
(issues 23 and 30).

    .venv/bin/python benchmarks/closed_loop_plan.py [--method TOG-Net+ActionSearch] [--tasks all]
                        [--scenes 150] [--workers 2] [--out /tmp/tognet-closed-loop] [--no-stages]

``--method``: any method a robot can run, with the shipped models (default the action search, what
``tognet plan`` runs by default); the user path and the evaluation run the same one. Besides success it
records each user plan's own score and whether it warned of low confidence, and prints the share of
successes and of failures that warned (the threshold: ``tognet/models/confidence.json``).

The scenes are the evaluation's own (``tognet evaluate``'s default settings): per task, ``--scenes / 3`` per
category (PG-Primitive, PG-Complex, Realistic), the test objects and scene seeds of the evaluation's first
jobs (:func:`tognet.evaluate.jobs.plan_eval_jobs`). On each scene:

1. **the evaluation's** planner of the method: plans on the simulator's observation (its overhead
   Kinect2-like camera, the ray caster of :mod:`tognet.sim.depth`, camera pose known) and is executed
   (trial seed 0).
2. **user**: a user's camera photographs the same settled scene: a RealSense D435, Azure Kinect (NFOV) or
   Kinect2's intrinsics, 0.5-1.0 m from a point within 4 cm of the tool's centre, tilted 0-30 degrees from
   straight down towards any side and rolled any way; MuJoCo's OpenGL renderer draws it
   (:class:`tognet.sim.glcamera.GLDepthCamera`: every visible geom, the task's props too, not the planner's
   or the simulator's ray caster); half the scenes get no return past the table's edge, every one a
   sensor's artefacts (:class:`tognet.sim.glcamera.SensorModel`: range noise growing with depth squared,
   0.5-2 mm at 1 m; random and silhouette dropouts; millimetre readings), and is handed over as a user's
   16-bit file holds it (integer millimetres, 0 = no reading). ``tognet.plan(image, intrinsics,
   task=...)``: no camera pose. The plan's table-frame grasp is put into the world with the camera's true
   pose, its action (task frame) kept as planned, and executed with the same trial seed.
3. **stages** (unless ``--no-stages``), each on the same scene, to tell which stage loses what: *pose* (the
   same image, the true camera pose given: no table fit), *clean* (the same camera without the sensor's
   artefacts, floor seen, no pose), *simcam* (the simulator's own image through ``tognet.plan``, no pose:
   the user pipeline without the camera change) and *simcam+pose*.

Per user-path plan it also records whether the object planned on is the tool (MuJoCo's geom ids at the
pixels) and the grasp pixel lies on it, and the fitted table's error. Writes OUT/records.jsonl (resumable:
scenes already there are skipped) and prints per task the rates, the paired difference to TOG-Net with its
95 % interval (Newcombe), and the stages.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

SENSORS: dict[str, tuple[tuple[int, int, float, float, float, float], tuple[float, float]]] = {
    # name: ((width, height, fx, fy, cx, cy), (nearest, farthest) distance to the aimed point, m)
    "realsense_d435": ((640, 480, 615.0, 615.0, 320.3, 238.9), (0.6, 1.0)),
    "azure_kinect_nfov": ((640, 576, 504.0, 504.2, 322.6, 333.1), (0.5, 1.0)),
    "kinect2": ((512, 424, 365.0, 365.0, 255.5, 211.5), (0.5, 1.0)),
}
MAX_TILT = math.radians(30.0)
STAGES = ("pose", "clean", "simcam", "simcam+pose")


def user_camera(rng: np.random.Generator, aim_xy: np.ndarray) -> tuple[str, Any, dict[str, float]]:
    """A user's camera for one scene: (sensor name, Camera, its draw)."""
    from tognet.geometry import Camera, CameraIntrinsics

    name = list(SENSORS)[int(rng.integers(len(SENSORS)))]
    (w, h, fx, fy, cx, cy), (near, far) = SENSORS[name]
    k = CameraIntrinsics(width=w, height=h, fx=fx, fy=fy, cx=cx, cy=cy)
    target = np.array([*(aim_xy + rng.uniform(-0.04, 0.04, size=2)), 0.0])
    draw = {"distance": float(rng.uniform(near, far)), "tilt": float(rng.uniform(0.0, MAX_TILT)),
            "azimuth": float(rng.uniform(0.0, 2 * math.pi)), "roll": float(rng.uniform(-math.pi, math.pi))}
    return name, Camera.aimed_at(k, target, **draw), draw


def _world_grasp(plan: Any, world_from_camera: np.ndarray) -> np.ndarray:
    """The plan's table-frame grasp in the world, through the camera's true pose."""
    world_from_table = world_from_camera @ np.linalg.inv(plan.table_from_camera)
    g = plan.grasp.table
    p = world_from_table @ np.array([g[0], g[1], g[2], 1.0])
    axis = world_from_table[:3, :3] @ np.array([math.cos(g[3]), math.sin(g[3]), 0.0])
    return np.array([p[0], p[1], p[2], math.atan2(axis[1], axis[0]) % (2 * math.pi)])


def _execute(sim: Any, grasp: np.ndarray, action: np.ndarray, seed: int) -> dict[str, Any]:
    from tognet.geometry import Grasp

    try:
        r = sim.execute(Grasp.from_array(grasp), action, seed=seed)
    except ValueError:
        return {"valid": True, "grasp_success": False, "task_success": False, "failure": "unreachable"}
    return {"valid": bool(r.valid), "grasp_success": bool(r.grasp_success),
            "task_success": bool(r.task_success), "failure": r.failure.value}


def _user_trial(sim: Any, task: str, method: str, depth: np.ndarray, camera: Any, pose: np.ndarray | None,
                seed: int, tool: np.ndarray | None = None) -> dict[str, Any]:
    """``tognet.plan`` on ``depth`` (metres, NaN holes) handed over as integer millimetres, with the
    intrinsics (and ``pose`` if given), executed in ``sim``; with ``tool`` (the tool's pixels), whether
    the plan was made on the tool."""
    import tognet
    from tognet.errors import TognetError
    from tognet.planning.camera import intrinsics_dict
    from tognet.planning.table import plane_from_pose

    mm = np.where(np.isfinite(depth), np.rint(depth * 1000.0), 0).astype(np.uint16)
    t0 = time.perf_counter()
    try:
        plan = tognet.plan(mm, intrinsics_dict(camera.intrinsics), task=task, camera_pose=pose, method=method)
    except TognetError as exc:
        return {"planned": False, "error": str(exc), "valid": True, "grasp_success": False,
                "task_success": False, "failure": "no_plan", "plan_s": time.perf_counter() - t0}
    out: dict[str, Any] = {"planned": True, "plan_s": time.perf_counter() - t0, "q_t": plan.grasp.q_t,
                           "score": plan.grasp.score, "timing": plan.timing,
                           "low_confidence": any(w.startswith("low confidence") for w in plan.warnings),
                           "objects": len(plan.objects),
                           "qualifying": sum(o["qualifies"] for o in plan.objects),
                           "object": {k: plan.object[k] for k in ("index", "area_cm2", "height_m", "pixel",
                                                                  "touches_image_border", "why")},
                           "warnings": plan.warnings}
    truth = plane_from_pose(camera.pose)
    out["table_tilt_error_deg"] = math.degrees(math.acos(min(1.0, float(plan.plane.normal @ truth.normal))))
    out["table_offset_error_m"] = float(plan.plane.offset - truth.offset)
    if tool is not None:  # the grasp centre's pixel within 3 pixels of the tool's
        u, v = np.rint(plan.grasp.pixel).astype(int)
        k = camera.intrinsics
        win = tool[max(0, v - 3):min(k.height, v + 4), max(0, u - 3):min(k.width, u + 4)]
        out["grasp_on_tool"] = bool(win.any())
    grasp = _world_grasp(plan, camera.pose)
    out.update(_execute(sim, grasp, plan.grasp.action, seed))
    out["grasp"] = [float(x) for x in grasp]
    out["action"] = [float(x) for x in plan.grasp.action]
    return out


def _shipped(kind: str, task: str) -> str:
    from tognet.models import default_checkpoint

    return str(default_checkpoint({"grasp": "grasping", "task": task, "search": f"{task}_search"}[kind]))


def run_job(job: Any, stages: bool, method: str) -> list[dict[str, Any]]:
    """Every scene of one evaluation job: the evaluation's planner of ``method``, the user path and
    (``stages``) the stage variants."""
    import torch

    torch.set_num_threads(1)
    from tognet.jobs.models import load_model
    from tognet.jobs.scenes import reset_scene
    from tognet.planning import NEEDS, PlanningError, make_planner
    from tognet.sim import Simulator
    from tognet.sim.glcamera import GLDepthCamera, SensorModel, no_return_below

    sim = Simulator(job.config.sim, job.task, job.obj)
    models = {f"{k}_model": load_model(_shipped(k, job.task)) for k in NEEDS[method]}
    tognet_planner = make_planner(method, sim.task, config=job.config.plan, **models)
    gl = GLDepthCamera(sim.model)
    tool_geom = sim.model.geom("object_visual").id
    records = []
    stats: Counter[str] = Counter()
    try:
        for s in range(job.scenes):
            scene_seed = job.scene_seed(s)
            obs = reset_scene(sim, scene_seed, stats)
            if obs is None:
                continue
            rec: dict[str, Any] = {"task": job.task, "category": job.category, "job": job.index, "scene": s,
                                   "object_id": job.obj.object_id, "scene_seed": scene_seed, "method": method}
            try:
                plan = tognet_planner(obs, np.random.default_rng(job.seed(s, 2)))
                rec["tognet"] = _execute(sim, plan.grasp, plan.action, job.config.trial_seed)
                rec["tognet"].update(score=plan.own.get("score"), plan_s=plan.timing["total"])
            except PlanningError:
                rec["tognet"] = {"valid": True, "grasp_success": False, "task_success": False,
                                 "failure": "no_grasp"}
            rng = np.random.default_rng([scene_seed, 23])
            sensor_name, camera, draw = user_camera(rng, sim.scene["object_com"][:2])
            no_return = bool(rng.random() < 0.5)
            sensor = SensorModel(range_noise=float(rng.uniform(0.0005, 0.002)),
                                 dropout=float(rng.uniform(0.0, 0.02)),
                                 edge_dropout=float(rng.uniform(0.2, 0.8)))
            clean = gl.render(sim.data, camera)
            tool = gl.geom_ids(sim.data, camera) == tool_geom
            image = no_return_below(clean, camera) if no_return else clean
            image = sensor.apply(image, rng)
            rec.update(sensor=sensor_name, no_return_past_table=no_return, range_noise=sensor.range_noise,
                       holes=float(np.isnan(image).mean()), tool_pixels=int(tool.sum()),
                       tool_cut_by_border=bool(tool[0].any() or tool[-1].any() or tool[:, 0].any()
                                               or tool[:, -1].any()),
                       **{k: round(v, 4) for k, v in draw.items()})
            seed = job.config.trial_seed
            rec["user"] = _user_trial(sim, job.task, method, image, camera, None, seed, tool)
            if stages:
                rec["pose"] = _user_trial(sim, job.task, method, image, camera, camera.pose, seed, tool)
                rec["clean"] = _user_trial(sim, job.task, method, clean, camera, None, seed, tool)
                rec["simcam"] = _user_trial(sim, job.task, method, obs.depth, obs.camera, None, seed)
                rec["simcam+pose"] = _user_trial(sim, job.task, method, obs.depth, obs.camera,
                                                 obs.camera.pose, seed)
            records.append(rec)
    finally:
        gl.close()
    return records


def _jobs(tasks: list[str], scenes: int, work: Path, method: str) -> list[Any]:
    from tognet.evaluate.config import CATEGORIES, EvalConfig
    from tognet.evaluate.harness import test_objects
    from tognet.evaluate.jobs import plan_eval_jobs

    config = EvalConfig()
    per_cat = -(-scenes // len(CATEGORIES))
    n_objects = -(-per_cat // config.scenes_per_job)
    jobs = []
    for cat in CATEGORIES:
        objects = test_objects(cat, n_objects, work, progress=False, log=lambda s: print(s, flush=True))
        for task in tasks:
            jobs += plan_eval_jobs(task, cat, objects, per_cat, (method,), config)
    return jobs


def _rate(records: list[dict[str, Any]], key: str) -> tuple[int, int]:
    valid = [r for r in records if r[key]["valid"] and r["tognet"]["valid"]]
    return sum(r[key]["task_success"] for r in valid), len(valid)


def _warned(rs: list[dict[str, Any]], task: str, method: str) -> str:
    """'w / n, w / n': user plans that warn of low confidence among the successes and the failures, by the
    plans' scores against today's calibrated threshold (tognet/models/confidence.json; what the plan said
    when it ran is in its record too)."""
    from tognet.planning import NEEDS
    from tognet.planning.confidence import threshold

    entry = threshold(task, method, {k: _shipped(k, task) for k in NEEDS[method]})
    limit = None if entry is None else entry.get("warn_below")

    def warns(r: dict[str, Any]) -> bool:
        return limit == "always" or (limit is not None and r["user"]["score"] < float(limit))

    planned = [r for r in rs if r["user"]["planned"]]
    wins = [r for r in planned if r["user"]["task_success"]]
    losses = [r for r in planned if not r["user"]["task_success"]]
    return (f"{sum(map(warns, wins))} / {len(wins)}, {sum(map(warns, losses))} / {len(losses)}"
            + (" (no threshold)" if entry is None else ""))


def summarise(records: list[dict[str, Any]], tasks: list[str]) -> str:
    """The markdown table per task and the stage diagnostics."""
    from tognet.evaluate.stats import paired_difference, wilson

    method = records[0].get("method", "TOG-Net") if records else "TOG-Net"
    lines = [f"| task | scenes | {method}, evaluation (simulator's camera) | tognet.plan, image + intrinsics "
             "only | difference [95 %] | no plan | planned on the tool | warned: successes / failures | "
             + " | ".join(f"{s}" for s in STAGES) + " |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | " + " | ".join("---" for _ in STAGES) + " |"]
    notes = []
    for task in tasks:
        rs = [r for r in records if r["task"] == task and r["tognet"]["valid"] and r["user"]["valid"]]
        if not rs:
            continue
        t = np.array([r["tognet"]["task_success"] for r in rs])
        u = np.array([r["user"]["task_success"] for r in rs])
        d = paired_difference(u, t)
        lo, hi = wilson(int(u.sum()), len(u))
        no_plan = sum(not r["user"]["planned"] for r in rs)
        on_tool = sum(r["user"].get("grasp_on_tool", False) for r in rs if r["user"]["planned"])
        planned = len(rs) - no_plan
        warned = _warned(rs, task, method)
        cells = []
        for st in STAGES:
            have = [r for r in rs if st in r and r[st]["valid"]]
            if have:
                x = np.array([r[st]["task_success"] for r in have])
                y = np.array([r["tognet"]["task_success"] for r in have])
                dd = paired_difference(x, y)
                cells.append(f"{100 * x.mean():.1f} ({100 * dd['difference']:+.1f})")
            else:
                cells.append("-")
        lines.append(f"| {task} | {len(rs)} | {100 * t.mean():.1f} | {100 * u.mean():.1f} [{100 * lo:.1f}, "
                     f"{100 * hi:.1f}] | {100 * d['difference']:+.1f} [{100 * d['ci'][0]:+.1f}, "
                     f"{100 * d['ci'][1]:+.1f}] | {no_plan} | {on_tool} / {planned} | {warned} | "
                     + " | ".join(cells) + " |")
        errors = Counter(r["user"]["error"].split(":")[0] for r in rs if not r["user"]["planned"])
        fails = Counter(r["user"]["failure"] for r in rs if not r["user"]["task_success"])
        tfails = Counter(r["tognet"]["failure"] for r in rs if not r["tognet"]["task_success"])
        tilt = [r["user"]["table_tilt_error_deg"] for r in rs if r["user"]["planned"]]
        off = [abs(r["user"]["table_offset_error_m"]) for r in rs if r["user"]["planned"]]
        by = {}
        for key in ("sensor", "no_return_past_table"):
            for val in sorted({str(r[key]) for r in rs}):
                sub = [r for r in rs if str(r[key]) == val]
                by[f"{key}={val}"] = (f"{100 * np.mean([r['user']['task_success'] for r in sub]):.0f} vs "
                                      f"{100 * np.mean([r['tognet']['task_success'] for r in sub]):.0f} "
                                      f"(n {len(sub)})")
        tilt_hi = [r for r in rs if r["tilt"] > math.radians(20)]
        by["tilt>20deg"] = (f"{100 * np.mean([r['user']['task_success'] for r in tilt_hi]):.0f} vs "
                            f"{100 * np.mean([r['tognet']['task_success'] for r in tilt_hi]):.0f} "
                            f"(n {len(tilt_hi)})") if tilt_hi else "-"
        notes.append(f"- {task}: user failures {dict(fails)}; TOG-Net failures {dict(tfails)}; no plan "
                     f"{dict(errors)}; table fit: tilt error median {np.median(tilt):.3f} deg (max "
                     f"{np.max(tilt):.2f}), height error median {1000 * np.median(off):.2f} mm (max "
                     f"{1000 * np.max(off):.1f}); user vs TOG-Net by " + "; ".join(f"{k} {v}" for k, v in
                                                                                  by.items()))
    return "\n".join(lines + [""] + notes)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="TOG-Net+ActionSearch",
                    help="a method a robot can run (with the shipped models)")
    ap.add_argument("--tasks", default="all", help="comma-separated task names, or all")
    ap.add_argument("--scenes", type=int, default=150, help="scenes per task (a third per category)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("/tmp/tognet-closed-loop"))
    ap.add_argument("--no-stages", action="store_true", help="only TOG-Net and the user path")
    args = ap.parse_args()
    from tognet.cli.util import task_list

    tasks = task_list(args.tasks)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "records.jsonl"
    records = [json.loads(line) for line in path.read_text().splitlines()] if path.is_file() else []
    done = {(r["task"], r["category"], r["job"]) for r in records}
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, load average "
          f"{os.getloadavg()[0]:.2f}; {args.workers} workers", flush=True)
    jobs = [j for j in _jobs(tasks, args.scenes, args.out, args.method)
            if (j.task, j.category, j.index) not in done]
    print(f"{len(jobs)} jobs to run ({len(done)} done)", flush=True)
    t0 = time.perf_counter()
    with open(path, "a") as fh:
        if args.workers <= 1:
            for i, job in enumerate(jobs):
                for r in run_job(job, not args.no_stages, args.method):
                    fh.write(json.dumps(r) + "\n")
                fh.flush()
                print(f"{i + 1}/{len(jobs)} {time.perf_counter() - t0:.0f} s", flush=True)
        else:
            with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool:
                futures = [pool.submit(run_job, job, not args.no_stages, args.method) for job in jobs]
                for i, fut in enumerate(as_completed(futures)):
                    for r in fut.result():
                        fh.write(json.dumps(r) + "\n")
                    fh.flush()
                    if (i + 1) % 10 == 0 or i + 1 == len(jobs):
                        print(f"{i + 1}/{len(jobs)} jobs, {time.perf_counter() - t0:.0f} s", flush=True)
    records = [json.loads(line) for line in path.read_text().splitlines()]
    records = [r for r in records if r["task"] in tasks]
    print(f"{len(records)} scenes, {time.perf_counter() - t0:.0f} s this run, load average "
          f"{os.getloadavg()[0]:.2f}")
    print(summarise(records, tasks))


if __name__ == "__main__":
    main()
