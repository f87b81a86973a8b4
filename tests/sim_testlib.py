"""Helpers for the simulator tests."""

from __future__ import annotations

from tognet.geometry import Grasp
from tognet.objects.handmade import grasp_on_object
from tognet.sim import Simulator
from tognet.tasks.hammering_props import HAMMER_GRASPS


def far_end_grasp(sim: Simulator) -> Grasp:
    """The T hammer's far-end-of-the-handle grasp on the settled scene."""
    pos, rot = sim.object_pose()
    return grasp_on_object(pos, rot, *HAMMER_GRASPS["far_end"][:2])
