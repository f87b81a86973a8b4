"""Grasp-aligned depth crops at a fixed metric resolution (the network's image inputs).

For each grasp a square grid of ``size`` x ``size`` points is laid in the horizontal plane at the
grasp height, centred on the grasp centre, with columns along the jaw axis (phi) and rows along
(sin phi, -cos phi) (image "down" for a camera looking straight down with zero yaw). The grid is
projected through the camera and the image of world surface heights is sampled bilinearly there
(torch ``grid_sample``, all grasps in one call). Each value is

    crop = z_grasp - height_of_surface_seen,

the distance of the surface below the gripper centre. For a camera looking straight down this is
exactly ``depth - gripper depth``; using world heights instead of raw depth removes the gradient a
tilted camera would otherwise put across every crop. Because the grid is metric (``extent`` metres
across, whatever the camera's height or focal length), the crops do not change when the camera's
height or intrinsics are disturbed, only through small perspective effects (a surface far below the
grasp plane is seen slightly displaced away from the image centre). Holes were filled beforehand
(from their farthest valid neighbours, see :func:`tognet.grasping.depth.fill_holes`); grid points
outside the image read the table height.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc
from tognet.geometry import Camera
from tognet.grasping.depth import DepthScene, prepare_depth


@dataclass(frozen=True)
class CropConfig(Config):
    """Shape and metric extent of the grasp-aligned crops."""

    size: int = doc(64, "Crop side in pixels (the task/action streams' input).", ge=4)
    extent: float = doc(
        0.6,
        "Crop side in metres: the 64 px crop covers 0.6 m (9.4 mm per pixel), its 32 px centre 0.3 m. Wide "
        "enough that the whole tool lies inside the crop from nearly every grasp (a far-end grasp must see "
        "the head it strikes with; benchmarks/crop_coverage.py, RESULTS.md).",
        gt=0,
    )
    center_size: int = doc(32, "Side of the centre crop (the grasp-quality stream's input).", ge=1)
    table_z: float = doc(0.0, "World height (m) read for grid points that fall outside the image.")
    max_value: float | None = doc(
        0.3,
        "Values are clipped to at most this (m below the gripper centre): a floor seen past the table's "
        "edge (~0.75 m down) would otherwise dominate normalisation statistics. None: no clipping.",
    )

    @property
    def resolution(self) -> float:
        """Metres per crop pixel."""
        return self.extent / self.size


def crop_grid(grasps: NDArray[np.float64], config: CropConfig) -> NDArray[np.float64]:
    """(N, size, size, 3) world points of each grasp's crop grid (row i, column j)."""
    grasps = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
    s = (np.arange(config.size) - (config.size - 1) / 2) * config.resolution
    c, sn = np.cos(grasps[:, 3]), np.sin(grasps[:, 3])
    a = np.stack([c, sn], axis=1)  # columns: along the jaw axis
    b = np.stack([sn, -c], axis=1)  # rows: perpendicular
    xy = (
        grasps[:, None, None, :2]
        + s[None, None, :, None] * a[:, None, None, :]
        + s[None, :, None, None] * b[:, None, None, :]
    )
    z = np.broadcast_to(grasps[:, None, None, 2:3], xy.shape[:3] + (1,))
    return np.concatenate([xy, z], axis=-1)


def extract_crops(
    depth: NDArray | DepthScene, camera: Camera | None, grasps: NDArray[np.float64], config: CropConfig
) -> NDArray[np.float32]:
    """(N, size, size) float32 grasp-aligned crops (metres below the gripper centre), one vectorised call.

    ``depth`` is a raw image (validated, holes filled) or a :class:`DepthScene`. N = 0 gives an empty
    (0, size, size) array.
    """
    scene = prepare_depth(depth, camera)
    cam = scene.camera
    grasps = np.asarray(grasps, dtype=np.float64)
    if grasps.ndim != 2 or grasps.shape[1] != 4:
        raise ValueError(f"grasps must have shape (N, 4) (x, y, z, phi), got {grasps.shape}")
    if not np.all(np.isfinite(grasps)):
        raise ValueError("grasps contain NaN or infinite values")
    n, m = grasps.shape[0], config.size
    if n == 0:
        return np.zeros((0, m, m), dtype=np.float32)
    # The grid is affine in (i, j), so its camera-frame coordinates are too: X = X0 + i*Di + j*Dj.
    cam_from_world = cam.camera_from_world
    rot, trans = cam_from_world[:3, :3], cam_from_world[:3, 3]
    s0 = -(m - 1) / 2 * config.resolution
    c, sn = np.cos(grasps[:, 3]), np.sin(grasps[:, 3])
    zeros = np.zeros(n)
    a = np.stack([c, sn, zeros], axis=1)  # unit step along the columns (jaw axis)
    b = np.stack([sn, -c, zeros], axis=1)  # unit step along the rows
    origin = grasps[:, :3] + s0 * (a + b)
    p0 = origin @ rot.T + trans  # camera coordinates of grid point (0, 0)
    da = (a * config.resolution) @ rot.T
    db = (b * config.resolution) @ rot.T
    # Homogeneous normalised grid_sample coordinates are a 3x3 linear map of (1, i, j) per grasp:
    # (x_n w, y_n w, w) = A K [p0 | db | da] (1, i, j)^T, with A mapping pixels to [-1, 1].
    k = cam.intrinsics
    to_unit = np.array([[2.0 / (k.width - 1), 0.0, -1.0], [0.0, 2.0 / (k.height - 1), -1.0], [0.0, 0.0, 1.0]])
    maps = np.einsum("ab,bc,ncd->nad", to_unit, k.matrix, np.stack([p0, db, da], axis=2))
    maps = maps.astype(np.float32)
    ar = np.arange(m, dtype=np.float32)
    grid = np.empty((n, m, m, 2), dtype=np.float32)
    # Few full-size temporaries: large allocations dominate the cost at this size.
    w = maps[:, 2, 0, None, None] + ar[None, :, None] * maps[:, 2, 1, None, None]
    w = w + ar[None, None, :] * maps[:, 2, 2, None, None]
    np.reciprocal(np.maximum(w, np.float32(1e-6), out=w), out=w)
    for c in range(2):
        rows = maps[:, c, 0, None, None] + ar[None, :, None] * maps[:, c, 1, None, None]
        np.add(rows, ar[None, None, :] * maps[:, c, 2, None, None], out=grid[..., c])
        np.multiply(grid[..., c], w, out=grid[..., c])
    import torch  # here, not at the top: the configs and the shard format import this module

    height = scene.height if config.table_z == 0.0 else scene.height - np.float32(config.table_z)
    sampled = (
        torch.nn.functional.grid_sample(
            torch.from_numpy(height)[None, None],
            torch.from_numpy(grid).reshape(1, n * m, m, 2),
            mode="bilinear",
            padding_mode="zeros",
            align_corners=True,
        )
        .numpy()
        .reshape(n, m, m)
    )
    z = (grasps[:, 2] - config.table_z).astype(np.float32)
    out = np.subtract(z[:, None, None], sampled, out=sampled)
    if config.max_value is not None:
        np.minimum(out, np.float32(config.max_value), out=out)
    return out


def trained_crop(model: Any) -> CropConfig | None:
    """The CropConfig a model's training crops were made with (its checkpoint says), or None when it does
    not say (an untrained network, a checkpoint from before crops were saved)."""
    crop = getattr(model, "crop_config", None)
    return crop if isinstance(crop, CropConfig) else None


def resolve_crop(models: Iterable[Any], given: CropConfig | None = None) -> CropConfig:
    """The one CropConfig to make crops with for ``models`` (predictors; None entries are skipped):
    ``given``, else the first model's training crops, else the default with the first model's network
    sizes. Raises ValueError, naming the fields, when a model was trained on crops made otherwise."""
    models = [m for m in models if m is not None]
    known = [c for c in map(trained_crop, models) if c is not None]
    crop = given or (known[0] if known else None)
    if crop is None:
        arch = next((m.model.arch for m in models if hasattr(getattr(m, "model", None), "arch")), None)
        crop = CropConfig() if arch is None else CropConfig(size=arch.crop_size, center_size=arch.center_size)
    for m in models:
        trained = trained_crop(m)
        if trained is not None and trained != crop:
            diff = sorted(k for k, v in crop.to_dict().items() if trained.to_dict().get(k) != v)
            raise ValueError(f"{getattr(m, 'info', {}).get('path') or 'a model'}: trained on crops made with "
                             f"another CropConfig (differs in {diff})")
        arch = getattr(getattr(m, "model", None), "arch", None)
        if arch is not None and (crop.size, crop.center_size) != (arch.crop_size, arch.center_size):
            raise ValueError(f"crops of {crop.size} px (centre {crop.center_size}) but the network takes "
                             f"{arch.crop_size} (centre {arch.center_size})")
    return crop


def center_crops(crops: NDArray[np.float32], center_size: int = 32) -> NDArray[np.float32]:
    """The central ``center_size`` x ``center_size`` of each crop, (N, center_size, center_size)."""
    crops = np.asarray(crops)
    if crops.ndim != 3 or crops.shape[1] != crops.shape[2] or crops.shape[1] < center_size:
        raise ValueError(f"crops must have shape (N, S, S) with S >= {center_size}, got {crops.shape}")
    lo = (crops.shape[1] - center_size) // 2
    return crops[:, lo : lo + center_size, lo : lo + center_size]
