"""Choosing MuJoCo's GL backend before ``mujoco`` is imported (this module must not import it).

Imported first by :mod:`tognet.sim`: on a headless Linux it sets ``MUJOCO_GL=egl`` (or ``disable`` where
Mesa's EGL is missing), and a ``MUJOCO_GL`` the user set that cannot work here is recorded in
:data:`GL_PROBLEM` and replaced by ``disable``, so that only the animations fail (saying what to set),
never the import and with it every command.
"""

import ctypes.util as ctypes_util
import os
import sys

# MuJoCo's offscreen renderer needs a GL backend chosen before mujoco is imported: EGL on a headless Linux. A
# machine without Mesa's EGL (`make system-deps` installs it) gets none, so that `import mujoco` does not
# trip over a half-present GL stack; only the animations then need it (they say so).
if sys.platform.startswith("linux") and "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl" if ctypes_util.find_library("EGL") else "disable"

#: Why the MUJOCO_GL the user set cannot work (an unknown value, a backend whose library is missing), or
#: None. Such a value would make ``import mujoco`` fail, and with it every command, ``tognet --help``
#: included; MuJoCo is then imported with rendering disabled and the animations report this instead.
GL_PROBLEM: str | None = None


def _gl_problem(value: str) -> str | None:
    """Why ``MUJOCO_GL=value`` cannot work on this machine, or None."""
    key = value.lower().strip()
    if key in ("disable", "disabled", "off", "false", "0", ""):
        return None
    display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    if key in ("enable", "enabled", "on", "true", "1", "glfw", "glx") and sys.platform.startswith("linux") \
            and not display:
        return (f"MUJOCO_GL={value} needs a display (DISPLAY is not set); on a headless machine set "
                "MUJOCO_GL=egl (`make system-deps` installs Mesa's EGL)")
    if key in ("enable", "enabled", "on", "true", "1", "glfw"):
        return None
    linux = ("glx", "egl", "osmesa")
    if key not in linux or not sys.platform.startswith("linux"):
        return (f"MUJOCO_GL={value} is not a rendering backend MuJoCo knows here (egl, osmesa, glx, glfw, or "
                "disable); unset it or set MUJOCO_GL=egl")
    library = {"egl": "EGL", "osmesa": "OSMesa", "glx": "GL"}[key]
    if ctypes_util.find_library(library) is None:
        hint = {"egl": "install Mesa's EGL with `make system-deps` (apt-get install libegl1 libgl1 libgles2)",
                "osmesa": "install it (apt-get install libosmesa6) or set MUJOCO_GL=egl",
                "glx": "install it (apt-get install libgl1) or set MUJOCO_GL=egl"}[key]
        return f"MUJOCO_GL={value} needs the lib{library} library, which is not installed; {hint}"
    return None


GL_PROBLEM = _gl_problem(os.environ.get("MUJOCO_GL", ""))
if GL_PROBLEM is not None:
    os.environ["TOGNET_MUJOCO_GL_ASKED"] = os.environ.get("MUJOCO_GL", "")
    os.environ["MUJOCO_GL"] = "disable"
elif os.environ.get("TOGNET_MUJOCO_GL_ASKED") and os.environ.get("MUJOCO_GL") == "disable":
    GL_PROBLEM = _gl_problem(os.environ["TOGNET_MUJOCO_GL_ASKED"])  # a worker of such a process
