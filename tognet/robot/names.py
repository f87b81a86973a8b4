"""What can carry the hand, by name, and each arm's default base: MuJoCo-free, so the command line's
choices and help and the config's check read them without loading an arm (:mod:`tognet.robot.arms` has
the rest of each arm's spec)."""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The floating x, y, z, yaw base (the default; no arm).
FLOATING = "floating"


@dataclass(frozen=True)
class BasePose:
    """An arm's base pose in tognet's world frame: ``position`` (m; the table top is z = 0), ``yaw`` (rad)."""

    position: tuple[float, float, float]
    yaw: float


#: Each arm's default base: beside the table's far long side (y > 0), facing it, a little towards the
#: grasping half. The paper does not give its Sawyer's; from there the arm reaches the grasps and every
#: task's moves, the sweep's stroke (40 cm along +y, past the table's edge) included, which from the near
#: side (y < 0) it does not (benchmarks/RESULTS.md).
ARM_BASES: dict[str, BasePose] = {
    "sawyer": BasePose((-0.2, 0.6, 0.0), -math.pi / 2),
    "panda": BasePose((-0.2, 0.45, 0.0), -math.pi / 2),
}
#: Every name of what can carry the hand: the floating base, then the arms (the optional ``robot`` extra).
ROBOT_NAMES: tuple[str, ...] = (FLOATING, *ARM_BASES)


def check_robot_name(name: str, what: str = "robot") -> str:
    """``name`` if it is one of :data:`ROBOT_NAMES`; otherwise ValueError with the one message of an
    unknown robot, ``unknown robot 'name': choose from ...`` (``what``: how the caller's user named it,
    e.g. ``--robot``)."""
    if name not in ROBOT_NAMES:
        raise ValueError(f"unknown {what} {name!r}: choose from {', '.join(ROBOT_NAMES)}")
    return name
