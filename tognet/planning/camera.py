"""A user's depth camera files: intrinsics and pose, read and written, checked field by field.

Pure numpy (no torch, no simulator). The files ``tognet plan`` reads and ``tognet sim --depth-png``
writes:

- depth: a 16-bit PNG in millimetres (0 = no reading), or .npy/.npz (float metres with NaN or 0 holes, or
  integer millimetres); see :func:`tognet.grasping.load_depth_file`.
- intrinsics (JSON): ``{"width": 640, "height": 480, "fx": 615.0, "fy": 615.0, "cx": 319.5, "cy": 239.5}``,
  pixels, pinhole, an undistorted image (see :func:`load_intrinsics` for the accepted variants).
- camera pose (JSON, optional): ``{"world_from_camera": [[4 x 4]]}``: the camera (OpenCV axes: x right, y
  down, z forward) in a world frame whose z = 0 plane is the table top, z up (the simulator's world).
  One file may hold both (``tognet.geometry.Camera.save`` writes it so).

The table the camera sees is :mod:`tognet.planning.table`; what stands on it, :mod:`tognet.planning.segment`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.errors import TognetError
from tognet.geometry import CameraIntrinsics, DepthImageError
from tognet.geometry.camera import focal_length_problem
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
