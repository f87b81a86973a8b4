"""A second depth camera of the simulated world: MuJoCo's own OpenGL depth rendering, through any pinhole
camera, and what a real sensor does to the image (range noise, holes, no return).

The simulator's depth camera (:mod:`tognet.sim.depth`) casts rays analytically and sees only the table, the
ground and the tool. This one rasterises every visible geom of a MuJoCo model (the task's props too: the
cans, the peg and its slot) with MuJoCo's renderer (EGL on a headless machine), for any intrinsics (an
asymmetric frustum: any fx, fy, cx, cy) and any pose. It is what the user-path benchmark and the tests of
``tognet plan`` photograph a scene with, so that the planner is never checked against its own geometry::

    cam = GLDepthCamera(sim.model)
    depth = cam.render(sim.data, Camera(intrinsics, world_from_camera))   # metres, NaN: nothing hit
    depth = SensorModel(range_noise=0.002).apply(depth, rng)              # a real sensor's artefacts

:class:`SensorModel` is pure numpy (no MuJoCo), usable on any depth image.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.geometry import Camera
from tognet.sim.groups import GROUP_DECOR, GROUP_OBJECT_VISUAL, GROUP_PROPS, GROUP_STATIC
from tognet.sim.render import RenderError

#: What the second camera sees by default: the table, the ground, the tool's visual mesh, the task's props
#: and the table's legs (not the gripper, nor the tool's collision pieces, which duplicate its mesh).
SEEN_GROUPS = (GROUP_STATIC, GROUP_OBJECT_VISUAL, GROUP_PROPS, GROUP_DECOR)


class GLDepthCamera:
    """MuJoCo's OpenGL depth (and geom-id) rendering of one model through any :class:`Camera`.

    ``groups``: the geom groups drawn. The model's offscreen buffer is enlarged to the largest image asked
    for (``model.vis.global_``, a visual setting only). Raises :class:`RenderError` when no GL backend
    starts (install Mesa's EGL: ``make system-deps``)."""

    def __init__(self, model: mujoco.MjModel, groups: tuple[int, ...] = SEEN_GROUPS) -> None:
        self.model = model
        self.option = mujoco.MjvOption()
        for g in range(len(self.option.geomgroup)):
            self.option.geomgroup[g] = 1 if g in groups else 0
        self._renderers: dict[tuple[int, int, str], Any] = {}

    def _renderer(self, width: int, height: int, kind: str) -> Any:
        key = (width, height, kind)
        r = self._renderers.get(key)
        if r is None:
            vis = self.model.vis.global_
            vis.offwidth, vis.offheight = max(int(vis.offwidth), width), max(int(vis.offheight), height)
            try:
                r = mujoco.Renderer(self.model, height, width)
            except Exception as exc:  # no GL backend: say what to install rather than a GL stack trace
                backend = os.environ.get("MUJOCO_GL", "(default)")
                raise RenderError(
                    f"MuJoCo's offscreen renderer did not start (MUJOCO_GL={backend}): {exc}. On a headless "
                    "Debian/Ubuntu machine install Mesa's EGL (`make system-deps`)."
                ) from exc
            if kind == "depth":
                r.enable_depth_rendering()
            else:
                r.enable_segmentation_rendering()
            self._renderers[key] = r
        return r

    def _draw(self, data: mujoco.MjData, camera: Camera, kind: str) -> NDArray[Any]:
        k = camera.intrinsics
        r = self._renderer(k.width, k.height, kind)
        r.update_scene(data, camera=mujoco.MjvCamera(), scene_option=self.option)
        m = self.model
        near, far = m.vis.map.znear * m.stat.extent, m.vis.map.zfar * m.stat.extent
        # OpenCV pixel (u, v) covers [u - 0.5, u + 0.5]; the frustum's sides at unit distance:
        left, right = (-0.5 - k.cx) / k.fx, (k.width - 0.5 - k.cx) / k.fx
        top, bottom = (k.cy + 0.5) / k.fy, -(k.height - 0.5 - k.cy) / k.fy  # GL's y is up, OpenCV's down
        rot, pos = camera.pose[:3, :3], camera.pose[:3, 3]
        for glcam in r.scene.camera:  # both eyes of MuJoCo's stereo pair: the same pinhole
            glcam.pos[:] = pos
            glcam.forward[:] = rot[:, 2]
            glcam.up[:] = -rot[:, 1]
            glcam.orthographic = 0
            glcam.frustum_near, glcam.frustum_far = near, far
            glcam.frustum_center = near * 0.5 * (left + right)
            glcam.frustum_width = near * 0.5 * (right - left)
            glcam.frustum_top, glcam.frustum_bottom = near * top, near * bottom
        return r.render()

    def render(self, data: mujoco.MjData, camera: Camera) -> NDArray[np.float32]:
        """(H, W) float32 camera-frame depth (metres) of the world in ``data``; NaN where nothing is hit."""
        depth = np.asarray(self._draw(data, camera, "depth"), dtype=np.float32).copy()
        m = self.model
        far = m.vis.map.zfar * m.stat.extent
        depth[~(depth < np.float32(0.999 * far))] = np.nan
        return depth

    def geom_ids(self, data: mujoco.MjData, camera: Camera) -> NDArray[np.int32]:
        """(H, W) id of the geom seen at each pixel (-1: none)."""
        seg = self._draw(data, camera, "segmentation")
        ids = np.asarray(seg[..., 0], dtype=np.int32).copy()
        ids[seg[..., 1] != int(mujoco.mjtObj.mjOBJ_GEOM)] = -1
        return ids

    def close(self) -> None:
        """Free the GL contexts."""
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()


@dataclass(frozen=True)
class SensorModel(Config):
    """What a real depth sensor does to a clean depth image (RealSense, Azure Kinect, Kinect2 alike)."""

    range_noise: float = doc(
        0.0015, "Standard deviation (m) of the Gaussian range noise at 1 m; it grows with depth squared "
        "(stereo and time-of-flight sensors alike: ~1-2 mm at 1 m)."
    )
    dropout: float = doc(0.01, "Fraction of the pixels lost at random (no reading).")
    edge_dropout: float = doc(
        0.5, "Probability that a pixel next to a depth step (``edge_step``) is lost: sensors lose most "
        "readings at silhouettes (mixed pixels, the projector's shadow)."
    )
    edge_step: float = doc(
        0.01, "A depth difference (m) to a 4-neighbour above this makes a silhouette pixel."
    )
    max_range: float = doc(3.0, "No return beyond this depth (m).")
    min_range: float = doc(0.2, "No return nearer than this depth (m).")
    quantum: float = doc(0.001, "Readings are rounded to this (m): 16-bit millimetre images.")

    def apply(self, depth: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.float32]:
        """``depth`` (metres, NaN holes) as this sensor would read it (NaN: no reading); a new array."""
        d = np.asarray(depth, dtype=np.float32).copy()
        lost = ~np.isfinite(d)
        if self.edge_dropout > 0:
            filled = np.where(lost, np.float32(np.inf), d)
            step = np.zeros(d.shape, dtype=bool)
            for axis in (0, 1):
                with np.errstate(invalid="ignore"):  # inf - inf: a hole's border, a step below
                    diff = np.abs(np.diff(filled, axis=axis))
                jump = ~(diff <= self.edge_step)
                if axis == 0:
                    step[1:] |= jump
                    step[:-1] |= jump
                else:
                    step[:, 1:] |= jump
                    step[:, :-1] |= jump
            lost |= step & (rng.random(d.shape) < self.edge_dropout)
        if self.dropout > 0:
            lost |= rng.random(d.shape) < self.dropout
        if self.range_noise > 0:
            sigma = np.float32(self.range_noise) * np.where(np.isfinite(d), d, 0) ** 2
            d += (rng.standard_normal(d.shape).astype(np.float32) * sigma).astype(np.float32)
        if self.quantum > 0:
            d = (np.rint(d / np.float32(self.quantum)) * np.float32(self.quantum)).astype(np.float32)
        lost |= ~(d <= self.max_range) | ~(d >= self.min_range)
        d[lost] = np.nan
        return d


def no_return_below(depth: NDArray[np.float32], camera: Camera, z: float = -0.01) -> NDArray[np.float32]:
    """``depth`` with every pixel that sees a point below world height ``z`` lost (NaN): a sensor with no
    return past the table's edge (a dark floor, out of range), as a camera tilted over the edge sees it."""
    k = camera.intrinsics
    xn = (np.arange(k.width) - k.cx) / k.fx
    yn = (np.arange(k.height) - k.cy) / k.fy
    r = camera.pose[:3, :3]
    scale = r[2, 0] * xn[None, :] + r[2, 1] * yn[:, None] + r[2, 2]
    height = depth * scale + camera.pose[2, 3]
    out = np.asarray(depth, dtype=np.float32).copy()
    out[~(height >= z)] = np.nan
    return out
