"""Per-part densities: mass properties of multi-material objects, their MJCF, and the generators' draws."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from tognet.objects import assemble_object, generate_set, load_catalog
from tognet.objects.assemble import MeshError
from tognet.objects.compose import ShapeRanges, part_densities, sample_part_densities
from tognet.objects.stats import object_stats

REPO = Path(__file__).resolve().parents[1]
#: The last commit whose assemble.py had only the single-density path.
SINGLE_DENSITY_COMMIT = "11c0b8f"


def box(extents, centre) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation(centre)
    return mesh


def box_inertia_about(extents, centre, density: float, point) -> tuple[float, np.ndarray]:
    """(mass, inertia tensor about ``point``) of a solid axis-aligned box, closed form."""
    a, b, c = extents
    mass = density * a * b * c
    own = mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    d = np.asarray(centre, dtype=np.float64) - np.asarray(point, dtype=np.float64)
    return mass, own + mass * (float(d @ d) * np.eye(3) - np.outer(d, d))


def write(folder: Path, name: str, visual, pieces, **kwargs):
    return assemble_object(
        folder, object_id=name, kind="primitive", split="test", shape_rule="T",
        part_types=["cuboid", "cuboid"], visual=visual, collision_pieces=pieces, friction=0.8, **kwargs,
    )  # fmt: skip


def mujoco_body(record) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, principal moments sorted) of body 'object' as MuJoCo compiled it."""
    model = mujoco.MjModel.from_xml_path(str(record.path(record.mjcf)))
    body = model.body("object").id
    return float(model.body_mass[body]), np.array(model.body_ipos[body]), np.sort(model.body_inertia[body])


def test_two_boxes_side_by_side_match_closed_forms(tmp_path):
    # a light 20 cm handle and a heavy 5 cm block touching it end to end: no overlap
    ext_a, ext_b = (0.20, 0.03, 0.02), (0.05, 0.03, 0.02)
    ca, cb = (-0.025, 0.0, 0.0), (0.10, 0.0, 0.0)
    a, b = box(ext_a, ca), box(ext_b, cb)
    visual = trimesh.boolean.union([a, b], engine="manifold")
    rho_a, rho_b = 600.0, 7800.0
    record = write(tmp_path, "side", visual, [a, b], parts=[(a, rho_a), (b, rho_b)], part_names=["A", "B"])
    m_a, m_b = rho_a * 0.2 * 0.03 * 0.02, rho_b * 0.05 * 0.03 * 0.02
    com = (m_a * np.array(ca) + m_b * np.array(cb)) / (m_a + m_b)
    inertia = box_inertia_about(ext_a, ca, rho_a, com)[1] + box_inertia_about(ext_b, cb, rho_b, com)[1]
    # (manifold3d's booleans are exact to ~1e-7 relative)
    assert record.mass == pytest.approx(m_a + m_b, rel=1e-6)
    assert np.allclose(record.com, com, atol=1e-7)
    assert np.allclose(record.inertia, inertia, rtol=1e-5, atol=1e-11)
    assert record.volume == pytest.approx(0.25 * 0.03 * 0.02, rel=1e-6)
    assert record.density == pytest.approx(record.mass / record.volume, rel=1e-6)
    assert record.extra["part_masses"] == pytest.approx([m_a, m_b], rel=1e-6)
    assert record.extra["part_densities"] == [rho_a, rho_b] and record.extra["part_names"] == ["A", "B"]
    # a single density could not give this centre of mass: it would sit at the box's middle, x = 0.0
    assert com[0] > 0.05
    # the order of parts that do not overlap does not matter
    swapped = write(tmp_path, "swapped", visual, [a, b], parts=[(b, rho_b), (a, rho_a)])
    assert swapped.mass == pytest.approx(record.mass, rel=1e-6)
    assert np.allclose(swapped.com, record.com, atol=1e-7)
    # MuJoCo reads the explicit inertial: same mass, centre of mass and principal moments
    mass, ipos, principal = mujoco_body(record)
    assert mass == pytest.approx(record.mass, rel=1e-6)
    assert np.allclose(ipos, record.com, atol=1e-7)
    assert np.allclose(principal, np.sort(np.linalg.eigvalsh(inertia)), rtol=1e-5)


@pytest.mark.parametrize("head_first", [True, False])
def test_overlapping_t_counts_the_overlap_once(tmp_path, head_first):
    ext_handle, c_handle = (0.25, 0.03, 0.025), (0.0, 0.0, 0.0)
    ext_head, c_head = (0.04, 0.12, 0.03), (0.11, 0.0, 0.0025)  # overlaps the handle's end by 2.5 cm
    handle, head = box(ext_handle, c_handle), box(ext_head, c_head)
    # the overlap, by hand: x 0.09..0.125, y -0.015..0.015, z -0.0125..0.0125
    ext_ov, c_ov = (0.035, 0.03, 0.025), (0.1075, 0.0, 0.0)
    visual = trimesh.boolean.union([handle, head], engine="manifold")
    rho_handle, rho_head = 700.0, 7800.0
    parts = [(head, rho_head), (handle, rho_handle)]
    if not head_first:
        parts.reverse()
    record = write(tmp_path, f"t{int(head_first)}", visual, [handle, head], parts=parts)
    # hand computation: the first part owns the overlap, the other loses it (a negative box)
    owner, loser = (rho_head, rho_handle) if head_first else (rho_handle, rho_head)
    boxes = [(ext_handle, c_handle, rho_handle), (ext_head, c_head, rho_head), (ext_ov, c_ov, -loser)]
    mass = sum(rho * np.prod(e) for e, _, rho in boxes)
    com = sum(rho * np.prod(e) * np.asarray(c) for e, c, rho in boxes) / mass
    inertia = sum(box_inertia_about(e, c, rho, com)[1] for e, c, rho in boxes)
    assert record.mass == pytest.approx(mass, rel=1e-6)
    assert np.allclose(record.com, com, atol=1e-7)
    assert np.allclose(record.inertia, inertia, rtol=1e-5, atol=1e-11)
    v_handle, v_head, v_ov = np.prod(ext_handle), np.prod(ext_head), np.prod(ext_ov)
    assert mass == pytest.approx(
        rho_handle * (v_handle - v_ov) + rho_head * (v_head - v_ov) + owner * v_ov, rel=1e-12
    )
    # strictly between the all-light and all-heavy objects made from the same visual
    light = write(tmp_path, f"light{int(head_first)}", visual, [handle, head], density=rho_handle)
    heavy = write(tmp_path, f"heavy{int(head_first)}", visual, [handle, head], density=rho_head)
    assert light.mass < record.mass < heavy.mass
    assert record.volume == pytest.approx(light.volume, rel=1e-6)
    # mass = sum of density_i * own volume_i, and the own volumes add up to the union's volume once
    extra = record.extra
    assert sum(v for v in extra["part_volumes"]) == pytest.approx(visual.volume, rel=1e-6)
    assert record.mass == pytest.approx(
        sum(d * v for d, v in zip(extra["part_densities"], extra["part_volumes"], strict=True)), rel=1e-6
    )
    mj_mass, ipos, principal = mujoco_body(record)
    assert mj_mass == pytest.approx(mass, rel=1e-6) and np.allclose(ipos, com, atol=1e-6)
    assert np.allclose(principal, np.sort(np.linalg.eigvalsh(inertia)), rtol=1e-4)


def test_bad_part_models_are_refused(tmp_path):
    a, b = box((0.2, 0.03, 0.02), (0, 0, 0)), box((0.05, 0.1, 0.02), (0.1, 0, 0))
    visual = trimesh.boolean.union([a, b], engine="manifold")
    with pytest.raises(MeshError, match="exactly one of density= and parts="):
        write(tmp_path, "both", visual, [a, b], density=800.0, parts=[(a, 800.0), (b, 800.0)])
    with pytest.raises(MeshError, match="exactly one of"):
        write(tmp_path, "neither", visual, [a, b])
    with pytest.raises(MeshError, match="part 1: density must be positive"):
        write(tmp_path, "neg", visual, [a, b], parts=[(a, 800.0), (b, -1.0)])
    with pytest.raises(MeshError, match="is not the visual"):  # the parts miss the head
        write(tmp_path, "missing", visual, [a, b], parts=[(a, 800.0)])
    with pytest.raises(MeshError, match="2 part names for 1 parts"):
        write(tmp_path, "names", a, [a], parts=[(a, 800.0)], part_names=["A", "B"])
    assert not (tmp_path / "both").exists()  # refused before anything is written


def _single_density_assemble():
    """assemble_object as it was before per-part densities, loaded from git history."""
    try:
        source = subprocess.run(
            ["git", "-C", str(REPO), "show", f"{SINGLE_DENSITY_COMMIT}:tognet/objects/assemble.py"],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.skip(f"no git history with commit {SINGLE_DENSITY_COMMIT} ({exc})")
    spec = importlib.util.spec_from_loader("tognet_objects_assemble_single_density", loader=None)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    exec(compile(source, "assemble.py@" + SINGLE_DENSITY_COMMIT, "exec"), module.__dict__)
    return module.assemble_object


def test_single_density_objects_are_byte_identical_to_the_previous_code(tmp_path):
    previous = _single_density_assemble()
    # a non-convex object (an L of two boxes) and a lone cylinder, written by the old and the new code
    a, b = box((0.22, 0.03, 0.02), (0.0, 0.0, 0.0)), box((0.03, 0.1, 0.02), (0.095, 0.035, 0.0))
    ell = trimesh.boolean.union([a, b], engine="manifold")
    rod = trimesh.creation.cylinder(radius=0.012, height=0.2, sections=24)
    for name, visual, pieces, density in (("ell", ell, [a, b], 923.4567), ("rod", rod, [rod], 2712.5)):
        kwargs = dict(
            object_id=name, kind="imported", split="test", shape_rule="none", part_types=["mesh"],
            visual=visual, collision_pieces=pieces, density=density, friction=0.65, extra={"k": 1},
        )  # fmt: skip
        old = previous(tmp_path / "old", **kwargs)
        new = assemble_object(tmp_path / "new", **kwargs)
        assert new == old  # every field but the folder (not compared)
        old_files = sorted(p.name for p in (tmp_path / "old" / name).iterdir())
        assert old_files == sorted(p.name for p in (tmp_path / "new" / name).iterdir())
        for file in old_files:
            new_bytes = (tmp_path / "new" / name / file).read_bytes()
            assert new_bytes == (tmp_path / "old" / name / file).read_bytes(), file


def test_sample_part_densities_stay_in_their_intervals_and_mass_window():
    rng = np.random.default_rng(3)
    light, metal, window = (400.0, 1400.0), (2700.0, 7900.0), (0.08, 1.2)
    volumes = [60e-6, 90e-6]  # a 60 cm^3 head, a 90 cm^3 handle
    draws = np.array([sample_part_densities(rng, volumes, [metal, light], window) for _ in range(2000)])
    masses = draws @ np.array(volumes)
    assert draws[:, 0].min() >= metal[0] and draws[:, 0].max() <= metal[1]
    assert draws[:, 1].min() >= light[0] and draws[:, 1].max() <= light[1]
    assert masses.min() >= window[0] - 1e-12 and masses.max() <= window[1] + 1e-12
    # the head's feasible interval is 2700 .. (1.2 - 400 * 90e-6) / 60e-6 = 19400 -> all of metal: spread out
    assert np.percentile(draws[:, 0], 10) < 3500 and np.percentile(draws[:, 0], 90) > 7000
    # a huge steel head cannot fit: None; part_densities then falls back to light parts
    assert sample_part_densities(rng, [500e-6, 90e-6], [metal, light], window) is None  # >= 1.39 kg
    ranges = ShapeRanges(metal_probability=(1.0, 1.0, 1.0))
    rho_a, rho_b, classes = part_densities(rng, ranges, "T", 90e-6, 500e-6)
    assert classes == ["light", "light"] and rho_a * 90e-6 + rho_b * 500e-6 <= window[1] + 1e-12
    rho_a, rho_b, classes = part_densities(rng, ranges, "T", 90e-6, 60e-6)
    assert classes == ["light", "metal"] and rho_b >= metal[0] and rho_a <= light[1]
    with pytest.raises(ValueError, match="2 volumes for 1 density intervals"):
        sample_part_densities(rng, volumes, [light], window)


@pytest.fixture(scope="module")
def primitive_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("parts") / "primitive"
    return folder, generate_set("primitive", "train", 60, folder)


def test_generated_objects_have_per_part_masses(primitive_set):
    folder, records = primitive_set
    ranges = ShapeRanges()
    span = {"light": ranges.light_density, "metal": ranges.metal_density}
    heads, metal_heads = [], 0
    for record in records:
        extra = record.extra
        assert extra["part_names"] == ["B", "A"]
        assert ranges.mass[0] - 1e-9 <= record.mass <= ranges.mass[1] + 1e-9
        assert record.mass == pytest.approx(sum(extra["part_masses"]), rel=1e-6)
        for name, rho in zip(extra["part_names"], extra["part_densities"], strict=True):
            lo, hi = span[extra["part_materials"][name]]
            assert lo <= rho <= hi
        # B owns the overlap: its volume is the whole convex part B, A's is the rest of the union
        piece_b = record.load_mesh(record.collision_meshes[1])
        visual = record.load_mesh(record.visual_mesh)
        assert extra["part_volumes"][0] == pytest.approx(piece_b.volume, rel=2e-3)
        assert sum(extra["part_volumes"]) == pytest.approx(visual.volume, rel=1e-4)
        if record.shape_rule in ("T", "L"):
            assert extra["part_materials"]["A"] == "light"
        head = object_stats(record).head_fraction  # what `tognet objects stats` reports: B's mass share
        assert head == pytest.approx(extra["part_masses"][0] / sum(extra["part_masses"]), rel=1e-9)
        if record.shape_rule == "T":
            heads.append(head)
            metal_heads += extra["part_materials"]["B"] == "metal"
    assert len(heads) >= 12
    # before per-part densities the head's mass share was its volume share: median ~40 %
    assert np.median(heads) > 0.55
    assert 0.2 < metal_heads / len(heads) < 0.8
    assert load_catalog(folder) == sorted(records, key=lambda r: r.object_id)


def test_generated_mjcf_mass_and_inertia_match_the_record(primitive_set):
    _folder, records = primitive_set
    for record in records[:10]:
        mass, ipos, principal = mujoco_body(record)
        assert mass == pytest.approx(record.mass, rel=1e-6)
        assert np.allclose(ipos, record.com, atol=1e-6)
        assert np.allclose(principal, np.sort(np.linalg.eigvalsh(np.asarray(record.inertia))), rtol=1e-4)


def test_realistic_hammer_is_head_heavy(tmp_path):
    from tognet.objects.realistic import realistic_index

    index = realistic_index("hammer")
    record = generate_set("realistic", "test", 1, tmp_path, start=index)[0]
    extra = record.extra
    masses = dict(zip(extra["part_names"], extra["part_masses"], strict=True))
    assert set(masses) == {"hardwood", "steel"}
    share = masses["steel"] / sum(masses.values())
    # real claw hammers (16-20 oz heads on a 150-200 g handle): about 70-82 % of the mass in the head;
    # one density for the whole hammer would have put 29 % there (the steel's share of the volume)
    assert 0.65 <= share <= 0.85
    assert record.mass == pytest.approx(sum(masses.values()), rel=1e-6)
    assert record.density == pytest.approx(record.mass / record.volume, rel=1e-6)
    mass, ipos, _principal = mujoco_body(record)
    assert mass == pytest.approx(record.mass, rel=1e-6) and np.allclose(ipos, record.com, atol=1e-6)
    # the centre of mass sits towards the head (the +x or -x end, whichever the rest pose chose)
    visual = record.load_mesh(record.visual_mesh)
    uniform_com = np.asarray(visual.center_mass)
    assert np.linalg.norm(np.asarray(record.com) - uniform_com) > 0.02
