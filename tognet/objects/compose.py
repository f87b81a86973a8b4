"""Shape rules T, L and X: place two convex parts and join them rigidly (PG-Primitive and PG-Complex).

Every part is built in a canonical frame: centred at the origin, its long axis along x, its width along y
and its (small) height along z, with bounding-box extents exactly ``(length, width, height)``.
Part A is the long part (a handle, or a long edge); part B is placed by the rule:

- **T** (hammer-like): B lies crosswise (about 90 degrees) over one end of A, centred on A's axis,
  like a hammer head on its handle. B is the thick, heavy part.
- **L**: B is perpendicular-ish (70-90 degrees) at one end of A, flush with one of A's sides, so that
  A's long straight side and B form an L (a long sweeping edge with a hook).
- **X**: B crosses A somewhere in A's middle at 35-90 degrees.

Each part has its own density (:func:`part_densities`): the handle light (wood, plastic), the T head
or L arm metal with some probability, the two X parts independently, within the object's mass range.
Part B is listed first in the mass model, so the volume where the parts overlap is B's (the head block
is one material, the handle ends where it enters the head).

Part variants (:class:`PartVariant`, ``ShapeRanges.variants``, none by default) let some parts leave the
rule's size ranges: with a variant's probability a part A or B is redrawn as, e.g., a flat blade (3-15 mm
high, its width still the rule's), a thin shaft or a tall head. With no variants no extra random number is
drawn, so the default generator's objects are unchanged.

Both parts rest with their lowest points at the same height so a tool lies flat on a table; the object
frame is then moved to the centre of the bounding box. The visual is the boolean union of the two
parts (watertight, used for mass properties); the collision pieces are the two convex parts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import trimesh

from tognet.config import Config, ConfigRangeError, doc
from tognet.objects.assemble import MeshError
from tognet.objects.decompose import capped_hull, thin_vertices

RULES = ("T", "L", "X")


@dataclass(frozen=True)
class PartVariant(Config):
    """Another shape for part A or B, drawn with some probability instead of the rule's sizes.

    A field left None keeps the rule's draw; a given range replaces it (uniform, metres). The variants of
    one part are exclusive: one uniform number picks at most one of them (their probabilities add up).
    """

    name: str = doc("variant", "Short name, recorded in each object's extra['variants'].")
    part: Literal["A", "B"] = doc("B", "Which part: A (handle / long edge) or B (head, arm, crossing part).")
    probability: float = doc(0.0, "Chance that the part takes this variant.", ge=0, le=1)
    rules: tuple[str, ...] = doc(RULES, "Shape rules the variant applies to (T, L, X).")
    length: tuple[float, float] | None = doc(None, "Length range (m); None keeps the rule's.", gt=0)
    width: tuple[float, float] | None = doc(None, "Width range (m); None keeps the rule's.", gt=0)
    height: tuple[float, float] | None = doc(None, "Height range (m); None keeps the rule's.", gt=0)

    def check(self) -> None:
        """Known rules, and ranges whose low end is not above the high end."""
        unknown = [r for r in self.rules if r not in RULES]
        if unknown:
            raise ConfigRangeError("PartVariant", "rules", f"has unknown rules {unknown} (T, L, X)")
        for name in ("length", "width", "height"):
            bounds = getattr(self, name)
            if bounds is not None and bounds[0] > bounds[1]:
                raise ConfigRangeError("PartVariant", name,
                                       f"must be (low, high) with low <= high, got {bounds}")


@dataclass(frozen=True)
class ShapeRanges(Config):
    """Size ranges (metres) of the two parts, per rule. Length along a part's long axis."""

    handle_length: tuple[float, float] = doc((0.15, 0.34), "Part A (handle / long edge) length range (m).")
    handle_width: tuple[float, float] = doc((0.018, 0.045), "Part A width range (m): fits an 8 cm gripper.")
    handle_height: tuple[float, float] = doc((0.015, 0.035), "Part A height range (m).")
    t_head_length: tuple[float, float] = doc((0.06, 0.15), "T rule: head length (crosswise) range (m).")
    t_head_width: tuple[float, float] = doc((0.025, 0.06), "T rule: head width (along the handle) range (m).")
    t_head_height: tuple[float, float] = doc((0.022, 0.04), "T rule: head height range (m).")
    l_arm_length: tuple[float, float] = doc((0.06, 0.18), "L rule: short arm length range (m).")
    l_arm_width: tuple[float, float] = doc((0.018, 0.045), "L rule: short arm width range (m).")
    l_arm_height: tuple[float, float] = doc((0.015, 0.035), "L rule: short arm height range (m).")
    x_cross_length_ratio: tuple[float, float] = doc((0.35, 0.9), "X rule: crossing part length / A length.")
    x_cross_width: tuple[float, float] = doc((0.018, 0.05), "X rule: crossing part width range (m).")
    x_cross_height: tuple[float, float] = doc((0.015, 0.035), "X rule: crossing part height range (m).")
    max_length: float = doc(0.40, "Longest side of the whole object at most this (m); larger layouts shrink.")
    density: tuple[float, float] = doc(
        (300.0, 2500.0),
        "One-density range (kg/m^3) of sample_density (a single material for a whole object); the "
        "generators draw one density per part from light_density / metal_density instead.",
    )
    light_density: tuple[float, float] = doc(
        (400.0, 1400.0), "Per-part density range (kg/m^3) of light parts, uniform: woods and plastics."
    )
    metal_density: tuple[float, float] = doc(
        (2700.0, 7900.0), "Per-part density range (kg/m^3) of metal parts, uniform: aluminium to steel."
    )
    metal_probability: tuple[float, float, float] = doc(
        (0.5, 0.3, 0.2),
        "Probability that a part is metal, per rule T, L, X: the T head and the L arm (part A, the "
        "handle, is always light), each X part independently.",
    )
    mass: tuple[float, float] = doc(
        (0.08, 1.2), "Mass range (kg): densities are drawn from the part of their range giving such masses."
    )
    friction: tuple[float, float] = doc((0.5, 1.2), "Sliding friction coefficient range, uniform.")
    rule_weights: tuple[float, float, float] = doc((1.0, 1.0, 1.0), "Relative frequency of rules T, L, X.")
    variants: tuple[PartVariant, ...] = doc(
        (),
        "Other shapes some parts take instead of the sizes above (flat blades, thin shafts, tall heads); "
        "none by default (then no extra random number is drawn: the default objects stay the same; "
        "left out of a saved config while empty).",
        omit_default=True,
    )

    def check(self) -> None:
        """The variants of each part leave room for the plain part: probabilities add up to 1 at most."""
        for part in ("A", "B"):
            total = sum(v.probability for v in self.variants if v.part == part)
            if total > 1 + 1e-9:
                raise ConfigRangeError("ShapeRanges", "variants",
                                       f"probabilities of part {part} add up to {total:g}, more than 1")


@dataclass
class Layout:
    """Where the two parts go: their extents and B's pose relative to A (all in metres / radians)."""

    rule: str
    extents_a: tuple[float, float, float]
    extents_b: tuple[float, float, float]
    yaw_b: float
    centre_b: tuple[float, float]
    info: dict[str, Any] = field(default_factory=dict)


def _u(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def vary_part(
    rng: np.random.Generator, ranges: ShapeRanges, part: str, rule: str, sizes: tuple[float, float, float],
    info: dict[str, Any],
) -> tuple[float, float, float]:
    """``sizes`` (length, width, height) of ``part``, redrawn by one of its variants or kept.

    Draws nothing when no variant of ``part`` applies to ``rule``; otherwise one uniform number picks a
    variant (or none), whose given ranges are drawn in the order length, width, height. The chosen
    variant's name (or "") goes into ``info["variants"][part]``.
    """
    options = [v for v in ranges.variants if v.part == part and rule in v.rules and v.probability > 0]
    if not options:
        return sizes
    u = float(rng.uniform())
    chosen = None
    total = 0.0
    for variant in options:
        total += variant.probability
        if u < total:
            chosen = variant
            break
    info.setdefault("variants", {})[part] = "" if chosen is None else chosen.name
    if chosen is None:
        return sizes
    drawn = [sizes[i] if bounds is None else _u(rng, bounds)
             for i, bounds in enumerate((chosen.length, chosen.width, chosen.height))]
    return drawn[0], drawn[1], drawn[2]


def sample_rule(rng: np.random.Generator, ranges: ShapeRanges) -> str:
    """One of T, L, X with the configured weights."""
    weights = np.asarray(ranges.rule_weights, dtype=np.float64)
    return RULES[int(rng.choice(len(RULES), p=weights / weights.sum()))]


def sample_layout(rng: np.random.Generator, ranges: ShapeRanges, rule: str) -> Layout:
    """Draw the parts' extents and B's placement for ``rule``."""
    if rule not in RULES:
        raise ValueError(f"unknown shape rule {rule!r}; expected one of {', '.join(RULES)}")
    info: dict[str, Any] = {}
    la, wa, ha = _u(rng, ranges.handle_length), _u(rng, ranges.handle_width), _u(rng, ranges.handle_height)
    la, wa, ha = vary_part(rng, ranges, "A", rule, (la, wa, ha), info)
    if rule == "T":
        lb, wb = _u(rng, ranges.t_head_length), _u(rng, ranges.t_head_width)
        hb = _u(rng, ranges.t_head_height)
        lb, wb, hb = vary_part(rng, ranges, "B", rule, (lb, wb, hb), info)
        yaw = np.pi / 2 + float(rng.uniform(-0.12, 0.12))
        overlap = float(rng.uniform(0.75, 1.0)) * wb  # how much of the head's width sits over the handle
        centre = (la / 2 + wb / 2 - overlap, float(rng.uniform(-0.1, 0.1)) * lb)
    elif rule == "L":
        lb, wb, hb = _u(rng, ranges.l_arm_length), _u(rng, ranges.l_arm_width), _u(rng, ranges.l_arm_height)
        lb, wb, hb = vary_part(rng, ranges, "B", rule, (lb, wb, hb), info)
        lb = max(lb, wa + 0.02)
        yaw = np.pi / 2 + float(rng.uniform(-0.35, 0.0))
        side = 1.0 if rng.random() < 0.5 else -1.0
        centre = (la / 2 - wb / 2 * float(rng.uniform(0.8, 1.0)), side * (lb / 2 - wa / 2))
        yaw *= side
    else:  # X
        lb = la * _u(rng, ranges.x_cross_length_ratio)
        wb, hb = _u(rng, ranges.x_cross_width), _u(rng, ranges.x_cross_height)
        lb, wb, hb = vary_part(rng, ranges, "B", rule, (lb, wb, hb), info)
        lb = max(lb, wa + 0.04)
        yaw = float(rng.uniform(np.radians(35), np.radians(90))) * (1.0 if rng.random() < 0.5 else -1.0)
        centre = (float(rng.uniform(-0.3, 0.3)) * la, float(rng.uniform(-0.15, 0.15)) * lb)
    return Layout(rule=rule, extents_a=(la, wa, ha), extents_b=(lb, wb, hb), yaw_b=yaw, centre_b=centre,
                  info=info)


def fit_extents(mesh: trimesh.Trimesh, extents: tuple[float, float, float]) -> trimesh.Trimesh:
    """Centre a mesh at its bounding-box centre and scale each axis so the box is exactly ``extents``."""
    mesh = mesh.copy()
    lo, hi = mesh.bounds
    size = np.maximum(hi - lo, 1e-12)
    mesh.vertices = (mesh.vertices - (lo + hi) / 2) * (np.asarray(extents) / size)
    return mesh


def _placed(mesh: trimesh.Trimesh, yaw: float, centre: tuple[float, float]) -> trimesh.Trimesh:
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out = mesh.copy()
    out.vertices = out.vertices @ rot.T + np.array([centre[0], centre[1], 0.0])
    return out


def _rest_on_floor(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    out = mesh.copy()
    out.vertices = out.vertices - np.array([0.0, 0.0, out.bounds[0, 2]])
    return out


def convex_part(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The convex hull of ``mesh`` with outward faces (collision pieces must be convex)."""
    hull = trimesh.convex.convex_hull(np.asarray(mesh.vertices))
    if not hull.is_volume:
        raise MeshError("convex part is not a closed volume")
    return hull


def union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Watertight boolean union (manifold3d engine)."""
    result = trimesh.boolean.union(meshes, engine="manifold")
    if not isinstance(result, trimesh.Trimesh) or not result.is_watertight or result.volume <= 0:
        raise MeshError("boolean union of the parts is not a watertight volume")
    return result


def compose(
    part_a: trimesh.Trimesh, part_b: trimesh.Trimesh, layout: Layout, max_length: float = 0.40
) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    """Place two canonical convex parts by ``layout`` and join them.

    Returns (visual, [piece_a, piece_b]) in the object frame (bounding-box centre at the origin).
    If the parts barely touch (pointy polytopes), B slides towards A's centre until they overlap
    by a few percent of the smaller part, so the object is one rigid, connected body.
    """
    a = _rest_on_floor(convex_part(part_a))
    b0 = _rest_on_floor(convex_part(part_b))
    centre = np.asarray(layout.centre_b, dtype=np.float64)
    small = min(a.volume, b0.volume)
    for _ in range(12):
        b = _placed(b0, layout.yaw_b, (float(centre[0]), float(centre[1])))
        visual = union([a, b])
        overlap = a.volume + b.volume - visual.volume
        if overlap > 0.04 * small and len(visual.split(only_watertight=False)) == 1:
            break
        centre = centre * 0.8
    else:
        raise MeshError("the two parts do not overlap enough to form one rigid object")
    layout.info["centre_b_used"] = [round(float(v), 6) for v in centre]
    lo, hi = visual.bounds
    scale = min(1.0, max_length / float(np.max(hi - lo)))
    shift = -(lo + hi) / 2
    out = []
    for mesh in (visual, a, b):
        moved = mesh.copy()
        moved.vertices = (moved.vertices + shift) * scale
        out.append(moved)
    layout.info["shrink"] = round(scale, 6)
    return out[0], out[1:]


def flat_bottom(part: trimesh.Trimesh, fraction: float, max_vertices: int = 48) -> trimesh.Trimesh:
    """A convex part with its lowest ``fraction`` of height cut off by a horizontal plane (a flat face).

    The cut adds vertices; the hull is thinned back to ``max_vertices`` (farthest points first), keeping
    up to a third of them on the cut face so the face stays broad.
    """
    if fraction <= 0:
        return part
    if not 0 < fraction < 0.5:
        raise ValueError(f"flat_bottom must be in [0, 0.5), got {fraction}")
    z = np.asarray(part.vertices)[:, 2]
    cut = float(z.min() + fraction * (z.max() - z.min()))
    try:
        sliced = trimesh.intersections.slice_mesh_plane(part, [0.0, 0.0, 1.0], [0.0, 0.0, cut], cap=True)
        points = np.asarray(trimesh.convex.convex_hull(np.asarray(sliced.vertices)).vertices)
        on_face = points[:, 2] < cut + 1e-9 * max(1.0, abs(cut))
        face = thin_vertices(points[on_face], max(3, max_vertices // 3))
        rest = thin_vertices(points[~on_face], max(1, max_vertices - len(face)))
        hull = capped_hull(np.concatenate([face, rest]), max_vertices)
    except Exception as exc:  # slicing fails on degenerate parts
        raise MeshError(f"cannot cut a flat bottom ({exc})") from None
    if hull is None or not hull.is_volume:
        raise MeshError("the part with a flat bottom is not a closed volume")
    return hull


def sample_density(rng: np.random.Generator, ranges: ShapeRanges, volume: float) -> float:
    """A density, uniform over the part of ``ranges.density`` that keeps the mass in ``ranges.mass``.

    Drawing from the feasible interval (rather than drawing from the whole range and clamping the mass)
    keeps both density and mass inside their ranges without piling objects up at a mass bound. If no
    density in the range gives a mass in the range (a very small or very large object), the density
    nearest to the mass range is used: the material stays plausible and the mass misses its range.
    """
    if not volume > 0:
        raise MeshError(f"cannot choose a density for a volume of {volume}")
    lo = max(ranges.density[0], ranges.mass[0] / volume)
    hi = min(ranges.density[1], ranges.mass[1] / volume)
    u = float(rng.uniform(0.0, 1.0))
    if lo <= hi:
        return lo + u * (hi - lo)
    return float(ranges.density[1] if ranges.mass[0] / volume > ranges.density[1] else ranges.density[0])


def sample_part_densities(
    rng: np.random.Generator,
    volumes: list[float],
    intervals: list[tuple[float, float]],
    mass: tuple[float, float],
) -> list[float] | None:
    """Per-part densities, each uniform in its interval, with total mass sum(rho_i * V_i) in ``mass``.

    The multi-part form of :func:`sample_density`: the parts are drawn in order, each uniformly over
    the part of its interval that still leaves the remaining parts a way to reach the mass range
    (their interval bounds), so every draw stays feasible. Returns None when no choice in the
    intervals gives a mass in range. A part of volume 0 gets the middle of its interval.
    """
    vols = [float(v) for v in volumes]
    if len(vols) != len(intervals) or not vols:
        raise ValueError(f"{len(vols)} volumes for {len(intervals)} density intervals")
    if any(v < 0 for v in vols) or not sum(vols) > 0:
        raise MeshError(f"cannot choose densities for part volumes {vols}")
    lo_mass = sum(lo * v for (lo, _), v in zip(intervals, vols, strict=True))
    hi_mass = sum(hi * v for (_, hi), v in zip(intervals, vols, strict=True))
    if lo_mass > mass[1] or hi_mass < mass[0]:
        return None
    out: list[float] = []
    fixed = 0.0
    for i, ((lo, hi), v) in enumerate(zip(intervals, vols, strict=True)):
        rest_lo = sum(a * w for (a, _), w in zip(intervals[i + 1 :], vols[i + 1 :], strict=True))
        rest_hi = sum(b * w for (_, b), w in zip(intervals[i + 1 :], vols[i + 1 :], strict=True))
        u = float(rng.uniform(0.0, 1.0))
        if v <= 0:
            out.append(0.5 * (lo + hi))
            continue
        a = max(lo, (mass[0] - fixed - rest_hi) / v)
        b = min(hi, (mass[1] - fixed - rest_lo) / v)
        b = max(a, b)  # rounding only: the check above keeps a <= b
        rho = a + u * (b - a)
        out.append(rho)
        fixed += rho * v
    return out


def part_densities(
    rng: np.random.Generator, ranges: ShapeRanges, rule: str, volume_a: float, volume_b: float
) -> tuple[float, float, list[str]]:
    """(density of A, density of B, [material class of A, of B]) for a two-part object.

    Classes are ``light`` (``ranges.light_density``) or ``metal`` (``ranges.metal_density``), drawn
    with ``ranges.metal_probability`` of the rule (T head, L arm; both X parts independently; part A
    of T and L is always light). B is drawn first, then A, each from its feasible interval so the mass
    stays in ``ranges.mass``. If the metal choice cannot fit the mass range both parts become light;
    if no light choice fits either (a very small or very large object), the densities nearest to the
    mass range are used (the mass misses its range, the materials stay plausible).
    """
    p = dict(zip(RULES, ranges.metal_probability, strict=True))[rule]
    metal_a = rule == "X" and float(rng.uniform()) < p
    metal_b = float(rng.uniform()) < p
    classes = ["metal" if metal_a else "light", "metal" if metal_b else "light"]
    span = {"light": tuple(ranges.light_density), "metal": tuple(ranges.metal_density)}
    while True:
        # draw order B, A (the head decides most of the mass)
        drawn = sample_part_densities(
            rng, [volume_b, volume_a], [span[classes[1]], span[classes[0]]], tuple(ranges.mass)
        )
        if drawn is not None:
            return drawn[1], drawn[0], classes
        if "metal" not in classes:
            break
        classes = ["light", "light"]
    too_heavy = ranges.light_density[0] * (volume_a + volume_b) > ranges.mass[1]
    rho = float(ranges.light_density[0] if too_heavy else ranges.light_density[1])
    return rho, rho, classes
