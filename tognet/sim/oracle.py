"""Hand-computed ("oracle") actions for any grasp on any object, from the settled scene's geometry.

Used to measure whether a task is feasible at all on an object (some (grasp, action) succeeds), by the
scripted diagnostics, by the evaluation's Oracle and, when a collection round asks for it
(``PolicyConfig.expert_actions``), as privileged exploration while collecting training data; never by a
planner a robot could run (they read the simulator's ground truth).

The tool is assumed to stay in the hand as it was grasped: its vertices are taken from the settled pose
into the gripper frame (x = jaw axis at yaw phi, z up, origin at the grasp centre). Each task computes its
actions from them (:meth:`tognet.tasks.props.TaskProps.oracle_actions`). The start yaw of every task is
absolute, so the grasp's phi versus phi + pi decides which side of the hand the tool is on.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.sim.simulator import Simulator
from tognet.tasks.props import tool_in_gripper

__all__ = ["task_actions", "tool_in_gripper"]


def task_actions(
    sim: Simulator, grasp: Grasp, in_hand: object = None, **options: Any
) -> list[NDArray[np.float64]]:
    """The candidate actions of the simulator's task for ``grasp`` in its settled scene; ``in_hand`` the
    (3, 4) pose of the tool in the hand a trial reported (default: the tool as it lies, taken into the
    hand); ``options`` go to the task's :meth:`~tognet.tasks.props.TaskProps.oracle_actions`."""
    if sim.task is None:
        raise ValueError(f"no hand-computed actions for task {sim.task_name!r}")
    return sim.props.oracle_actions(tool_in_gripper(sim, grasp, in_hand), **options)
