"""The Realistic object set: whole everyday objects with real-world dimensions, tool-like and not.

Each model is built by hand from convex parts (see ``realistic_parts``): hulls of cross-sections for
handles and heads, extruded convex outlines for blades and jaws, circumscribed sector pieces for
thin-walled vessels. The visual mesh is the watertight union of the parts (manifold3d); the collision
pieces are the parts themselves. Each part has a material (``realistic_parts.MATERIALS``); mass, centre
of mass and inertia come from each material's solid and density (a hammer's steel head makes it
head-heavy), and the rest pose is chosen for that centre of mass. Everything is in metres, the object
lies in a stable rest pose on the plane z = 0, centred in x and y. No randomness: ``make_realistic(i)``
always builds the same meshes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import trimesh
from shapely.geometry import Point, Polygon

from tognet.objects.assemble import combine, part_masses
from tognet.objects.realistic_parts import (
    Builder,
    annulus,
    box,
    ellipsoid,
    frustum,
    hull,
    plate,
    polygon_plate,
    rest_pose,
    revolved_solid,
    rotation,
    sec,
    translation,
    tube,
    vessel,
)


@dataclass(frozen=True)
class RealisticModel:
    """One realistic object: watertight visual mesh and convex collision pieces, in its rest pose.

    ``parts`` are (material, solid, density) per material, in the rest pose, whose union is the
    visual: the mass model (see ``Builder.mass_parts``). ``density`` is the overall mass / volume.
    """

    name: str
    category: str
    tool_like: bool
    visual: trimesh.Trimesh
    pieces: list[trimesh.Trimesh]
    density: float
    friction: float
    parts: tuple[tuple[str, trimesh.Trimesh, float], ...] = ()

    @property
    def mass(self) -> float:
        """Total mass (kg): ``density`` is mass / visual volume."""
        return self.density * float(self.visual.volume)


# ----------------------------------------------------------------------------------------------- tools


def _hammer() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.016, 0.011, p=3), sec(0.08, 0.017, 0.0115, p=3), sec(0.29, 0.013, 0.0095, p=3)),
        "hardwood",
    )
    b.add(box((0.284, -0.017, -0.013), (0.316, 0.017, 0.013)), "steel")  # eye block
    b.add(frustum((0.30, 0.015, 0.0), (0.30, 0.058, 0.0), 0.0135, 0.0145, n=20), "steel")  # face
    for lo, hi in ((0.284, 0.2975), (0.3025, 0.316)):  # split claw
        root = np.array([[x, -0.016, z] for x in (lo, hi) for z in (-0.012, 0.012)])
        tip_lo, tip_hi = (lo + 0.004, hi - 0.002) if lo < 0.3 else (lo + 0.002, hi - 0.004)
        tip = np.array([[x, -0.072, z] for x in (tip_lo, tip_hi) for z in (-0.003, 0.002)])
        b.add(hull(root, tip), "steel")
    return b


def _mallet() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.0135, 0.0135, n=20), sec(0.27, 0.0115, 0.0115, n=20)), "hardwood")
    b.add(frustum((0.29, -0.055, 0.0), (0.29, 0.055, 0.0), 0.032, 0.032, n=24), "rubber")
    return b


def _spatula() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.013, 0.008, p=4), sec(0.15, 0.011, 0.007, p=4)), "nylon")
    blade_z = -0.030
    neck_end = np.array([[0.20, y, blade_z + dz] for y in (-0.016, 0.016) for dz in (0.0, 0.0025)])
    b.add(hull(sec(0.14, 0.010, 0.006, p=4), neck_end), "nylon")
    outline = [(0.195, -0.03), (0.30, -0.043), (0.305, -0.038), (0.305, 0.038), (0.30, 0.043), (0.195, 0.03)]
    b.add(plate(outline, blade_z, blade_z + 0.0025), "nylon")
    return b


def _frying_pan() -> Builder:
    b = Builder()
    wall = vessel([(0.095, 0.0, 0.0915, 0.004), (0.12, 0.045, 0.1165, 0.045)], sectors=16)
    slope = 0.025 / 0.045
    b.add(
        hull(sec(0.112, 0.012, 0.0075, z=0.033, p=3, shear=slope), sec(0.30, 0.0145, 0.007, z=0.070, p=3)),
        "plastic",
    )
    b.add_vessel(wall, "aluminium")
    return b


def _open_end_head(
    center: tuple[float, float], direction: float, radius: float, opening: float
) -> list[Polygon]:
    """Convex pieces of an open-end wrench head: a disc minus a slot along ``direction`` (radians)."""
    disc = Point(center).buffer(radius, 8)  # 32-gon
    d = np.array([math.cos(direction), math.sin(direction)])
    p = np.array([-d[1], d[0]])
    c = np.asarray(center)
    big = 4 * radius

    def half_plane(normal: np.ndarray, offset: float) -> Polygon:
        # {q : normal . (q - c) >= offset}
        t = np.array([-normal[1], normal[0]])
        base = c + normal * offset
        return Polygon(
            [base - t * big, base + t * big, base + t * big + normal * big, base - t * big + normal * big]
        )

    pieces = [
        disc.intersection(half_plane(p, opening / 2)),
        disc.intersection(half_plane(-p, opening / 2)),
        disc.intersection(half_plane(-d, 0.005)),
    ]
    return [poly.simplify(1e-6) for poly in pieces]


def _wrench() -> Builder:
    b = Builder()
    t0, t1 = -0.0032, 0.0032
    bar = Polygon(
        [
            (0.015, -0.0075),
            (0.10, -0.0095),
            (0.185, -0.0085),
            (0.185, 0.0085),
            (0.10, 0.0095),
            (0.015, 0.0075),
        ]
    )
    b.add(polygon_plate(bar, t0 + 0.0005, t1 - 0.0005), "steel")
    for poly in _open_end_head((0.0, 0.0), math.pi + math.radians(15), 0.0185, 0.017):
        b.add(polygon_plate(poly, t0, t1), "steel")
    for poly in _open_end_head((0.20, 0.0), math.radians(15), 0.0205, 0.019):
        b.add(polygon_plate(poly, t0, t1), "steel")
    return b


def _screwdriver() -> Builder:
    b = Builder()
    b.add(
        hull(
            sec(-0.006, 0.009, 0.009, n=12),
            sec(0.0, 0.0135, 0.0135, n=12),
            sec(0.03, 0.016, 0.016, n=12),
            sec(0.10, 0.0145, 0.0145, n=12),
        ),
        "plastic",
    )
    b.add(frustum((0.10, 0, 0), (0.112, 0, 0), 0.010, 0.005, n=16), "plastic")
    b.add(frustum((0.11, 0, 0), (0.21, 0, 0), 0.003, 0.003, n=12), "steel")
    tip = np.array([[0.222, y, z] for y in (-0.003, 0.003) for z in (-0.0004, 0.0004)])
    b.add(hull(sec(0.208, 0.003, 0.003, n=12), tip), "steel")
    return b


def _ladle() -> Builder:
    """Nylon soup ladle (3 mm walls)."""
    b = Builder()
    strip0 = np.array([[0.0435, y, z] for y in (-0.009, 0.009) for z in (0.036, 0.040)])
    angle = math.radians(32)
    end = np.array([0.043 + 0.25 * math.cos(angle), 0.0, 0.038 + 0.25 * math.sin(angle)])
    strip1 = np.array([[end[0], y, end[2] + dz] for y in (-0.011, 0.011) for dz in (-0.002, 0.002)])
    b.add(hull(strip0, strip1), "nylon")
    bowl = vessel(
        [(0.026, 0.0, 0.023, 0.003), (0.041, 0.018, 0.0378, 0.0195), (0.045, 0.040, 0.0418, 0.040)], sectors=8
    )
    b.add_vessel(bowl, "nylon")
    return b


def _brush() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.011, 0.0065, p=3), sec(0.05, 0.013, 0.007, p=3), sec(0.13, 0.009, 0.0055, p=3)),
        "wood",
    )
    b.add(hull(sec(0.125, 0.0255, 0.0075, p=6), sec(0.16, 0.0255, 0.0075, p=6)), "aluminium")
    b.add(hull(sec(0.158, 0.0245, 0.0065, p=6), sec(0.22, 0.0235, 0.0015, p=6)), "bristle")
    return b


def _saucepan() -> Builder:
    b = Builder()
    slope = 0.005 / 0.09
    b.add(
        hull(sec(0.081, 0.011, 0.0075, z=0.070, p=3, shear=slope), sec(0.26, 0.0135, 0.007, z=0.088, p=3)),
        "plastic",
    )
    b.add_vessel(vessel([(0.08, 0.0, 0.077, 0.004), (0.085, 0.09, 0.082, 0.09)], sectors=14), "aluminium")
    return b


def _flat_handle(x1: float, w0: float, w1: float, t: float, z0: float = 0.0) -> trimesh.Trimesh:
    """Flat cutlery handle from x = 0 (rounded end, width ``w0``) to ``x1`` (width ``w1``)."""
    arc = [
        (w0 / 2 * (1 - math.sin(a)) - 0.0, w0 / 2 * math.cos(a))
        for a in np.linspace(-math.pi / 2, math.pi / 2, 9)
    ]
    outline = [(x, y) for x, y in arc] + [(x1, -w1 / 2), (x1, w1 / 2)]
    return plate(outline, z0, z0 + t)


def _spoon() -> Builder:
    """Tablespoon lying face down: flat rim and handle on the table, the back of the bowl up."""
    b = Builder()
    b.add(_flat_handle(0.135, 0.026, 0.009, 0.0025), "steel")
    b.add(ellipsoid((0.17, 0.0, 0.0), (0.037, 0.021, 0.009), z_min=0.0), "steel")
    return b


def _fork() -> Builder:
    b = Builder()
    b.add(_flat_handle(0.13, 0.025, 0.009, 0.0025), "steel")
    b.add(plate([(0.125, -0.0045), (0.155, -0.0115), (0.155, 0.0115), (0.125, 0.0045)], 0.0, 0.0022), "steel")
    width, gap = 0.0035, (0.023 - 4 * 0.0035) / 3
    for k in range(4):
        y0 = -0.0115 + k * (width + gap)
        tip = 0.202 if k in (1, 2) else 0.199
        b.add(
            plate(
                [
                    (0.154, y0),
                    (tip - 0.002, y0),
                    (tip, y0 + width / 2),
                    (tip - 0.002, y0 + width),
                    (0.154, y0 + width),
                ],
                0.0,
                0.002,
            ),
            "steel",
        )
    return b


def _knife() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.011, 0.009, p=3), sec(0.06, 0.0125, 0.0105, p=3), sec(0.12, 0.011, 0.0095, p=3)),
        "plastic",
    )
    b.add(hull(sec(0.118, 0.010, 0.0085, p=3), sec(0.132, 0.021, 0.0035, p=4, y=-0.012)), "steel")  # bolster
    blade = [
        (0.125, 0.006),
        (0.125, -0.040),
        (0.20, -0.037),
        (0.26, -0.026),
        (0.30, -0.011),
        (0.32, 0.0),
        (0.28, 0.006),
    ]
    b.add(plate(blade, -0.001, 0.001), "steel")
    return b


def _scraper() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.013, 0.010, p=3), sec(0.10, 0.015, 0.011, p=3)), "plastic")
    b.add(hull(sec(0.10, 0.016, 0.008, p=4), sec(0.115, 0.019, 0.003, p=4)), "steel")
    b.add(plate([(0.11, -0.020), (0.205, -0.038), (0.205, 0.038), (0.11, 0.020)], -0.0005, 0.0005), "steel")
    return b


def _trowel() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.014, 0.014, n=16), sec(0.03, 0.016, 0.016, n=16), sec(0.12, 0.0145, 0.0145, n=16)),
        "wood",
    )
    b.add(
        tube([(0.115, 0, 0), (0.145, 0, -0.012), (0.165, 0, -0.028)], 0.005, 0.004, (0, 1, 0), n=8), "steel"
    )
    tilt = math.radians(14)
    half = [(0.155, 0.0), (0.155, 0.042), (0.21, 0.040), (0.26, 0.022), (0.295, 0.0)]
    for side in (1.0, -1.0):
        pts = []
        for x, y in half:
            base = np.array([x, side * y * math.cos(tilt), -0.030 + y * math.sin(tilt)])
            normal = np.array([0.0, -side * math.sin(tilt), math.cos(tilt)])
            pts += [base, base + 0.0015 * normal]
        b.add(hull(np.asarray(pts)), "steel")
    return b


def _rolling_pin() -> Builder:
    b = Builder()
    b.add(frustum((-0.125, 0, 0), (0.125, 0, 0), 0.029, 0.029, n=24), "wood")
    for x0, x1 in ((-0.2, -0.12), (0.12, 0.2)):
        b.add(
            hull(
                sec(x0, 0.013, 0.013, n=16),
                sec(x1, 0.0125, 0.0125, n=16),
                sec(x0 - 0.006 * np.sign(x0), 0.009, 0.009, n=16),
            ),
            "wood",
        )
    return b


def _file() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.010, 0.010, n=16), sec(0.02, 0.014, 0.014, n=16), sec(0.11, 0.0125, 0.0125, n=16)),
        "wood",
    )
    b.add(frustum((0.105, 0, 0), (0.12, 0, 0), 0.0125, 0.0125, n=16), "steel")
    b.add(
        hull(sec(0.118, 0.0125, 0.0032, p=8), sec(0.30, 0.011, 0.0029, p=8), sec(0.36, 0.0065, 0.002, p=8)),
        "steel",
    )
    return b


def _chisel() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.010, 0.010, n=16), sec(0.015, 0.014, 0.014, n=16), sec(0.11, 0.0155, 0.0155, n=16)),
        "hardwood",
    )
    b.add(frustum((0.108, 0, 0), (0.125, 0, 0), 0.0125, 0.0075, n=16), "steel")
    b.add(box((0.12, -0.0095, -0.0025), (0.235, 0.0095, 0.0025)), "steel")
    edge = np.array([[0.255, y, -0.0025] for y in (-0.0095, 0.0095)])
    b.add(
        hull(np.array([[0.234, y, z] for y in (-0.0095, 0.0095) for z in (-0.0025, 0.0025)]), edge), "steel"
    )
    return b


def _pliers() -> Builder:
    b = Builder()
    zt = (-0.0045, 0.0045)
    b.add(plate([(0.0, 0.013), (0.0, 0.030), (0.005, 0.031), (0.118, 0.012), (0.118, 0.0015)], *zt), "rubber")
    b.add(
        plate([(0.0, -0.013), (0.0, -0.030), (0.005, -0.031), (0.118, -0.012), (0.118, -0.0015)], *zt),
        "rubber",
    )
    b.add(frustum((0.125, 0, -0.0055), (0.125, 0, 0.0055), 0.013, 0.013, n=20), "steel")
    b.add(
        plate(
            [
                (0.11, -0.0115),
                (0.175, -0.0075),
                (0.198, -0.003),
                (0.198, 0.003),
                (0.175, 0.0075),
                (0.11, 0.0115),
            ],
            -0.005,
            0.005,
        ),
        "steel",
    )
    b.add(plate([(0.10, -0.011), (0.12, -0.012), (0.12, 0.012), (0.10, 0.011)], -0.0048, 0.0048), "steel")
    return b


def _wooden_spoon() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.008, 0.0055, p=3), sec(0.21, 0.0105, 0.0065, p=3)), "wood")
    b.add(ellipsoid((0.255, 0.0, 0.0), (0.048, 0.030, 0.009), z_min=-0.0065, z_max=0.0045), "wood")
    return b


def _ice_cream_scoop() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.012, 0.010, p=3), sec(0.03, 0.0135, 0.0115, p=3), sec(0.12, 0.012, 0.010, p=3)),
        "aluminium",
    )
    b.add(hull(sec(0.118, 0.009, 0.007, p=3), sec(0.132, 0.007, 0.003, p=3, z=0.0)), "aluminium")
    cup = vessel(
        [(0.012, 0.0, 0.010, 0.002), (0.025, 0.016, 0.023, 0.016), (0.0285, 0.033, 0.0265, 0.033)],
        sectors=8,
        transform=translation(0.158, 0.0, -0.033) @ np.eye(4),
    )
    b.add_vessel(cup, "aluminium")
    return b


def _squeegee() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.0125, 0.0075, p=3), sec(0.05, 0.014, 0.008, p=3), sec(0.22, 0.012, 0.0075, p=3)),
        "plastic",
    )
    b.add(box((0.215, -0.15, -0.008), (0.24, 0.15, 0.008)), "aluminium")
    b.add(box((0.238, -0.15, -0.0015), (0.256, 0.15, 0.0015)), "rubber")
    return b


def _paint_roller() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.014, 0.014, n=16), sec(0.03, 0.0165, 0.0165, n=16), sec(0.12, 0.015, 0.015, n=16)),
        "plastic",
    )
    b.add(
        tube([(0.115, 0.0, 0.0), (0.22, 0.0, 0.0), (0.22, 0.04, 0.0)], 0.003, 0.003, (0, 0, 1), n=8), "steel"
    )
    b.add(frustum((0.22, 0.035, 0.0), (0.22, 0.265, 0.0), 0.024, 0.024, n=24), "foam")
    return b


def _hand_rake() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.014, 0.014, n=16), sec(0.03, 0.016, 0.016, n=16), sec(0.12, 0.0145, 0.0145, n=16)),
        "wood",
    )
    b.add(hull(sec(0.115, 0.007, 0.003, p=6), sec(0.17, 0.007, 0.003, p=6)), "steel")
    b.add(box((0.165, -0.038, -0.003), (0.177, 0.038, 0.003)), "steel")
    for y in (-0.033, 0.0, 0.033):
        b.add(
            tube(
                [(0.17, y, 0.0), (0.205, y, -0.006), (0.225, y, -0.03), (0.222, y, -0.05)],
                0.003,
                0.0035,
                (0, 1, 0),
                n=8,
            ),
            "steel",
        )
    return b


def _crowbar() -> Builder:
    b = Builder()
    b.add(frustum((0.02, 0, 0), (0.33, 0, 0), 0.0085, 0.0085, n=6, phase=math.pi / 6), "steel")
    b.add(hull(sec(0.0, 0.010, 0.0025, p=4), sec(0.025, 0.0085, 0.0085, n=6)), "steel")
    arc = [
        (0.33 + 0.035 * math.sin(a), 0.035 - 0.035 * math.cos(a), 0.0) for a in np.radians([0, 55, 110, 160])
    ]
    b.add(tube(arc, 0.0085, 0.0085, (0, 0, 1), n=6), "steel")
    end = np.array(arc[-1])
    claw_dir = np.array([-math.cos(math.radians(20)), math.sin(math.radians(20)), 0.0])
    tip = end + 0.03 * claw_dir
    claw_tip = np.array(
        [tip + (dx, dy, dz) for dx, dy in ((0.0, 0.0), (0.004, 0.008)) for dz in (-0.0025, 0.0025)]
    )
    b.add(hull(sec(0.0, 0.0085, 0.0085, n=6) + end, claw_tip), "steel")
    return b


def _tongs() -> Builder:
    b = Builder()
    b.add(plate([(0.0, -0.009), (0.26, -0.0095), (0.26, 0.0095), (0.0, 0.009)], 0.0, 0.0015), "steel")
    arm2 = np.array(
        [
            [x, y, z]
            for x, z0 in ((0.0, 0.034), (0.26, 0.0045))
            for y in (-0.009, 0.009)
            for z in (z0, z0 + 0.0015)
        ]
    )
    b.add(hull(arm2), "steel")
    b.add(box((-0.022, -0.011, 0.0), (0.004, 0.011, 0.0355)), "plastic")
    b.add(ellipsoid((0.28, 0.0, 0.0), (0.03, 0.02, 0.004), z_min=0.0, z_max=0.0025), "steel")
    b.add(ellipsoid((0.28, 0.0, 0.0035), (0.03, 0.02, 0.004), z_min=0.0035, z_max=0.006), "steel")
    return b


def _toothbrush() -> Builder:
    b = Builder()
    b.add(
        hull(sec(0.0, 0.0065, 0.004, p=3), sec(0.04, 0.0085, 0.0055, p=3), sec(0.12, 0.006, 0.004, p=3)),
        "plastic",
    )
    b.add(hull(sec(0.118, 0.006, 0.004, p=3), sec(0.158, 0.0035, 0.0028, p=3)), "plastic")
    b.add(hull(sec(0.156, 0.006, 0.0028, p=4), sec(0.187, 0.0055, 0.0028, p=4)), "plastic")
    b.add(box((0.158, -0.0055, 0.002), (0.186, 0.0055, 0.013)), "bristle")
    return b


def _hex_key() -> Builder:
    b = Builder()
    r = 0.005
    b.add(
        tube(
            [(0.0, 0.0, 0.0), (0.14, 0.0, 0.0), (0.152, 0.012, 0.0), (0.152, 0.055, 0.0)],
            r,
            r,
            (0, 0, 1),
            n=6,
            p=2.0,
        ),
        "steel",
    )
    return b


def _dustpan() -> Builder:
    b = Builder()
    b.add(hull(sec(-0.13, 0.013, 0.011, p=3), sec(-0.035, 0.015, 0.012, p=3, z=0.012)), "plastic")
    b.add(plate([(-0.03, -0.14), (0.19, -0.15), (0.19, 0.15), (-0.03, 0.14)], 0.0, 0.003), "plastic")
    b.add(box((-0.035, -0.14, 0.0), (-0.025, 0.14, 0.065)), "plastic")
    for side in (1.0, -1.0):
        y_in, y_out = 0.136 * side, 0.145 * side
        wall = np.array(
            [
                [x, y, z]
                for y in (y_in, y_out)
                for x, z in ((-0.035, 0.0), (-0.035, 0.065), (0.19, 0.0), (0.19, 0.006))
            ]
        )
        b.add(hull(wall), "plastic")
    return b


# -------------------------------------------------------------------------------------------- household


def _mug() -> Builder:
    b = Builder()
    path = [
        (0.0385, 0.0, 0.076),
        (0.060, 0.0, 0.079),
        (0.071, 0.0, 0.060),
        (0.068, 0.0, 0.034),
        (0.0385, 0.0, 0.024),
    ]
    b.add(tube(path, 0.0065, 0.0045, (0, 1, 0), n=12, p=3), "ceramic")
    b.add_vessel(vessel([(0.040, 0.0, 0.0355, 0.007), (0.041, 0.095, 0.0365, 0.095)], sectors=12), "ceramic")
    return b


def _bottle() -> Builder:
    b = Builder()
    lie = translation(0, 0, 0.032) @ rotation((0, 1, 0), math.pi / 2)
    profile = [
        (0.0, 0.027),
        (0.004, 0.0315),
        (0.012, 0.032),
        (0.155, 0.032),
        (0.185, 0.027),
        (0.20, 0.0145),
        (0.216, 0.0135),
        (0.214, 0.0155),
        (0.236, 0.0155),
    ]
    b.add(revolved_solid(profile, [(0, 3), (3, 6), (5, 6)], n=16, transform=lie), "filled_drink")
    b.add(revolved_solid(profile, [(7, 8)], n=20, transform=lie), "plastic")
    return b


def _can() -> Builder:
    b = Builder()
    profile = [
        (0.0, 0.025),
        (0.005, 0.0315),
        (0.012, 0.033),
        (0.104, 0.033),
        (0.113, 0.0295),
        (0.116, 0.0285),
        (0.1185, 0.0285),
    ]
    b.add(revolved_solid(profile, [(0, 2), (2, 4), (4, 6)], n=20), "filled_drink")
    return b


def _bowl() -> Builder:
    b = Builder()
    b.add_vessel(
        vessel(
            [(0.035, 0.0, 0.030, 0.006), (0.061, 0.028, 0.0555, 0.0295), (0.076, 0.062, 0.0705, 0.062)],
            sectors=10,
        ),
        "ceramic",
    )
    return b


def _cup() -> Builder:
    b = Builder()
    b.add_vessel(vessel([(0.027, 0.0, 0.0245, 0.003), (0.040, 0.095, 0.0375, 0.095)], sectors=12), "plastic")
    return b


def _tape_roll() -> Builder:
    b = Builder()
    b.add_vessel(annulus(0.038, 0.055, 0.024, sectors=12), "paper_tape")
    return b


def _stapler() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.014, 0.009, z=0.035, p=4), sec(0.14, 0.015, 0.011, z=0.031, p=4)), "mixed_metal")
    b.add(hull(sec(-0.005, 0.018, 0.004, z=0.004, p=4), sec(0.16, 0.018, 0.004, z=0.004, p=4)), "mixed_metal")
    b.add(box((0.0, -0.014, 0.006), (0.025, 0.014, 0.03)), "plastic")
    return b


def _remote_control() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.022, 0.010, z=0.010, p=4), sec(0.18, 0.025, 0.0115, z=0.0115, p=4)), "electronics")
    b.add(frustum((0.14, 0.0, 0.018), (0.14, 0.0, 0.025), 0.013, 0.012, n=20), "plastic")
    b.add(box((0.02, -0.012, 0.018), (0.09, 0.012, 0.0235)), "plastic")
    return b


def _banana() -> Builder:
    b = Builder()
    radius, span = 0.16, math.radians(95)
    angles = np.linspace(-span / 2, span / 2, 7)
    path = [(radius * math.sin(a), radius * (1 - math.cos(a)), 0.0) for a in angles]
    half = [0.006, 0.0135, 0.0175, 0.018, 0.0165, 0.012, 0.005]
    b.add(tube(path, [h * 0.92 for h in half], half, (0, 0, 1), n=10, p=2.4), "fruit")
    end = np.array(path[-1])
    tangent = end - np.array(path[-2])
    tangent /= np.linalg.norm(tangent)
    b.add(
        hull(sec(0, 0.0045, 0.0045, n=8) + end, sec(0, 0.0035, 0.0035, n=8) + end + 0.022 * tangent), "fruit"
    )
    return b


def _flashlight() -> Builder:
    b = Builder()
    b.add(frustum((0.0, 0, 0), (0.17, 0, 0), 0.0165, 0.0165, n=20), "battery_tube")
    b.add(frustum((0.165, 0, 0), (0.19, 0, 0), 0.0165, 0.026, n=20), "aluminium")
    b.add(frustum((0.188, 0, 0), (0.235, 0, 0), 0.026, 0.026, n=20), "aluminium")
    b.add(box((0.13, -0.006, 0.014), (0.155, 0.006, 0.0195)), "rubber")  # switch stops it rolling away
    return b


def _marker() -> Builder:
    b = Builder()
    b.add(frustum((0.0, 0, 0), (0.10, 0, 0), 0.0085, 0.0085, n=16), "plastic")
    b.add(frustum((0.095, 0, 0), (0.14, 0, 0), 0.0095, 0.009, n=16), "plastic")
    b.add(box((0.105, -0.0025, 0.007), (0.138, 0.0025, 0.0125)), "plastic")  # clip
    return b


def _ruler() -> Builder:
    b = Builder()
    b.add(plate([(0.0, -0.016), (0.31, -0.016), (0.31, 0.016), (0.0, 0.016)], 0.0, 0.003), "plastic")
    return b


def _comb() -> Builder:
    b = Builder()
    b.add(plate([(0.0, 0.0), (0.18, 0.0), (0.178, 0.012), (0.002, 0.012)], 0.0, 0.004), "plastic")
    teeth = 14
    pitch = 0.172 / teeth
    for k in range(teeth):
        x0 = 0.005 + k * pitch
        w = 0.0045 if k < 5 else 0.003
        b.add(
            plate(
                [(x0, 0.0115), (x0 + w, 0.0115), (x0 + w - 0.0008, 0.033), (x0 + 0.0008, 0.033)],
                0.0004,
                0.0036,
            ),
            "plastic",
        )
    return b


def _smartphone() -> Builder:
    b = Builder()
    b.add(
        hull(
            sec(0.0, 0.034, 0.0035, z=0.0042, p=6),
            sec(0.006, 0.0355, 0.0042, z=0.0042, p=6),
            sec(0.141, 0.0355, 0.0042, z=0.0042, p=6),
            sec(0.147, 0.034, 0.0035, z=0.0042, p=6),
        ),
        "electronics",
    )
    b.add(box((0.005, 0.006, 0.0076), (0.04, 0.03, 0.0098)), "electronics")  # camera bump
    return b


def _cleaver() -> Builder:
    b = Builder()
    b.add(hull(sec(0.0, 0.012, 0.009, p=3), sec(0.115, 0.013, 0.010, p=3)), "hardwood")
    b.add(plate([(0.11, -0.005), (0.29, -0.005), (0.29, 0.085), (0.11, 0.075)], -0.0015, 0.0015), "steel")
    return b


def _whisk_handle_spatula() -> Builder:
    """Silicone kitchen scraper (spatula with a flexible head)."""
    b = Builder()
    b.add(hull(sec(0.0, 0.009, 0.006, p=3), sec(0.19, 0.008, 0.005, p=3)), "plastic")
    head = [(0.185, -0.024), (0.245, -0.026), (0.255, -0.018), (0.255, 0.024), (0.245, 0.026), (0.185, 0.024)]
    b.add(plate(head, -0.003, 0.003), "rubber")
    return b


Factory = Callable[[], Builder]
_MODELS: list[tuple[str, str, bool, Factory]] = [
    ("hammer", "hand_tool", True, _hammer),
    ("mallet", "hand_tool", True, _mallet),
    ("spatula", "kitchen", True, _spatula),
    ("frying_pan", "kitchen", True, _frying_pan),
    ("wrench", "hand_tool", True, _wrench),
    ("screwdriver", "hand_tool", True, _screwdriver),
    ("ladle", "kitchen", True, _ladle),
    ("brush", "hand_tool", True, _brush),
    ("mug", "container", False, _mug),
    ("bottle", "container", False, _bottle),
    ("can", "container", False, _can),
    ("saucepan", "kitchen", True, _saucepan),
    ("spoon", "kitchen", True, _spoon),
    ("fork", "kitchen", True, _fork),
    ("knife", "kitchen", True, _knife),
    ("scraper", "hand_tool", True, _scraper),
    ("trowel", "garden", True, _trowel),
    ("rolling_pin", "kitchen", True, _rolling_pin),
    ("file", "hand_tool", True, _file),
    ("chisel", "hand_tool", True, _chisel),
    ("pliers", "hand_tool", True, _pliers),
    ("wooden_spoon", "kitchen", True, _wooden_spoon),
    ("ice_cream_scoop", "kitchen", True, _ice_cream_scoop),
    ("squeegee", "cleaning", True, _squeegee),
    ("paint_roller", "hand_tool", True, _paint_roller),
    ("hand_rake", "garden", True, _hand_rake),
    ("crowbar", "hand_tool", True, _crowbar),
    ("tongs", "kitchen", True, _tongs),
    ("toothbrush", "household", True, _toothbrush),
    ("hex_key", "hand_tool", True, _hex_key),
    ("dustpan", "cleaning", True, _dustpan),
    ("cleaver", "kitchen", True, _cleaver),
    ("silicone_spatula", "kitchen", True, _whisk_handle_spatula),
    ("bowl", "container", False, _bowl),
    ("cup", "container", False, _cup),
    ("tape_roll", "office", False, _tape_roll),
    ("stapler", "office", False, _stapler),
    ("remote_control", "household", False, _remote_control),
    ("banana", "food", False, _banana),
    ("flashlight", "household", False, _flashlight),
    ("marker", "office", False, _marker),
    ("ruler", "office", True, _ruler),
    ("comb", "household", False, _comb),
    ("smartphone", "household", False, _smartphone),
]

REALISTIC_NAMES: list[str] = [name for name, _, _, _ in _MODELS]


def make_realistic(index: int) -> RealisticModel:
    """Build realistic model ``index`` (0 <= index < len(REALISTIC_NAMES)), always the same meshes."""
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise TypeError(f"realistic index must be an int, got {type(index).__name__}")
    if not 0 <= int(index) < len(_MODELS):
        raise IndexError(
            f"realistic index {index} out of range: there are {len(_MODELS)} models (0..{len(_MODELS) - 1})"
        )
    name, category, tool_like, factory = _MODELS[int(index)]
    builder = factory()
    visual = builder.visual()
    pieces = [p.copy() for p in builder.pieces]
    parts = builder.mass_parts()
    mass, volume, com, _inertia = combine(part_masses([(solid, rho) for _, solid, rho in parts]))
    transform = rest_pose(visual, pieces, com=com)
    visual.apply_transform(transform)
    for mesh in [*pieces, *(solid for _, solid, _ in parts)]:
        mesh.apply_transform(transform)
    return RealisticModel(
        name=name,
        category=category,
        tool_like=tool_like,
        visual=visual,
        pieces=pieces,
        density=round(mass / float(visual.volume), 3),
        friction=builder.friction(),
        parts=tuple(parts),
    )


def realistic_index(name: str) -> int:
    """Index of a realistic model by name."""
    try:
        return REALISTIC_NAMES.index(name)
    except ValueError:
        raise KeyError(f"no realistic model named {name!r}; known: {', '.join(REALISTIC_NAMES)}") from None


__all__ = ["REALISTIC_NAMES", "RealisticModel", "make_realistic", "realistic_index"]
