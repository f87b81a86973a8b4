"""Hammering: drive a stiff peg fully into its slot with one swing of the wrist.

Task description
    A slot (a block with a bore) stands in the manipulation half of the table; a square peg lies
    horizontally in the bore, half inserted, its free end pointing toward world -x. The peg slides only
    along its axis and resists with dry friction (``peg_friction`` N, a stiff friction constraint that
    does not creep). The gripper, holding the tool, goes to the start pose a = (a_x, a_y, a_z, a_phi)
    relative to the reference point (the peg's centre), then the wrist turns 90 degrees counter-clockwise
    at full speed (``SimConfig.gripper.yaw_speed``) while the gripper stays put. The wrist's torque limit is
    kept low enough that pushing the peg slowly fails for any useful lever (torque / lever < friction):
    the peg moves only under the momentum the swung tool carries, which grows with the lever and with
    mass far from the grasp (a heavy head held by the far end of a handle). The start yaw is absolute,
    so the grasp decides where the tool points at impact.

Grasp orientation (phi versus phi + pi)
    The gripper's yaw is the grasp's phi exactly (not modulo pi) and the start yaw is absolute, so the
    two jaw orientations of one grasp placement (the antipodal sampler draws either) hold the tool on
    opposite sides of the hand; both are executable and they are different trials. The striking part
    must point along world -y from the gripper when the swing reaches the peg, so with the start yaw in
    nominal_yaw + [-pi/4, pi/4] only a part lying within 45 degrees of the gripper's -y axis can strike.
    Of phi and phi + pi, exactly one puts a given part there (the other turns it to +y, and no action in
    the box brings it back: measured, the far-end grasp of the T hammer hammers with one and misses with
    every oracle action with the other, tests/test_sim_oracle.py). So the box is enough when the grasp
    picks the orientation: with that choice, anything within 45 degrees of the axis across the jaws (where
    a tool grasped across its width extends) can be made to strike; parts along the jaw axis cannot. A
    scorer must therefore tell phi from phi + pi (the grasp-aligned crop does: it turns by 180 degrees).

Randomizations
    Slot position (``slot_x``, ``slot_y``); the slot's orientation is fixed.

Success conditions
    The whole peg is inside the slot (its free end within ``success_tolerance`` of the slot face) at
    the end. Touching the peg or the slot with the tool or the gripper before the swing fails
    (COLLISION_BEFORE_MOTION); a swing that never touches the peg is MISSED.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.tasks.base import FailureReason, Motion, Task, TaskOutcome


@dataclass(frozen=True)
class HammeringConfig(Config):
    """Hammering task set-up (SI units; world frame, origin at the centre of the table top)."""

    slot_x: tuple[float, float] = doc((0.22, 0.36), "Range of the slot face's x (m), manipulation half.")
    slot_y: tuple[float, float] = doc((-0.2, 0.0), "Range of the peg axis' y (m).")
    peg_length: float = doc(0.1, "Peg length (m); half of it sticks out of the slot at the start.")
    peg_friction_impedance: float = doc(
        0.9999,
        "Impedance (solimpfriction) of the peg's dry friction. MuJoCo's friction is soft and creeps under a "
        "push below the threshold; this makes the creep negligible, so only a blow moves the peg "
        "(benchmarks/RESULTS.md).",
    )
    peg_size: float = doc(0.03, "Peg cross-section side (m), square.")
    peg_height: float = doc(0.045, "Height of the peg's axis above the table (m).")
    peg_mass: float = doc(0.05, "Peg mass (kg).")
    peg_friction: float = doc(
        11.0, "Dry friction resisting the peg's slide (N): frictionloss on its joint, stiff solreffriction."
    )
    contact_solref: tuple[float, float] = doc(
        (0.005, 1.0),
        "Contact solref of the peg and slot (time constant s, damping ratio): stiff, like metal.",
    )
    slot_size: tuple[float, float, float] = doc(
        (0.12, 0.1, 0.09), "Slot block size (m): depth along x, width along y, height (from the table)."
    )
    success_tolerance: float = doc(
        0.003, "The peg counts as fully inside when at most this much sticks out (m)."
    )
    settle_time: float = doc(0.1, "Time simulated after the swing before checking (s).")
    swing: float = doc(np.pi / 2, "Wrist turn of the primitive (rad), counter-clockwise.")
    nominal_offset: tuple[float, float, float] = doc(
        (-0.06, 0.22, 0.0),
        "Gripper start position minus the peg centre at a = 0 (m): a tool pointing -y with its head 22 cm "
        "from the grasp meets the peg's free end mid-swing.",
    )
    nominal_yaw: float = doc(
        -np.pi / 4,
        "Gripper start yaw at a_phi = 0 (rad): the tool (along gripper -y) meets the peg after 45 deg.",
    )
    action_low: tuple[float, float, float, float] = doc(
        (-0.1, -0.13, -0.05, -np.pi / 4), "Lower corner of the action box (a_x, a_y, a_z m; a_phi rad)."
    )
    action_high: tuple[float, float, float, float] = doc(
        (0.1, 0.13, 0.06, np.pi / 4), "Upper corner of the action box."
    )


class Hammering(Task):
    """Hammer the peg into the slot (see the module docstring)."""

    name = "hammering"
    reference_point = "the peg's centre"
    config: HammeringConfig
    config_class = HammeringConfig

    def sample_layout(self, rng: np.random.Generator) -> dict[str, Any]:
        """The slot face position (x, y); the peg's centre is on the face at its axis height."""
        return {"slot": (float(rng.uniform(*self.config.slot_x)), float(rng.uniform(*self.config.slot_y)))}

    def reference(self, layout: dict[str, Any]) -> NDArray[np.float64]:
        """The peg's centre at the start (it sits half inserted, so on the slot face)."""
        x, y = layout["slot"]
        return np.array([x, y, self.config.peg_height])

    def told_layout(self, reference: NDArray[np.float64]) -> dict[str, Any] | None:
        """The slot face under the reference point (the peg's centre): the whole layout."""
        return {"slot": (float(reference[0]), float(reference[1]))}

    def primitive(self) -> list[Motion]:
        """The wrist turns ``swing`` counter-clockwise at full speed; the gripper stays put."""
        return [Motion(dyaw=self.config.swing)]

    def evaluate(self, outcome: TaskOutcome) -> tuple[bool, FailureReason]:
        """Success when ``outcome.values['peg_out']`` (what still sticks out, m) is within the tolerance."""
        out = float(outcome.values.get("peg_out", np.inf))
        if out <= self.config.success_tolerance:
            return True, FailureReason.NONE
        if not outcome.touched_targets:
            return False, FailureReason.MISSED
        return False, FailureReason.TASK_FAILED

    def progress(self, values: dict[str, Any]) -> float:
        """The share of the peg's free half driven in: 0 untouched, 1 when at most ``success_tolerance``
        sticks out (``values['peg_out']``)."""
        if "peg_out" not in values:
            return float("nan")
        free = 0.5 * self.config.peg_length - self.config.success_tolerance
        left = float(values["peg_out"]) - self.config.success_tolerance
        return float(np.clip(1.0 - left / free, 0.0, 1.0))
