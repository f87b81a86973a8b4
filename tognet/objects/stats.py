"""How tool-like a set is: the distribution of sizes, masses and shapes that the tasks care about.

Per object (:func:`object_stats`), in the object frame (z up, as the object lies on the table):

- ``length``: the longer side of the xy bounding box (a lever for hammering, an edge for sweeping);
- ``height``: the z extent (a flat tool lies low);
- ``narrowest``: the smallest xy width of any collision piece, over all directions (what a top-down
  parallel-jaw gripper must close around); ``graspable``: narrowest <= gripper opening - 1 cm;
- ``head_fraction``: for two-part objects, the mass share of part B (the head of a T): from the
  record's per-part masses (``extra["part_masses"]`` of the part named "B") when the object has a
  per-part mass model, otherwise B's volume share of the two convex parts (one density);
- ``rests_flat``: the centre of mass lies (2 mm inside) over the convex hull of the mesh points within
  1 mm of its lowest point, so the object stays in the pose it was made in;
- ``mass``, ``density``, ``friction`` as recorded.

:func:`summary_lines` prints min / 5th percentile / median / 95th percentile / max of each, per kind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import MultiPoint, Point

from tognet.objects.record import ObjectRecord

GRIPPER_OPENING = 0.08
GRASP_MARGIN = 0.01


@dataclass(frozen=True)
class ObjectStats:
    """Tool-likeness measures of one object (metres, kilograms)."""

    object_id: str
    kind: str
    shape_rule: str
    length: float
    height: float
    narrowest: float
    graspable: bool
    head_fraction: float | None
    rests_flat: bool
    mass: float
    density: float
    friction: float


def min_width(points: np.ndarray, directions: int = 180) -> float:
    """The smallest width of a 2-D point set over ``directions`` evenly spaced directions."""
    angles = np.linspace(0.0, np.pi, directions, endpoint=False)
    proj = np.asarray(points)[:, :2] @ np.stack([np.cos(angles), np.sin(angles)])
    return float((proj.max(axis=0) - proj.min(axis=0)).min())


def rests_flat(
    vertices: np.ndarray, com: np.ndarray, tolerance: float = 0.001, margin: float = 0.002
) -> bool:
    """Whether ``com`` lies ``margin`` inside the support polygon of the points near the lowest one."""
    vertices = np.asarray(vertices)
    low = vertices[vertices[:, 2] < vertices[:, 2].min() + tolerance][:, :2]
    polygon = MultiPoint([tuple(p) for p in low]).convex_hull
    if polygon.area <= 0:
        return False
    return bool(polygon.buffer(-margin).contains(Point(float(com[0]), float(com[1]))))


def object_stats(record: ObjectRecord, opening: float = GRIPPER_OPENING) -> ObjectStats:
    """Measure one object (loads its visual mesh and collision pieces)."""
    pieces = [record.load_mesh(name) for name in record.collision_meshes]
    visual = record.load_mesh(record.visual_mesh)
    narrowest = min(min_width(np.asarray(p.vertices)) for p in pieces)
    head = None
    names, masses = record.extra.get("part_names"), record.extra.get("part_masses")
    if record.shape_rule in ("T", "L", "X") and names and masses and "B" in names and sum(masses) > 0:
        head = float(masses[names.index("B")]) / float(sum(masses))
    elif len(pieces) == 2 and record.shape_rule in ("T", "L", "X"):
        volumes = [float(p.volume) for p in pieces]
        head = volumes[1] / sum(volumes)
    return ObjectStats(
        object_id=record.object_id,
        kind=record.kind,
        shape_rule=record.shape_rule,
        length=float(max(record.extents[0], record.extents[1])),
        height=float(record.extents[2]),
        narrowest=narrowest,
        graspable=narrowest <= opening - GRASP_MARGIN,
        head_fraction=head,
        rests_flat=rests_flat(np.asarray(visual.vertices), np.asarray(record.com)),
        mass=record.mass,
        density=record.density,
        friction=record.friction,
    )


def _row(name: str, values: list[float], scale: float, unit: str, fmt: str = ".1f") -> str:
    if not values:
        return f"  {name:<22} -"
    v = np.asarray(values, dtype=np.float64) * scale
    cells = [v.min(), *np.percentile(v, [5, 50, 95]), v.max()]
    return f"  {name:<22} " + " ".join(f"{c:>7{fmt}}" for c in cells) + f"  {unit}"


def summary_lines(stats: list[ObjectStats], opening: float = GRIPPER_OPENING) -> list[str]:
    """A short text summary per kind: distributions (min, p5, median, p95, max) and fractions."""
    lines: list[str] = []
    for kind in sorted({s.kind for s in stats}):
        group = [s for s in stats if s.kind == kind]
        rules: dict[str, int] = {}
        for s in group:
            rules[s.shape_rule] = rules.get(s.shape_rule, 0) + 1
        rule_text = ", ".join(f"{k} {v}" for k, v in sorted(rules.items()))
        lines.append(f"{kind}: {len(group)} objects (rules: {rule_text})")
        lines.append(f"  {'':<22} {'min':>7} {'p5':>7} {'median':>7} {'p95':>7} {'max':>7}")
        lines.append(_row("length", [s.length for s in group], 100, "cm"))
        lines.append(_row("height", [s.height for s in group], 100, "cm"))
        lines.append(_row("narrowest part", [s.narrowest for s in group], 100, "cm"))
        lines.append(_row("mass", [s.mass for s in group], 1000, "g", ".0f"))
        lines.append(_row("density", [s.density for s in group], 1, "kg/m^3", ".0f"))
        lines.append(_row("friction", [s.friction for s in group], 1, "", ".2f"))
        for rule in ("T", "L", "X"):
            heads = [s.head_fraction for s in group if s.shape_rule == rule and s.head_fraction is not None]
            if heads:
                lines.append(_row(f"part B share ({rule})", heads, 100, "% of mass", ".0f"))
        graspable = np.mean([s.graspable for s in group])
        flat = np.mean([s.rests_flat for s in group])
        lines.append(
            f"  graspable (a part <= {100 * (opening - GRASP_MARGIN):.0f} cm wide): {100 * graspable:.0f} %;"
            f" rests in its generated pose: {100 * flat:.0f} %"
        )
    return lines
