"""The simulated world (the only package that imports MuJoCo): table, camera, gripper, task props."""

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
