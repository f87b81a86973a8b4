"""The table a user's depth camera looks down on: a plane fitted to the image (or known from the camera's
pose), and the table frame every plan is computed in.

The **table frame**: z up along the table's normal, origin on the table top straight below the camera's
centre, x along the image's x axis laid onto the table (y = z cross x). It depends only on the camera and
the table, never on where a user put their world origin, so a plan does not change with the robot's frame;
a camera pose only replaces the fitted plane by the known one and adds world coordinates to the output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.geometry import CameraIntrinsics
from tognet.geometry.transforms import invert_pose, make_pose


class TableNotFoundError(TognetError):
    """No table plane could be fitted to the depth image."""


@dataclass(frozen=True)
class PlaneFitConfig(Config):
    """The robust fit of the table plane when no camera pose is given (RANSAC, then least squares)."""

    points: int = doc(8000, "Valid pixels sampled (on a regular grid) for the fit.")
    hypotheses: int = doc(
        128,
        "RANSAC plane hypotheses (three points each): 128 leave a table on 30 % of the image unfound with "
        "probability (1 - 0.3^3)^128 = 3 %, on half of it 4e-8.",
    )
    score_points: int = doc(1024, "Points each hypothesis is scored on (a random subset of ``points``).")
    inlier_distance: float = doc(
        0.01, "A point within this distance (m) of a hypothesis supports it (RANSAC's threshold)."
    )
    refine_distance: float = doc(
        0.004,
        "Least-squares refits use the points within max(this, 3 x the residual RMS) (m) of the last plane.",
    )
    refinements: int = doc(3, "Least-squares refits after RANSAC.")
    max_tilt: float = doc(
        50.0, "Planes whose normal is more than this (degrees) from the viewing direction are not the table."
    )
    min_inliers: float = doc(0.15, "The table must hold at least this fraction of the valid pixels.")
    level_gap: float = doc(
        0.05,
        "A plane parallel to the one holding most pixels (within ``parallel`` degrees), at least this much "
        "(m) nearer the camera and itself holding ``min_inliers`` of them, is the table: the larger one is "
        "a floor seen past the table's edge (a camera tilted over it, or far above). The highest such "
        "level is taken.",
    )
    parallel: float = doc(5.0, "Planes whose normals are within this (degrees) are parallel (``level_gap``).")
    seed: int = doc(0, "Seed of the point and hypothesis sampling (the fit is deterministic).")


@dataclass(frozen=True)
class TablePlane:
    """The table top in the camera frame: points p with ``normal . p + offset = 0``; ``normal`` (unit)
    points from the table towards the camera, so ``offset`` is the camera's height above the table (m).
    ``inliers``: fraction of the valid pixels on it; ``rms``: their residual (m); ``fitted``: from the
    image (False: from a camera pose)."""

    normal: NDArray[np.float64]
    offset: float
    inliers: float = 1.0
    rms: float = 0.0
    fitted: bool = False

    @property
    def tilt(self) -> float:
        """Angle (degrees) between the viewing direction and the table's downward normal."""
        return math.degrees(math.acos(float(np.clip(-self.normal[2], -1.0, 1.0))))

    def camera_from_table(self) -> NDArray[np.float64]:
        """The table frame in the camera frame (4 x 4): z = ``normal``, origin below the camera, x = the
        camera's x axis laid onto the table (see the module docstring)."""
        n = self.normal
        x = np.array([1.0, 0.0, 0.0]) - n[0] * n
        if np.linalg.norm(x) < 1e-6:  # cannot happen within max_tilt; guard anyway
            x = np.array([0.0, 1.0, 0.0]) - n[1] * n
        x /= np.linalg.norm(x)
        y = np.cross(n, x)
        return make_pose(np.stack([x, y, n], axis=1), -self.offset * n)

    def table_from_camera(self) -> NDArray[np.float64]:
        """The camera's pose in the table frame (4 x 4): what the planner's :class:`Camera` holds."""
        return invert_pose(self.camera_from_table())

    def depth_of_rays(self, intrinsics: CameraIntrinsics) -> NDArray[np.float32]:
        """(H, W) camera-frame depth at which each pixel's ray meets the plane (inf if it never does)."""
        k = intrinsics
        xn = (np.arange(k.width) - k.cx) / k.fx
        yn = (np.arange(k.height) - k.cy) / k.fy
        denom = self.normal[0] * xn[None, :] + self.normal[1] * yn[:, None] + self.normal[2]
        with np.errstate(divide="ignore"):
            t = np.where(denom < -1e-9, -self.offset / denom, np.inf)
        return t.astype(np.float32)


def plane_from_pose(world_from_camera: ArrayLike, table_z: float = 0.0) -> TablePlane:
    """The table plane (world z = ``table_z``) in the frame of a camera at ``world_from_camera``."""
    pose = np.asarray(world_from_camera, dtype=np.float64)
    normal = pose[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    return TablePlane(normal / np.linalg.norm(normal), float(pose[2, 3] - table_z))


def _grid_points(depth: NDArray[np.float32], k: CameraIntrinsics, n: int) -> NDArray[np.float64]:
    """Camera-frame points of valid pixels on a regular grid of about ``n`` of them."""
    valid = np.isfinite(depth)
    count = int(valid.sum())
    step = max(1, int(math.sqrt(count / max(n, 1))))
    sub = depth[::step, ::step]
    rows, cols = np.nonzero(np.isfinite(sub))
    z = sub[rows, cols].astype(np.float64)
    u, v = cols * step, rows * step
    return np.column_stack([(u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z])


def fit_table_plane(depth: NDArray[np.float32], intrinsics: CameraIntrinsics,
                    config: PlaneFitConfig | None = None) -> TablePlane:
    """The table plane of a depth image (metres, NaN holes): the plane holding most pixels among those
    facing the camera within ``max_tilt`` (RANSAC), or a parallel one nearer the camera that holds enough
    of them too (``level_gap``: the table above a floor), refined by least squares on its points.

    Raises :class:`TableNotFoundError` when no such plane holds ``min_inliers`` of the valid pixels."""
    cfg = config or PlaneFitConfig()
    rng = np.random.default_rng(cfg.seed)
    pts = _grid_points(depth, intrinsics, cfg.points)
    if len(pts) < 50:
        raise TableNotFoundError(f"too few valid pixels ({len(pts)}) to find the table plane")
    score = pts[rng.choice(len(pts), size=min(cfg.score_points, len(pts)), replace=False)]
    tri = pts[rng.integers(0, len(pts), size=(cfg.hypotheses, 3))]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    ok = length > 1e-9
    normals = normals[ok] / length[ok, None]
    offsets = -np.einsum("ij,ij->i", normals, tri[ok, 0])
    flip = offsets < 0  # orient every normal towards the camera (the origin): offset > 0
    normals[flip] *= -1
    offsets[flip] *= -1
    facing = -normals[:, 2] >= math.cos(math.radians(cfg.max_tilt))
    normals, offsets = normals[facing], offsets[facing]
    if len(normals) == 0:
        raise TableNotFoundError(f"no plane within {cfg.max_tilt:g} degrees of facing the camera")
    support = np.count_nonzero(np.abs(score @ normals.T + offsets) < cfg.inlier_distance, axis=0)
    best = int(np.argmax(support))
    # The highest large level parallel to the largest plane: a floor seen past the table's edge can hold
    # more pixels than the table.
    above = ((normals @ normals[best] > math.cos(math.radians(cfg.parallel)))
             & (support >= cfg.min_inliers * len(score)) & (offsets < offsets[best] - cfg.level_gap))
    if above.any():
        top = float(offsets[above].min())
        level = above & (offsets < top + cfg.level_gap)
        best = int(np.flatnonzero(level)[np.argmax(support[level])])
    n, c = normals[best], float(offsets[best])
    threshold = cfg.inlier_distance
    rms = 0.0
    for _ in range(max(cfg.refinements, 1)):
        inl = pts[np.abs(pts @ n + c) < threshold]
        if len(inl) < 3:
            break
        centre = inl.mean(axis=0)
        centred = inl - centre
        _, vecs = np.linalg.eigh(centred.T @ centred)  # the normal: the smallest eigenvalue's vector
        n = vecs[:, 0] if vecs[:, 0] @ centre < 0 else -vecs[:, 0]  # towards the camera
        c = float(-n @ centre)
        rms = float(np.sqrt(np.mean((centred @ n) ** 2)))
        threshold = max(cfg.refine_distance, 3 * rms)
    fraction = float((np.abs(pts @ n + c) < threshold).mean())
    if fraction < cfg.min_inliers or c <= 0:
        raise TableNotFoundError(
            f"no table plane: the largest plane facing the camera holds {100 * fraction:.0f} % of the valid "
            f"pixels (at least {100 * cfg.min_inliers:.0f} % needed); is the table in view?"
        )
    plane = TablePlane(n, c, fraction, rms, fitted=True)
    if plane.tilt > cfg.max_tilt:
        raise TableNotFoundError(f"the fitted table is tilted {plane.tilt:.0f} degrees from the viewing "
                                 f"direction (at most {cfg.max_tilt:g})")
    return plane
