"""Sweeping: push every can off the table with the tool in one straight stroke.

Task description
    One or two cans (upright cylinders) stand in the manipulation half of the table (x > 0), near the
    table's far edge (y = +table_width/2). The gripper, holding the tool, goes to the start pose
    a = (a_x, a_y, a_z, a_phi) relative to the reference point (the mean position of the cans; its z is
    the cans' mid-height), then moves ``stroke`` (40 cm) in a straight line along world +y, toward that
    edge. The start yaw is absolute (``nominal_yaw + a_phi``), so the grasp decides how the tool lies across
    the cans' path: a long edge across the path catches both cans, a tool held along the path catches one.

Grasp orientation (phi versus phi + pi)
    The gripper's yaw is the grasp's phi exactly (not modulo pi), so phi and phi + pi put the tool on
    opposite sides of the hand, which decides whether it trails or leads the gripper along the stroke.
    Both are executable. At a_phi = 0 the jaw axis lies along world x, across the path; a_phi in +-pi/4
    turns it by at most 45 degrees. So a long edge lies across the cans' path only when it runs roughly
    along the jaw axis (a part branching off it is grasped, as an L held by its short end); a straight
    bar grasped across its width stays within 45 degrees of along the path, whichever of phi or phi + pi.

Randomizations
    Number of cans (1 or 2, ``n_cans``), their x/y positions (in ``can_x``, ``can_y``; two cans are
    ``can_spacing`` apart in x), their masses (``can_mass``).

Success conditions
    Every can touches the ground (it fell off the table) before the time runs out.

Evaluation
    The paper's mix of one and two cans is the headline; the report breaks it down by number of cans
    (a long edge across the path matters most with two).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.tasks.base import FailureReason, Motion, SceneSubset, Task, TaskOutcome


@dataclass(frozen=True)
class SweepingConfig(Config):
    """Sweeping task set-up (SI units; world frame, origin at the centre of the table top)."""

    n_cans: tuple[int, ...] = doc((1, 2), "Numbers of cans to choose from uniformly per episode.")
    can_radius: float = doc(0.033, "Can radius (m), a soda can.")
    can_height: float = doc(0.12, "Can height (m).")
    can_mass: tuple[float, float] = doc((0.05, 0.35), "Range of each can's mass (kg), uniform.")
    can_friction: float = doc(0.5, "Sliding friction of the cans (table and tool contacts).")
    can_x: tuple[float, float] = doc((0.2, 0.4), "Range of the cans' mean x (m), manipulation half.")
    can_y: tuple[float, float] = doc((0.15, 0.24), "Range of each can's y (m); the edge is at +0.38.")
    can_spacing: tuple[float, float] = doc(
        (0.14, 0.2), "Range of the x distance between two cans' centres (m): wider than a short edge."
    )
    stroke: float = doc(0.4, "Length of the straight sweep along world +y (m), as in the paper.")
    sweep_speed: float = doc(
        0.6,
        "Gripper speed during the sweep (m/s). Not faster: a faster stroke flicks cans off the table with "
        "a badly placed tool, so the grasp would matter less, and saves few steps (benchmarks/RESULTS.md).",
    )
    settle_time: float = doc(
        1.0,
        "Time allowed after the stroke for the cans to fall (s); ends early when every can is down or "
        "those left on the table are at rest.",
    )
    fallen_margin: float = doc(
        0.01,
        "A can whose centre is below the table top by more than its half-diagonal plus this (m) is wholly "
        "beside the table and unsupported: it counts as on the ground without simulating the rest of its "
        "fall (saves ~0.3 s of simulated time per can).",
    )
    rest_speed: float = doc(
        0.01,
        "A can on the table slower than this (m/s; and 10x this in rad/s) is at rest after the stroke.",
    )
    rest_checks: int = doc(
        3, "The wait after the stroke ends once the cans left on the table rest this many checks in a row."
    )
    can_hold_margin: float = doc(
        0.1,
        "Simulation shortcut, not part of the task: until the tool or the hand comes this close (m, in x "
        "and y, around a sphere holding the whole tool) the cans standing still are left out of the "
        "physics (the world is stepped without them: their contacts and degrees of freedom cost a good "
        "part of every step) and come back as they stood.",
    )
    nominal_offset: tuple[float, float, float] = doc(
        (0.0, -0.15, -0.03), "Gripper start position minus the reference point at a = 0 (m)."
    )
    nominal_yaw: float = doc(0.0, "Gripper start yaw at a_phi = 0 (rad): jaw axis along world x.")
    action_low: tuple[float, float, float, float] = doc(
        (-0.15, -0.1, -0.05, -np.pi / 4), "Lower corner of the action box (a_x, a_y, a_z m; a_phi rad)."
    )
    action_high: tuple[float, float, float, float] = doc(
        (0.15, 0.1, 0.06, np.pi / 4), "Upper corner of the action box."
    )


class Sweeping(Task):
    """Sweep the cans off the table (see the module docstring)."""

    name = "sweeping"
    reference_point = "the cans' mean position at their mid-height"
    config: SweepingConfig
    config_class = SweepingConfig
    subsets = (SceneSubset("mix", "the paper's mix: one or two cans"),
               SceneSubset("one-can", "one can", "n_cans", 1),
               SceneSubset("two-can", "two cans", "n_cans", 2))
    subsets_by = "number of cans"
    subsets_note = ("With one can almost any grasp that lifts the tool can succeed; with two the tool must "
                    "span both, and the grasp decides whether it can.")

    def scene_facts(self, layout: dict[str, Any]) -> dict[str, Any]:
        """The number of cans (``n_cans``)."""
        return {"n_cans": len(layout["cans"])}

    def sample_layout(self, rng: np.random.Generator) -> dict[str, Any]:
        """Cans: list of (x, y, mass)."""
        c = self.config
        n = int(rng.choice(np.asarray(c.n_cans)))
        mean_x = rng.uniform(*c.can_x)
        if n == 1:
            xs = [mean_x]
        else:
            half = 0.5 * rng.uniform(*c.can_spacing)
            xs = [mean_x - half, mean_x + half]
        cans = [(float(x), float(rng.uniform(*c.can_y)), float(rng.uniform(*c.can_mass))) for x in xs]
        return {"cans": cans}

    def reference(self, layout: dict[str, Any]) -> NDArray[np.float64]:
        """Mean position of the cans (z at their mid-height)."""
        xy = np.mean([[x, y] for x, y, _ in layout["cans"]], axis=0)
        return np.array([xy[0], xy[1], 0.5 * self.config.can_height])

    def primitive(self) -> list[Motion]:
        """A straight stroke along world +y."""
        return [Motion(delta=(0.0, self.config.stroke, 0.0), speed=self.config.sweep_speed)]

    def evaluate(self, outcome: TaskOutcome) -> tuple[bool, FailureReason]:
        """Success when every can touched the ground (``outcome.values['cans_on_ground']``)."""
        on_ground = list(outcome.values.get("cans_on_ground", []))
        if on_ground and all(on_ground):
            return True, FailureReason.NONE
        if not outcome.touched_targets:
            return False, FailureReason.MISSED
        if outcome.still_moving:
            return False, FailureReason.TIMEOUT
        return False, FailureReason.TASK_FAILED

    def progress(self, values: dict[str, Any]) -> float:
        """The share of the cans that reached the ground (``values['cans_on_ground']``)."""
        on_ground = list(values.get("cans_on_ground", []))
        return float(np.mean(on_ground)) if on_ground else float("nan")
