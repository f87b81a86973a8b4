"""A user's depth camera: intrinsics and pose files, the table plane, the table frame and what stands on it.

Pure numpy/scipy (no torch, no simulator). The files ``tognet plan`` reads and ``tognet sim --depth-png``
writes:

- depth: a 16-bit PNG in millimetres (0 = no reading), or .npy/.npz (float metres with NaN or 0 holes, or
  integer millimetres); see :func:`tognet.grasping.load_depth_file`.
- intrinsics (JSON): ``{"width": 640, "height": 480, "fx": 615.0, "fy": 615.0, "cx": 319.5, "cy": 239.5}``,
  pixels, pinhole, an undistorted image (see :func:`load_intrinsics` for the accepted variants).
- camera pose (JSON, optional): ``{"world_from_camera": [[4 x 4]]}``: the camera (OpenCV axes: x right, y
  down, z forward) in a world frame whose z = 0 plane is the table top, z up (the simulator's world).

The **table frame** every plan is computed in: z up along the table's normal, origin on the table top
straight below the camera's centre, x along the image's x axis laid onto the table (y = z cross x). It
depends only on the camera and the table, never on where a user put their world origin, so a plan does
not change with the robot's frame; a camera pose only replaces the fitted plane by the known one and adds
world coordinates to the output.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.geometry import CameraIntrinsics, DepthImageError
from tognet.geometry.camera import focal_length_problem
from tognet.geometry.transforms import invert_pose, make_pose

INTRINSICS_KEYS = ("width", "height", "fx", "fy", "cx", "cy")
#: Other names for the intrinsics' fields (librealsense writes ppx/ppy).
_ALIASES = {"ppx": "cx", "ppy": "cy"}
#: Keys an intrinsics file may carry that do not change anything (descriptions).
_IGNORED = ("model", "frame", "comment", "description", "units", "camera", "serial")
_DISTORTION = ("coeffs", "distortion", "dist_coeffs", "d")


class CameraFileError(TognetError):
    """An intrinsics or camera-pose file (or value) is malformed; the message names it and the field."""


class TableNotFoundError(TognetError):
    """No table plane could be fitted to the depth image."""


class NoObjectError(TognetError):
    """Nothing stands on the table."""


# --- files ------------------------------------------------------------------------------------------------
def _read_json(path: Path, what: str) -> Any:
    if not path.is_file():
        folder = " (it is a folder)" if path.is_dir() else ""
        raise FileNotFoundError(f"{what} file not found: {path}{folder}")
    try:
        return json.loads(path.read_text())
    except UnicodeDecodeError as exc:
        raise CameraFileError(f"{path}: not a JSON text file ({exc.reason})") from None
    except json.JSONDecodeError as exc:
        raise CameraFileError(f"{path}: not valid JSON ({exc})") from None


def load_intrinsics(source: str | Path | dict[str, Any] | CameraIntrinsics) -> CameraIntrinsics:
    """Pinhole intrinsics from a JSON file, a dict or :class:`CameraIntrinsics`.

    The JSON object holds ``width``, ``height`` (pixels, integers), ``fx``, ``fy``, ``cx``, ``cy`` (pixels).
    Also accepted: the same under an ``"intrinsics"`` key (a camera file written by ``Camera.save``), the
    names ``ppx``/``ppy`` for ``cx``/``cy`` (librealsense), descriptive keys (``model``, ``frame``,
    ``comment``, ...) and all-zero distortion coefficients (``coeffs``). Anything else (an unknown key,
    a missing or non-positive value, a principal point outside the image, non-zero distortion) raises
    :class:`CameraFileError` naming the file and the field.
    """
    if isinstance(source, CameraIntrinsics):
        data: Any = {k: getattr(source, k) for k in INTRINSICS_KEYS}
        where = "intrinsics"
    elif isinstance(source, dict):
        data, where = source, "intrinsics"
    else:
        path = Path(source)
        data, where = _read_json(path, "intrinsics"), str(path)
    if isinstance(data, dict) and isinstance(data.get("intrinsics"), dict):
        data = data["intrinsics"]
    if not isinstance(data, dict):
        raise CameraFileError(f"{where}: expected a JSON object with {', '.join(INTRINSICS_KEYS)}")
    values: dict[str, Any] = {}
    for key, value in data.items():
        name = _ALIASES.get(key, key)
        if name in INTRINSICS_KEYS:
            values[name] = value
        elif key in _DISTORTION:
            coeffs = np.asarray(value, dtype=object).reshape(-1)
            if any(not isinstance(c, int | float) or c != 0 for c in coeffs):
                raise CameraFileError(
                    f"{where}: non-zero distortion coefficients '{key}': tognet models an undistorted "
                    "pinhole image; undistort the depth image first (e.g. OpenCV's undistort), drop the key"
                )
        elif key not in _IGNORED and key not in ("pose", "intrinsics") and not key.startswith("_"):
            raise CameraFileError(f"{where}: unknown key '{key}'; an intrinsics file holds "
                                  f"{', '.join(INTRINSICS_KEYS)}")
    missing = [k for k in INTRINSICS_KEYS if k not in values]
    if missing:
        raise CameraFileError(f"{where}: missing {', '.join(missing)} (an intrinsics file holds "
                              f"{', '.join(INTRINSICS_KEYS)}, in pixels)")
    for key in ("width", "height"):
        v = values[key]
        if isinstance(v, bool) or not isinstance(v, int | float) or v != int(v) or v <= 0:
            raise CameraFileError(f"{where}: {key} must be a positive whole number of pixels, got {v!r}")
    for key in ("fx", "fy", "cx", "cy"):
        v = values[key]
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise CameraFileError(f"{where}: {key} must be a number of pixels, got {v!r}")
    k = CameraIntrinsics(width=int(values["width"]), height=int(values["height"]), fx=float(values["fx"]),
                         fy=float(values["fy"]), cx=float(values["cx"]), cy=float(values["cy"]))
    if k.fx <= 0 or k.fy <= 0:
        raise CameraFileError(f"{where}: fx and fy must be positive, got {k.fx:g}, {k.fy:g}")
    for name, focal, size in (("fx", k.fx, k.width), ("fy", k.fy, k.height)):
        problem = focal_length_problem(name, focal, size)
        if problem is not None:
            raise CameraFileError(f"{where}: {problem}")
    if not (-0.5 <= k.cx <= k.width - 0.5 and -0.5 <= k.cy <= k.height - 0.5):
        raise CameraFileError(
            f"{where}: principal point ({k.cx:g}, {k.cy:g}) lies outside the {k.width} x {k.height} image: "
            "intrinsics of another resolution, or width and height swapped?"
        )
    return k


def intrinsics_dict(k: CameraIntrinsics) -> dict[str, Any]:
    """The intrinsics file's content for ``k``."""
    return {"width": k.width, "height": k.height, "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy}


def load_camera_pose(source: str | Path | ArrayLike) -> NDArray[np.float64]:
    """The camera pose (world_from_camera, 4 x 4) from a JSON file or an array.

    The file holds ``{"world_from_camera": [[...], [...], [...], [...]]}`` (also accepted: ``"pose"``, as
    ``Camera.save`` writes, or a bare 4 x 4 list). The world frame's z = 0 plane must be the table top,
    z up; the rotation must be proper and the camera above the table, looking at it.
    """
    where = "camera pose"
    if isinstance(source, str | Path):
        path = Path(source)
        where = str(path)
        data = _read_json(path, "camera pose")
        if isinstance(data, dict):
            key = next((k for k in ("world_from_camera", "pose") if k in data), None)
            if key is None:
                raise CameraFileError(f"{where}: expected a 'world_from_camera' 4 x 4 matrix")
            data = data[key]
    else:
        data = source
    try:
        pose = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError):
        raise CameraFileError(f"{where}: world_from_camera must be a 4 x 4 matrix of numbers") from None
    if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
        raise CameraFileError(f"{where}: world_from_camera must be a finite 4 x 4 matrix, got shape "
                              f"{pose.shape}")
    if not np.allclose(pose[3], [0, 0, 0, 1], atol=1e-6):
        raise CameraFileError(f"{where}: the last row of world_from_camera must be 0 0 0 1, got "
                              f"{pose[3].tolist()}")
    r = pose[:3, :3]
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-3) or np.linalg.det(r) < 0:
        raise CameraFileError(f"{where}: the rotation part of world_from_camera is not a rotation "
                              "(orthonormal, determinant +1)")
    if pose[2, 3] <= 0:
        raise CameraFileError(f"{where}: the camera is at z = {pose[2, 3]:.3f} m, not above the table top "
                              "(the world's z = 0 plane); is this camera_from_world (the inverse)?")
    if r[2, 2] > -0.2:
        tilt = math.degrees(math.acos(float(np.clip(-r[2, 2], -1, 1))))
        raise CameraFileError(f"{where}: the camera looks {tilt:.0f} degrees away from straight down, not at "
                              "the table (its z axis is the viewing direction, OpenCV axes)")
    return pose


def check_image_size(shape: tuple[int, ...], k: CameraIntrinsics, where: str = "depth image") -> None:
    """DepthImageError when a (H, W) image does not match the intrinsics' size, with a hint."""
    if len(shape) != 2 or tuple(shape) == k.shape:
        return
    h, w = shape
    hint = ""
    if (h, w) == (k.width, k.height):
        hint = " (the image is transposed, or width and height are swapped in the intrinsics)"
    elif w * k.height == h * k.width:
        hint = f" (same aspect: scale fx, fy, cx, cy by {w / k.width:g} for this resolution)"
    raise DepthImageError(f"{where} is {w} x {h} pixels but the intrinsics are for {k.width} x {k.height}"
                          f"{hint}")


def save_depth_png(path: str | Path, depth: ArrayLike) -> Path:
    """Write a depth image (metres, NaN holes) as a 16-bit PNG in millimetres (0 = hole)."""
    from PIL import Image

    d = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(d) & (d > 0)
    if np.any(d[valid] > 65.535):
        raise ValueError("depth beyond 65.535 m cannot be stored as 16-bit millimetres")
    mm = np.zeros(d.shape, dtype=np.uint16)
    mm[valid] = np.rint(d[valid] * 1000.0).astype(np.uint16)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(mm).save(path)
    return path


def save_intrinsics(path: str | Path, k: CameraIntrinsics) -> Path:
    """Write the intrinsics file :func:`load_intrinsics` reads."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(intrinsics_dict(k), indent=2) + "\n")
    return path


def save_camera_pose(path: str | Path, world_from_camera: ArrayLike) -> Path:
    """Write the camera-pose file :func:`load_camera_pose` reads."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"world_from_camera": np.asarray(world_from_camera, dtype=np.float64).tolist(),
               "frame": "world_from_camera; OpenCV camera axes (x right, y down, z forward); world z = 0 is "
                        "the table top, z up"}
    path.write_text(json.dumps(payload, indent=2) + "\n")
    return path


# --- the table plane --------------------------------------------------------------------------------------
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
    facing the camera within ``max_tilt`` (RANSAC), refined by least squares on its points.

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


# --- what stands on the table -----------------------------------------------------------------------------
@dataclass(frozen=True)
class SegmentConfig(Config):
    """What counts as an object standing on the table."""

    min_height: float = doc(
        0.007, "A pixel is part of an object when its surface is this much (m) above the table plane."
    )
    min_area: float = doc(
        4e-4, "Connected regions smaller than this (m^2, seen from above) are noise, not objects."
    )
    mask_margin: int = doc(
        2, "Pixels around a smaller object that are replaced by the table too (its edge, its shadow)."
    )


@dataclass(frozen=True)
class TableObject:
    """One object on the table: its pixels, area (m^2), highest point (m) and centre (table frame)."""

    mask: NDArray[np.bool_]
    area: float
    height: float
    centre: NDArray[np.float64]
    touches_border: bool

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (no mask)."""
        return {"area_cm2": round(self.area * 1e4, 1), "height_m": round(self.height, 4),
                "centre_table_m": [round(float(v), 4) for v in self.centre],
                "pixels": int(self.mask.sum()), "touches_image_border": self.touches_border}


def segment_objects(height: NDArray[np.float32], depth: NDArray[np.float32], intrinsics: CameraIntrinsics,
                    table_from_camera: NDArray[np.float64], config: SegmentConfig | None = None
                    ) -> list[TableObject]:
    """The objects standing on the table, largest first: 8-connected regions of pixels more than
    ``min_height`` above the table (``height``: per pixel, table frame; ``depth``: hole-filled) covering
    at least ``min_area`` (each pixel's footprint on the table: depth^2 / (fx fy cos(incidence)))."""
    cfg = config or SegmentConfig()
    above = height > np.float32(cfg.min_height)
    if not above.any():
        return []
    labels, count = ndimage.label(above, structure=np.ones((3, 3), dtype=bool))
    k = intrinsics
    n = table_from_camera[2, :3]  # row 2 of the rotation: the table's z axis in camera coordinates
    rows, cols = np.divmod(np.flatnonzero(above), k.width)
    z = depth[rows, cols].astype(np.float64)
    xn, yn = (cols - k.cx) / k.fx, (rows - k.cy) / k.fy
    cos_inc = np.maximum(np.abs(n[0] * xn + n[1] * yn + n[2]), 0.05)
    areas = np.bincount(labels[rows, cols], weights=z * z / (k.fx * k.fy) / cos_inc, minlength=count + 1)
    keep = np.flatnonzero(areas >= cfg.min_area)
    keep = keep[keep > 0]
    if keep.size == 0:
        return []
    slices = ndimage.find_objects(labels)
    out = []
    r, t = table_from_camera[:3, :3], table_from_camera[:3, 3]
    for lab in keep:
        sl = slices[lab - 1]
        local = labels[sl] == lab
        mask = np.zeros(labels.shape, dtype=bool)
        mask[sl] = local
        top = float(height[sl][local].max())
        lr, lc = np.nonzero(local)
        lr, lc = lr + sl[0].start, lc + sl[1].start
        zz = depth[lr, lc].astype(np.float64)
        cam = np.column_stack([(lc - k.cx) / k.fx * zz, (lr - k.cy) / k.fy * zz, zz])
        centre = (cam @ r.T + t).mean(axis=0)
        centre[2] = 0.0
        border = bool(sl[0].start == 0 or sl[1].start == 0 or sl[0].stop == k.height or sl[1].stop == k.width)
        out.append(TableObject(mask, float(areas[lab]), top, centre, border))
    out.sort(key=lambda o: -o.area)
    return out


def mask_to_table(depth: NDArray[np.float32], mask: NDArray[np.bool_], plane: TablePlane,
                  intrinsics: CameraIntrinsics, margin: int = 2) -> NDArray[np.float32]:
    """``depth`` with the pixels of ``mask`` (grown by ``margin``) replaced by the table plane's depth."""
    grown = ndimage.binary_dilation(mask, iterations=margin) if margin > 0 else mask
    out = depth.copy()
    out[grown] = plane.depth_of_rays(intrinsics)[grown]
    return out
