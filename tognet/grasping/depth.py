"""A depth image prepared once for sampling and cropping: validated, holes filled, world heights.

Real sensors leave holes (NaN or 0). They are filled from their valid neighbours, layer by layer,
taking the farthest neighbouring depth (holes at an object's edge become background, so the object
keeps its outline and no step is invented); very large holes fall back to the nearest valid pixel.
Every later stage works on the filled image; the hole mask is kept for reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tognet.geometry import Camera, DepthImageError, validate_depth


@dataclass(frozen=True)
class DepthScene:
    """A validated depth image with its camera, hole-filled depth and per-pixel world height.

    Attributes:
        camera: the camera model the image was taken with.
        depth: float32 metres of camera-frame z, NaN holes (as validated).
        filled: ``depth`` with holes filled (see :func:`fill_holes`).
        height: world z (metres) of the surface seen at each pixel, from ``filled``.
        holes: boolean mask of the holes in ``depth``.
    """

    camera: Camera
    depth: NDArray[np.float32]
    filled: NDArray[np.float32]
    height: NDArray[np.float32]
    holes: NDArray[np.bool_]


def fill_holes(
    depth: NDArray[np.float32], holes: NDArray[np.bool_], max_passes: int = 16
) -> NDArray[np.float32]:
    """Fill the ``holes`` of ``depth`` from their valid 8-neighbours, layer by layer, farthest first.

    Each pass gives every hole pixel that touches a valid pixel the largest (farthest) valid
    neighbouring depth, so a hole straddling an object's edge takes the background's value and the
    object keeps its outline. Only hole pixels are touched, so sparse sensor dropouts cost little;
    holes still open after ``max_passes`` passes take the nearest valid pixel (distance transform).
    """
    if not holes.any():
        return depth
    out = depth.copy()
    h, w = out.shape
    open_ = holes.copy()
    rows, cols = np.divmod(np.flatnonzero(open_), w)  # much faster than 2-D np.nonzero
    dr = np.array([-1, -1, -1, 0, 0, 1, 1, 1])
    dc = np.array([-1, 0, 1, -1, 1, -1, 0, 1])
    for _ in range(max_passes):
        if rows.size == 0:
            return out
        rr = np.clip(rows[:, None] + dr, 0, h - 1)
        cc = np.clip(cols[:, None] + dc, 0, w - 1)
        vals = np.where(open_[rr, cc], -np.inf, out[rr, cc])
        best = vals.max(axis=1)
        done = np.isfinite(best)
        out[rows[done], cols[done]] = best[done]
        open_[rows[done], cols[done]] = False
        rows, cols = rows[~done], cols[~done]
    if open_.any():
        idx = ndimage.distance_transform_edt(open_, return_distances=False, return_indices=True)
        out = out[idx[0], idx[1]]
    return out


def height_map(depth: NDArray[np.float32], camera: Camera) -> NDArray[np.float32]:
    """World z of the point seen at every pixel of a (hole-free) depth image."""
    k = camera.intrinsics
    r = camera.pose[:3, :3]
    xn = ((np.arange(k.width) - k.cx) / k.fx).astype(np.float32)
    yn = ((np.arange(k.height) - k.cy) / k.fy).astype(np.float32)
    scale = np.float32(r[2, 0]) * xn[None, :] + np.float32(r[2, 1]) * yn[:, None] + np.float32(r[2, 2])
    return (depth * scale + np.float32(camera.pose[2, 3])).astype(np.float32)


def prepare_depth(depth: NDArray | DepthScene, camera: Camera | None = None) -> DepthScene:
    """Validate ``depth`` against ``camera`` and precompute the filled image and height map.

    Passing an existing :class:`DepthScene` returns it unchanged, so callers may prepare once and
    hand the scene to both :func:`sample_antipodal` and :func:`extract_crops`.
    """
    if isinstance(depth, DepthScene):
        if camera is not None and camera is not depth.camera:
            if not np.array_equal(camera.pose, depth.camera.pose):
                raise ValueError("a prepared DepthScene was passed with a different camera (pose differs)")
            if camera.intrinsics != depth.camera.intrinsics:
                raise ValueError(
                    "a prepared DepthScene was passed with a different camera (intrinsics differ)"
                )
        return depth
    if camera is None:
        raise ValueError("a camera is needed to prepare a depth image")
    valid = validate_depth(depth, camera.intrinsics)
    holes = ~np.isfinite(valid)
    filled = fill_holes(valid, holes)
    return DepthScene(camera, valid, filled, height_map(filled, camera), holes)


def load_depth_file(path: str | Path) -> NDArray[np.float32]:
    """Read a depth image from .npy / .npz (metres) or a 16-bit .png (millimetres).

    Integer .npy/.npz arrays are taken as millimetres (what sensors write). Raises FileNotFoundError or
    :class:`DepthImageError` naming the file and the problem.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"depth file not found: {path}")
    suffix = path.suffix.lower()
    with open(path, "rb") as fh:
        head = fh.read(8)
    magic = {".npy": (b"\x93NUMPY", "a .npy file (no NumPy header)"),
             ".npz": (b"PK", "a .npz file (not a zip archive)"),
             ".png": (b"\x89PNG\r\n\x1a\n", "a PNG image (no PNG signature)")}.get(suffix)
    if magic is not None and not head.startswith(magic[0]):
        what = "empty" if not head else "damaged, or another format renamed?"
        raise DepthImageError(f"{path}: not {magic[1]}: {what}")
    try:
        if suffix == ".npy":
            arr = np.load(path, allow_pickle=False)
        elif suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                keys = list(data.keys())
                key = "depth" if "depth" in keys else (keys[0] if len(keys) == 1 else None)
                if key is None:
                    raise DepthImageError(
                        f"{path}: .npz holds {keys}; expected one array or an array named 'depth'"
                    )
                arr = data[key]
        elif suffix == ".png":
            from PIL import Image

            with Image.open(path) as img:
                if img.mode not in ("I;16", "I;16B", "I;16L", "I"):
                    raise DepthImageError(
                        f"{path}: PNG mode {img.mode!r} is not a 16-bit depth image (millimetres expected)"
                    )
                arr = np.asarray(img).astype(np.float32) / 1000.0
        else:
            raise DepthImageError(f"{path}: unsupported depth file type {suffix!r} (use .npy, .npz or .png)")
    except DepthImageError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        text = str(exc)
        if "allow_pickle" in text or "pickled" in text:  # numpy's advice to unpickle is not ours to give
            raise DepthImageError(f"{path}: holds Python objects, not a numeric depth array") from None
        raise DepthImageError(f"{path}: cannot read depth image, damaged or truncated? ({text})") from None
    arr = np.asarray(arr)
    if arr.dtype.kind in "iu" and suffix != ".png":
        arr = arr.astype(np.float32) / 1000.0
    if arr.dtype.kind not in "fiu":
        raise DepthImageError(f"{path}: depth image must be numeric, got dtype {arr.dtype}")
    return arr.astype(np.float32, copy=False)
