"""What every planner returns and the one signature they share.

    plan = planner.plan(observation, rng)        # or planner(observation, rng)
    sim.execute(plan.grasp_pose, plan.action, seed)

``observation`` is anything with a depth image, its camera and the task's name (the simulator's
:class:`tognet.sim.Observation`, or one built from a user's own depth image); ``rng`` a seeded
``numpy.random.Generator``: a plan is reproducible from (planner, observation, rng seed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.geometry import Grasp


class PlanningError(TognetError):
    """A planner found nothing to do on an observation (e.g. no antipodal grasp candidate at all)."""


@dataclass(frozen=True)
class Choice:
    """A grasp and action a planner ranked beside its plan (an alternative), with the method's own scores
    of it (:attr:`Plan.own`)."""

    grasp: NDArray[np.float64]
    action: NDArray[np.float64]
    own: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    """A grasp and an action for one observation, with how they were chosen.

    ``grasp``: (4,) world grasp (x, y, z, phi); ``action``: (4,) start pose of the task's primitive
    relative to its reference point (a_x, a_y, a_z m; a_phi rad), zeros for the grasp-only task.
    ``scores``: the numbers the planner chose by (e.g. ``q_t``, ``q_g``, the Oracle's search successes).
    ``timing``: seconds per stage (``depth``, ``candidates``, ``grasp``, ``action``, ``search``...) and
    ``total``. ``info``: anything else worth keeping (sources, the Oracle's search trials).
    ``own``: the method's own scores of its plan, from the models it uses: ``score`` (what it ranked its
    grasps by: :attr:`tognet.planning.methods.Method.score`) and its parts (``q_g``, ``q_t_given_g`` or,
    for the action search, ``q_t_given_ga`` of the chosen action, ``q_t``). ``alternatives``: the
    method's next grasps, ranked its way, each at least ``PlanConfig.alternatives.radius`` from those
    before (asked for with ``alternatives=`` by the user path; none in an evaluation).
    """

    method: str
    grasp: NDArray[np.float64]
    action: NDArray[np.float64]
    scores: dict[str, float] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    own: dict[str, float] = field(default_factory=dict)
    alternatives: tuple[Choice, ...] = ()

    @property
    def grasp_pose(self) -> Grasp:
        """The grasp as a :class:`tognet.geometry.Grasp` (what the simulator executes)."""
        return Grasp.from_array(self.grasp)


class Planner(Protocol):
    """Every method's interface: ``name`` and ``plan(observation, rng) -> Plan`` (also ``__call__``)."""

    name: str

    def plan(self, observation: Any, rng: np.random.Generator) -> Plan: ...

    def __call__(self, observation: Any, rng: np.random.Generator) -> Plan: ...
