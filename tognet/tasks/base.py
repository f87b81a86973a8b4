"""What a task is, without a simulator: action space, prop layout, motion primitive, success rule.

A task module describes everything in plain numbers; :mod:`tognet.sim` (the only package that imports
MuJoCo) builds the props, runs the primitive and hands the outcome back as a :class:`TaskOutcome`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray


class FailureReason(StrEnum):
    """Why an episode did not succeed (NONE for a success).

    The order is the int8 code stored in episode shards (``tognet.data.format.FAILURE_CODES``): add new
    reasons at the end only."""

    NONE = "none"
    GRASP_FAILED = "grasp_failed"  # the tool was not held clear of the table after the lift
    DROPPED = "dropped"  # the tool slipped out of the fingers after a successful grasp (failed task)
    COLLISION_BEFORE_MOTION = (
        "collision_before_motion"  # tool or gripper hit a task prop before the primitive
    )
    MISSED = "missed"  # the primitive ran but the tool never touched the targets
    TASK_FAILED = "task_failed"  # the tool touched the targets but the success condition did not hold
    TIMEOUT = "timeout"  # the targets were still moving when the time allowed ran out
    UNSTABLE = "unstable"  # NaN, explosion or deep penetration: the episode is invalid
    UNREACHABLE = "unreachable"  # an arm cannot reach a pose the trial needs (no inverse kinematics)
    JOINT_LIMIT = "joint_limit"  # an arm reaches a pose the trial needs only past a joint's range


@dataclass(frozen=True)
class Motion:
    """One straight segment of the gripper's setpoint: move by ``delta`` (world, m) and turn by ``dyaw``.

    ``speed`` (m/s) and ``yaw_speed`` (rad/s) cap the segment's rates; None means the gripper's maximum.
    """

    delta: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dyaw: float = 0.0
    speed: float | None = None
    yaw_speed: float | None = None


@dataclass
class TaskOutcome:
    """What the simulator observed while the primitive ran and after it settled."""

    touched_targets: bool  # the tool (or gripper) touched a target prop during the primitive
    still_moving: bool  # props were still moving when the time allowed ran out
    values: dict[str, Any] = field(default_factory=dict)  # task-specific measurements


@dataclass(frozen=True)
class SceneSubset:
    """A named subset of a task's evaluation scenes, chosen by one fact of the scene
    (:meth:`Task.scene_facts`).

    ``fact`` None takes every scene. The evaluation reports every subset; a task's first is its headline."""

    name: str  # the key in results.json (e.g. "two-can")
    label: str  # how the report says it (e.g. "two cans")
    fact: str | None = None  # the scene fact that chooses the scenes (a key of scene_facts)
    value: Any = None  # the fact's value in the subset

    def holds(self, facts: dict[str, Any]) -> bool:
        """Whether a scene with these facts belongs to the subset."""
        return self.fact is None or facts.get(self.fact) == self.value


class Task:
    """Base class of a task; subclasses set ``name`` and ``config_class`` and implement the abstract
    methods."""

    name: str = ""
    #: What the task's reference point is, in a few words (help texts: ``tognet plan --reference``).
    reference_point: str = ""
    #: The task's config class (a section of ``SimConfig`` named after the task); its defaults when none
    #: is given.
    config_class: type = object
    #: The subsets of scenes the evaluation reports; the first is the task's headline (every scene here).
    subsets: tuple[SceneSubset, ...] = (SceneSubset("all", "all scenes"),)
    #: What the subsets break the scenes down by, for the report's heading ("" with one subset).
    subsets_by: str = ""
    #: What the report says under the breakdown by subset (why it is shown).
    subsets_note: str = ""

    def __init__(self, config: Any = None) -> None:
        self.config = config if config is not None else self.config_class()

    # --- action space -------------------------------------------------------------------------------
    @property
    def nominal_action(self) -> NDArray[np.float64]:
        """The action (a_x, a_y, a_z, a_phi) at the centre of the random baseline's box: zeros.

        The task's fixed nominal offset and yaw are added on top by :meth:`start_pose`.
        """
        return np.zeros(4)

    @property
    def action_low(self) -> NDArray[np.float64]:
        """Lower corner of the action box (the learned policy's and round-1 exploration's range)."""
        return np.asarray(self.config.action_low, dtype=np.float64)

    @property
    def action_high(self) -> NDArray[np.float64]:
        """Upper corner of the action box."""
        return np.asarray(self.config.action_high, dtype=np.float64)

    def random_action(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """The baselines' random action: uniform within +-5 cm (x, y, z) and +-pi/20 of the nominal."""
        half = np.array([0.05, 0.05, 0.05, np.pi / 20])
        return self.nominal_action + rng.uniform(-half, half)

    def uniform_action(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Uniform over the whole action box."""
        return rng.uniform(self.action_low, self.action_high)

    def check_action(self, action: Any) -> NDArray[np.float64]:
        """The action as a float64 (4,) array; a wrong shape or non-finite value raises ValueError."""
        arr = np.asarray(action, dtype=np.float64).reshape(-1)
        if arr.shape != (4,) or not np.all(np.isfinite(arr)):
            raise ValueError(
                f"{self.name}: an action is 4 finite numbers (a_x, a_y, a_z, a_phi), got {action!r}"
            )
        return arr

    def start_pose(self, reference: NDArray[np.float64], action: Any) -> tuple[NDArray[np.float64], float]:
        """Gripper start position (world) and yaw: reference + nominal offset + a_xyz, nominal yaw + a_phi."""
        a = self.check_action(action)
        offset = np.asarray(self.config.nominal_offset, dtype=np.float64)
        return np.asarray(reference, dtype=np.float64) + offset + a[:3], float(self.config.nominal_yaw + a[3])

    def scene_facts(self, layout: dict[str, Any]) -> dict[str, Any]:
        """Facts of one scene's layout that the evaluation records with each trial and chooses
        :attr:`subsets` by (none here)."""
        return {}

    def told_layout(self, reference: NDArray[np.float64]) -> dict[str, Any] | None:
        """The props' layout as a robot is told it: from the task's reference point alone, each prop's
        hidden properties (a can's mass) at the middle of their range; None where the reference point does
        not fix the layout (this base class)."""
        return None

    # --- to implement -------------------------------------------------------------------------------
    def sample_layout(self, rng: np.random.Generator) -> dict[str, Any]:
        """Random prop layout for one episode (plain numbers)."""
        raise NotImplementedError

    def reference(self, layout: dict[str, Any]) -> NDArray[np.float64]:
        """The task's reference point (world) for this layout."""
        raise NotImplementedError

    def primitive(self) -> list[Motion]:
        """The motion primitive, run from the start pose."""
        raise NotImplementedError

    def evaluate(self, outcome: TaskOutcome) -> tuple[bool, FailureReason]:
        """Task success and, if it failed, why."""
        raise NotImplementedError

    def progress(self, values: dict[str, Any]) -> float:
        """How much of the task a trial did, in [0, 1] (1 for a success), from the outcome values its props
        measured (``TrialResult.info``): a graded label beside S_T, so that a trial that nearly worked can
        teach more than a bare failure. NaN when the values do not say (this base class)."""
        return float("nan")
