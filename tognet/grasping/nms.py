"""Non-maximum suppression over ranked grasps (diverse grasp modes for exploration).

Grasps are compared with a Euclidean distance in a scaled grasp space,

    d(g, h)^2 = |p_g - p_h|^2 + (angle_scale * dtheta(g, h))^2,

where p is the gripper centre (x, y, z) and dtheta the smallest angle between the jaw axes. By
default the jaw axis is a *line* (dtheta taken modulo pi): phi and phi + pi put the fingers on the
same contacts, so they are the same physical grasp placement and NMS, which looks for distinct
places to hold the tool, treats them as one mode. Set ``symmetric_jaw=False`` to keep both (angle
modulo 2 pi) when the in-hand orientation matters for the scorer. Going through the grasps from the
best score down, a grasp is kept when its distance to every grasp already kept is at least
``radius``; so the result is pairwise separated by ``radius``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tognet.config import Config, doc


@dataclass(frozen=True)
class NMSConfig(Config):
    """Distance used to suppress grasps near a better one."""

    radius: float = doc(
        0.02,
        "Minimum distance (m, in the scaled grasp space) between kept grasps: a few tens of modes per tool "
        "(benchmarks/RESULTS.md).",
        ge=0,
    )
    angle_scale: float = doc(
        0.03, "Metres per radian of jaw-axis angle difference (0.03: a 60 degree turn counts like 3.1 cm).",
        ge=0,
    )
    symmetric_jaw: bool = doc(True, "Angle difference modulo pi (phi and phi + pi are the same placement).")
    max_keep: int | None = doc(None, "Keep at most this many grasps (None: all that survive).", ge=1)
    min_score: float | None = doc(None, "Drop grasps scoring below this before suppression (None: keep all).")


def angle_difference(a: NDArray, b: NDArray, period: float = 2 * np.pi) -> NDArray[np.float64]:
    """Smallest absolute difference of angles a and b modulo ``period`` (broadcasting)."""
    d = np.mod(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64), period)
    return np.minimum(d, period - d)


def grasp_distances(grasps: NDArray[np.float64], config: NMSConfig) -> NDArray[np.float64]:
    """(N, N) pairwise grasp distances as used by :func:`nms`."""
    g = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
    dp = g[:, None, :3] - g[None, :, :3]
    period = np.pi if config.symmetric_jaw else 2 * np.pi
    da = angle_difference(g[:, None, 3], g[None, :, 3], period) * config.angle_scale
    return np.sqrt(np.einsum("ijk,ijk->ij", dp, dp) + da * da)


def nms(grasps: NDArray[np.float64], scores: NDArray[np.float64], config: NMSConfig) -> NDArray[np.intp]:
    """Indices of the grasps kept by non-maximum suppression, best score first."""
    grasps = np.asarray(grasps, dtype=np.float64)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    if grasps.ndim != 2 or grasps.shape[1] != 4:
        raise ValueError(f"grasps must have shape (N, 4), got {grasps.shape}")
    if scores.shape[0] != grasps.shape[0]:
        raise ValueError(f"{grasps.shape[0]} grasps but {scores.shape[0]} scores")
    if not np.all(np.isfinite(grasps)) or not np.all(np.isfinite(scores)):
        raise ValueError("grasps and scores must be finite")
    order = np.argsort(-scores, kind="stable")
    if config.min_score is not None:
        order = order[scores[order] >= config.min_score]
    if order.size == 0:
        return np.zeros(0, dtype=np.intp)
    dist = grasp_distances(grasps[order], config)
    suppressed = np.zeros(order.size, dtype=bool)
    kept: list[int] = []
    limit = config.max_keep if config.max_keep is not None else order.size
    for r in range(order.size):
        if suppressed[r]:
            continue
        kept.append(r)
        if len(kept) >= limit:
            break
        suppressed |= dist[r] < config.radius
    return order[np.asarray(kept, dtype=np.intp)]
