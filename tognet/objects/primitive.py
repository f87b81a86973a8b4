"""PG-Primitive: two parts from cuboids, cylinders and random convex polytopes, composed by T, L or X.

Part types:
- ``cuboid``: a box (long flat edges: what sweeping needs);
- ``cylinder``: an elliptic cylinder whose axis is the part's long axis (a round handle or head);
- ``polytope``: the convex hull of 8-16 random points, its bottom cut flat (``polytope_flat_bottom``),
  stretched to the part's extents.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from tognet.config import Config, doc
from tognet.objects.compose import (
    Layout,
    ShapeRanges,
    compose,
    fit_extents,
    flat_bottom,
    sample_layout,
    sample_rule,
)

PART_TYPES = ("cuboid", "cylinder", "polytope")


@dataclass(frozen=True)
class PrimitiveConfig(Config):
    """How PG-Primitive objects are drawn."""

    ranges: ShapeRanges = doc(factory=ShapeRanges, text="Part sizes, density, friction and rule weights.")
    part_weights: tuple[float, float, float] = doc(
        (0.45, 0.3, 0.25), "Relative frequency of part types cuboid, cylinder, polytope."
    )
    cylinder_sections: int = doc(20, "Facets around a cylinder.")
    polytope_points: tuple[int, int] = doc((8, 16), "Number of random points of a polytope (inclusive).")
    polytope_flat_bottom: float = doc(
        0.15,
        "Cut a polytope's bottom flat at this fraction of its height (then restretch it), so it rests on "
        "a face rather than a vertex and the object stays in the pose it was made in; 0 = no cut.",
    )


def make_part(
    part_type: str, extents: tuple[float, float, float], rng: np.random.Generator, config: PrimitiveConfig
) -> trimesh.Trimesh:
    """One convex primitive in the canonical frame (long axis x) with bounding box ``extents``."""
    if part_type == "cuboid":
        mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    elif part_type == "cylinder":
        mesh = trimesh.creation.cylinder(radius=0.5, height=1.0, sections=config.cylinder_sections)
        mesh.vertices = mesh.vertices[:, [2, 0, 1]]  # axis z -> x
        mesh.fix_normals()
    elif part_type == "polytope":
        lo, hi = config.polytope_points
        for _ in range(50):
            points = rng.uniform(-0.5, 0.5, size=(int(rng.integers(lo, hi + 1)), 3))
            hull = trimesh.convex.convex_hull(points)
            box = np.prod(hull.extents)
            if hull.is_volume and box > 0 and hull.volume / box > 0.25:
                break
        mesh = flat_bottom(fit_extents(hull, extents), config.polytope_flat_bottom)
    else:
        raise ValueError(f"unknown part type {part_type!r}; expected one of {', '.join(PART_TYPES)}")
    return fit_extents(mesh, extents)


def make_primitive(
    rng: np.random.Generator, config: PrimitiveConfig | None = None
) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh], str, list[str], dict[str, Any]]:
    """Draw one PG-Primitive object: (visual, convex pieces, rule, part types, info)."""
    config = config or PrimitiveConfig()
    rule = sample_rule(rng, config.ranges)
    layout: Layout = sample_layout(rng, config.ranges, rule)
    weights = np.asarray(config.part_weights, dtype=np.float64)
    types = [PART_TYPES[int(rng.choice(len(PART_TYPES), p=weights / weights.sum()))] for _ in range(2)]
    part_a = make_part(types[0], layout.extents_a, rng, config)
    part_b = make_part(types[1], layout.extents_b, rng, config)
    visual, pieces = compose(part_a, part_b, layout, config.ranges.max_length)
    info = {
        "extents_a": [round(v, 6) for v in layout.extents_a],
        "extents_b": [round(v, 6) for v in layout.extents_b],
        "yaw_b": round(layout.yaw_b, 6),
        **layout.info,
    }
    return visual, pieces, rule, types, info
