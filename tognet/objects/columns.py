"""An object made from what one overhead depth image shows of it: columns from the table up to the seen
surface, one convex piece per cell of a grid over the table.

A tool lying on a table is seen from above; what lies under its top surface is hidden. Filling every seen
point down to the table (a 2.5-D "extrusion") gives a solid that matches the tool's outline and top
exactly and overfills under overhangs (the lower half of a lying cylinder). Each pixel is taken as the
small square of table it covers (``footprint``: its half-size), so neighbouring cells' pieces touch and
no gap opens inside the tool. Cells are ``cell`` wide: a piece is the convex hull of its pixels' squares
at their seen height and on the table, so concavities smaller than a cell are filled.

The density and friction are not in the image: the caller gives them (nominal values), so mass and
inertia follow from the solid's shape only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import NDArray

from tognet.objects.assemble import MeshError, assemble_object
from tognet.objects.record import ObjectRecord

#: Pixels a cell needs to become a piece (fewer: depth noise at the outline, dropped).
MIN_PIXELS = 3


def column_pieces(points: NDArray[np.float64], footprint: NDArray[np.float64], cell: float,
                  table_z: float = 0.0) -> list[trimesh.Trimesh]:
    """Convex pieces (world frame) of the columns under ``points`` (N, 3: the seen surface), each pixel
    a square of half-size ``footprint`` (N,) from ``table_z`` up to its point, grouped into ``cell``-wide
    cells of the table's x, y grid."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    half = np.broadcast_to(np.asarray(footprint, dtype=np.float64), (len(points),))
    if not cell > 0:
        raise ValueError(f"cell must be positive, got {cell}")
    keys = np.floor(points[:, :2] / cell).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    corners = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]], dtype=np.float64)
    pieces = []
    for k in np.flatnonzero(counts >= MIN_PIXELS):
        rows = np.flatnonzero(inverse == k)
        p, h = points[rows], half[rows]
        xy = (p[:, None, :2] + corners[None] * h[:, None, None]).reshape(-1, 2)
        top = np.repeat(np.maximum(p[:, 2], table_z + 1e-3), 4)
        verts = np.concatenate([np.column_stack([xy, top]), np.column_stack([xy, np.full(len(xy), table_z)])])
        try:
            hull = trimesh.convex.convex_hull(np.round(verts, 6))
        except Exception:  # qhull on a degenerate cell (a sliver at the outline): leave it out
            continue
        if hull.is_volume:
            pieces.append(hull)
    return pieces


def column_object(set_dir: str | Path, object_id: str, points: NDArray[np.float64],
                  footprint: NDArray[np.float64], *, cell: float, density: float, friction: float,
                  table_z: float = 0.0) -> ObjectRecord:
    """The columns' object (:func:`column_pieces`) written into ``set_dir/object_id``: its frame is the
    world's (the pieces where the image saw them), kind "imported". MeshError when no cell makes a
    piece."""
    pieces = column_pieces(points, footprint, cell, table_z)
    if not pieces:
        raise MeshError(f"{object_id}: no part of the image's object is large enough to make a solid")
    visual = trimesh.util.concatenate(pieces)
    return assemble_object(set_dir, object_id=object_id, kind="imported", split="test",
                           shape_rule="columns", part_types=["columns"], visual=visual,
                           collision_pieces=pieces, density=density, friction=friction,
                           extra={"cell": cell, "pieces": len(pieces)})
