"""The Realistic object set: geometry, collision pieces, rest poses, determinism, and a MuJoCo drop."""

from __future__ import annotations

import functools

import numpy as np
import pytest
import trimesh
from shapely.geometry import MultiPoint, Point

from tognet.objects.assemble import combine, part_masses
from tognet.objects.realistic import REALISTIC_NAMES, RealisticModel, make_realistic, realistic_index

REQUIRED = [
    "hammer",
    "mallet",
    "spatula",
    "frying_pan",
    "wrench",
    "screwdriver",
    "ladle",
    "brush",
    "mug",
    "bottle",
    "can",
]
INDICES = list(range(len(REALISTIC_NAMES)))


@functools.cache
def model(index: int) -> RealisticModel:
    return make_realistic(index)


def true_com(m: RealisticModel) -> np.ndarray:
    return combine(part_masses([(solid, rho) for _, solid, rho in m.parts]))[2]


def surface_points(mesh: trimesh.Trimesh, count: int = 1500) -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=7)
    return np.asarray(points)


def test_names_and_required_models():
    assert len(REALISTIC_NAMES) >= 30
    assert len(set(REALISTIC_NAMES)) == len(REALISTIC_NAMES)
    for name in REQUIRED:
        assert name in REALISTIC_NAMES
        assert model(realistic_index(name)).name == name
    tool_like = sum(model(i).tool_like for i in INDICES)
    assert 10 <= tool_like < len(REALISTIC_NAMES)  # both kinds present


def test_out_of_range_and_bad_index():
    with pytest.raises(IndexError, match="out of range"):
        make_realistic(len(REALISTIC_NAMES))
    with pytest.raises(IndexError, match="out of range"):
        make_realistic(-1)
    with pytest.raises(TypeError):
        make_realistic("hammer")  # type: ignore[arg-type]
    with pytest.raises(KeyError, match="no realistic model"):
        realistic_index("teapot")


@pytest.mark.parametrize("index", INDICES, ids=REALISTIC_NAMES)
def test_visual_is_a_plausible_solid(index: int):
    m = model(index)
    v = m.visual
    assert v.is_watertight and v.is_volume
    assert v.volume > 1e-6  # > 1 cm^3
    ext = np.asarray(v.extents)
    assert 0.05 <= ext.max() <= 0.45, ext
    mass = v.volume * m.density
    assert 0.005 <= mass <= 2.0, mass
    assert 100.0 <= m.density <= 8000.0
    assert 0.2 <= m.friction <= 1.0
    # lies on the table, centred
    lo, hi = v.bounds
    lowest_piece = min(p.vertices[:, 2].min() for p in m.pieces)
    assert min(lo[2], lowest_piece) == pytest.approx(0.0, abs=1e-9)
    assert lo[2] < 0.002 and lowest_piece < 0.002  # neither floats
    assert np.allclose((lo[:2] + hi[:2]) / 2, 0.0, atol=0.01)
    if m.tool_like:
        assert ext[2] < max(ext[0], ext[1])  # tools lie flat


@pytest.mark.parametrize("index", INDICES, ids=REALISTIC_NAMES)
def test_pieces_are_convex_small_and_cover_the_visual(index: int):
    m = model(index)
    assert 1 <= len(m.pieces) <= 24
    for piece in m.pieces:
        assert len(piece.vertices) <= 64
        assert piece.is_watertight and piece.volume > 0
        assert piece.volume == pytest.approx(piece.convex_hull.volume, rel=1e-6)
    union = trimesh.boolean.union(m.pieces, engine="manifold")
    assert union.volume == pytest.approx(m.visual.volume, rel=0.15)
    # the pieces and the visual overlap: little of either lies outside the other
    with np.errstate(invalid="ignore", divide="ignore"):  # an empty difference (one-box ruler) has volume 0
        outside = trimesh.boolean.difference([union, m.visual], engine="manifold").volume
        uncovered = trimesh.boolean.difference([m.visual, union], engine="manifold").volume
    assert outside < 0.2 * m.visual.volume and uncovered < 0.2 * m.visual.volume, (outside, uncovered)
    # every sampled visual surface point lies inside a piece or within 3 mm of one
    pts = surface_points(m.visual)
    outside = np.ones(len(pts), bool)
    for piece in m.pieces:
        normals = piece.face_normals
        offsets = np.einsum("ij,ij->i", normals, piece.triangles[:, 0])
        inside = (pts @ normals.T - offsets[None, :]).max(axis=1) <= 1e-6
        outside &= ~inside
    if outside.any():
        triangles = np.vstack([p.triangles for p in m.pieces])
        far = pts[outside]
        tri = np.repeat(triangles[None], len(far), axis=0).reshape(-1, 3, 3)
        query = np.repeat(far, len(triangles), axis=0)
        closest = trimesh.triangles.closest_point(tri, query)
        dist = np.linalg.norm(closest - query, axis=1).reshape(len(far), len(triangles)).min(axis=1)
        assert dist.max() < 0.003, f"{m.name}: visual point {dist.max() * 1000:.1f} mm from the pieces"


@pytest.mark.parametrize("index", INDICES, ids=REALISTIC_NAMES)
def test_rest_pose_is_statically_stable(index: int):
    m = model(index)
    verts = np.vstack([p.vertices for p in m.pieces])
    contact = verts[verts[:, 2] < verts[:, 2].min() + 0.002]
    support = MultiPoint([tuple(p) for p in contact[:, :2]]).convex_hull
    com = true_com(m)  # per-material centre of mass (the steel head of a hammer pulls it towards the head)
    assert support.area > 0 and support.contains(Point(com[0], com[1])), m.name


@pytest.mark.parametrize(
    "index", [i for i in INDICES if model(i).tool_like], ids=lambda i: REALISTIC_NAMES[i]
)
def test_tool_like_models_have_a_graspable_part(index: int):
    """Somewhere along the long axis the object is narrow enough for an 8 cm parallel-jaw gripper."""
    m = model(index)
    pts = surface_points(m.visual, 4000)
    xs = pts[:, 0]
    widths = []
    for x0 in np.arange(xs.min(), xs.max(), 0.01):
        sel = pts[(xs >= x0) & (xs < x0 + 0.01)]
        if len(sel) >= 10:
            widths.append(np.ptp(sel[:, 1]))
    assert widths and min(widths) <= 0.08, (m.name, widths)


# real-world longest side (m) and mass (kg) of the required models
REAL_WORLD = {
    "hammer": ((0.25, 0.40), (0.3, 1.0)),
    "mallet": ((0.25, 0.40), (0.2, 1.0)),
    "spatula": ((0.25, 0.38), (0.03, 0.2)),
    "frying_pan": ((0.35, 0.45), (0.4, 1.5)),
    "wrench": ((0.15, 0.30), (0.08, 0.4)),
    "screwdriver": ((0.15, 0.30), (0.05, 0.25)),
    "ladle": ((0.25, 0.38), (0.04, 0.4)),
    "brush": ((0.15, 0.30), (0.03, 0.2)),
    "mug": ((0.08, 0.14), (0.25, 0.45)),
    "bottle": ((0.18, 0.30), (0.4, 0.7)),
    "can": ((0.10, 0.13), (0.3, 0.4)),
}


@pytest.mark.parametrize("name", sorted(REAL_WORLD))
def test_required_models_have_real_world_size_and_mass(name: str):
    m = model(realistic_index(name))
    (lo, hi), (m_lo, m_hi) = REAL_WORLD[name]
    assert lo <= max(m.visual.extents) <= hi
    assert m_lo <= m.visual.volume * m.density <= m_hi


def test_hollow_and_non_convex_where_the_real_object_is():
    for name in ["mug", "frying_pan", "bowl", "cup", "saucepan", "wrench", "pliers", "hammer", "tape_roll"]:
        m = model(realistic_index(name))
        assert m.visual.volume < 0.7 * m.visual.convex_hull.volume, name
        # the collision pieces keep the shape open too (a mug's cavity is not filled in)
        pieces_hull = trimesh.convex.convex_hull(np.vstack([p.vertices for p in m.pieces]))
        union = trimesh.boolean.union(m.pieces, engine="manifold")
        assert union.volume < 0.7 * pieces_hull.volume, name


def test_same_index_same_meshes():
    for name in ["mug", "wrench", "banana"]:
        i = realistic_index(name)
        a, b = make_realistic(i), make_realistic(i)
        assert np.array_equal(a.visual.vertices, b.visual.vertices)
        assert np.array_equal(a.visual.faces, b.visual.faces)
        assert len(a.pieces) == len(b.pieces)
        for pa, pb in zip(a.pieces, b.pieces, strict=True):
            assert np.array_equal(pa.vertices, pb.vertices)
        assert (a.density, a.friction) == (b.density, b.friction)


def _mjcf(m: RealisticModel) -> str:
    assets, geoms = [], []
    for k, piece in enumerate(m.pieces):
        vert = " ".join(f"{c:.7f}" for c in np.asarray(piece.vertices).ravel())
        face = " ".join(str(int(c)) for c in np.asarray(piece.faces).ravel())
        assets.append(f'<mesh name="p{k}" vertex="{vert}" face="{face}"/>')
        geoms.append(
            f'<geom type="mesh" mesh="p{k}" density="{m.density}" friction="{m.friction} 0.005 0.0001"/>'
        )
    return f"""<mujoco>
  <option timestep="0.002"/>
  <asset>{"".join(assets)}</asset>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="obj" pos="0 0 0.03" euler="0.05 0.08 0.3"><freejoint/>{"".join(geoms)}</body>
  </worldbody>
</mujoco>"""


@pytest.mark.parametrize("name", ["hammer", "mug", "frying_pan", "wrench"])
def test_drop_in_mujoco_comes_to_rest_without_sinking(name: str):
    mujoco = pytest.importorskip("mujoco")
    m = model(realistic_index(name))
    mj_model = mujoco.MjModel.from_xml_string(_mjcf(m))
    data = mujoco.MjData(mj_model)
    for _ in range(1000):  # 2 s
        mujoco.mj_step(mj_model, data)
    assert np.linalg.norm(data.qvel) < 0.02, data.qvel
    body = mj_model.body("obj").id
    rot = data.xmat[body].reshape(3, 3)
    pos = data.xpos[body]
    # MuJoCo re-centres mesh geoms on their own frames: use each geom's world pose and mesh vertices
    lowest = np.inf
    for g in range(mj_model.ngeom):
        if mj_model.geom_bodyid[g] != body:
            continue
        mesh_id = mj_model.geom_dataid[g]
        start, count = mj_model.mesh_vertadr[mesh_id], mj_model.mesh_vertnum[mesh_id]
        local = mj_model.mesh_vert[start : start + count]
        world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        lowest = min(lowest, world[:, 2].min())
    assert lowest > -0.003, f"{name} sank {-lowest * 1000:.1f} mm"
    assert pos[2] < 0.2 and np.isfinite(rot).all()
