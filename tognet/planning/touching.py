"""Two objects touching in one region of the height map: the evidence that a region is two tools lying
against each other rather than one tool, and the split of such a region in two.

One tool's parts are rigidly joined: climbing from its lower part to its higher one never goes down much,
and where a thin handle meets a big head the narrowest bit is the handle itself. Two tools lying side by
side meet where their sides curve down to the table, so between their tops lies a *valley* well below both
(:func:`find_valley`: the evidence used to split, grown into two parts by :func:`split_labels`), and two
tools touching at a corner meet at a *pinch*, a neck narrower than both parts (:func:`find_pinch`:
ambiguous alone, so reported, not split). Two exceptions look the same and are one object: a container,
whose rim rises on both sides of its floor and encloses it (:func:`enclosed_floor`), and a handle that runs
into its head through a low or narrow joint (a trowel's grip, a roller's frame, a bar tilted down into a
block): a convex, elongated part whose long axis runs through the joint (:func:`solidity`,
:func:`elongation`, :func:`axis_offset`). The thresholds are :class:`tognet.planning.segment.SegmentConfig`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import ConvexHull, QhullError

_EIGHT = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class Valley:
    """The lowest level at which the region's height map falls apart into two large parts: the level
    (``saddle``, m above the table), the two parts' tops (``peaks``, m: 95th percentiles, the higher first)
    and areas (m^2) at that level, and ``seeds``: the parts' pixels (labels 1 and 2) to grow a split from."""

    saddle: float
    peaks: tuple[float, float]
    areas: tuple[float, float]
    seeds: NDArray[np.int32]

    @property
    def depth(self) -> float:
        """How far the saddle lies below the lower part's top (m)."""
        return self.peaks[1] - self.saddle


@dataclass(frozen=True)
class Pinch:
    """The narrowest place between two parts of the footprint: its width (m), the widths of the two parts
    (m, the widest inscribed disc's diameter) and where it is (``at``: row, column of its middle)."""

    width: float
    part_widths: tuple[float, float]
    at: tuple[int, int]


def smoothed_heights(mask: NDArray[np.bool_], height: NDArray[np.float32]) -> tuple[NDArray[np.bool_],
                                                                                  NDArray[np.float64]]:
    """The region (``mask`` with its small holes closed) and its heights: holes take their nearest measured
    pixel's height, then a 3 x 3 median takes out range noise; 0 outside the region."""
    known = mask & np.isfinite(height)
    region = ndimage.binary_fill_holes(ndimage.binary_closing(known, _EIGHT, iterations=2) | known)
    region &= ndimage.binary_dilation(known, _EIGHT, iterations=2)
    _, (ir, ic) = ndimage.distance_transform_edt(~known, return_indices=True)
    filled = np.where(region, height[ir, ic], 0.0).astype(np.float64)
    return region, np.where(region, ndimage.median_filter(filled, size=3), 0.0)


def find_valley(region: NDArray[np.bool_], h: NDArray[np.float64], pixel_area: float, part_area: float,
                start: float, step: float = 0.001) -> Valley | None:
    """The lowest level from ``start`` (m, every ``step``) at which the pixels above it form two parts of at
    least ``part_area`` (m^2) each; None if it never does (one tool climbs into its higher part)."""
    least = part_area / pixel_area
    top = float(np.percentile(h[region], 99))
    for level in np.arange(start, top, step):
        labels, count = ndimage.label(region & (h > level), _EIGHT)
        if count < 2:
            continue
        sizes = np.bincount(labels.ravel())[1:]
        big = np.flatnonzero(sizes >= least) + 1
        if len(big) < 2:
            continue
        big = big[np.argsort(-sizes[big - 1])][:2]
        peaks = [float(np.percentile(h[labels == b], 95)) for b in big]
        order = np.argsort(peaks)[::-1]
        seeds = np.zeros(labels.shape, dtype=np.int32)
        for j, i in enumerate(order):
            seeds[labels == big[i]] = j + 1
        areas = [float(sizes[big[i] - 1] * pixel_area) for i in order]
        return Valley(float(level), (peaks[order[0]], peaks[order[1]]), (areas[0], areas[1]), seeds)
    return None


def encloses(region: NDArray[np.bool_], h: NDArray[np.float64], level: float, pixel_area: float) -> float:
    """The area (m^2) of the table-side floor that the pixels above ``level`` enclose (a container's rim
    around its floor: the pot's two arcs are one rim)."""
    above = region & (h > level)
    return float((ndimage.binary_fill_holes(above) & ~above).sum() * pixel_area)


def find_pinch(region: NDArray[np.bool_], seeds: NDArray[np.int32], pixel: float) -> Pinch | None:
    """The narrowest place between the two seeds' parts of the footprint (``pixel``: m per pixel): the
    footprint eroded ever deeper (half-pixel steps) until the parts come apart; None when one part thins
    out first (the narrow bit is a part itself: a handle). The parts stay joined up to some depth and apart
    beyond it, so the depth is found by bisection."""
    half = ndimage.distance_transform_edt(region)
    a, b = seeds == 1, seeds == 2
    widths = (2.0 * float(half[a].max()) * pixel, 2.0 * float(half[b].max()) * pixel)
    depths = np.arange(0.5, min(half[a].max(), half[b].max()), 0.5)

    def joined(i: int) -> bool:
        la, lb = _cores_of(half > depths[i], a, b)
        return bool((la & lb).any())

    lo, hi = -1, len(depths)  # joined at lo (or before the first depth), apart from hi on
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if joined(mid) else (lo, mid)
    if hi == len(depths):
        return None
    r = float(depths[hi])
    la, lb = _cores_of(half > r, a, b)
    if not la.any() or not lb.any():
        return None
    return Pinch(2.0 * r * pixel, widths, neck_point(half > r - 0.5, la, lb))


def _cores_of(core: NDArray[np.bool_], a: NDArray[np.bool_], b: NDArray[np.bool_]
              ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """The pieces of ``core`` that hold pixels of ``a`` and of ``b``."""
    labels, _ = ndimage.label(core, _EIGHT)
    ia, ib = np.unique(labels[a & core]), np.unique(labels[b & core])
    return np.isin(labels, ia[ia > 0]), np.isin(labels, ib[ib > 0])


def split_labels(region: NDArray[np.bool_], h: NDArray[np.float64], seeds: NDArray[np.int32]
                 ) -> NDArray[np.int32]:
    """Every pixel of the region given to one of the two seeds (1, 2), grown downhill from them (a
    watershed on the height map); 0 outside the region."""
    top = max(float(h.max()), 1e-6)
    cost = np.round((top - h) / top * 1000.0).astype(np.uint16)
    cost[~region] = 2000
    markers = seeds.astype(np.int16)
    markers[~region & (markers == 0)] = 3
    labels = ndimage.watershed_ift(cost, markers, structure=_EIGHT).astype(np.int32)
    labels[~region | (labels == 3)] = 0
    return labels


def neck_seeds(region: NDArray[np.bool_], pixel_area: float, part_area: float) -> NDArray[np.int32] | None:
    """Seeds (labels 1, 2) of the two largest parts that eroding the footprint leaves apart, each part (its
    core and what lies within the erosion's depth of it) at least ``part_area`` (m^2); None if eroding it
    never leaves two such parts."""
    half = ndimage.distance_transform_edt(region)
    least = part_area / pixel_area
    r = 0.5
    while r < half.max():
        r = max(r + 0.5, 1.08 * r)  # half a pixel, or 8 % deeper in wide regions
        core = half > r
        labels, count = ndimage.label(core, _EIGHT)
        if count < 2:
            continue
        reach, (ir, ic) = ndimage.distance_transform_edt(~core, return_indices=True)
        own = np.where(region & (reach <= r + 1.5), labels[ir, ic], 0)
        sizes = np.bincount(own.ravel(), minlength=count + 1)[1:]
        big = np.flatnonzero(sizes >= least) + 1
        if len(big) >= 2:
            big = big[np.argsort(-sizes[big - 1])][:2]
            seeds = np.zeros(labels.shape, dtype=np.int32)
            seeds[labels == big[0]], seeds[labels == big[1]] = 1, 2
            return seeds
    return None


def neck_point(region: NDArray[np.bool_], a: NDArray[np.bool_], b: NDArray[np.bool_]) -> tuple[int, int]:
    """(row, column) of the middle of the shortest way across the region from ``a`` to ``b``."""
    da, db = ndimage.distance_transform_edt(~a), ndimage.distance_transform_edt(~b)
    cost = np.where(region, da + db + 1e-3 * np.abs(da - db), np.inf)
    row, col = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return int(row), int(col)


def axis_offset(part: NDArray[np.bool_], point: tuple[int, int], elongation: float = 1.5) -> float:
    """How far ``point`` lies from the part's long axis, as a share of the part's width (0: the axis runs
    through it, as a tool's handle and head both point at the neck between them; 0.5: at the part's
    side); 0 for a part about as wide as long (it points everywhere)."""
    rows, cols = np.nonzero(part)
    xy = np.column_stack([cols, rows]).astype(np.float64)
    centre = xy.mean(axis=0)
    vals, vecs = np.linalg.eigh(np.cov((xy - centre).T))
    if vals[1] < elongation**2 * max(vals[0], 1e-9):
        return 0.0
    width = np.sqrt(12.0 * max(vals[0], 1e-9))
    off = np.array([point[1], point[0]], dtype=np.float64) - centre
    return float(abs(off @ vecs[:, 0]) / width)


def enclosed_floor(region: NDArray[np.bool_], h: NDArray[np.float64], start: float, stop: float,
                   pixel_area: float, step: float = 0.002) -> float:
    """The largest area (m^2) that the pixels above some level between ``start`` and ``stop`` enclose: a
    container's rim around its floor (a pot's two arcs are one rim, seen at the level below its lowest
    point)."""
    best = 0.0
    for level in np.arange(start, stop, step):
        best = max(best, encloses(region, h, float(level), pixel_area))
    return best


def cut_point(labels: NDArray[np.int32]) -> tuple[int, int] | None:
    """(row, column) of the middle of the cut between labels 1 and 2 (its pixel nearest their mean)."""
    one, two = labels == 1, labels == 2
    cut = (one & ndimage.binary_dilation(two, _EIGHT)) | (two & ndimage.binary_dilation(one, _EIGHT))
    rows, cols = np.nonzero(cut)
    if rows.size == 0:
        return None
    i = int(np.argmin(np.hypot(rows - rows.mean(), cols - cols.mean())))
    return int(rows[i]), int(cols[i])


def solidity(part: NDArray[np.bool_]) -> float:
    """The part's pixels over the area of their convex hull (1: a convex piece, a handle or a bar)."""
    rows, cols = np.nonzero(part)
    if rows.size < 3:
        return 1.0
    corners = np.column_stack([np.concatenate([cols - 0.5, cols + 0.5, cols - 0.5, cols + 0.5]),
                               np.concatenate([rows - 0.5, rows - 0.5, rows + 0.5, rows + 0.5])])
    try:
        hull = ConvexHull(corners)
    except QhullError:
        return 1.0
    return float(rows.size / hull.volume)


def elongation(part: NDArray[np.bool_]) -> float:
    """The part's length over its width (the square root of its pixels' covariance eigenvalues' ratio)."""
    rows, cols = np.nonzero(part)
    if rows.size < 3:
        return 1.0
    vals = np.linalg.eigvalsh(np.cov(np.vstack([cols, rows]).astype(np.float64)))
    return float(np.sqrt(vals[1] / max(vals[0], 1e-9)))
