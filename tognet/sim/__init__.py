"""The simulated world (the only package that imports MuJoCo): table, camera, gripper, task props."""

import os as _os

# MuJoCo's offscreen renderer needs a GL backend chosen before mujoco is imported: EGL when headless.
if "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY"):
    _os.environ["MUJOCO_GL"] = "egl"

from tognet.sim.config import (
    CameraConfig,
    EpisodeConfig,
    GripperConfig,
    PhysicsConfig,
    SimConfig,
    WorldConfig,
)
from tognet.sim.simulator import Observation, SimulationError, Simulator, TrialResult
from tognet.tasks.base import FailureReason

__all__ = [
    "CameraConfig",
    "EpisodeConfig",
    "FailureReason",
    "GripperConfig",
    "Observation",
    "PhysicsConfig",
    "SimConfig",
    "SimulationError",
    "Simulator",
    "TrialResult",
    "WorldConfig",
]
