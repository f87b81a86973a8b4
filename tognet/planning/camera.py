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
from dataclasses import dataclass, replace
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
from tognet.io import atomic_path, atomic_write_text

INTRINSICS_KEYS = ("width", "height", "fx", "fy", "cx", "cy")
#: Other names for the intrinsics' fields (librealsense writes ppx/ppy).
_ALIASES = {"ppx": "cx", "ppy": "cy"}
#: Keys an intrinsics file may carry that do not change anything (descriptions).
_IGNORED = ("model", "frame", "comment", "description", "units", "camera", "serial",
            "world_from_camera", "pose")  # a camera file also holds the pose
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
    A camera file (``Camera.save``) is such an object with the pose beside (``world_from_camera``). Also
    accepted: the same under an ``"intrinsics"`` key (camera files of older versions), the
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

    The file holds ``{"world_from_camera": [[...], [...], [...], [...]]}`` (a camera file of
    ``Camera.save``, with the intrinsics beside, is one; also accepted: ``"pose"``, as older camera files
    have it, or a bare 4 x 4 list). The world frame's z = 0 plane must be the table top,
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
    with atomic_path(path) as tmp:
        Image.fromarray(mm).save(tmp)
    return path


def save_intrinsics(path: str | Path, k: CameraIntrinsics) -> Path:
    """Write the intrinsics file :func:`load_intrinsics` reads."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(intrinsics_dict(k), indent=2) + "\n")
    return path


def save_camera_pose(path: str | Path, world_from_camera: ArrayLike) -> Path:
    """Write the camera-pose file :func:`load_camera_pose` reads."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"world_from_camera": np.asarray(world_from_camera, dtype=np.float64).tolist(),
               "frame": "world_from_camera; OpenCV camera axes (x right, y down, z forward); world z = 0 is "
                        "the table top, z up"}
    atomic_write_text(path, json.dumps(payload, indent=2) + "\n")
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


# --- what stands on the table -----------------------------------------------------------------------------
@dataclass(frozen=True)
class SegmentConfig(Config):
    """What counts as an object a gripper can pick up off the table. Objects are made of measured pixels
    only: a hole (no reading) never makes an object nor adds to one's area or height."""

    min_height: float = doc(
        0.005,
        "A measured pixel is part of an object when its surface is this much (m) above the table plane (the "
        "antipodal sampler's ``min_object_height``), or ``noise_sigmas`` times the range noise at its "
        "depth if that is more.",
    )
    noise_sigmas: float = doc(
        3.0,
        "The height threshold is at least this many times the range noise at the pixel's depth (measured on "
        "the table's own pixels, growing with depth squared, see :func:`table_noise`): a far, noisy table "
        "does not rise into objects.",
    )
    min_area: float = doc(
        4e-4,
        "Regions whose measured pixels cover less than this (m^2, seen from above) are noise: not listed.",
    )
    max_area: float = doc(
        0.12,
        "An object covering more than this (m^2; 1,200 cm^2, a 60 x 20 cm board) is not something the "
        "gripper picks up: another surface (a shelf, a box), or the table's plane fitted wrong.",
    )
    max_height: float = doc(
        0.3,
        "An object whose top is more than this (m) above the table is not a tool lying on it: a wall, a "
        "person, or the table itself seen above the floor.",
    )
    min_measured: float = doc(
        0.5,
        "Share of an object's region (its measured pixels and the holes bridged into it, see ``bridge``) "
        "that must have been measured; less is mostly guessed.",
    )
    bridge: int = doc(
        2,
        "Holes within this many pixels of an object's measured pixels join them into one region, so that a "
        "dropout across a handle does not cut the tool in two; they never add to its area or height.",
    )
    core: int = doc(
        1,
        "A region must hold a pixel whose neighbours within this many pixels are all measured and above "
        "the table (a core): range noise alone almost never makes one, so the speckles of a far, noisy "
        "table are not objects (a 3 x 3 core: 1e-7 per pixel where noise lifts 16 % of them). 0: off.",
    )
    wall_ratio: float = doc(
        0.25,
        "A region touching the image border whose footprint on the table is thinner than this fraction of "
        "its rise is a vertical surface (a wall, a cupboard's side), not an object.",
    )
    centre_zone: float = doc(
        1 / 6,
        "Of the objects that look like something to pick up, the plan is made on the largest of those that "
        "reach within this fraction of the image's smaller side of its centre (the camera is taken to be "
        "aimed at the tool: a can or a block beside it is passed over), or else on the one nearest the "
        "centre.",
    )
    mask_margin: int = doc(
        2, "Pixels around an object not planned on that are replaced by the table too (its edge, its shadow)."
    )


@dataclass(frozen=True, eq=False)
class TableObject:
    """One region standing on the table: its measured pixels (``mask``), their area (m^2, seen from above),
    its top (m above the table: the 99th percentile of its heights), centre (table frame, z = 0) and centre
    pixel (u, v), the share of its region measured, its pixel box (u0, v0, u1, v1; exclusive ends), whether
    it touches the image border, ``rejected``: why it does not look like something to pick up (None: it
    does), ``index``: its place in :func:`segment_objects`' list, ``centre_distance``: pixels from the
    image's centre to its nearest pixel and ``central``: whether that is within ``centre_zone``."""

    mask: NDArray[np.bool_]
    area: float
    height: float
    centre: NDArray[np.float64]
    touches_border: bool
    measured: float = 1.0
    pixel: tuple[float, float] = (0.0, 0.0)
    box: tuple[int, int, int, int] = (0, 0, 0, 0)
    rejected: str | None = None
    index: int = 0
    centre_distance: float = 0.0
    central: bool = True

    @property
    def qualifies(self) -> bool:
        """It looks like something a gripper can pick up."""
        return self.rejected is None

    def summary(self) -> str:
        """One line: '#i: A cm^2, H mm high, at pixel (u, v)' (and why it was rejected)."""
        text = (f"#{self.index}: {self.area * 1e4:.0f} cm^2, {1000 * self.height:.0f} mm high, at pixel "
                f"({self.pixel[0]:.0f}, {self.pixel[1]:.0f})")
        return text if self.rejected is None else f"{text}, {self.rejected}"

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (no mask)."""
        return {"index": self.index, "area_cm2": round(self.area * 1e4, 1), "height_m": round(self.height, 4),
                "centre_table_m": [round(float(v), 4) for v in self.centre],
                "pixel": [round(float(v), 1) for v in self.pixel], "box_px": list(self.box),
                "pixels": int(self.mask.sum()), "measured_share": round(self.measured, 3),
                "touches_image_border": self.touches_border,
                "centre_distance_px": round(self.centre_distance, 1), "qualifies": self.qualifies,
                "rejected_because": self.rejected}


def _rejection(cfg: SegmentConfig, area: float, top: float, measured: float, thickness: float, rise: float,
               border: bool) -> str | None:
    """Why a region does not look like something a gripper picks up off the table (None: it does)."""
    if measured < cfg.min_measured:
        return (f"mostly unmeasured ({100 * measured:.0f} % of it measured, at least "
                f"{100 * cfg.min_measured:.0f} % needed)")
    if border and thickness < cfg.wall_ratio * rise:
        return (f"a vertical surface at the image's edge ({1000 * thickness:.0f} mm thick seen from above, "
                f"rising {1000 * rise:.0f} mm): a wall?")
    if top > cfg.max_height:
        return (f"too tall for a tool lying on the table (at most {1000 * cfg.max_height:.0f} mm): a wall, a "
                "person, or the table seen above the floor?")
    if area > cfg.max_area:
        return (f"larger than anything the gripper picks up (at most {1e4 * cfg.max_area:.0f} cm^2): another "
                "surface, or the table not flat?")
    return None


def table_noise(height: NDArray[np.float32], depth: NDArray[np.float32], band: float = 0.01,
                samples: int = 4000) -> tuple[float, float]:
    """(sigma, depth) of the range noise the table's own pixels show: the robust spread (1.4826 x the median
    absolute deviation) of the heights within ``band`` of the table, on a grid of about ``samples`` of
    them, and their median depth. (0, 1) when too few are seen."""
    step = max(1, int(math.sqrt(height.size / max(samples, 1))))
    h, d = height[::step, ::step].ravel(), depth[::step, ::step].ravel()
    with np.errstate(invalid="ignore"):
        on = np.abs(h) < band
    if np.count_nonzero(on) < 50:
        return 0.0, 1.0
    h, d = h[on].astype(np.float64), d[on].astype(np.float64)
    return 1.4826 * float(np.median(np.abs(h - np.median(h)))), float(np.median(d))


def segment_objects(height: NDArray[np.float32], depth: NDArray[np.float32], intrinsics: CameraIntrinsics,
                    table_from_camera: NDArray[np.float64], config: SegmentConfig | None = None,
                    noise: tuple[float, float] = (0.0, 1.0)) -> list[TableObject]:
    """Every region standing on the table, from measured pixels only, in the order a plan would choose
    them (``index``: the place in this list): first those that look like something a gripper picks up,
    those reaching within ``centre_zone`` of the image's centre largest first, then the others nearest the
    centre first; then the rest, largest first.

    ``height``: per pixel, m above the table, NaN where nothing was measured; ``depth``: the measured depth
    (NaN holes); ``table_from_camera``: the table frame; ``noise``: the range noise (sigma, at depth) of
    :func:`table_noise`. A region is 8-connected measured pixels more than ``min_height`` (or
    ``noise_sigmas`` x the noise at their depth) above the table, joined across holes at most ``bridge``
    pixels from them; its area sums its measured pixels' footprints on the table (depth^2 / (fx fy
    cos(incidence))), and regions under ``min_area`` or without a ``core`` (noise) are left out. A region
    is rejected (``TableObject.rejected`` says why) when mostly unmeasured, a vertical surface at the
    image's edge (a wall), taller than ``max_height`` or larger than ``max_area``."""
    cfg = config or SegmentConfig()
    k = intrinsics
    measured = np.isfinite(depth)
    sigma, at = noise
    with np.errstate(invalid="ignore"):
        if sigma > 0 and cfg.noise_sigmas * sigma * (np.nanmax(depth) / at) ** 2 > cfg.min_height:
            scale = np.float32(cfg.noise_sigmas * sigma / at**2)
            above = height > np.maximum(np.float32(cfg.min_height), scale * depth * depth)
        else:
            above = height > np.float32(cfg.min_height)
    rows_in, cols_in = np.flatnonzero(above.any(axis=1)), np.flatnonzero(above.any(axis=0))
    if rows_in.size == 0:
        return []
    # Everything below works in the box around what rises above the table (and the holes it may bridge).
    pad = cfg.bridge + 1
    r0, r1 = max(int(rows_in[0]) - pad, 0), min(int(rows_in[-1]) + pad + 1, k.height)
    c0, c1 = max(int(cols_in[0]) - pad, 0), min(int(cols_in[-1]) + pad + 1, k.width)
    box = (slice(r0, r1), slice(c0, c1))
    up, seen_px = above[box], measured[box]
    region = up
    if cfg.bridge > 0 and not seen_px.all():
        near = ndimage.binary_dilation(up, structure=np.ones((3, 3), dtype=bool), iterations=cfg.bridge)
        region = up | (near & ~seen_px)
    labels, count = ndimage.label(region, structure=np.ones((3, 3), dtype=bool))
    n = table_from_camera[2, :3]  # row 2 of the rotation: the table's z axis in camera coordinates
    rows, cols = np.divmod(np.flatnonzero(up), c1 - c0)
    lab = labels[rows, cols]
    rows, cols = rows + r0, cols + c0
    z = depth[rows, cols].astype(np.float64)
    xn, yn = (cols - k.cx) / k.fx, (rows - k.cy) / k.fy
    cos_inc = np.maximum(np.abs(n[0] * xn + n[1] * yn + n[2]), 0.05)
    areas = np.bincount(lab, weights=z * z / (k.fx * k.fy) / cos_inc, minlength=count + 1)
    seen = np.bincount(lab, minlength=count + 1)
    unseen = np.zeros_like(seen)
    if region is not up:  # the holes bridged into each region
        unseen = np.bincount(labels[region & ~seen_px], minlength=count + 1)
    keep = np.flatnonzero(areas >= cfg.min_area)
    keep = keep[keep > 0]
    if cfg.core > 0 and keep.size:
        core = ndimage.binary_erosion(up, structure=np.ones((3, 3), dtype=bool), iterations=cfg.core)
        keep = np.intersect1d(keep, labels[core])
    if keep.size == 0:
        return []
    slices = ndimage.find_objects(labels)
    out = [_region_object(labels[sl] == lab_id, up[sl], sl, (r0, c0), above.shape, depth, height, k,
                          table_from_camera, cfg, float(areas[lab_id]),
                          float(seen[lab_id] / (seen[lab_id] + unseen[lab_id])))
           for lab_id in keep for sl in (slices[lab_id - 1],)]
    out.sort(key=lambda o: (o.rejected is not None, o.rejected is None and not o.central,
                            o.centre_distance if o.rejected is None and not o.central else 0.0, -o.area))
    return [replace(o, index=i) for i, o in enumerate(out)]


def _region_object(in_label: NDArray[np.bool_], up: NDArray[np.bool_], sl: tuple[slice, slice],
                   offset: tuple[int, int], shape: tuple[int, ...], depth: NDArray[np.float32],
                   height: NDArray[np.float32], k: CameraIntrinsics, table_from_camera: NDArray[np.float64],
                   cfg: SegmentConfig, area: float, share: float) -> TableObject:
    """One labelled region (its bounding box ``sl`` within the search box at ``offset``) as a
    :class:`TableObject`: mask, height, footprint centre and thickness, border, reach to the image's
    centre, and whether (and why) it is rejected; ``index`` 0 until the list is sorted."""
    r0, c0 = offset
    local = in_label & up
    top_row, left = sl[0].start + r0, sl[1].start + c0
    bottom, right = sl[0].stop + r0, sl[1].stop + c0
    mask = np.zeros(shape, dtype=bool)
    mask[top_row:bottom, left:right] = local
    lr, lc = np.nonzero(local)
    lr, lc = lr + top_row, lc + left
    zz = depth[lr, lc].astype(np.float64)
    r, t = table_from_camera[:3, :3], table_from_camera[:3, 3]
    pts = np.column_stack([(lc - k.cx) / k.fx * zz, (lr - k.cy) / k.fy * zz, zz]) @ r.T + t
    hs = height[lr, lc].astype(np.float64)
    lo, top = np.percentile(hs, [5.0, 99.0])
    xy = pts[:, :2] - pts[:, :2].mean(axis=0)
    _, vecs = np.linalg.eigh(xy.T @ xy)
    across = xy @ vecs[:, 0]  # along the footprint's narrow direction
    thickness = float(np.subtract(*np.percentile(across, [95.0, 5.0])))
    centre = np.array([*pts[:, :2].mean(axis=0), 0.0])
    border = bool(top_row == 0 or left == 0 or bottom == k.height or right == k.width)
    reach = float(np.min(np.hypot(lc - 0.5 * (k.width - 1), lr - 0.5 * (k.height - 1))))
    return TableObject(
        mask, area, float(top), centre, border, share, (float(lc.mean()), float(lr.mean())),
        (left, top_row, right, bottom),
        _rejection(cfg, area, float(top), share, thickness, float(top - lo), border), 0, reach,
        reach <= cfg.centre_zone * min(k.width, k.height))


def choice_reason(fit: list[TableObject], first: int = 0) -> str:
    """Why ``fit[first]`` is planned on, of the objects ``fit`` that look like something to pick up, in
    :func:`segment_objects`' order."""
    central = [o for o in fit if o.central]
    if fit[first].central:
        if len(central) == 1:
            return (f"the only one near the image's centre of the {len(fit)} objects that look like "
                    "something to pick up")
        return (f"the largest of the {len(central)} objects near the image's centre that look like something "
                "to pick up" + (" on which the gripper finds a grasp" if first else ""))
    return (f"the nearest to the image's centre of the {len(fit)} objects that look like something to pick up"
            + (" on which the gripper finds a grasp" if first else ""))


def pick_object(objects: list[TableObject], choice: int | tuple[float, float] | None = None,
                near: float = 15.0) -> tuple[TableObject, str]:
    """The object to plan on and why: ``choice`` None: the first of :func:`segment_objects`' list that
    looks like something to pick up (the largest near the image's centre, else the nearest to it); an int:
    that index of ``objects``; (u, v): the object at that pixel (or the nearest within ``near`` pixels).
    Raises :class:`NoObjectError` naming what was seen when there is nothing to choose."""
    if choice is None:
        fit = [o for o in objects if o.qualifies]
        if not fit:
            raise NoObjectError("no object on the table looks like something the gripper can pick up; seen: "
                                + "; ".join(o.summary() for o in objects[:4])
                                + (f"; and {len(objects) - 4} more" if len(objects) > 4 else ""))
        if len(fit) == 1:
            return fit[0], "the only object that looks like something to pick up"
        return fit[0], choice_reason(fit)
    if isinstance(choice, int | np.integer) and not isinstance(choice, bool):
        i = int(choice)
        if not 0 <= i < len(objects):
            raise NoObjectError(f"no object #{i}: the image shows {len(objects)} (#0 to "
                                f"#{len(objects) - 1}): " + "; ".join(o.summary() for o in objects[:6]))
        return objects[i], f"object #{i}, as asked"
    try:
        u, v = (float(c) for c in choice)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"an object is chosen by its index or by a pixel (u, v), got {choice!r}") from None
    best, dist = None, math.inf
    for o in objects:
        rows, cols = np.nonzero(o.mask)
        d = float(np.min(np.hypot(cols - u, rows - v)))
        if d < dist:
            best, dist = o, d
    if best is None or dist > near:
        seen = "; ".join(o.summary() for o in objects[:6]) if objects else "nothing stands on the table"
        raise NoObjectError(f"no object at pixel ({u:g}, {v:g}) (none within {near:g} pixels); seen: {seen}")
    return best, f"object #{best.index}, at pixel ({u:g}, {v:g}) as asked"


def mask_to_table(depth: NDArray[np.float32], mask: NDArray[np.bool_], plane: TablePlane,
                  intrinsics: CameraIntrinsics, margin: int = 2) -> NDArray[np.float32]:
    """``depth`` with the pixels of ``mask`` (grown by ``margin``) replaced by the table plane's depth."""
    grown = ndimage.binary_dilation(mask, iterations=margin) if margin > 0 else mask
    out = depth.copy()
    out[grown] = plane.depth_of_rays(intrinsics)[grown]
    return out
