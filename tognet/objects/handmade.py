"""Hand-made test objects (a T-shaped hammer, a long L-shaped tool) built from boxes with assemble_object.

They serve the scripted checks, the tests and the CLI's demo before (or besides) generated sets.
Object frame: the tool lies flat on z = 0, its handle (long edge) along +x starting at x = 0. Their sizes
are plain constants here (cheap to import: the mesh libraries load when an object is made).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tognet.geometry import Grasp

if TYPE_CHECKING:
    import trimesh

    from tognet.objects.record import ObjectRecord


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    import trimesh

    extents = [h - low for low, h in zip(lo, hi, strict=True)]
    centre = [(h + low) / 2 for low, h in zip(lo, hi, strict=True)]
    return trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(centre))


# T hammer: handle 2.5 cm square x 28 cm, head 3 (x) x 10 (y) x 3 (z) cm at the handle's +x end.
HAMMER_HANDLE = 0.28
HAMMER_WIDTH = 0.025
HAMMER_HEAD = (0.03, 0.10, 0.03)
# L tool: long edge 30 cm along x, short part 10 cm along +y at the x = 0 end, 2.5 cm square bars.
L_LONG = 0.30
L_SHORT = 0.10
L_WIDTH = 0.025


def make_t_hammer(
    set_dir: str | Path, object_id: str = "t_hammer", density: float = 1200.0, friction: float = 0.8
) -> ObjectRecord:
    """A T-shaped hammer: handle along +x from x = 0, head across y at x = 0.28 .. 0.31."""
    from tognet.objects.assemble import assemble_object
    from tognet.objects.compose import union

    w, (hx, hy, hz) = HAMMER_WIDTH, HAMMER_HEAD
    handle = _box((0.0, -w / 2, 0.0), (HAMMER_HANDLE, w / 2, w))
    head = _box((HAMMER_HANDLE, -hy / 2, 0.0), (HAMMER_HANDLE + hx, hy / 2, hz))
    return assemble_object(
        set_dir,
        object_id=object_id,
        kind="imported",
        split="test",
        shape_rule="T",
        part_types=["box", "box"],
        visual=union([handle, head]),
        collision_pieces=[handle, head],
        density=density,
        friction=friction,
    )


def make_l_tool(
    set_dir: str | Path, object_id: str = "l_tool", density: float = 1000.0, friction: float = 0.8
) -> ObjectRecord:
    """A long L: long bar along +x from x = 0 to 0.30, short bar along +y from the x = 0 end (10 cm)."""
    from tognet.objects.assemble import assemble_object
    from tognet.objects.compose import union

    w = L_WIDTH
    long_bar = _box((0.0, 0.0, 0.0), (L_LONG, w, w))
    short_bar = _box((0.0, w, 0.0), (w, L_SHORT, w))
    return assemble_object(
        set_dir,
        object_id=object_id,
        kind="imported",
        split="test",
        shape_rule="L",
        part_types=["box", "box"],
        visual=union([long_bar, short_bar]),
        collision_pieces=[long_bar, short_bar],
        density=density,
        friction=friction,
    )


def make_test_tools(set_dir: str | Path) -> dict[str, ObjectRecord]:
    """Write both tools and a catalog into ``set_dir``; returns them by id."""
    from tognet.objects.record import write_catalog

    records = [make_t_hammer(set_dir), make_l_tool(set_dir)]
    write_catalog(set_dir, records, meta={"source": "tognet.objects.handmade"})
    return {r.object_id: r for r in records}


def grasp_on_object(
    position: np.ndarray,
    rotation: np.ndarray,
    point: tuple[float, float, float],
    jaw_axis: tuple[float, float, float],
) -> Grasp:
    """The top-down grasp at ``point`` (object frame) with the jaw along ``jaw_axis`` (object frame).

    ``position``/``rotation`` are the object's pose in the world (as ``Simulator.object_pose()``).
    """
    p = np.asarray(position) + np.asarray(rotation) @ np.asarray(point, dtype=np.float64)
    axis = np.asarray(rotation) @ np.asarray(jaw_axis, dtype=np.float64)
    return Grasp.from_array([p[0], p[1], p[2], np.arctan2(axis[1], axis[0])])
