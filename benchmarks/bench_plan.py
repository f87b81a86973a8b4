"""One plan on a user's depth image, end to end (files read, table fitted, objects, candidates, CEM, action),
with the model's loading excluded: 1 core / 1 torch thread and 2 cores / 2 threads.

    .venv/bin/python benchmarks/bench_plan.py [--repeats 40] [--checkpoint best.pt] [--pose]

The image: the simulator's hammering scene with the T hammer (512 x 424), written as a 16-bit PNG with its
intrinsics, planned without the camera pose (the table plane fitted) unless ``--pose``. The model: the
given checkpoint, else the default architecture with random weights (the speed does not depend on them).
200 candidates, 3 CEM iterations of 64 (the defaults). Prints the median and p90 of wall and CPU time per
plan, the stages' medians and the load average: the machine is shared, and other jobs move these a lot.
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


def _image(folder: Path) -> tuple[Path, Path, Path]:
    from tognet.objects.handmade import make_test_tools
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics
    from tognet.sim import SimConfig, Simulator

    tools = make_test_tools(folder / "tools")
    obs = Simulator(SimConfig(), "hammering", tools["t_hammer"]).reset(3)
    return (save_depth_png(folder / "depth.png", obs.depth),
            save_intrinsics(folder / "k.json", obs.camera.intrinsics),
            save_camera_pose(folder / "pose.json", obs.camera.pose))


def _planner(checkpoint: str | None, threads: int) -> object:
    from tognet.model.config import ArchConfig
    from tognet.model.network import TOGNet
    from tognet.model.predict import TOGNetPredictor
    from tognet.model.runtime import set_threads, tune_allocator
    from tognet.planning.user import UserPlanner

    if checkpoint:
        return UserPlanner("hammering", checkpoint, num_threads=threads)
    set_threads(threads)
    tune_allocator()
    torch.manual_seed(0)
    return UserPlanner("hammering", TOGNetPredictor(TOGNet(ArchConfig()).eval(), device="cpu"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=40)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--checkpoint", default=None)
    ap.add_argument("--pose", action="store_true", help="give the camera pose (no plane fit)")
    args = ap.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, torch {torch.__version__}, "
          f"load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        depth, intr, pose = _image(Path(tmp))
        for n in (1, 2):
            if n > len(cores):
                print(f"{n} cores: only {len(cores)} available")
                continue
            os.sched_setaffinity(0, cores[:n])
            planner = _planner(args.checkpoint, n)
            walls, cpus, stages = [], [], []
            plan = None
            for i in range(args.warmup + args.repeats):
                w, c = time.perf_counter(), time.process_time()
                plan = planner.plan(depth, intr, pose if args.pose else None)  # type: ignore[attr-defined]
                if i >= args.warmup:
                    walls.append(time.perf_counter() - w)
                    cpus.append(time.process_time() - c)
                    stages.append(plan.timing)
            wa, ca = np.array(walls) * 1000, np.array(cpus) * 1000
            parts = {k: float(np.median([s[k] for s in stages])) * 1000 for k in stages[0] if k != "total"}
            assert plan is not None
            print(f"{n} core(s), {torch.get_num_threads()} thread(s): wall median {np.median(wa):.1f} ms "
                  f"(p90 {np.percentile(wa, 90):.1f}, min {wa.min():.1f}), CPU median {np.median(ca):.1f} "
                  f"ms; {plan.candidates} candidates, {plan.evaluated} grasps scored; "
                  f"load {os.getloadavg()[0]:.2f}")
            print("  stages (median ms): " + ", ".join(f"{k} {v:.1f}" for k, v in parts.items()))
        os.sched_setaffinity(0, cores)


if __name__ == "__main__":
    main()
