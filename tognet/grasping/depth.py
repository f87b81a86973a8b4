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
    depth: NDArray[np.float32], holes: NDArray[np.bool_], max_passes: int = 16, rest: float | None = None
) -> NDArray[np.float32]:
    """Fill the ``holes`` of ``depth`` from their valid 8-neighbours, layer by layer, farthest first.

    Each pass gives every hole pixel that touches a valid (or already filled) pixel the largest
    (farthest) such neighbouring depth, so a hole straddling an object's edge takes the background's
    value and the object keeps its outline. Each pass looks only at the open pixels next to those the
    last one filled, so a large hole costs its filled rim, not its area times the passes. Holes still
    open after ``max_passes`` passes take ``rest`` when given, else the nearest valid pixel (distance
    transform).
    """
    if not holes.any():
        return depth
    h, w = depth.shape
    # A one-pixel border of -inf (never a neighbour's value, never open) spares the index clipping.
    pw = w + 2
    buf = np.full((h + 2, pw), -np.inf, dtype=np.float32)
    buf[1:-1, 1:-1] = np.where(holes, -np.inf, depth)
    open_ = np.zeros((h + 2, pw), dtype=bool)
    open_[1:-1, 1:-1] = holes
    closed = ~open_
    closed[0], closed[-1], closed[:, 0], closed[:, -1] = False, False, False, False
    near = np.zeros((h, w), dtype=bool)  # the holes' first layer: a valid 8-neighbour
    for dr in (0, 1, 2):
        for dc in (0, 1, 2):
            if dr != 1 or dc != 1:
                near |= closed[dr:dr + h, dc:dc + w]
    rows, cols = np.nonzero(holes & near)
    front = (rows + 1) * pw + cols + 1  # flat indices into the padded arrays
    offsets = np.array([-pw - 1, -pw, -pw + 1, -1, 1, pw - 1, pw, pw + 1])
    flat, flat_open = buf.ravel(), open_.ravel()
    stamp = np.zeros(flat.size, dtype=np.int32)  # for removing repeats without sorting
    for _ in range(max_passes):
        if front.size == 0:
            break
        nb = front[:, None] + offsets
        flat[front] = flat[nb].max(axis=1)  # open neighbours hold -inf
        flat_open[front] = False
        nxt = nb.ravel()
        nxt = nxt[flat_open[nxt]]  # the open neighbours of this layer: the next one, each once
        stamp[nxt] = np.arange(1, nxt.size + 1, dtype=np.int32)
        front = nxt[stamp[nxt] == np.arange(1, nxt.size + 1, dtype=np.int32)]
    out = buf[1:-1, 1:-1]
    left = open_[1:-1, 1:-1]
    if left.any():
        if rest is not None:
            out[left] = np.float32(rest)
        else:
            idx = ndimage.distance_transform_edt(left, return_distances=False, return_indices=True)
            out = out[idx[0], idx[1]]
    return np.ascontiguousarray(out, dtype=np.float32)


def height_map(depth: NDArray[np.float32], camera: Camera) -> NDArray[np.float32]:
    """World z of the point seen at every pixel of a (hole-free) depth image."""
    k = camera.intrinsics
    r = camera.pose[:3, :3]
    xn = ((np.arange(k.width) - k.cx) / k.fx).astype(np.float32)
    yn = ((np.arange(k.height) - k.cy) / k.fy).astype(np.float32)
    scale = np.float32(r[2, 0]) * xn[None, :] + np.float32(r[2, 1]) * yn[:, None] + np.float32(r[2, 2])
    return (depth * scale + np.float32(camera.pose[2, 3])).astype(np.float32)


def ray_height_scale(camera: Camera) -> NDArray[np.float32]:
    """(H, W) d(world z) / d(depth) along each pixel's ray: world z = depth * scale + camera z."""
    k = camera.intrinsics
    r = camera.pose[:3, :3]
    xn = ((np.arange(k.width) - k.cx) / k.fx).astype(np.float32)
    yn = ((np.arange(k.height) - k.cy) / k.fy).astype(np.float32)
    return np.float32(r[2, 0]) * xn[None, :] + np.float32(r[2, 1]) * yn[:, None] + np.float32(r[2, 2])


def fill_holes_by_height(
    depth: NDArray[np.float32], holes: NDArray[np.bool_], camera: Camera, max_passes: int = 16,
    height: NDArray[np.float32] | None = None,
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """(filled depth, height map): the holes filled in world height rather than in depth, each from its
    lowest neighbouring surface (:func:`fill_holes` on the negated heights), then put back on its own ray.

    For a camera looking straight down this is :func:`fill_holes`. For a tilted one it is what a hole
    means: a band with no return past the table's far edge continues the table instead of rising along
    the rays that kept the edge's depth (by 10 cm at 30 degrees), and a hole at an object's edge still
    takes the table's height, so the object keeps its outline. Holes farther than ``max_passes`` pixels
    from any reading take the table's height (world z = 0: ``camera`` is in the table frame). Rays that
    (nearly) never descend keep :func:`fill_holes`' depth. ``height``: the image's heights if already
    computed (:func:`height_map` of ``depth``, NaN at the holes)."""
    scale = ray_height_scale(camera)
    cz = np.float32(camera.pose[2, 3])
    if height is None:
        height = (depth * scale + cz).astype(np.float32)
    if not holes.any():
        return depth, height
    height = -fill_holes(-height, holes, max_passes, rest=0.0)
    down = scale < np.float32(-0.05)
    with np.errstate(divide="ignore", invalid="ignore"):
        filled = np.where(holes & down, (height - cz) / np.where(down, scale, np.float32(-1)), depth)
    if not np.all(down[holes]):
        far = fill_holes(depth, holes, max_passes)
        filled = np.where(holes & ~down, far, filled)
        height = np.where(holes & ~down, far * scale + cz, height)
    return filled.astype(np.float32), height.astype(np.float32)


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


#: The depth formats read, by suffix: (the file's first bytes, what the file should be).
DEPTH_FORMATS = {".npy": (b"\x93NUMPY", "a .npy file (no NumPy header)"),
                 ".npz": (b"PK", "a .npz file (not a zip archive)"),
                 ".png": (b"\x89PNG\r\n\x1a\n", "a PNG image (no PNG signature)")}


def load_depth_file(path: str | Path) -> NDArray[np.float32]:
    """Read a depth image from .npy / .npz (metres) or a 16-bit .png (millimetres).

    Integer .npy/.npz arrays are taken as millimetres (what sensors write). Raises FileNotFoundError or
    :class:`DepthImageError` naming the file and the problem.
    """
    return depth_in_metres(read_depth_file(path))


def read_depth_file(path: str | Path) -> NDArray:
    """The depth image of a file as stored (a 16-bit PNG's integer millimetres, a .npy/.npz array's own
    dtype), for callers that judge its unit (:func:`load_depth_file` converts it to metres)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"depth file not found: {path}")
    return read_depth_bytes(path.read_bytes(), path.suffix.lower(), str(path))


def depth_in_metres(raw: NDArray) -> NDArray[np.float32]:
    """A depth image as read (integer millimetres or float metres) in float32 metres."""
    if raw.dtype.kind in "iu":
        return (raw.astype(np.float32) / 1000.0).astype(np.float32, copy=False)
    return raw.astype(np.float32, copy=False)


def depth_suffix(data: bytes) -> str | None:
    """The format of depth image bytes by their first bytes (".png", ".npy", ".npz"), None if none."""
    return next((suffix for suffix, (magic, _) in DEPTH_FORMATS.items() if data.startswith(magic)), None)


def load_depth_bytes(data: bytes, suffix: str, where: str = "depth image") -> NDArray[np.float32]:
    """A depth image from the bytes of a file of type ``suffix`` (as :func:`load_depth_file`; ``where``
    names it in errors)."""
    return depth_in_metres(read_depth_bytes(data, suffix, where))


def read_depth_bytes(data: bytes, suffix: str, where: str = "depth image") -> NDArray:
    """The depth image of a file's bytes as stored (as :func:`read_depth_file`)."""
    import io

    magic = DEPTH_FORMATS.get(suffix)
    if magic is not None and not data.startswith(magic[0]):
        what = "empty" if not data else "damaged, or another format renamed?"
        raise DepthImageError(f"{where}: not {magic[1]}: {what}")
    try:
        if suffix == ".npy":
            arr = np.load(io.BytesIO(data), allow_pickle=False)
        elif suffix == ".npz":
            with np.load(io.BytesIO(data), allow_pickle=False) as npz:
                keys = list(npz.keys())
                key = "depth" if "depth" in keys else (keys[0] if len(keys) == 1 else None)
                if key is None:
                    raise DepthImageError(
                        f"{where}: .npz holds {keys}; expected one array or an array named 'depth'"
                    )
                arr = npz[key]
        elif suffix == ".png":
            from PIL import Image

            with Image.open(io.BytesIO(data)) as img:
                if img.mode not in ("I;16", "I;16B", "I;16L", "I"):
                    raise DepthImageError(
                        f"{where}: PNG mode {img.mode!r} is not a 16-bit depth image (millimetres expected)"
                    )
                arr = np.asarray(img)
        else:
            raise DepthImageError(f"{where}: unsupported depth file type {suffix!r} (use .npy, .npz or .png)")
    except DepthImageError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        text = str(exc)
        if "allow_pickle" in text or "pickled" in text:  # numpy's advice to unpickle is not ours to give
            raise DepthImageError(f"{where}: holds Python objects, not a numeric depth array") from None
        raise DepthImageError(f"{where}: cannot read depth image, damaged or truncated? ({text})") from None
    arr = np.asarray(arr)
    if arr.dtype.kind not in "fiu":
        raise DepthImageError(f"{where}: depth image must be numeric, got dtype {arr.dtype}")
    return arr
