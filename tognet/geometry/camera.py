"""Pinhole depth camera in OpenCV convention (x right, y down, z forward).

A depth image is float32 metres holding, per pixel, the z coordinate of the seen point in the camera
frame (what a Kinect2 reports), not the length of the ray. Holes are NaN; real sensors that write 0
for "no reading" are accepted and converted by :func:`validate_depth`.
Pixel (u, v) is column u, row v; the centre of the top-left pixel is (0, 0).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.geometry.transforms import invert_pose, make_pose, transform_points
from tognet.io import atomic_write_text


class DepthImageError(ValueError):
    """A depth image is not usable: wrong shape, dtype, units or all holes."""


#: The fields of view (degrees) a depth camera's focal length may give: outside them the focal length is
#: in the wrong unit (millimetres, metres) or belongs to another image size.
FIELD_OF_VIEW_DEG = (5.0, 160.0)


def focal_length_problem(name: str, focal: float, size: int) -> str | None:
    """Why ``focal`` pixels is not a plausible focal length for an image ``size`` pixels across (its field
    of view outside :data:`FIELD_OF_VIEW_DEG`), or None when it is."""
    if not (np.isfinite(focal) and focal > 0):
        return f"{name} must be a positive number of pixels, got {focal:g}"
    fov = float(np.degrees(2 * np.arctan(size / (2 * focal))))
    lo, hi = FIELD_OF_VIEW_DEG
    if lo <= fov <= hi:
        return None
    f_lo = size / (2 * np.tan(np.radians(hi) / 2))
    f_hi = size / (2 * np.tan(np.radians(lo) / 2))
    return (f"{name} = {focal:g} px gives a {fov:.3g} deg field of view across {size} pixels; a depth "
            f"camera's is {lo:g}-{hi:g} deg ({name} {f_lo:.0f}-{f_hi:.0f} px): focal lengths are in pixels, "
            "for this image size")


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics of a depth camera, in pixels."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def kinect2(cls) -> CameraIntrinsics:
        """Nominal Kinect2 depth intrinsics: 512 x 424, fx = fy = 365 px, centred principal point."""
        return cls(width=512, height=424, fx=365.0, fy=365.0, cx=255.5, cy=211.5)

    @property
    def matrix(self) -> NDArray[np.float64]:
        """The 3x3 K matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of the images this camera produces."""
        return (self.height, self.width)


@dataclass(frozen=True)
class Camera:
    """A depth camera: intrinsics and pose (world_from_camera, 4x4, OpenCV camera frame)."""

    intrinsics: CameraIntrinsics
    pose: NDArray[np.float64]

    def __post_init__(self) -> None:
        pose = np.asarray(self.pose, dtype=np.float64)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ValueError(f"camera pose must be a finite 4x4 matrix, got shape {pose.shape}")
        object.__setattr__(self, "pose", pose)

    @classmethod
    def looking_down(
        cls, intrinsics: CameraIntrinsics, position: ArrayLike, yaw: float = 0.0
    ) -> Camera:
        """A camera at ``position`` looking straight down (-z world); image x is world x rotated by yaw."""
        c, s = np.cos(yaw), np.sin(yaw)
        # camera x -> world (c, s, 0); camera z -> world -z; camera y = z cross x = (s, -c, 0).
        x_axis = np.array([c, s, 0.0])
        z_axis = np.array([0.0, 0.0, -1.0])
        y_axis = np.array([s, -c, 0.0])
        rotation = np.stack([x_axis, y_axis, z_axis], axis=1)
        return cls(intrinsics, make_pose(rotation, position))

    @classmethod
    def aimed_at(
        cls, intrinsics: CameraIntrinsics, target: ArrayLike, distance: float, tilt: float = 0.0,
        azimuth: float = 0.0, roll: float = 0.0,
    ) -> Camera:
        """A camera ``distance`` m from the world point ``target``, its optical axis through it and ``tilt``
        rad from straight down, set back from the target towards ``azimuth`` (the direction, in the world's
        xy plane, from the target to the point below the camera), rolled by ``roll`` about its axis (0:
        image x horizontal, at right angles to the azimuth)."""
        st, ct = np.sin(tilt), np.cos(tilt)
        ca, sa = np.cos(azimuth), np.sin(azimuth)
        z_axis = np.array([-st * ca, -st * sa, -ct])
        x0 = np.array([-sa, ca, 0.0])
        y0 = np.cross(z_axis, x0)
        cr, sr = np.cos(roll), np.sin(roll)
        x_axis, y_axis = cr * x0 + sr * y0, -sr * x0 + cr * y0
        position = np.asarray(target, dtype=np.float64).reshape(3) - distance * z_axis
        return cls(intrinsics, make_pose(np.stack([x_axis, y_axis, z_axis], axis=1), position))

    @property
    def position(self) -> NDArray[np.float64]:
        """Camera centre in the world frame."""
        return self.pose[:3, 3].copy()

    @property
    def camera_from_world(self) -> NDArray[np.float64]:
        """Inverse of :attr:`pose`."""
        return invert_pose(self.pose)

    def pixel_directions(self) -> NDArray[np.float64]:
        """(H, W, 3) ray directions in the camera frame, scaled so that their z component is 1."""
        k = self.intrinsics
        u, v = np.meshgrid(np.arange(k.width, dtype=np.float64), np.arange(k.height, dtype=np.float64))
        return np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, np.ones_like(u)], axis=-1)

    def deproject_pixels(self, u: ArrayLike, v: ArrayLike, depth: ArrayLike) -> NDArray[np.float64]:
        """World points (N, 3) of pixels (u, v) seen at camera-frame depth ``depth``."""
        k = self.intrinsics
        u, v, depth = (np.asarray(a, dtype=np.float64) for a in (u, v, depth))
        cam = np.stack([(u - k.cx) / k.fx * depth, (v - k.cy) / k.fy * depth, depth], axis=-1)
        return transform_points(self.pose, cam)

    def deproject(self, depth: ArrayLike) -> NDArray[np.float64]:
        """(H, W, 3) world points of a depth image (NaN where the image has holes)."""
        depth = np.asarray(depth, dtype=np.float64)
        cam = self.pixel_directions() * depth[..., None]
        return transform_points(self.pose, cam)

    def project(self, points: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Project world points (N, 3) to pixel coordinates (N, 2) and camera-frame depths (N,)."""
        cam = transform_points(self.camera_from_world, np.atleast_2d(np.asarray(points, dtype=np.float64)))
        k = self.intrinsics
        z = cam[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([cam[:, 0] / z * k.fx + k.cx, cam[:, 1] / z * k.fy + k.cy], axis=-1)
        return uv, z

    def to_dict(self) -> dict:
        """The camera file: the intrinsics (``width`` ... ``cy``, as ``tognet plan --intrinsics`` reads
        them) and the pose (``world_from_camera``, as ``--camera-pose`` reads it) in one JSON object, so
        the same file serves both options."""
        k = self.intrinsics
        return {"width": k.width, "height": k.height, "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
                "world_from_camera": self.pose.tolist(),
                "frame": "world_from_camera; OpenCV camera axes (x right, y down, z forward)"}

    @classmethod
    def from_dict(cls, data: dict) -> Camera:
        """Inverse of :meth:`to_dict` (the older layout, ``{"intrinsics": {...}, "pose": [...]}``, is read
        too); a malformed description raises ValueError naming the field."""
        try:
            k = data["intrinsics"] if isinstance(data.get("intrinsics"), dict) else data
            intr = CameraIntrinsics(
                width=int(k["width"]), height=int(k["height"]), fx=float(k["fx"]), fy=float(k["fy"]),
                cx=float(k["cx"]), cy=float(k["cy"]),
            )
            pose = np.asarray(data["world_from_camera"] if "world_from_camera" in data else data["pose"],
                              dtype=np.float64)
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"camera description is missing or has a malformed field: {exc}") from exc
        if intr.width <= 0 or intr.height <= 0 or intr.fx <= 0 or intr.fy <= 0:
            raise ValueError(f"camera intrinsics must be positive, got {intr}")
        return cls(intr, pose)

    def save(self, path: str | Path) -> Path:
        """Write the camera as JSON."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> Camera:
        """Read a camera JSON written by :meth:`save`."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"camera file not found: {path}")
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: not valid JSON ({exc})") from exc
        return cls.from_dict(data)


def validate_depth(
    depth: ArrayLike,
    intrinsics: CameraIntrinsics | None = None,
    *,
    min_depth: float = 0.05,
    max_depth: float = 10.0,
) -> NDArray[np.float32]:
    """Check a depth image and return it as float32 metres with holes as NaN.

    Zeros and non-finite values are holes. Raises :class:`DepthImageError` for a non-numeric dtype,
    a shape that is not 2-D (or not the camera's), an image that is all holes, or a median depth outside
    ``min_depth``..``max_depth`` (values in another unit; :mod:`tognet.planning.limits` judges which).
    """
    arr = np.asarray(depth)
    if arr.dtype.kind not in "fiu":
        raise DepthImageError(f"depth image must be numeric, got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[-1] == 1:
        arr = arr[..., 0]
    if arr.ndim != 2:
        raise DepthImageError(f"depth image must be 2-D (H, W), got shape {arr.shape}")
    if intrinsics is not None and arr.shape != intrinsics.shape:
        raise DepthImageError(
            f"depth image shape {arr.shape} does not match the camera's (height, width) {intrinsics.shape}"
        )
    out = arr.astype(np.float32, copy=True)
    out[~np.isfinite(out) | (out <= 0)] = np.nan
    valid = np.isfinite(out)
    if not valid.any():
        raise DepthImageError("depth image has no valid pixels (all NaN, zero or negative)")
    median = float(np.median(out[valid]))
    read = "16-bit PNGs and integer arrays are read as millimetres, float arrays as metres"
    if median > max_depth:
        raise DepthImageError(f"median depth {median:.1f} m exceeds {max_depth:g} m: the values in another "
                              f"unit? ({read}; `tognet plan` names the unit they look like)")
    if median < min_depth:
        raise DepthImageError(f"median depth {median:.4f} m is below {min_depth:g} m: the values in another "
                              f"unit? ({read}; `tognet plan` names the unit they look like)")
    return out
