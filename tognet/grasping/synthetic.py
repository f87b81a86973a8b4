"""A small pure-numpy ray caster for synthetic depth images of known shapes (tests, benchmarks, demos).

Scenes are a table plane (world z = ``table_z``) plus boxes and cylinders with arbitrary poses. The
returned image follows the project convention: float32 metres of camera-frame z, NaN where a ray hits
nothing (only possible when the table plane is switched off or seen edge-on).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.geometry import Camera, CameraIntrinsics, make_pose, rot_x, rot_y, rot_z


@dataclass(frozen=True)
class Box:
    """A box with half extents (hx, hy, hz) along its local axes, placed by ``rotation`` and ``center``."""

    center: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    rotation: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))

    @classmethod
    def on_table(
        cls, x: float, y: float, size: tuple[float, float, float], yaw: float = 0.0, table_z: float = 0.0
    ) -> Box:
        """A box of full ``size`` (sx, sy, sz) resting on the table, rotated by ``yaw`` about world z."""
        sx, sy, sz = size
        return cls((x, y, table_z + sz / 2), (sx / 2, sy / 2, sz / 2), rot_z(yaw))


@dataclass(frozen=True)
class Cylinder:
    """A solid cylinder whose axis is its local x axis (radius, half length), placed by rotation/center."""

    center: tuple[float, float, float]
    radius: float
    half_length: float
    rotation: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))

    @classmethod
    def lying(
        cls, x: float, y: float, radius: float, length: float, yaw: float = 0.0, table_z: float = 0.0
    ) -> Cylinder:
        """A cylinder lying on the table, its axis horizontal at yaw ``yaw``."""
        return cls((x, y, table_z + radius), radius, length / 2, rot_z(yaw))

    @classmethod
    def upright(cls, x: float, y: float, radius: float, height: float, table_z: float = 0.0) -> Cylinder:
        """A cylinder standing on the table (axis vertical)."""
        return cls((x, y, table_z + height / 2), radius, height / 2, rot_y(-np.pi / 2))


Shape = Box | Cylinder


def t_shape(
    x: float,
    y: float,
    yaw: float = 0.0,
    handle: tuple[float, float, float] = (0.22, 0.03, 0.03),
    head: tuple[float, float, float] = (0.04, 0.12, 0.035),
    table_z: float = 0.0,
) -> list[Shape]:
    """A T-shaped tool (hammer-like): a handle along local x and a head across its far end."""
    c, s = np.cos(yaw), np.sin(yaw)
    hx = -head[0] / 2  # handle centre offset so that the head sits at the +x end
    head_x = handle[0] / 2 - head[0] / 2 + hx
    out: list[Shape] = []
    for size, off in ((handle, hx), (head, head_x)):
        out.append(Box.on_table(x + c * off, y + s * off, size, yaw, table_z))
    return out


def tilted_camera(
    height: float = 0.9,
    *,
    x: float = 0.0,
    y: float = 0.0,
    yaw: float = 0.0,
    tilt: tuple[float, float] = (0, 0),
    intrinsics: CameraIntrinsics | None = None,
) -> Camera:
    """A camera at (x, y, height) looking down, yawed by ``yaw``, tilted by (about cam x, about cam y)."""
    base = Camera.looking_down(intrinsics or CameraIntrinsics.kinect2(), [x, y, height], yaw=yaw)
    rotation = base.pose[:3, :3] @ rot_x(tilt[0]) @ rot_y(tilt[1])
    return Camera(base.intrinsics, make_pose(rotation, [x, y, height]))


def _safe(d: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.where(np.abs(d) < 1e-12, 1e-12, d)


def _hit_box(o: NDArray[np.float64], d: NDArray[np.float64], box: Box) -> NDArray[np.float64]:
    r = np.asarray(box.rotation)
    ol = (o - np.asarray(box.center)) @ r  # world -> local (R^T x as row vectors)
    dl = _safe(d @ r)
    h = np.asarray(box.half_extents)
    t1 = (-h - ol) / dl
    t2 = (h - ol) / dl
    tmin = np.minimum(t1, t2).max(axis=-1)
    tmax = np.maximum(t1, t2).min(axis=-1)
    hit = (tmax >= tmin) & (tmin > 0)
    return np.where(hit, tmin, np.inf)


def _hit_cylinder(o: NDArray[np.float64], d: NDArray[np.float64], cyl: Cylinder) -> NDArray[np.float64]:
    r = np.asarray(cyl.rotation)
    ol = (o - np.asarray(cyl.center)) @ r
    dl = _safe(d @ r)
    a = dl[..., 1] ** 2 + dl[..., 2] ** 2
    b = 2 * (ol[..., 1] * dl[..., 1] + ol[..., 2] * dl[..., 2])
    c = ol[..., 1] ** 2 + ol[..., 2] ** 2 - cyl.radius**2
    disc = b * b - 4 * a * c
    with np.errstate(invalid="ignore"):
        t_side = (-b - np.sqrt(disc)) / (2 * a)
    x_side = ol[..., 0] + t_side * dl[..., 0]
    side_ok = (disc >= 0) & (np.abs(x_side) <= cyl.half_length) & (t_side > 0)
    best = np.where(side_ok, t_side, np.inf)
    for end in (-cyl.half_length, cyl.half_length):
        t_cap = (end - ol[..., 0]) / dl[..., 0]
        yy = ol[..., 1] + t_cap * dl[..., 1]
        zz = ol[..., 2] + t_cap * dl[..., 2]
        ok = (yy**2 + zz**2 <= cyl.radius**2) & (t_cap > 0)
        best = np.minimum(best, np.where(ok, t_cap, np.inf))
    return best


def render_depth(
    camera: Camera,
    shapes: list[Shape] | tuple[Shape, ...] = (),
    *,
    table_z: float | None = 0.0,
) -> NDArray[np.float32]:
    """Ray-cast a depth image (camera-frame z, metres, float32, NaN where nothing is hit)."""
    dirs_cam = camera.pixel_directions()  # z component 1, so the ray parameter is the camera depth
    rot = camera.pose[:3, :3]
    d = dirs_cam @ rot.T
    o = camera.position
    depth = np.full(d.shape[:2], np.inf)
    if table_z is not None:
        with np.errstate(divide="ignore"):
            t = (table_z - o[2]) / d[..., 2]
        depth = np.where(t > 0, t, np.inf)
    for shape in shapes:
        hit = _hit_box(o, d, shape) if isinstance(shape, Box) else _hit_cylinder(o, d, shape)
        depth = np.minimum(depth, hit)
    out = depth.astype(np.float32)
    out[~np.isfinite(out)] = np.nan
    return out


def rotate_shapes(shapes: list[Shape], angle: float, pivot: ArrayLike = (0.0, 0.0)) -> list[Shape]:
    """The shapes rotated by ``angle`` about the vertical axis through ``pivot`` (x, y)."""
    rz = rot_z(angle)
    p = np.array([*np.asarray(pivot, dtype=float)[:2], 0.0])
    out: list[Shape] = []
    for s in shapes:
        center = tuple(float(v) for v in rz @ (np.asarray(s.center) - p) + p)
        rotation = rz @ np.asarray(s.rotation)
        if isinstance(s, Box):
            out.append(Box(center, s.half_extents, rotation))  # type: ignore[arg-type]
        else:
            out.append(Cylinder(center, s.radius, s.half_length, rotation))  # type: ignore[arg-type]
    return out
