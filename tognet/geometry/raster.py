"""Depth of a triangle mesh seen by a pinhole camera, per pixel, by exact ray-triangle intersection.

For every pixel whose centre ray passes through a triangle (edges included), the ray parameter of the
hit is computed exactly as a ray caster would (``t`` along the direction ``R @ ((u - cx) / fx,
(v - cy) / fy, 1)``, which is the hit's camera-frame z); the nearest hit per pixel wins. Only the
pixels inside each triangle's projected bounding box are tested, all triangles at once (vectorised), so
the cost grows with the mesh's projected area, not with pixels times triangles as in brute-force ray
casting. Pure numpy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Pairs (triangle, pixel) tested per vectorised batch: bounds the temporaries (~100 bytes per pair).
_BATCH = 400_000


def mesh_depth(
    rotation: NDArray[np.float64],
    position: NDArray[np.float64],
    intrinsics: tuple[float, float, float, float, int, int],
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    depth: NDArray[np.float64],
) -> bool:
    """Lower ``depth`` (flat, row-major, H * W) to the mesh's hit distance where a pixel's ray hits it.

    ``rotation``/``position``: world_from_camera (OpenCV camera frame); ``intrinsics``: (fx, fy, cx, cy,
    width, height); ``vertices``: (N, 3) world points; ``faces``: (M, 3) vertex indices. Returns False,
    leaving ``depth`` untouched, when a vertex is not in front of the camera (the caller should then cast
    rays another way); True otherwise.
    """
    fx, fy, cx, cy, width, height = intrinsics
    k = (fx, fy, cx, cy, width)
    cam = (np.asarray(vertices, dtype=np.float64) - position) @ rotation  # camera frame: R^T (p - o)
    z = cam[:, 2]
    if len(cam) == 0 or not np.all(z > 1e-9):
        return len(cam) == 0
    u = cam[:, 0] / z * fx + cx
    v = cam[:, 1] / z * fy + cy
    f = np.asarray(faces, dtype=np.int64)
    p0, p1, p2 = cam[f[:, 0]], cam[f[:, 1]], cam[f[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    normal = np.empty_like(e1)  # e1 x e2, written out (np.cross costs ~50 us of overhead per call)
    normal[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    normal[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    normal[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    offset = np.einsum("ij,ij->i", normal, p0)  # plane: normal . p = offset
    uu, vv = u[f], v[f]  # (M, 3) projected corners
    # Pixel-centre bounding boxes, clipped to the image; triangles seen edge-on (no area) never hit.
    u0 = np.maximum(np.ceil(uu.min(axis=1)), 0).astype(np.int64)
    u1 = np.minimum(np.floor(uu.max(axis=1)), width - 1).astype(np.int64)
    v0 = np.maximum(np.ceil(vv.min(axis=1)), 0).astype(np.int64)
    v1 = np.minimum(np.floor(vv.max(axis=1)), height - 1).astype(np.int64)
    area = (uu[:, 1] - uu[:, 0]) * (vv[:, 2] - vv[:, 0]) - (vv[:, 1] - vv[:, 0]) * (uu[:, 2] - uu[:, 0])
    keep = np.flatnonzero((u1 >= u0) & (v1 >= v0) & (area != 0) & (offset != 0))
    if keep.size == 0:
        return True
    # Batches of whole triangles (one row span per triangle and image row), so the temporaries stay
    # bounded for big meshes close to the camera.
    rows = v1[keep] - v0[keep] + 1
    ends = np.cumsum(rows * (u1[keep] - u0[keep] + 1))  # bounding-box pixels: an upper bound on pairs
    start = 0
    while start < keep.size:
        base = ends[start - 1] if start else 0
        stop = max(int(np.searchsorted(ends, base + _BATCH, side="right")), start + 1)
        tris = keep[start:stop]
        _spans(tris, rows[start:stop], u0[tris], u1[tris], v0[tris], uu, vv, area, normal, offset, k, depth)
        start = stop
    return True


def _spans(
    tris: NDArray[np.int64],
    rows: NDArray[np.int64],
    u0: NDArray[np.int64],
    u1: NDArray[np.int64],
    v0: NDArray[np.int64],
    uu: NDArray[np.float64],
    vv: NDArray[np.float64],
    area: NDArray[np.float64],
    normal: NDArray[np.float64],
    offset: NDArray[np.float64],
    k: tuple[float, float, float, float, int],
    depth: NDArray[np.float64],
) -> None:
    """Rasterise triangles ``tris`` row by row: on each image row the triangle covers one span of
    columns, found from its three edges; the pixels of the span (plus a rounding margin) then get the
    exact inside test and the hit distance."""
    fx, fy, cx, cy, width = k
    which = np.repeat(np.arange(tris.size), rows)  # one entry per (triangle, row)
    first = np.cumsum(rows) - rows
    tri = tris[which]
    pv = (v0[which] + np.arange(which.size) - first[which]).astype(np.float64)
    sign = np.sign(area[tri])
    tu, tv = uu[tri], vv[tri]
    lo = u0[which].astype(np.float64)
    hi = u1[which].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            # Edge function (ub - ua)(v - va) - (vb - va)(u - ua) = c - s u, inside where sign * it >= 0.
            s = tv[:, b] - tv[:, a]
            c = (tu[:, b] - tu[:, a]) * (pv - tv[:, a]) + s * tu[:, a]
            ss = sign * s
            bound = c / s
            lo = np.where(ss < 0, np.maximum(lo, bound), lo)
            hi = np.where(ss > 0, np.minimum(hi, bound), hi)
            hi = np.where((ss == 0) & (sign * c < 0), -np.inf, hi)
    lo_px = np.ceil(lo - 1e-6)
    hi_px = np.floor(hi + 1e-6)
    n = np.maximum(hi_px - lo_px + 1, 0).astype(np.int64)
    if n.sum() == 0:
        return
    span = np.repeat(np.arange(n.size), n)
    pu = lo_px[span] + (np.arange(span.size) - (np.cumsum(n) - n)[span])
    pv = pv[span]
    tri = tri[span]
    # The exact inside test (edges included) on every candidate, as a ray caster would decide.
    sign = sign[span]
    tu, tv = tu[span], tv[span]
    inside = np.ones(span.size, dtype=bool)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        e = (tu[:, b] - tu[:, a]) * (pv - tv[:, a]) - (tv[:, b] - tv[:, a]) * (pu - tu[:, a])
        inside &= e * sign >= 0
    tri, pu, pv = tri[inside], pu[inside], pv[inside]
    n3 = normal[tri]
    den = n3[:, 0] * ((pu - cx) / fx) + n3[:, 1] * ((pv - cy) / fy) + n3[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = offset[tri] / den
    ok = (t > 0) & np.isfinite(t)
    pix = (pv[ok] * width + pu[ok]).astype(np.int64)
    np.minimum.at(depth, pix, t[ok])
