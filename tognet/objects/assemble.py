"""Write one object to disk: convex collision pieces, a watertight visual mesh, an MJCF model.

Mass properties come from the watertight visual mesh and the density (the convex pieces may overlap
where the parts join, so summing them would count the overlap twice); the MJCF states them
explicitly in an ``<inertial>`` element so MuJoCo does not recompute them from the pieces.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from tognet.errors import TognetError
from tognet.objects.record import ObjectRecord


class MeshError(TognetError):
    """A mesh cannot become a simulated object (empty, degenerate, not watertight, absurd size)."""


def write_obj(mesh: trimesh.Trimesh, path: Path) -> None:
    """Write a triangle mesh as OBJ with fixed precision, so equal meshes give identical bytes."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64) + 1
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"f {a} {b} {c}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def rounded_hull(piece: trimesh.Trimesh, object_id: str = "", index: int = 0) -> trimesh.Trimesh:
    """The convex hull of a piece's vertices rounded as the OBJ writer rounds them.

    Hulling after rounding keeps the written piece exactly convex (rounding a hull's vertices can
    make nearly coplanar faces slightly concave).
    """
    points = np.round(np.asarray(piece.vertices, dtype=np.float64), 6)
    try:
        hull = trimesh.convex.convex_hull(points)
    except Exception as exc:  # qhull fails on flat or degenerate point sets
        raise MeshError(f"{object_id}: collision piece {index} is flat or degenerate ({exc})") from None
    if not hull.is_volume:
        raise MeshError(f"{object_id}: collision piece {index} is not a closed convex volume")
    return hull


def mass_properties(mesh: trimesh.Trimesh, density: float) -> tuple[float, float, np.ndarray, np.ndarray]:
    """(mass, volume, centre of mass, 3x3 inertia about the centre of mass) of a watertight mesh."""
    if not mesh.is_watertight:
        raise MeshError("mass properties need a watertight mesh")
    volume = float(mesh.volume)
    if not volume > 0:
        raise MeshError(f"mesh volume {volume} is not positive (inverted or degenerate)")
    props = mesh.mass_properties
    com = np.asarray(props["center_mass"], dtype=np.float64)
    inertia = np.asarray(props["inertia"], dtype=np.float64) * density / float(props["density"])
    return density * volume, volume, com, inertia


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def mjcf_text(
    record: ObjectRecord, friction_torsional: float = 0.005, friction_rolling: float = 0.0001
) -> str:
    """A standalone MJCF model of the object: body ``object`` with a free joint, resting above z=0."""
    inertia = np.asarray(record.inertia)
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    assets = [
        f'    <mesh name="piece_{i:02d}" file="{name}"/>' for i, name in enumerate(record.collision_meshes)
    ]
    assets.append(f'    <mesh name="visual" file="{record.visual_mesh}"/>')
    friction = f"{record.friction:.6g} {friction_torsional:g} {friction_rolling:g}"
    geoms = [
        f'      <geom name="piece_{i:02d}" type="mesh" mesh="piece_{i:02d}" friction="{friction}" group="3"/>'
        for i in range(len(record.collision_meshes))
    ]
    geoms.append(
        '      <geom name="visual" type="mesh" mesh="visual" contype="0" conaffinity="0" group="1"/>'
    )
    half_height = 0.5 * float(record.extents[2]) + 0.05
    return "\n".join(
        [
            f'<mujoco model="{record.object_id}">',
            "  <asset>",
            *assets,
            "  </asset>",
            "  <worldbody>",
            f'    <body name="object" pos="0 0 {half_height:.4f}">',
            "      <freejoint/>",
            f'      <inertial pos="{_fmt(record.com)}" mass="{record.mass:.9g}" fullinertia="{_fmt(full)}"/>',
            *geoms,
            "    </body>",
            "  </worldbody>",
            "</mujoco>",
            "",
        ]
    )


def assemble_object(
    set_dir: str | Path,
    *,
    object_id: str,
    kind: str,
    split: str,
    shape_rule: str,
    part_types: list[str],
    visual: trimesh.Trimesh,
    collision_pieces: list[trimesh.Trimesh],
    density: float,
    friction: float,
    extra: dict[str, Any] | None = None,
) -> ObjectRecord:
    """Write an object's files into ``set_dir/object_id`` and return its record.

    ``visual`` must be watertight (it defines mass properties); ``collision_pieces`` must be convex.
    """
    if not collision_pieces:
        raise MeshError(f"{object_id}: no collision pieces")
    if density <= 0 or friction <= 0:
        raise MeshError(f"{object_id}: density and friction must be positive, got {density}, {friction}")
    mass, volume, com, inertia = mass_properties(visual, density)
    folder = Path(set_dir) / object_id
    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for i, piece in enumerate(collision_pieces):
        name = f"collision_{i:02d}.obj"
        write_obj(rounded_hull(piece, object_id, i), folder / name)
        names.append(name)
    write_obj(visual, folder / "visual.obj")
    record = ObjectRecord(
        object_id=object_id,
        kind=kind,
        split=split,
        shape_rule=shape_rule,
        part_types=list(part_types),
        extents=[round(float(e), 6) for e in visual.extents],
        mass=round(mass, 9),
        volume=round(volume, 12),
        density=round(float(density), 6),
        friction=round(float(friction), 6),
        com=[round(float(c), 9) for c in com],
        inertia=[[round(float(v), 12) for v in row] for row in inertia],
        collision_meshes=names,
        visual_mesh="visual.obj",
        mjcf="object.xml",
        folder=str(folder.resolve()),
        extra=dict(extra or {}),
    )
    (folder / "object.xml").write_text(mjcf_text(record))
    return record
