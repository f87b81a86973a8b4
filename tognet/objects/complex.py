"""PG-Complex: parts cut by convex decomposition from irregular meshes this module generates.

For each object one irregular source mesh is drawn (about a thousand faces):

- ``superellipsoid``: a superellipsoid (random exponent and semi-axes) with low-frequency radial noise;
- ``revolved``: a surface of revolution of a random bumpy profile (vase, bottle, bulb);
- ``lofted``: stacked random star-ish cross-sections, shifted, scaled and twisted along the axis;
- ``blob``: the union of 3-5 random ellipsoids.

CoACD cuts it into convex pieces (:mod:`tognet.objects.decompose`); two pieces (the larger ones are
likelier) become parts A and B: each is turned so its principal axes match the canonical frame (long
axis x, height z), stretched to the part sizes of the T/L/X layout (:mod:`tognet.objects.compose`),
and its underside is cut flat (``flat_bottom``): the pieces are often rounded, and an object resting
on two rounded undersides kept rocking on the table for seconds in MuJoCo.
The realistic objects are never used as sources.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from tognet.config import Config, doc
from tognet.objects.assemble import MeshError
from tognet.objects.compose import (
    ShapeRanges,
    compose,
    fit_extents,
    flat_bottom,
    sample_layout,
    sample_rule,
    union,
)
from tognet.objects.decompose import DecomposeConfig, decompose

__all__ = ["ComplexConfig", "flat_bottom", "make_complex", "source_mesh"]

SOURCES = ("superellipsoid", "revolved", "lofted", "blob")


def _default_decompose() -> DecomposeConfig:
    return DecomposeConfig(threshold=0.08, max_pieces=10, max_vertices=48, mcts_iterations=30, resolution=500)


@dataclass(frozen=True)
class ComplexConfig(Config):
    """How PG-Complex objects are drawn."""

    ranges: ShapeRanges = doc(factory=ShapeRanges, text="Part sizes, density, friction and rule weights.")
    source_weights: tuple[float, float, float, float] = doc(
        (1.0, 1.0, 1.0, 1.0), "Relative frequency of source meshes superellipsoid, revolved, lofted, blob."
    )
    decompose: DecomposeConfig = doc(factory=_default_decompose, text="CoACD settings for the source meshes.")
    noise: tuple[float, float] = doc((0.04, 0.14), "Amplitude range of each radial noise wave (fraction).")
    flat_bottom: float = doc(
        0.15,
        "Cut each part's bottom flat at this fraction of its height (then restretch it to its extents), "
        "so the object rests on faces instead of rocking on a rounded underside; 0 = no cut.",
    )


def _waves(rng: np.random.Generator, directions: np.ndarray, amplitude: tuple[float, float]) -> np.ndarray:
    """Sum of 6 random plane waves over unit directions: smooth low-frequency radial noise."""
    out = np.zeros(len(directions))
    for _ in range(6):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        amp = rng.uniform(*amplitude)
        out += amp * np.sin(rng.uniform(2.0, 6.0) * (directions @ axis) + rng.uniform(0.0, 2 * np.pi))
    return out


def superellipsoid(rng: np.random.Generator, config: ComplexConfig) -> trimesh.Trimesh:
    """A noisy superellipsoid with semi-axes ~ (1, 0.3-0.8, 0.2-0.6)."""
    sphere = trimesh.creation.icosphere(subdivisions=3)
    d = np.asarray(sphere.vertices)
    axes = np.array([1.0, rng.uniform(0.3, 0.8), rng.uniform(0.2, 0.6)])
    n = rng.uniform(1.2, 5.0)
    radius = np.sum(np.abs(d / axes) ** n, axis=1) ** (-1.0 / n)
    radius *= 1.0 + _waves(rng, d, config.noise)
    return trimesh.Trimesh(d * radius[:, None], sphere.faces, process=True)


def revolved(rng: np.random.Generator, config: ComplexConfig) -> trimesh.Trimesh:
    """A surface of revolution of a random bumpy profile around z."""
    count = 14
    h = np.linspace(0.0, 1.0, count)
    r = rng.uniform(0.15, 0.35) + 0.0 * h
    for _ in range(3):
        r += rng.uniform(0.03, 0.15) * np.sin(rng.uniform(2.0, 9.0) * h + rng.uniform(0, 2 * np.pi))
    r = np.clip(r, 0.05, None)
    profile = np.column_stack([np.concatenate([[0.0], r, [0.0]]), np.concatenate([[0.0], h, [1.0]])])
    mesh = trimesh.creation.revolve(profile, sections=24)
    mesh.fix_normals()
    return mesh


def lofted(rng: np.random.Generator, config: ComplexConfig) -> trimesh.Trimesh:
    """Random star-ish cross-sections stacked along z, drifting, scaling and twisting."""
    angles = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    shape = np.ones_like(angles)
    for k in (2, 3, 4, 5):
        shape += rng.uniform(0.0, 0.25) * np.cos(k * angles + rng.uniform(0, 2 * np.pi))
    shape = np.clip(shape, 0.3, None)
    rings = 9
    z = np.linspace(0.0, 1.2, rings)
    scale = 0.25 * (1.0 + 0.5 * np.sin(rng.uniform(1.0, 5.0) * z + rng.uniform(0, 2 * np.pi)))
    drift = rng.uniform(-0.15, 0.15, size=2)
    twist = rng.uniform(-1.0, 1.0)
    vertices = []
    for i in range(rings):
        a = angles + twist * z[i]
        xy = (scale[i] * shape)[:, None] * np.column_stack([np.cos(a), np.sin(a)]) + drift * z[i]
        vertices.append(np.column_stack([xy, np.full(len(a), z[i])]))
    vertices = np.concatenate(vertices + [[[*(drift * z[0]), z[0]], [*(drift * z[-1]), z[-1]]]])
    n = len(angles)
    faces = []
    for i in range(rings - 1):
        for j in range(n):
            a, b = i * n + j, i * n + (j + 1) % n
            faces += [[a, b, b + n], [a, b + n, a + n]]
    bottom, top = rings * n, rings * n + 1
    for j in range(n):
        faces.append([bottom, (j + 1) % n, j])
        faces.append([top, (rings - 1) * n + j, (rings - 1) * n + (j + 1) % n])
    mesh = trimesh.Trimesh(vertices, np.asarray(faces), process=True)
    mesh.fix_normals()
    return mesh


def blob(rng: np.random.Generator, config: ComplexConfig) -> trimesh.Trimesh:
    """The union of 3-5 random ellipsoids whose centres lie near a random line."""
    pieces = []
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    for _ in range(int(rng.integers(3, 6))):
        sphere = trimesh.creation.icosphere(subdivisions=2)
        sphere.vertices *= rng.uniform(0.15, 0.4, size=3)
        centre = direction * rng.uniform(-0.5, 0.5) + rng.normal(scale=0.1, size=3)
        sphere.apply_translation(centre)
        pieces.append(sphere)
    return union(pieces)


_MAKERS = {"superellipsoid": superellipsoid, "revolved": revolved, "lofted": lofted, "blob": blob}


def source_mesh(rng: np.random.Generator, config: ComplexConfig) -> tuple[str, trimesh.Trimesh]:
    """Draw one irregular source mesh: (source type, mesh)."""
    weights = np.asarray(config.source_weights, dtype=np.float64)
    name = SOURCES[int(rng.choice(len(SOURCES), p=weights / weights.sum()))]
    return name, _MAKERS[name](rng, config)


def canonical(piece: trimesh.Trimesh, rng: np.random.Generator) -> trimesh.Trimesh:
    """A convex piece turned so its oriented bounding box is axis-aligned: longest side x, shortest z."""
    to_origin, extents = trimesh.bounds.oriented_bounds(piece)
    out = piece.copy()
    out.apply_transform(to_origin)
    order = np.argsort(-np.asarray(extents))
    out.vertices = out.vertices[:, order] * rng.choice([-1.0, 1.0], size=3)
    out = trimesh.convex.convex_hull(out.vertices)
    return out


def make_complex(
    rng: np.random.Generator, config: ComplexConfig | None = None
) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh], str, list[str], dict[str, Any]]:
    """Draw one PG-Complex object: (visual, convex pieces, rule, part types, info)."""
    config = config or ComplexConfig()
    source, mesh = source_mesh(rng, config)
    pieces = decompose(mesh, config.decompose, seed=int(rng.integers(0, 2**31 - 1)))
    if not pieces:
        raise MeshError(f"convex decomposition of a {source} mesh gave no pieces")
    volumes = np.array([p.volume for p in pieces])
    if len(pieces) >= 2:
        chosen = rng.choice(len(pieces), size=2, replace=False, p=volumes / volumes.sum())
    else:
        chosen = np.array([0, 0])
    rule = sample_rule(rng, config.ranges)
    layout = sample_layout(rng, config.ranges, rule)
    parts = [canonical(pieces[int(c)], rng) for c in chosen]
    part_a, part_b = (
        fit_extents(flat_bottom(fit_extents(p, e), config.flat_bottom, config.decompose.max_vertices), e)
        for p, e in zip(parts, (layout.extents_a, layout.extents_b), strict=True)
    )
    visual, parts = compose(part_a, part_b, layout, config.ranges.max_length)
    info = {
        "source": source,
        "source_pieces": len(pieces),
        "pieces_used": [int(c) for c in chosen],
        "extents_a": [round(v, 6) for v in layout.extents_a],
        "extents_b": [round(v, 6) for v in layout.extents_b],
        "yaw_b": round(layout.yaw_b, 6),
        **layout.info,
    }
    return visual, parts, rule, [f"{source}-piece", f"{source}-piece"], info
