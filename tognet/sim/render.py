"""Animations of an episode with MuJoCo's offscreen renderer (EGL on a headless machine)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.io import atomic_path


class RenderError(TognetError):
    """MuJoCo's offscreen renderer cannot start on this machine (no GL backend)."""


def check_renderer() -> None:
    """Raise :class:`RenderError` (one line: what to set or install) when the MUJOCO_GL the user set
    cannot work; called before an episode that is to be animated, so the error comes first."""
    from tognet.sim.gl import GL_PROBLEM

    if GL_PROBLEM is not None:
        raise RenderError(f"cannot animate: {GL_PROBLEM}")


class GifRecorder:
    """Captures a frame every ``every`` physics chunks while attached to a Simulator (``sim.recording``),
    with the simulated time of each, so that :meth:`save` writes a GIF that plays at the real speed.
    ``max_fps``: skip chunks less than 1 / max_fps simulated seconds after the last frame (rendering is
    the cost: ~30 ms a frame with software GL). ``azimuth`` None: the camera looks from the table's side
    away from an arm (the arm's side without one)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int = 320,
        height: int = 240,
        every: int = 2,
        lookat: tuple[float, float, float] = (0.0, 0.0, 0.0),
        distance: float = 1.5,
        azimuth: float | None = None,
        elevation: float = -40.0,
        max_fps: float | None = None,
    ) -> None:
        check_renderer()
        try:
            self.renderer = mujoco.Renderer(model, height, width)
        except Exception as exc:  # no GL backend: say what to install rather than a GL stack trace
            backend = os.environ.get("MUJOCO_GL", "(default)")
            raise RenderError(
                f"MuJoCo's offscreen renderer did not start (MUJOCO_GL={backend}): {exc}. On a headless "
                "Debian/Ubuntu machine install Mesa's EGL with `make system-deps` (apt-get install libegl1 "
                "libgl1 libgles2); with a display, MUJOCO_GL=glfw."
            ) from exc
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = lookat
        self.camera.distance = distance
        if azimuth is None:  # from the table's -y side (90), unless an arm stands there: then from +y
            arm = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "arm_mount")
            azimuth = -90.0 if arm >= 0 and model.body_pos[arm][1] < 0 else 90.0
        self.camera.azimuth = azimuth
        self.camera.elevation = elevation
        self.option = mujoco.MjvOption()
        for group in range(6):
            self.option.geomgroup[group] = 1
        self.option.geomgroup[3] = 0  # the object's collision pieces duplicate its visual mesh
        self.every = every
        self.min_interval = 1.0 / max_fps if max_fps else 0.0
        self.count = 0
        self.frames: list[np.ndarray] = []
        self.times: list[float] = []

    def __call__(self, sim: Any) -> None:
        self.count += 1
        if self.count % self.every:
            return
        t = float(sim.data.time)
        if self.times and self.times[-1] <= t < self.times[-1] + self.min_interval - 1e-9:
            return
        self.capture(sim.data)

    def capture(self, data: mujoco.MjData) -> None:
        """Render one frame now."""
        self.renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        self.frames.append(self.renderer.render().copy())
        self.times.append(float(data.time))

    def elapsed(self) -> NDArray[np.float64]:
        """Simulated seconds since the first frame, per frame (a clock that restarts, e.g. a new trial,
        continues from where it was, one nominal 20 ms frame later)."""
        t = np.asarray(self.times, dtype=np.float64)
        if len(t) != len(self.frames):  # frames appended by hand: 20 ms apart
            return 0.02 * np.arange(len(self.frames))
        steps = np.diff(t, prepend=t[:1])
        steps[steps <= 0] = 0.02
        steps[0] = 0.0
        return np.cumsum(steps)

    def save(self, path: str | Path, fps: int = 25, max_frames: int = 120, speed: float = 1.0,
             hold: float = 0.5) -> Path:
        """Write the frames as an animated GIF that plays at ``speed`` times the simulated speed: at most
        ``fps`` frames per second of simulated time (and at most ``max_frames``: frames further apart
        when the episode is long), each shown for the simulated time until the next one (in the GIF's
        10 ms units, rounded so that the total is exact; browsers show delays under 20 ms as 100 ms, so
        none is). The last frame stays ``hold`` seconds longer."""
        from PIL import Image

        if not self.frames:
            raise ValueError("no frame to save")
        times = self.elapsed() / speed
        step = max(1.0 / fps, times[-1] / max(1, max_frames - 1), 0.02)
        keep = [0]
        for i in range(1, len(times)):
            if times[i] - times[keep[-1]] >= step - 1e-9:
                keep.append(i)
        centis = np.round(times[keep] * 100).astype(int)  # GIF delays are in hundredths of a second
        ends = np.append(centis[1:], centis[-1] + max(2, round(100 * step)) + round(100 * hold))
        delays = np.maximum(ends - centis, 2) * 10  # milliseconds
        images = [Image.fromarray(self.frames[i]) for i in keep]
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            images[0].save(tmp, save_all=True, append_images=images[1:], duration=[int(d) for d in delays],
                           loop=0, disposal=1)
        return path

    def close(self) -> None:
        """Free the GL context."""
        self.renderer.close()
