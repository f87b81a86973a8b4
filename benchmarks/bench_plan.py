"""One plan on a user's depth image, end to end (files read, table fitted, objects, candidates, CEM, action),
with the model's loading excluded: 1 core / 1 torch thread and 2 cores / 2 threads.

    .venv/bin/python benchmarks/bench_plan.py [--repeats 40] [--checkpoint best.pt] [--pose] [--user-camera]
                                              [--robot sawyer|panda]

The image: the simulator's hammering scene with the T hammer (512 x 424), written as a 16-bit PNG with its
intrinsics, planned without the camera pose (the table plane fitted) unless ``--pose``. ``--user-camera``:
the same scene seen by a RealSense D435 (640 x 480) 0.8 m from the hammer, tilted 28 degrees over the
table's far edge with no return past it (a fifth of the image unmeasured), 1.5 mm range noise at 1 m and
1 % random and half the silhouette pixels lost (:class:`tognet.sim.glcamera.SensorModel` on the simulator's
ray caster). The model: the
given checkpoint, else the default architecture with random weights (the speed does not depend on them).
200 candidates, 3 CEM iterations of 64 (the defaults). ``--robot``: the same plans for that arm at its
default base (``tognet plan --robot``: the reach filter and the joint trajectory), with the camera pose and
the scene's peg as the reference point, each timed beside the same plan without the arm (ratio of the
medians). Prints the median and p90 of wall and CPU time per plan, the stages' medians and the load
average: the machine is shared, and other jobs move these a lot.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
import torch


def _image(folder: Path, user_camera: bool = False) -> tuple[Path, Path, Path, np.ndarray]:
    from tognet.objects.handmade import make_test_tools
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics
    from tognet.sim import SimConfig, Simulator

    tools = make_test_tools(folder / "tools")
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    obs = sim.reset(3)
    depth, camera = obs.depth, obs.camera
    if user_camera:
        import math

        from tognet.geometry import Camera, CameraIntrinsics
        from tognet.sim.glcamera import SensorModel, no_return_below

        k = CameraIntrinsics(width=640, height=480, fx=615.0, fy=615.0, cx=320.3, cy=238.9)
        com = sim.scene["object_com"]
        camera = Camera.aimed_at(k, [com[0], com[1], 0.0], 0.8, math.radians(28), 0.0, 0.3)
        depth = no_return_below(sim.render_depth(camera), camera)
        depth = SensorModel(range_noise=0.0015, dropout=0.01, edge_dropout=0.5).apply(
            depth, np.random.default_rng(0))
    return (save_depth_png(folder / "depth.png", depth),
            save_intrinsics(folder / "k.json", camera.intrinsics),
            save_camera_pose(folder / "pose.json", camera.pose), obs.reference)


def _planner(checkpoint: str | None, threads: int, robot: str | None = None) -> object:
    from tognet.model.config import ArchConfig
    from tognet.model.network import TOGNet
    from tognet.model.predict import TOGNetPredictor
    from tognet.model.runtime import set_threads, tune_allocator
    from tognet.planning.user import UserPlanner

    if checkpoint:
        return UserPlanner("hammering", checkpoint, num_threads=threads, robot=robot)
    set_threads(threads)
    tune_allocator()
    torch.manual_seed(0)
    return UserPlanner("hammering", TOGNetPredictor(TOGNet(ArchConfig()).eval(), device="cpu"), robot=robot)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=40)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--checkpoint", default=None)
    ap.add_argument("--pose", action="store_true", help="give the camera pose (no plane fit)")
    ap.add_argument("--user-camera", action="store_true",
                    help="a tilted RealSense's noisy image with no return past the table (see above)")
    ap.add_argument("--robot", choices=["sawyer", "panda"], default=None,
                    help="also plan for this arm (camera pose and reference point given)")
    args = ap.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, torch {torch.__version__}, "
          f"load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        depth, intr, pose, reference = _image(Path(tmp), args.user_camera)
        if args.robot:
            args.pose = True
        for n in (1, 2):
            if n > len(cores):
                print(f"{n} cores: only {len(cores)} available")
                continue
            os.sched_setaffinity(0, cores[:n])
            kinds = [None, args.robot] if args.robot else [None]
            planners = {kind: _planner(args.checkpoint, n, kind) for kind in kinds}
            walls: dict[str | None, list[float]] = {kind: [] for kind in kinds}
            cpus: dict[str | None, list[float]] = {kind: [] for kind in kinds}
            stages: dict[str | None, list[dict[str, float]]] = {kind: [] for kind in kinds}
            plans: dict[str | None, object] = {}
            ref = reference if args.robot else None
            for i in range(args.warmup + args.repeats):
                for kind in kinds:  # interleaved: the machine's load moves both alike
                    w, c = time.perf_counter(), time.process_time()
                    plan = planners[kind].plan(depth, intr, pose if args.pose else None,  # type: ignore
                                               reference=ref)
                    if i >= args.warmup:
                        walls[kind].append(time.perf_counter() - w)
                        cpus[kind].append(time.process_time() - c)
                        stages[kind].append(plan.timing)
                    plans[kind] = plan
            for kind in kinds:
                wa, ca = np.array(walls[kind]) * 1000, np.array(cpus[kind]) * 1000
                parts = {k: float(np.median([s[k] for s in stages[kind]])) * 1000 for k in stages[kind][0]
                         if k != "total"}
                plan = plans[kind]
                what = f"with the {kind}: " if kind else ("without an arm: " if args.robot else "")
                ratio = (f", x{np.median(wa) / np.median(np.array(walls[None]) * 1000):.2f} the plan without "
                         "an arm" if kind else "")
                print(f"{n} core(s), {torch.get_num_threads()} thread(s): {what}wall median "
                      f"{np.median(wa):.1f} ms (p90 {np.percentile(wa, 90):.1f}, min {wa.min():.1f}), CPU "
                      f"median {np.median(ca):.1f} ms{ratio}; {plan.candidates} candidates, "  # type: ignore
                      f"{plan.evaluated} grasps scored; load {os.getloadavg()[0]:.2f}")  # type: ignore
                print("  stages (median ms): " + ", ".join(f"{k} {v:.1f}" for k, v in parts.items()))
        os.sched_setaffinity(0, cores)


if __name__ == "__main__":
    main()
