"""Building blocks for the Realistic object set: convex parts, thin-walled vessels, rest poses.

Every model is assembled from parts whose convexity is known by construction (hulls of cross-sections,
extruded convex outlines, frusta), so the collision pieces come straight from the construction and no
convex decomposition is needed. Thin-walled solids of revolution (mugs, pans, bowls) are cut into
angular sectors; each sector piece is the hull of the wall profile swept to the sector's two bounding
angles with radii scaled by ``1 / cos(pi / sectors)``, so the pieces circumscribe the smooth wall instead
of cutting chords through it and never reach into the cavity.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import trimesh
from shapely.geometry import MultiPoint, Point, Polygon

# density kg/m^3, sliding friction coefficient
MATERIALS: dict[str, tuple[float, float]] = {
    "steel": (7850.0, 0.50),
    "aluminium": (2700.0, 0.45),
    "cast_iron": (7200.0, 0.55),
    "wood": (700.0, 0.60),
    "hardwood": (780.0, 0.60),
    "plastic": (1050.0, 0.45),
    "nylon": (1150.0, 0.40),
    "rubber": (1150.0, 0.90),
    "ceramic": (2400.0, 0.50),
    "bristle": (350.0, 0.60),
    "foam": (150.0, 0.80),
    "filled_drink": (850.0, 0.40),
    "battery_tube": (1500.0, 0.45),
    "electronics": (1100.0, 0.50),
    "paper_tape": (900.0, 0.55),
    "fruit": (950.0, 0.55),
    "mixed_metal": (2200.0, 0.45),
}

Vec = Sequence[float]


def hull(*point_sets: np.ndarray) -> trimesh.Trimesh:
    """Convex hull of the union of point sets, as a watertight outward-facing mesh."""
    points = np.vstack([np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in point_sets])
    mesh = trimesh.convex.convex_hull(points)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def ring(
    center: Vec, u: Vec, v: Vec, a: float, b: float, n: int = 16, p: float = 2.0, phase: float | None = None
) -> np.ndarray:
    """Points of a superellipse (exponent ``p``: 2 = ellipse, larger = rounded rectangle) in plane (u, v).

    The default phase (half a step) puts an edge, not a vertex, at the extremes of u and v, so a part
    lying on such a section rests on a flat face rather than rocking on a ridge.
    """
    if phase is None:
        phase = math.pi / n
    t = phase + 2.0 * math.pi * np.arange(n) / n
    c, s = np.cos(t), np.sin(t)
    e = 2.0 / p
    cu = np.sign(c) * np.abs(c) ** e
    sv = np.sign(s) * np.abs(s) ** e
    return (
        np.asarray(center, float)[None, :]
        + a * cu[:, None] * np.asarray(u, float)[None, :]
        + b * sv[:, None] * np.asarray(v, float)[None, :]
    )


def sec(
    x: float,
    a: float,
    b: float,
    *,
    y: float = 0.0,
    z: float = 0.0,
    n: int = 16,
    p: float = 2.0,
    shear: float = 0.0,
) -> np.ndarray:
    """Cross-section perpendicular to x at ``x``: half-width ``a`` along y, half-height ``b`` along z.

    ``shear`` tilts the section: x grows by ``shear * (z_point - z)``.
    """
    pts = ring((x, y, z), (0, 1, 0), (0, 0, 1), a, b, n=n, p=p)
    pts[:, 0] += shear * (pts[:, 2] - z)
    return pts


def box(lo: Vec, hi: Vec) -> trimesh.Trimesh:
    """Axis-aligned box between corners ``lo`` and ``hi``."""
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array(
        [[x, y, z] for x in (lo_a[0], hi_a[0]) for y in (lo_a[1], hi_a[1]) for z in (lo_a[2], hi_a[2])]
    )
    return hull(corners)


def _frame(axis: Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    w = np.asarray(axis, float)
    w = w / np.linalg.norm(w)
    ref = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(ref, w)
    u /= np.linalg.norm(u)
    return w, u, np.cross(w, u)


def frustum(
    p0: Vec, p1: Vec, r0: float, r1: float, n: int = 20, phase: float | None = None
) -> trimesh.Trimesh:
    """Truncated cone (or cylinder when ``r0 == r1``) from point ``p0`` to ``p1``."""
    w, u, v = _frame(np.asarray(p1, float) - np.asarray(p0, float))
    return hull(ring(p0, u, v, r0, r0, n=n, phase=phase), ring(p1, u, v, r1, r1, n=n, phase=phase))


def plate(outline: Sequence[tuple[float, float]], z0: float, z1: float) -> trimesh.Trimesh:
    """Prism over a convex outline in the xy plane, from height ``z0`` to ``z1``."""
    pts = np.asarray(outline, float)
    lower = np.column_stack([pts, np.full(len(pts), z0)])
    upper = np.column_stack([pts, np.full(len(pts), z1)])
    return hull(lower, upper)


def polygon_plate(poly: Polygon, z0: float, z1: float) -> trimesh.Trimesh:
    """Prism over a convex shapely polygon."""
    coords = np.asarray(poly.exterior.coords)[:-1]
    return plate([tuple(c) for c in coords], z0, z1)


def ellipsoid(
    center: Vec, radii: Vec, z_min: float | None = None, z_max: float | None = None
) -> trimesh.Trimesh:
    """Ellipsoid (icosphere, 42 vertices) optionally clipped flat below ``z_min`` / above ``z_max``."""
    pts = trimesh.creation.icosphere(subdivisions=1).vertices * np.asarray(radii, float) + np.asarray(
        center, float
    )
    if z_min is not None:
        pts[:, 2] = np.maximum(pts[:, 2], z_min)
    if z_max is not None:
        pts[:, 2] = np.minimum(pts[:, 2], z_max)
    return hull(pts)


def tube(
    path: Sequence[Vec],
    a: Sequence[float] | float,
    b: Sequence[float] | float,
    binormal: Vec,
    n: int = 12,
    p: float = 2.0,
) -> list[trimesh.Trimesh]:
    """Hulls of consecutive cross-sections along a polyline path lying in the plane normal to ``binormal``.

    The section's half-size ``a`` runs along ``binormal``, ``b`` along the in-plane normal of the path.
    """
    pts = np.asarray(path, float)
    count = len(pts)
    a_arr = np.broadcast_to(np.asarray(a, float), (count,))
    b_arr = np.broadcast_to(np.asarray(b, float), (count,))
    w = np.asarray(binormal, float)
    w = w / np.linalg.norm(w)
    sections = []
    for i in range(count):
        t = pts[min(i + 1, count - 1)] - pts[max(i - 1, 0)]
        t = t / np.linalg.norm(t)
        normal = np.cross(w, t)
        normal /= np.linalg.norm(normal)
        sections.append(ring(pts[i], w, normal, a_arr[i], b_arr[i], n=n, p=p))
    return [hull(sections[i], sections[i + 1]) for i in range(count - 1)]


def revolved_solid(
    profile: Sequence[tuple[float, float]],
    groups: Sequence[tuple[int, int]],
    n: int = 20,
    transform: np.ndarray | None = None,
) -> list[trimesh.Trimesh]:
    """Convex pieces of a solid of revolution about z: ``profile`` is (z, r); each group (i, j) is the hull
    of the rings i..j (choose groups where r(z) is concave so the hull equals the solid)."""
    prof = np.asarray(profile, float)
    pieces = []
    for i, j in groups:
        rings = [ring((0, 0, z), (1, 0, 0), (0, 1, 0), r, r, n=n) for z, r in prof[i : j + 1]]
        piece = hull(*rings)
        if transform is not None:
            piece.apply_transform(transform)
        pieces.append(piece)
    return pieces


def _sector_scale_minimax(sectors: int) -> float:
    """Radius scale for sector pieces: the flat face of a piece then lies between ``r (1 - e)`` (middle)
    and ``r (1 + e)`` (seams) of the smooth surface at radius ``r``, with ``e`` as small as possible."""
    return 2.0 / (1.0 + math.cos(math.pi / sectors))


def _sector_scale_circumscribed(sectors: int) -> float:
    return 1.0 / math.cos(math.pi / sectors)


_SECTOR_SCALE = _sector_scale_minimax


@dataclass
class Vessel:
    """A thin-walled open vessel about the z axis, smooth visual plus convex sector pieces."""

    visual: trimesh.Trimesh
    pieces: list[trimesh.Trimesh]


def vessel(
    stations: Sequence[tuple[float, float, float, float]],
    sectors: int = 12,
    visual_sections: int = 64,
    transform: np.ndarray | None = None,
) -> Vessel:
    """Open vessel standing on z = 0 with a flat bottom.

    ``stations`` are (r_out, z_out, r_in, z_in) from bottom to rim: the outer wall passes through
    (r_out, z_out), the inner wall through (r_in, z_in). The first station is the bottom corner
    (z_out = 0, z_in = bottom thickness); the last is the rim.
    """
    st = np.asarray(stations, float)
    outer = st[:, :2]
    inner = st[:, 2:]
    bottom_t = inner[0, 1]
    profile = [(0.0, 0.0), *map(tuple, outer), *map(tuple, inner[::-1]), (0.0, bottom_t)]
    visual = trimesh.creation.revolve(np.asarray(profile), sections=visual_sections)
    if visual.volume < 0:
        visual.invert()
    chunks: list[np.ndarray] = []
    first = [(inner[0, 0], 0.0), tuple(outer[0]), tuple(outer[1]), tuple(inner[1]), tuple(inner[0])]
    chunks.append(np.asarray(first))
    for k in range(1, len(st) - 1):
        chunks.append(np.asarray([inner[k], outer[k], outer[k + 1], inner[k + 1]]))
    scale = _SECTOR_SCALE(sectors)
    pieces = []
    r_b = inner[0, 0] * scale
    pieces.append(
        hull(
            ring((0, 0, 0), (1, 0, 0), (0, 1, 0), r_b, r_b, n=sectors, phase=0.0),
            ring((0, 0, bottom_t), (1, 0, 0), (0, 1, 0), r_b, r_b, n=sectors, phase=0.0),
        )
    )
    for chunk in chunks:
        for k in range(sectors):
            pts = []
            for theta in (2 * math.pi * k / sectors, 2 * math.pi * (k + 1) / sectors):
                c, s = math.cos(theta), math.sin(theta)
                for r, z in chunk:
                    pts.append((r * scale * c, r * scale * s, z))
            pieces.append(hull(np.asarray(pts)))
    if transform is not None:
        visual.apply_transform(transform)
        for piece in pieces:
            piece.apply_transform(transform)
    return Vessel(visual=visual, pieces=pieces)


def annulus(r_in: float, r_out: float, height: float, sectors: int = 12, visual_sections: int = 64) -> Vessel:
    """A ring (tape roll) standing on z = 0, as a smooth visual plus circumscribed sector pieces."""
    loop = np.array([[r_in, 0.0], [r_out, 0.0], [r_out, height], [r_in, height], [r_in, 0.0]])
    visual = trimesh.creation.revolve(loop, sections=visual_sections)
    if visual.volume < 0:
        visual.invert()
    scale = _SECTOR_SCALE(sectors)
    pieces = []
    for k in range(sectors):
        pts = []
        for theta in (2 * math.pi * k / sectors, 2 * math.pi * (k + 1) / sectors):
            c, s = math.cos(theta), math.sin(theta)
            for r in (r_in, r_out):
                for z in (0.0, height):
                    pts.append((r * scale * c, r * scale * s, z))
        pieces.append(hull(np.asarray(pts)))
    return Vessel(visual=visual, pieces=pieces)


def translation(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    """4x4 translation."""
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def rotation(axis: Vec, angle: float) -> np.ndarray:
    """4x4 rotation about an axis through the origin."""
    return trimesh.transformations.rotation_matrix(angle, np.asarray(axis, float))


@dataclass
class Builder:
    """Collects convex pieces (each with a material) and extra visual-only meshes."""

    pieces: list[trimesh.Trimesh] = field(default_factory=list)
    materials: list[str] = field(default_factory=list)
    visual_parts: list[trimesh.Trimesh] = field(default_factory=list)
    visual_materials: list[str] = field(default_factory=list)

    def add(self, mesh: trimesh.Trimesh | Sequence[trimesh.Trimesh], material: str) -> None:
        """Add convex part(s) that are both collision pieces and part of the visual union."""
        if material not in MATERIALS:
            raise KeyError(f"unknown material {material!r}; known: {', '.join(MATERIALS)}")
        meshes = [mesh] if isinstance(mesh, trimesh.Trimesh) else list(mesh)
        for m in meshes:
            self.pieces.append(m)
            self.materials.append(material)
            self.visual_parts.append(m)
            self.visual_materials.append(material)

    def add_vessel(self, v: Vessel, material: str) -> None:
        """Add a vessel: its smooth visual joins the union, its sector hulls become pieces."""
        if material not in MATERIALS:
            raise KeyError(f"unknown material {material!r}; known: {', '.join(MATERIALS)}")
        self.visual_parts.append(v.visual)
        self.visual_materials.append(material)
        for m in v.pieces:
            self.pieces.append(m)
            self.materials.append(material)

    def mass_parts(self) -> list[tuple[str, trimesh.Trimesh, float]]:
        """(material, watertight solid, density) per material, in the order materials were first added.

        Each solid is the union of that material's visual parts; where solids of two materials overlap
        the one added first owns the volume (``assemble_object``'s rule), e.g. a hammer's wooden
        handle where it runs into the steel head's eye.
        """
        order: list[str] = []
        for material in self.visual_materials:
            if material not in order:
                order.append(material)
        out = []
        for material in order:
            pairs = zip(self.visual_parts, self.visual_materials, strict=True)
            meshes = [m for m, mat in pairs if mat == material]
            solid = meshes[0].copy() if len(meshes) == 1 else trimesh.boolean.union(meshes, engine="manifold")
            if solid.volume < 0:
                solid.invert()
            out.append((material, solid, MATERIALS[material][0]))
        return out

    def density(self) -> float:
        """Volume-weighted density of the pieces' materials (a rough single-density summary only)."""
        vols = np.array([p.volume for p in self.pieces])
        rhos = np.array([MATERIALS[m][0] for m in self.materials])
        return float((vols * rhos).sum() / vols.sum())

    def friction(self) -> float:
        """Friction of the first part's material (by convention the part a gripper holds)."""
        return MATERIALS[self.materials[0]][1]

    def visual(self) -> trimesh.Trimesh:
        """Watertight union of the visual parts (manifold3d)."""
        if len(self.visual_parts) == 1:
            return self.visual_parts[0].copy()
        mesh = trimesh.boolean.union(self.visual_parts, engine="manifold")
        if mesh.volume < 0:
            mesh.invert()
        return mesh


def rest_pose(
    visual: trimesh.Trimesh,
    pieces: list[trimesh.Trimesh],
    margin: float = 0.002,
    settle: float = 0.0015,
    com: np.ndarray | None = None,
) -> np.ndarray:
    """4x4 transform putting the object on the table (z = 0) in the stable pose nearest to the built one.

    Candidate down directions are the face normals of the convex hull of the pieces. For each, the
    support polygon is made of the hull vertices within ``settle`` of the supporting plane (curved
    surfaces are triangulated into many thin faces; this groups them as the table would); the pose is
    stable when the centre of mass projects inside that polygon with ``margin`` to spare. Among stable
    poses the one whose down direction is nearest to -z wins, so a model built lying on its base keeps
    that pose. The result is centred on the origin in x and y, with its lowest point at z = 0.
    ``com`` is the centre of mass (default: the visual's at uniform density).
    """
    points = np.vstack([p.vertices for p in pieces])
    ch = trimesh.convex.convex_hull(points)
    verts = np.asarray(ch.vertices)
    com = np.asarray(visual.center_mass if com is None else com, dtype=np.float64)
    normals = np.asarray(ch.face_normals)
    order = np.argsort(normals[:, 2], kind="stable")  # most downward first
    chosen = normals[order[0]]
    for face in order:
        normal = normals[face]
        heights = verts @ normal
        support = verts[heights >= heights.max() - settle]
        if len(support) < 3:
            continue
        _, e1, e2 = _frame(normal)
        pts2 = np.column_stack([support @ e1, support @ e2])
        poly = Polygon(pts2).convex_hull
        if poly.area <= 0:
            continue
        if poly.buffer(-margin).contains(Point(com @ e1, com @ e2)):
            chosen = normal
            break
    transform = trimesh.geometry.align_vectors(chosen, np.array([0.0, 0.0, -1.0]))
    moved = trimesh.transform_points(points, transform)
    # yaw: put the long side of the smallest enclosing rectangle of the footprint along x
    rect = np.asarray(MultiPoint([tuple(p) for p in moved[:, :2]]).minimum_rotated_rectangle.exterior.coords)
    edges = np.diff(rect[:3], axis=0)
    longest = edges[int(np.argmax(np.linalg.norm(edges, axis=1)))]
    yaw = math.atan2(longest[1], longest[0])
    yaw = (yaw + math.pi / 2) % math.pi - math.pi / 2  # the nearest of the two directions along that side
    transform = rotation((0, 0, 1), -yaw) @ transform
    # the lowest point of pieces or visual touches z = 0 (a smooth visual may bulge a little past the
    # flat faces of its sector pieces; it should not dip below the table)
    moved = trimesh.transform_points(np.vstack([points, visual.vertices]), transform)
    lo, hi = moved.min(axis=0), moved.max(axis=0)
    shift = translation(-0.5 * (lo[0] + hi[0]), -0.5 * (lo[1] + hi[1]), -lo[2])
    return shift @ transform
