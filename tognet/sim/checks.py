"""Scripted checks that the tasks make the grasp matter (hand-made tools, hand-computed actions).

Hammering: a T hammer grasped at the far end of its handle, with the action computed by hand from the
grasp, must drive the peg home in >= 90 % of seeds; grasped by its head it must fail in most.
Sweeping: a long L tool grasped at its short end must sweep two cans off in >= 90 %; grasped in the
middle of its long edge it must succeed far less often.
"""

from __future__ import annotations

import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tognet.sim.config import SimConfig
from tognet.sim.simulator import Simulator
from tognet.sim.tools import (
    HAMMER_HANDLE,
    HAMMER_HEAD,
    HAMMER_WIDTH,
    L_LONG,
    L_SHORT,
    L_WIDTH,
    grasp_on_object,
    make_l_tool,
    make_t_hammer,
)


@dataclass
class CheckResult:
    """Outcome of one scripted check over many seeds."""

    name: str
    trials: int
    task_successes: int
    grasp_successes: int
    invalid: int
    failures: dict[str, int] = field(default_factory=dict)
    details: list[dict[str, Any]] = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Task success rate over the valid trials."""
        valid = self.trials - self.invalid
        return self.task_successes / valid if valid else 0.0

    def line(self) -> str:
        """One printable line."""
        fails = ", ".join(f"{k}={v}" for k, v in sorted(self.failures.items()))
        return (
            f"{self.name:<44} task {self.task_successes:>3}/{self.trials - self.invalid:<3} "
            f"= {self.rate:6.1%}"
            f"  grasp {self.grasp_successes}/{self.trials}  invalid {self.invalid}  [{fails}]"
        )


def _in_gripper(point: np.ndarray, grasp_point: np.ndarray, jaw: np.ndarray) -> np.ndarray:
    """Object-frame point in the gripper frame (x = jaw axis, z up), for a tool lying flat."""
    d = np.asarray(point, dtype=np.float64) - np.asarray(grasp_point, dtype=np.float64)
    jaw = np.asarray(jaw, dtype=np.float64)
    return np.array([jaw @ d, np.cross([0.0, 0.0, 1.0], jaw) @ d, d[2]])


# --- hammering ---------------------------------------------------------------------------------------
HAMMER_GRASPS = {
    # name: (grasp point in the object frame, jaw axis, striking point, striking direction)
    "far_end": (
        (0.03, 0.0, 0.018),
        (0.0, 1.0, 0.0),
        (HAMMER_HANDLE + 0.5 * HAMMER_HEAD[0], 0.5 * HAMMER_HEAD[1], 0.5 * HAMMER_HEAD[2]),
        (0.0, 1.0, 0.0),
    ),
    "head": (
        (HAMMER_HANDLE + 0.5 * HAMMER_HEAD[0], 0.035, 0.5 * HAMMER_HEAD[2]),
        (1.0, 0.0, 0.0),
        (0.015, -0.5 * HAMMER_WIDTH, 0.5 * HAMMER_WIDTH),
        (0.0, -1.0, 0.0),
    ),
}


def hammer_handle_grasp(x: float) -> tuple:
    """A grasp across the T hammer's handle at ``x`` along it (0 = the far end), striking as far_end."""
    far = HAMMER_GRASPS["far_end"]
    return ((x, 0.0, far[0][2]), far[1], far[2], far[3])


def hammer_action(
    sim: Simulator, grasp_name: str | tuple, impact_angle: float = -0.1, clip: bool = True
) -> np.ndarray:
    """Hand-computed hammering action for a T-hammer grasp: the striking face meets the peg's free end
    ``impact_angle`` (rad) before the striking direction points along world +x."""
    spec = HAMMER_GRASPS[grasp_name] if isinstance(grasp_name, str) else grasp_name
    point, jaw, strike, direction = (np.asarray(v) for v in spec)
    task = sim.task
    assert task is not None
    c = sim.config.hammering
    f = _in_gripper(strike, point, jaw)
    n = _in_gripper(direction + point, point, jaw)  # striking direction in the gripper frame
    # Yaw at which the striking direction points along world +x; impact a little before it.
    yaw_push = -np.arctan2(n[1], n[0])
    yaw_impact = yaw_push + impact_angle
    rot = np.array([[np.cos(yaw_impact), -np.sin(yaw_impact)], [np.sin(yaw_impact), np.cos(yaw_impact)]])
    ref = np.asarray(sim.scene["reference"])
    target = np.array([ref[0] - 0.5 * c.peg_length, ref[1]])
    grip_xy = target - rot @ f[:2]
    grip_z = ref[2] - f[2]
    start_yaw = yaw_impact - np.pi / 4  # meet the peg 45 degrees into the swing
    a = np.array(
        [
            *(np.array([*grip_xy, grip_z]) - ref - np.asarray(c.nominal_offset)),
            (start_yaw - c.nominal_yaw + np.pi) % (2 * np.pi) - np.pi,
        ]
    )
    if clip:
        a = np.clip(a, task.action_low, task.action_high)
    return a


# --- sweeping ----------------------------------------------------------------------------------------
SWEEP_GRASPS = {
    # name: (grasp point, jaw axis) in the L tool's frame (long bar along +x, short bar along +y at x = 0)
    "short_end": ((0.5 * L_WIDTH, L_SHORT - 0.02, 0.5 * L_WIDTH), (1.0, 0.0, 0.0)),
    "long_middle": ((0.5 * L_LONG, 0.5 * L_WIDTH, 0.5 * L_WIDTH), (0.0, 1.0, 0.0)),
}


def sweep_action(sim: Simulator, grasp_name: str, clip: bool = True, yaw: float = 0.0) -> np.ndarray:
    """Hand-computed sweeping action: the tool's long bar centred on the cans, just behind them.

    The start yaw is the nominal one (a_phi = 0) turned by at most the action box: the grasp decides
    how the tool lies across the cans' path.
    """
    point, jaw = (np.asarray(v) for v in SWEEP_GRASPS[grasp_name])
    task = sim.task
    assert task is not None
    c = sim.config.sweeping
    ref = np.asarray(sim.scene["reference"])
    cans = sim.scene["layout"]["cans"]
    # The tool's footprint in the gripper frame (yaw = nominal = 0: gripper x = world x).
    corners = np.array(
        [[x, y, 0.0] for x in (0.0, L_LONG) for y in (0.0, L_WIDTH)]
        + [[x, y, 0.0] for x in (0.0, L_WIDTH) for y in (L_WIDTH, L_SHORT)]
    )
    pts = np.array([_in_gripper(p, point, jaw) for p in corners])
    c_, s_ = np.cos(yaw), np.sin(yaw)  # the start yaw turns the tool's footprint with the gripper
    xs, ys = c_ * pts[:, 0] - s_ * pts[:, 1], s_ * pts[:, 0] + c_ * pts[:, 1]
    front = ys.max()  # the tool's leading edge, gripper frame (y = direction of the stroke)
    centre_x = 0.5 * (xs.min() + xs.max())
    can_y_min = min(y for _, y, _ in cans)
    grip = np.array([ref[0] - centre_x, can_y_min - c.can_radius - 0.03 - front, 0.05])
    a = np.array([*(grip - ref - np.asarray(c.nominal_offset)), yaw])
    if clip:
        a = np.clip(a, task.action_low, task.action_high)
    return a


def run_check(
    task: str,
    grasp_name: str | tuple,
    seeds: range,
    config: SimConfig | None = None,
    clip: bool = True,
    folder: str | Path | None = None,
    yaw: float = 0.0,
    label: str = "",
) -> CheckResult:
    """Run one scripted check over ``seeds``; each seed is a new scene and one trial.

    ``grasp_name`` names a grasp of HAMMER_GRASPS / SWEEP_GRASPS or is a hammer grasp spec (see
    :func:`hammer_handle_grasp`); ``yaw`` is the sweeping start yaw (a_phi) to try.
    """
    config = config or SimConfig()
    if task == "sweeping":
        config = config.replace(sweeping=config.sweeping.replace(n_cans=(2,)))
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(folder) if folder else Path(tmp)
        obj = make_t_hammer(root) if task == "hammering" else make_l_tool(root)
        sim = Simulator(config, task, obj)
        grasps = HAMMER_GRASPS if task == "hammering" else SWEEP_GRASPS
        spec = grasps[grasp_name] if isinstance(grasp_name, str) else grasp_name
        point, jaw = spec[0], spec[1]
        name = label or f"{task}/{grasp_name}{'' if clip else ' (yaw unclipped)'}"
        result = CheckResult(name, 0, 0, 0, 0)
        counts: Counter[str] = Counter()
        for seed in seeds:
            sim.reset(seed)
            pos, rot = sim.object_pose()
            grasp = grasp_on_object(pos, rot, point, jaw)
            action = (
                hammer_action(sim, grasp_name, clip=clip)
                if task == "hammering"
                else sweep_action(sim, grasp_name, clip=clip, yaw=yaw)
            )
            res = sim.execute(grasp, action, seed)
            result.trials += 1
            result.task_successes += int(res.task_success)
            result.grasp_successes += int(res.grasp_success)
            result.invalid += int(not res.valid)
            counts[res.failure.value] += 1
            result.details.append(
                {
                    "seed": seed,
                    "action": action.tolist(),
                    "failure": res.failure.value,
                    **{k: v for k, v in res.info.items() if k in ("peg_out", "cans_on_ground")},
                }
            )
        result.failures = dict(counts)
    return result
