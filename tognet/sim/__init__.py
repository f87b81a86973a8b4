"""The simulated world (the only package that imports MuJoCo): table, camera, gripper, task props."""

import ctypes.util as _ctypes_util
import os as _os
import sys as _sys

# MuJoCo's offscreen renderer needs a GL backend chosen before mujoco is imported: EGL on a headless Linux. A
# machine without Mesa's EGL (`make system-deps` installs it) gets none, so that `import mujoco` does not
# trip over a half-present GL stack; only the animations then need it (they say so).
if _sys.platform.startswith("linux") and "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY"):
    _os.environ["MUJOCO_GL"] = "egl" if _ctypes_util.find_library("EGL") else "disable"

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
