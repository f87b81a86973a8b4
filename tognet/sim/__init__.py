"""The simulated world (the only package that imports MuJoCo): table, camera, gripper, task props."""

import ctypes.util as _ctypes_util
import os as _os
import sys as _sys

# MuJoCo's offscreen renderer needs a GL backend chosen before mujoco is imported: EGL on a headless Linux. A
# machine without Mesa's EGL (`make system-deps` installs it) gets none, so that `import mujoco` does not
# trip over a half-present GL stack; only the animations then need it (they say so).
if _sys.platform.startswith("linux") and "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY"):
    _os.environ["MUJOCO_GL"] = "egl" if _ctypes_util.find_library("EGL") else "disable"

#: Why the MUJOCO_GL the user set cannot work (an unknown value, a backend whose library is missing), or
#: None. Such a value would make ``import mujoco`` fail, and with it every command, ``tognet --help``
#: included; MuJoCo is then imported with rendering disabled and the animations report this instead.
GL_PROBLEM: str | None = None


def _gl_problem(value: str) -> str | None:
    """Why ``MUJOCO_GL=value`` cannot work on this machine, or None."""
    key = value.lower().strip()
    if key in ("disable", "disabled", "off", "false", "0", ""):
        return None
    display = _os.environ.get("DISPLAY") or _os.environ.get("WAYLAND_DISPLAY")
    if key in ("enable", "enabled", "on", "true", "1", "glfw", "glx") and _sys.platform.startswith("linux") \
            and not display:
        return (f"MUJOCO_GL={value} needs a display (DISPLAY is not set); on a headless machine set "
                "MUJOCO_GL=egl (`make system-deps` installs Mesa's EGL)")
    if key in ("enable", "enabled", "on", "true", "1", "glfw"):
        return None
    linux = ("glx", "egl", "osmesa")
    if key not in linux or not _sys.platform.startswith("linux"):
        return (f"MUJOCO_GL={value} is not a rendering backend MuJoCo knows here (egl, osmesa, glx, glfw, or "
                "disable); unset it or set MUJOCO_GL=egl")
    library = {"egl": "EGL", "osmesa": "OSMesa", "glx": "GL"}[key]
    if _ctypes_util.find_library(library) is None:
        hint = {"egl": "install Mesa's EGL with `make system-deps` (apt-get install libegl1 libgl1 libgles2)",
                "osmesa": "install it (apt-get install libosmesa6) or set MUJOCO_GL=egl",
                "glx": "install it (apt-get install libgl1) or set MUJOCO_GL=egl"}[key]
        return f"MUJOCO_GL={value} needs the lib{library} library, which is not installed; {hint}"
    return None


GL_PROBLEM = _gl_problem(_os.environ.get("MUJOCO_GL", ""))
if GL_PROBLEM is not None:
    _os.environ["TOGNET_MUJOCO_GL_ASKED"] = _os.environ.get("MUJOCO_GL", "")
    _os.environ["MUJOCO_GL"] = "disable"
elif _os.environ.get("TOGNET_MUJOCO_GL_ASKED") and _os.environ.get("MUJOCO_GL") == "disable":
    GL_PROBLEM = _gl_problem(_os.environ["TOGNET_MUJOCO_GL_ASKED"])  # a worker of such a process

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
