"""Inverse kinematics of the real arms (extra ``robot``) over the table: reach, accuracy and time, one core.

    .venv/bin/python benchmarks/bench_robot_ik.py [--arm panda sawyer] [--grid 5] [--yaws 8]

Each arm stands at its default base pose (tognet.robot.arms.ARMS). Poses: a grid over the grasping
half's drop area (x in drop_x, y in drop_y, 2 cm above the top) and over the manipulation half (x in
[0.05, 0.45], y in [-0.3, 0.3], 15 cm above the top), each at ``--yaws`` yaws in [0, 2 pi). Every solve
starts from the arm's home configuration. Prints per arm and region the share reached / unreachable /
joint_limit, the largest position and angle error of the reached ones, and the median and p90 solve
time (reached and not apart: a failed solve runs to the iteration cap twice). Then, with the arm's joint
servos (``add_servos``), two joint paths run at 1.25 x their shortest time (``control.follow``): a 30 cm
line along x 15 cm above the table, and a quarter wrist turn at (0.2, 0.05, 0.15). The machine is shared:
read the load average printed with the times.
"""

from __future__ import annotations

import argparse
import os
import time
from collections import Counter

import mujoco
import numpy as np

from tognet.robot import ARM_NAMES, ArmIK, IKStatus, grasp_frame, joint_path, load_arm
from tognet.robot.control import follow, set_joints
from tognet.robot.ik import tcp_errors
from tognet.sim import WorldConfig

PATHS = {
    "30 cm line": [(x, 0.0, 0.15, 0.0) for x in np.linspace(0.0, 0.3, 31)],
    "quarter wrist turn": [(0.2, 0.05, 0.15, 0.3 + a) for a in np.linspace(0.0, np.pi / 2, 10)],
}


def servo_runs(name: str) -> None:
    arm = load_arm(name, servos=True)
    model, data = arm.model, mujoco.MjData(arm.model)
    ik = ArmIK(arm)
    for label, poses in PATHS.items():
        path = joint_path(ik, poses)
        data.qpos[:] = model.qpos0
        set_joints(arm, model, data, path.q[0])
        t = follow(arm, model, data, path, slack=1.25)
        mujoco.mj_kinematics(model, data)
        pos_err, ang_err = tcp_errors(arm, data, grasp_frame(poses[-1]))
        print(f"  servos, {label}: shortest {path.min_duration:.3f} s, setpoints {t.move_time:.3f} s, settle "
              f"{t.settle_time:.3f} s, largest lag {t.max_lag:.3f} rad, fastest joint / limit "
              f"{t.max_speed_ratio:.2f}, TCP error {pos_err * 1e3:.2f} mm {np.degrees(ang_err):.2f} deg")


def regions(grid: int, yaws: int) -> dict[str, list[tuple[float, float, float, float]]]:
    world = WorldConfig()
    phis = np.arange(yaws) * 2 * np.pi / yaws
    spans = {
        "grasping": (world.drop_x, world.drop_y, 0.02),
        "manipulation": ((0.05, 0.45), (-0.3, 0.3), 0.15),
    }
    return {name: [(x, y, z, p) for x in np.linspace(*xs, grid) for y in np.linspace(*ys, grid) for p in phis]
            for name, (xs, ys, z) in spans.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arm", nargs="+", default=list(ARM_NAMES), choices=ARM_NAMES)
    parser.add_argument("--grid", type=int, default=5)
    parser.add_argument("--yaws", type=int, default=8)
    args = parser.parse_args()
    poses = regions(args.grid, args.yaws)
    for name in args.arm:
        start = time.perf_counter()
        arm = load_arm(name, ground_z=-WorldConfig().table_height)
        print(f"{name}: loaded in {time.perf_counter() - start:.3f} s, base {arm.spec.base_pos}")
        ik = ArmIK(arm)
        for region, items in poses.items():
            results = [ik.solve(p) for p in items]
            counts = Counter(r.status.value for r in results)
            ok = [r for r in results if r.status is IKStatus.REACHED]
            bad = [r for r in results if r.status is not IKStatus.REACHED]
            line = f"  {region:12s} {len(items)} poses: " + ", ".join(
                f"{s.value} {counts.get(s.value, 0)}" for s in IKStatus)
            if ok:
                ms = np.array([r.seconds for r in ok]) * 1e3
                line += (f" | reached: max error {max(r.position_error for r in ok) * 1e3:.3f} mm, "
                         f"{np.degrees(max(r.angle_error for r in ok)):.3f} deg, "
                         f"median {np.median(ms):.1f} ms, p90 {np.percentile(ms, 90):.1f} ms, "
                         f"median {np.median([r.iterations for r in ok]):.0f} iterations")
            if bad:
                ms = np.array([r.seconds for r in bad]) * 1e3
                line += f" | not reached: median {np.median(ms):.1f} ms"
            print(line)
        servo_runs(name)
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
