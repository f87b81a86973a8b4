"""Write one object to disk: convex collision pieces, a watertight visual mesh, an MJCF model.

Mass properties come either from the watertight visual mesh and one density, or (``parts=``) from
watertight part meshes with a density each, whose union is the visual. The convex pieces may overlap
where the parts join, so summing them would count the overlap twice: with parts, every bit of shared
volume belongs to exactly one part, the first one listed (part i's own solid is part i minus the
boolean union of parts 0..i-1, manifold3d). Masses add up; centres of mass combine weighted by mass;
inertias move to the common centre of mass by the parallel-axis theorem. The MJCF states the result
explicitly in an ``<inertial>`` element so MuJoCo does not recompute it from the pieces.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from tognet.errors import TognetError
from tognet.io import atomic_write_text
from tognet.objects.record import ObjectRecord


class MeshError(TognetError):
    """A mesh cannot become a simulated object (empty, degenerate, not watertight, absurd size)."""


def write_obj(mesh: trimesh.Trimesh, path: Path) -> None:
    """Write a triangle mesh as OBJ with fixed precision, so equal meshes give identical bytes."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64) + 1
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"f {a} {b} {c}" for a, b, c in faces]
    atomic_write_text(path, "\n".join(lines) + "\n")


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


PartSpec = tuple[trimesh.Trimesh, float]


@dataclass(frozen=True)
class PartMass:
    """Mass properties of one part's own solid (after the parts listed before it took their share)."""

    density: float
    volume: float
    mass: float
    com: np.ndarray
    inertia: np.ndarray


def _union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    if len(meshes) == 1:
        return meshes[0]
    result = trimesh.boolean.union(meshes, engine="manifold")
    if not isinstance(result, trimesh.Trimesh):
        raise MeshError("boolean union of the parts failed")
    return result


def exclusive_solids(meshes: list[trimesh.Trimesh]) -> list[trimesh.Trimesh | None]:
    """Each part minus the union of the parts before it (manifold3d); None where nothing is left.

    The first part keeps all of itself, so overlapping volume is counted once, for the earliest part.
    """
    out: list[trimesh.Trimesh | None] = []
    for i, mesh in enumerate(meshes):
        if not mesh.is_watertight or not float(mesh.volume) > 0:
            raise MeshError(f"part {i} is not a watertight volume with positive volume")
        if i == 0:
            out.append(mesh)
            continue
        before = _union(list(meshes[:i]))
        own = trimesh.boolean.difference([mesh, before], engine="manifold")
        if not isinstance(own, trimesh.Trimesh) or len(own.faces) == 0 or not float(own.volume) > 0:
            out.append(None)
        else:
            out.append(own)
    return out


def part_masses(parts: list[PartSpec]) -> list[PartMass]:
    """Mass properties of each part's own solid (see :func:`exclusive_solids`), in the parts' frame."""
    if not parts:
        raise MeshError("parts is empty")
    for i, (_mesh, rho) in enumerate(parts):
        if not float(rho) > 0:
            raise MeshError(f"part {i}: density must be positive, got {rho}")
    solids = exclusive_solids([mesh for mesh, _ in parts])
    out = []
    for (_mesh, rho), solid in zip(parts, solids, strict=True):
        if solid is None:
            out.append(PartMass(float(rho), 0.0, 0.0, np.zeros(3), np.zeros((3, 3))))
            continue
        mass, volume, com, inertia = mass_properties(solid, float(rho))
        out.append(PartMass(float(rho), volume, mass, com, inertia))
    return out


def combine(masses: list[PartMass]) -> tuple[float, float, np.ndarray, np.ndarray]:
    """(mass, volume, centre of mass, inertia about it) of rigidly joined parts (parallel-axis theorem)."""
    total = sum(p.mass for p in masses)
    volume = sum(p.volume for p in masses)
    if not total > 0:
        raise MeshError("the parts have no mass")
    com = sum(p.mass * p.com for p in masses) / total
    inertia = np.zeros((3, 3))
    for p in masses:
        d = p.com - com
        inertia += p.inertia + p.mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return float(total), float(volume), np.asarray(com, dtype=np.float64), inertia


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
    density: float | None = None,
    friction: float,
    extra: dict[str, Any] | None = None,
    parts: list[PartSpec] | None = None,
    part_names: list[str] | None = None,
) -> ObjectRecord:
    """Write an object's files into ``set_dir/object_id`` and return its record.

    ``visual`` must be watertight; ``collision_pieces`` must be convex. Give exactly one of:

    - ``density``: one density; mass properties come from the visual mesh (the original behaviour,
      byte for byte);
    - ``parts``: (watertight mesh, density) per part, in the object frame, whose union is the visual.
      Shared volume belongs to the first part listed that contains it. The record's ``volume`` is the
      parts' union volume (checked against the visual's, 0.5 % tolerance), ``density`` is mass / volume,
      and ``extra`` gains ``part_names`` (``part_names`` or "0", "1", ...), ``part_densities`` (kg/m^3),
      ``part_volumes`` (m^3, each part's own share) and ``part_masses`` (kg), in the parts' order.
    """
    _check_arguments(object_id, collision_pieces, density, parts, friction)
    extra = dict(extra or {})
    if parts is None:
        assert density is not None
        mass, volume, com, inertia = mass_properties(visual, density)
    else:
        (mass, volume, com, inertia), part_info = _part_properties(object_id, visual, parts, part_names)
        density = mass / volume
        extra.update(part_info)
    folder = Path(set_dir) / object_id
    folder.mkdir(parents=True, exist_ok=True)
    names = _write_collision(folder, collision_pieces, object_id)
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
        extra=extra,
    )
    atomic_write_text(folder / "object.xml", mjcf_text(record))
    return record


def _check_arguments(
    object_id: str, collision_pieces: list[trimesh.Trimesh], density: float | None,
    parts: list[PartSpec] | None, friction: float,
) -> None:
    """Raise MeshError for arguments :func:`assemble_object` cannot use."""
    if not collision_pieces:
        raise MeshError(f"{object_id}: no collision pieces")
    if (density is None) == (parts is None):
        raise MeshError(f"{object_id}: give exactly one of density= and parts=")
    if not friction > 0:
        raise MeshError(f"{object_id}: friction must be positive, got {friction}")
    if density is not None and not density > 0:
        raise MeshError(f"{object_id}: density must be positive, got {density}")


def _part_properties(
    object_id: str, visual: trimesh.Trimesh, parts: list[PartSpec], part_names: list[str] | None,
) -> tuple[tuple[float, float, np.ndarray, np.ndarray], dict[str, Any]]:
    """The parts' combined mass properties (union checked against the visual) and their ``extra`` entries."""
    names = list(part_names) if part_names is not None else [str(i) for i in range(len(parts))]
    if len(names) != len(parts):
        raise MeshError(f"{object_id}: {len(names)} part names for {len(parts)} parts")
    try:
        masses = part_masses(parts)
    except MeshError as exc:
        raise MeshError(f"{object_id}: {exc}") from None
    mass, volume, com, inertia = combine(masses)
    visual_volume = float(visual.volume)
    if abs(volume - visual_volume) > 0.005 * visual_volume:
        raise MeshError(
            f"{object_id}: the parts' union ({volume * 1e6:.3f} cm^3) is not the visual "
            f"({visual_volume * 1e6:.3f} cm^3)"
        )
    info = {
        "part_names": names,
        "part_densities": [round(p.density, 6) for p in masses],
        "part_volumes": [round(p.volume, 12) for p in masses],
        "part_masses": [round(p.mass, 9) for p in masses],
    }
    return (mass, volume, com, inertia), info


def _write_collision(folder: Path, collision_pieces: list[trimesh.Trimesh], object_id: str) -> list[str]:
    """Write each convex piece's rounded hull as ``collision_NN.obj`` in ``folder``; the file names."""
    names = []
    for i, piece in enumerate(collision_pieces):
        name = f"collision_{i:02d}.obj"
        write_obj(rounded_hull(piece, object_id, i), folder / name)
        names.append(name)
    return names
