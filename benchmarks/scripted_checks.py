"""The world issue's scripted checks: does the grasp matter? Prints success rates over N seeds.

    .venv/bin/python benchmarks/scripted_checks.py [--seeds 50]

Hammering: T hammer grasped at the far end of its handle (hand-computed action) vs by its head (best
action inside the action box, and, as a diagnostic, the action it would need with the yaw unclipped),
and the far-end grasp with a slow wrist (a sixth of full speed: 1.5 rad/s on the floating base) to show a
quasi-static push does not drive the peg.
Sweeping: long L tool grasped at its short end vs in the middle of its long edge, two cans.
Pulling: the same L tool grasped near the end of its long bar (the short bar the hook) vs near the hook.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from tognet.config import ConfigError
from tognet.sim import SimConfig
from tognet.sim.scripted_checks import run_check
from tognet.tasks.hammering_props import hammer_handle_grasp
from tognet.tasks.pulling_props import pull_bar_grasp


def _load_config(parser: argparse.ArgumentParser, path: Path | None) -> SimConfig:
    """The --config file's SimConfig (the defaults without one); a bad file ends with its message."""
    try:
        return SimConfig.load(path) if path else SimConfig()
    except ConfigError as exc:
        parser.error(str(exc))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50, help="scenes (seeds) per check")
    parser.add_argument(
        "--diagnostics",
        action="store_true",
        help="also grasp positions along the hammer's handle and the L tool's long bar, "
        "and the long-edge sweep turned to the action box's yaw limits (half the seeds)",
    )
    parser.add_argument("--config", type=Path, help="SimConfig JSON to check instead of the defaults")
    args = parser.parse_args()
    cfg = _load_config(parser, args.config)
    # A sixth of the wrist's full speed (1.5 rad/s on the floating base's 9; an arm's preset has its own).
    slow_speed = cfg.gripper.yaw_speed / 6
    slow = cfg.replace(gripper=cfg.gripper.replace(yaw_speed=slow_speed))
    checks = [
        ("hammering", "far_end", cfg, True, ">= 90%"),
        ("hammering", "head", cfg, True, "fails in most"),
        ("hammering", "head", cfg, False, "diagnostic: the yaw it needs, outside the box"),
        ("hammering", "far_end", slow, True, f"slow wrist {slow_speed:.2g} rad/s: push must fail"),
        ("sweeping", "short_end", cfg, True, ">= 90%"),
        ("sweeping", "long_middle", cfg, True, "far less often"),
        ("pulling", "far_end", cfg, True, ">= 90%"),
        ("pulling", "near_hook", cfg, True, "fails in most"),
    ]
    for task, grasp, config, clip, expect in checks:
        t0 = time.perf_counter()
        result = run_check(task, grasp, range(args.seeds), config, clip=clip)
        print(f"{result.line()}  ({expect}; {time.perf_counter() - t0:.1f} s)", flush=True)
    if args.diagnostics:
        seeds = range(1000, 1000 + args.seeds // 2)
        for x in (0.03, 0.08, 0.13, 0.18):
            r = run_check(
                "hammering", hammer_handle_grasp(x), seeds, cfg, label=f"hammering/handle grasp at x={x}"
            )
            print(f"{r.line()}  (diagnostic: where along the handle)", flush=True)
        for yaw in (-np.pi / 4, np.pi / 4):
            r = run_check(
                "sweeping", "long_middle", seeds, cfg, yaw=yaw, label=f"sweeping/long_middle a_phi={yaw:+.2f}"
            )
            print(f"{r.line()}  (diagnostic: turned as far as the action box allows)", flush=True)
        for x in (0.1, 0.15, 0.2, 0.24):
            r = run_check("pulling", pull_bar_grasp(x), seeds, cfg, label=f"pulling/bar grasp at x={x}")
            print(f"{r.line()}  (diagnostic: where along the long bar)", flush=True)


if __name__ == "__main__":
    main()
