"""The simulated world (the only package that imports MuJoCo): table, camera, gripper, task props."""

# MuJoCo's offscreen renderer needs its GL backend chosen before mujoco is imported (tognet.sim.gl): first.
from tognet.sim.gl import GL_PROBLEM

# isort: split
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
    "GL_PROBLEM",
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
