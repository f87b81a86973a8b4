"""Animations of an episode with MuJoCo's offscreen renderer (EGL on a headless machine)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from tognet.errors import TognetError


class RenderError(TognetError):
    """MuJoCo's offscreen renderer cannot start on this machine (no GL backend)."""


class GifRecorder:
    """Captures a frame every ``every`` physics chunks while attached to a Simulator (``sim._recorder``)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int = 320,
        height: int = 240,
        every: int = 2,
        lookat: tuple[float, float, float] = (0.0, 0.0, 0.0),
        distance: float = 1.5,
        azimuth: float = 90.0,
        elevation: float = -40.0,
    ) -> None:
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
        self.camera.azimuth = azimuth
        self.camera.elevation = elevation
        self.option = mujoco.MjvOption()
        for group in range(6):
            self.option.geomgroup[group] = 1
        self.option.geomgroup[3] = 0  # the object's collision pieces duplicate its visual mesh
        self.every = every
        self.count = 0
        self.frames: list[np.ndarray] = []

    def __call__(self, sim: Any) -> None:
        self.count += 1
        if self.count % self.every == 0:
            self.capture(sim.data)

    def capture(self, data: mujoco.MjData) -> None:
        """Render one frame now."""
        self.renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        self.frames.append(self.renderer.render().copy())

    def save(self, path: str | Path, fps: int = 25, max_frames: int = 120) -> Path:
        """Write the frames as an animated GIF (thinned to at most ``max_frames``)."""
        import imageio.v2 as imageio

        frames = self.frames
        if len(frames) > max_frames:
            idx = np.linspace(0, len(frames) - 1, max_frames).round().astype(int)
            frames = [frames[i] for i in idx]
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        imageio.mimsave(path, frames, duration=1.0 / fps, loop=0)
        return path

    def close(self) -> None:
        """Free the GL context."""
        self.renderer.close()
