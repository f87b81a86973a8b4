"""Plan time on a user's depth image, every method a robot can run on the same images, one sitting (issue 30):
the whole user path (files read, table, objects, candidates, the method's grasp, action, alternatives and
own scores), the models' loading excluded, one core and one torch thread.

    .venv/bin/python benchmarks/bench_plan.py [--tasks all] [--images 30] [--methods all] [--pose]
                                              [--user-camera] [--robot sawyer|panda] [--top 3]

The images: per task, ``--images`` settled scenes of the evaluation's unseen test objects (a third each
PG-Primitive, PG-Complex, Realistic; :func:`tognet.evaluate.harness.test_objects`), each photographed by
the simulator's camera and written as a 16-bit PNG with its intrinsics (and pose), planned without the
camera pose (the table plane fitted) unless ``--pose``. ``--user-camera``: the same scene seen by a
RealSense D435 (640 x 480) 0.8 m from the tool, tilted 28 degrees, no return past the table, 1.5 mm range
noise at 1 m, 1 % random and half the silhouette pixels lost. ``--robot``: planned for that arm at its
default base (camera pose and the scene's reference point given). Every method plans every image in turn
(interleaved: the machine's load moves them alike), the shipped models; prints per task and method the
median and p90 wall time per plan, the stages' medians, and the median over images of each plan's time
over TOG-Net's on the same image.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch


def _images(task: str, count: int, folder: Path, user_camera: bool) -> list[tuple[Path, Path, Path, Any]]:
    """``count`` scenes of ``task`` on test objects as files (depth PNG, intrinsics, pose, reference)."""
    from tognet.evaluate.config import CATEGORIES
    from tognet.evaluate.harness import test_objects
    from tognet.geometry import Camera, CameraIntrinsics
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics
    from tognet.sim import SimConfig, Simulator
    from tognet.sim.glcamera import SensorModel, no_return_below

    per = -(-count // len(CATEGORIES))
    out = []
    for cat in CATEGORIES:
        for obj in test_objects(cat, per, folder / "objects", progress=False, log=lambda s: None):
            if len(out) >= count:
                break
            sim = Simulator(SimConfig(), task, obj)
            obs = sim.reset(len(out))
            depth, camera = obs.depth, obs.camera
            if user_camera:
                k = CameraIntrinsics(width=640, height=480, fx=615.0, fy=615.0, cx=320.3, cy=238.9)
                com = sim.scene["object_com"]
                camera = Camera.aimed_at(k, [com[0], com[1], 0.0], 0.8, math.radians(28), 0.0, 0.3)
                depth = SensorModel(range_noise=0.0015, dropout=0.01, edge_dropout=0.5).apply(
                    no_return_below(sim.render_depth(camera), camera), np.random.default_rng(len(out)))
            name = f"{task}-{len(out):03d}"
            out.append((save_depth_png(folder / f"{name}.png", depth),
                        save_intrinsics(folder / f"{name}.json", camera.intrinsics),
                        save_camera_pose(folder / f"{name}.pose.json", camera.pose), obs.reference))
    return out


def _time(planners: dict[str, Any], images: list[tuple[Path, Path, Path, Any]], pose: bool, robot: bool
          ) -> tuple[dict[str, list[float]], dict[str, list[dict[str, float]]]]:
    """Each planner on each image, interleaved: wall seconds and stage timings per method."""
    from tognet.errors import TognetError

    walls: dict[str, list[float]] = {m: [] for m in planners}
    stages: dict[str, list[dict[str, float]]] = {m: [] for m in planners}
    for depth, intr, pose_file, reference in images:
        for method, planner in planners.items():
            t0 = time.perf_counter()
            try:
                plan = planner.plan(depth, intr, pose_file if pose else None,
                                    reference=reference if robot else None)
            except TognetError:  # no plan on this image (none within the arm's reach, ...): not timed
                walls[method].append(math.nan)
                continue
            walls[method].append(time.perf_counter() - t0)
            stages[method].append(plan.timing)
    return walls, stages


def _report(task: str, walls: dict[str, list[float]], stages: dict[str, list[dict[str, float]]]) -> None:
    base = np.array(walls.get("TOG-Net", []), dtype=float)
    print(f"| {task} | method | plans | wall median ms | p90 | x TOG-Net (median of per-image ratios) | "
          "stages (median ms) |")
    for method, w in walls.items():
        wa = np.array(w, dtype=float) * 1000
        ok = wa[np.isfinite(wa)]
        ratio = (f"{np.nanmedian(np.array(w) / base):.2f}" if len(base) == len(w) and method != "TOG-Net"
                 else "-")
        parts = {k: 1000 * float(np.median([s.get(k, 0.0) for s in stages[method]]))
                 for k in (stages[method][0] if stages[method] else {}) if k != "total"}
        print(f"| | {method} | {len(ok)} | {np.median(ok):.1f} | {np.percentile(ok, 90):.1f} | {ratio} | "
              + ", ".join(f"{k} {v:.1f}" for k, v in parts.items()) + " |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default="all", help="comma-separated task names, or all")
    ap.add_argument("--images", type=int, default=30, help="images per task")
    ap.add_argument("--methods", default="all", help="comma-separated methods a robot can run, or all")
    ap.add_argument("--top", type=int, default=3, help="alternatives per plan (tognet plan's default)")
    ap.add_argument("--pose", action="store_true", help="give the camera pose (no plane fit)")
    ap.add_argument("--user-camera", action="store_true",
                    help="a tilted RealSense's noisy image with no return past the table (see above)")
    ap.add_argument("--robot", choices=["sawyer", "panda"], default=None,
                    help="plan for this arm (camera pose and reference point given)")
    args = ap.parse_args()
    from tognet.cli.util import task_list
    from tognet.model.runtime import set_threads
    from tognet.planning.methods import BEST_FIRST, check_methods
    from tognet.planning.user import UserPlanConfig, UserPlanner

    methods = list(BEST_FIRST) if args.methods == "all" else list(check_methods(args.methods))
    if "TOG-Net" not in methods:
        methods.insert(0, "TOG-Net")  # the yardstick
    os.sched_setaffinity(0, sorted(os.sched_getaffinity(0))[:1])
    set_threads(1)
    print(f"{platform.processor() or platform.machine()}, 1 core, torch {torch.__version__} (1 thread), load "
          f"average {os.getloadavg()[0]:.2f}; {'user camera' if args.user_camera else 'simulator camera'}, "
          f"{'pose given' if args.pose or args.robot else 'table fitted'}"
          + (f", {args.robot}" if args.robot else ""), flush=True)
    config = UserPlanConfig(top=args.top)
    with tempfile.TemporaryDirectory() as tmp:
        for task in task_list(args.tasks):
            images = _images(task, args.images, Path(tmp), args.user_camera)
            planners = {m: UserPlanner(task, config=config, method=m, robot=args.robot) for m in methods}
            _time(planners, images[:2], args.pose, bool(args.robot))  # warm-up
            walls, stages = _time(planners, images, args.pose or bool(args.robot), bool(args.robot))
            _report(task, walls, stages)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
