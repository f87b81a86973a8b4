"""Pulling: hook an object lying out of the gripper's reach and pull it back within reach.

Task description
    A can (an upright cylinder) stands on the far side of the manipulation half of the table (large x),
    beyond where the gripper may go: the gripper's start pose is relative to the reference point (the can's
    centre at mid-height), and the action box keeps it at least ``-(nominal_offset[0] + action_high[0])``
    (6 cm) short of the can's centre in x. The gripper, holding the tool, goes to the start pose
    a = (a_x, a_y, a_z, a_phi), then moves ``pull`` in a straight line along world -x, toward the robot.
    The tool must reach past the can and catch it on a part facing the robot (a hook): a long lever held
    by the end away from the hook does it; a tool held near its hook cannot reach behind the can.

Grasp orientation (phi versus phi + pi)
    The gripper's yaw is the grasp's phi exactly (not modulo pi) and the start yaw is absolute
    (``nominal_yaw + a_phi``). At a_phi = 0 the gripper's +y axis points along world +x (away from the
    robot), so a tool reaching along the gripper's +y (across the jaws) reaches past the can; phi + pi puts
    it along -y, toward the robot, where no action in the box brings it back (a_phi is within +-pi/4).
    A hook branching off toward the gripper's +x then lies toward world -y, and the nominal offset puts the
    tool's bar 6 cm to +y of the can, the hook across the can's line; a hook branching off toward the
    gripper's -x lies toward +y and needs the bar on the other side (a_y about -0.12): the box holds both.

Randomizations
    The can's position (``can_x``, ``can_y``) and mass (``can_mass``).

Success conditions
    After the pull and the settling time, the can's centre is inside the target region (x in ``target_x``,
    within ``target_y`` of where it stood in y), upright (tilted less than ``max_tilt``) and on the table.
    A pull that never touches the can is MISSED; the tool or the gripper touching it before the pull fails
    (COLLISION_BEFORE_MOTION).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.tasks.base import FailureReason, Motion, Task, TaskOutcome


@dataclass(frozen=True)
class PullingConfig(Config):
    """Pulling task set-up (SI units; world frame, origin at the centre of the table top)."""

    can_radius: float = doc(0.033, "Can radius (m), a soda can.")
    can_height: float = doc(
        0.07,
        "Can height (m), a short can (a tuna can): the tool, carried to the start pose "
        "``SimConfig.gripper.start_clearance`` (10 cm) above it, passes over the can before it descends.",
    )
    can_mass: tuple[float, float] = doc((0.05, 0.35), "Range of the can's mass (kg), uniform.")
    can_friction: float = doc(0.5, "Sliding friction of the can (table and tool contacts).")
    can_x: tuple[float, float] = doc(
        (0.36, 0.48), "Range of the can's x (m): the far side of the manipulation half (the edge is at 0.61)."
    )
    can_y: tuple[float, float] = doc((-0.2, 0.2), "Range of the can's y (m).")
    pull: float = doc(0.3, "Length of the straight pull along world -x (m).")
    pull_speed: float = doc(0.3, "Gripper speed during the pull (m/s).")
    target_x: tuple[float, float] = doc(
        (0.0, 0.24),
        "Target region in x (m): within the gripper's reach, still in the manipulation half. A can hooked "
        "from just behind ends about ``pull`` nearer, in it from every start in ``can_x``.",
    )
    target_y: float = doc(
        0.08, "Target region in y: at most this far (m) from the can's starting y (pulled straight)."
    )
    max_tilt: float = doc(0.5, "The can counts as upright when its axis is tilted less than this (rad).")
    settle_time: float = doc(
        0.5, "Time allowed after the pull for the can to come to rest (s); ends early once it rests."
    )
    rest_speed: float = doc(0.01, "The can is at rest when slower than this (m/s; and 10x this in rad/s).")
    nominal_offset: tuple[float, float, float] = doc(
        (-0.16, 0.06, -0.015),
        "Gripper start position minus the reference point (the can's centre at mid-height) at a = 0 (m): "
        "about where an L tool held 4 cm from the end of its 30 cm bar has its hook 4 cm behind the can, its "
        "bar 6 cm beside the can's centre and 8 mm above the table.",
    )
    nominal_yaw: float = doc(
        -np.pi / 2, "Gripper start yaw at a_phi = 0 (rad): its +y axis (across the jaws) along world +x."
    )
    action_low: tuple[float, float, float, float] = doc(
        (-0.1, -0.14, -0.05, -np.pi / 4), "Lower corner of the action box (a_x, a_y, a_z m; a_phi rad)."
    )
    action_high: tuple[float, float, float, float] = doc(
        (0.1, 0.14, 0.06, np.pi / 4),
        "Upper corner of the action box. a_x at most 0.1: the gripper stays 6 cm short of the can's centre, "
        "so only a tool reaching about 13 cm past the grasp can hook it (the L tool held 15 cm or more from "
        "its hook's end; 10 cm is too near); a shorter reach leaves fewer generated tools able to pull.",
    )


class Pulling(Task):
    """Pull the can back within reach (see the module docstring)."""

    name = "pulling"
    reference_point = "the can's centre at mid-height"
    config: PullingConfig
    config_class = PullingConfig

    def sample_layout(self, rng: np.random.Generator) -> dict[str, Any]:
        """The can: (x, y, mass)."""
        c = self.config
        x, y = float(rng.uniform(*c.can_x)), float(rng.uniform(*c.can_y))
        return {"can": (x, y, float(rng.uniform(*c.can_mass)))}

    def reference(self, layout: dict[str, Any]) -> NDArray[np.float64]:
        """The can's centre (z at its mid-height)."""
        x, y, _ = layout["can"]
        return np.array([x, y, 0.5 * self.config.can_height])

    def told_layout(self, reference: NDArray[np.float64]) -> dict[str, Any] | None:
        """The can under the reference point, its mass (not seen) the middle of ``can_mass``."""
        return {"can": (float(reference[0]), float(reference[1]), float(np.mean(self.config.can_mass)))}

    def primitive(self) -> list[Motion]:
        """A straight pull along world -x."""
        return [Motion(delta=(-self.config.pull, 0.0, 0.0), speed=self.config.pull_speed)]

    def evaluate(self, outcome: TaskOutcome) -> tuple[bool, FailureReason]:
        """Success when ``outcome.values['can_in_target']`` (in the region, upright, on the table)."""
        if bool(outcome.values.get("can_in_target", False)):
            return True, FailureReason.NONE
        if not outcome.touched_targets:
            return False, FailureReason.MISSED
        if outcome.still_moving:
            return False, FailureReason.TIMEOUT
        return False, FailureReason.TASK_FAILED

    def progress(self, values: dict[str, Any]) -> float:
        """How far the can came back toward the target region: 0 where it stood (or off the table), 1 in
        the region (``values['can_xy']``, ``values['can_start_x']``)."""
        if bool(values.get("can_in_target", False)):
            return 1.0
        if "can_xy" not in values or "can_start_x" not in values or not values.get("can_on_table", True):
            return 0.0 if "can_xy" in values else float("nan")
        start, end = float(values["can_start_x"]), float(self.config.target_x[1])
        moved = start - float(values["can_xy"][0])
        return float(np.clip(moved / max(start - end, 1e-6), 0.0, 0.99))
