"""Generated objects (PG-Primitive, PG-Complex, realistic): physics, determinism, ids, sizes."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from objects_testlib import drop_on_plane

from tognet.objects import (
    ObjectRecord,
    generate_object,
    generate_set,
    load_catalog,
    object_id,
    object_seed,
)

HAS_REALISTIC = importlib.util.find_spec("tognet.objects.realistic") is not None
COUNTS = {"primitive": 6, "complex": 2, "realistic": 3}


@pytest.fixture(scope="module")
def sets(tmp_path_factory) -> dict[str, tuple[Path, list[ObjectRecord]]]:
    root = tmp_path_factory.mktemp("objects")
    out = {}
    for kind in ("primitive", "complex", "realistic"):
        if kind == "realistic" and not HAS_REALISTIC:
            continue
        split = "test" if kind == "realistic" else "train"
        folder = root / kind
        out[kind] = (folder, generate_set(kind, split, COUNTS[kind], folder))
    return out


def _records(sets, kind: str) -> list[ObjectRecord]:
    if kind not in sets:
        pytest.skip(f"{kind} objects not available")
    return sets[kind][1]


KINDS = ["primitive", "complex", "realistic"]


def test_catalog_lists_what_was_generated(sets):
    for _kind, (folder, records) in sets.items():
        loaded = load_catalog(folder)
        assert [r.object_id for r in loaded] == sorted(r.object_id for r in records)
        assert loaded == sorted(records, key=lambda r: r.object_id)
        assert (folder / "generator_config.json").is_file()


@pytest.mark.parametrize("kind", KINDS)
def test_mass_properties(sets, kind):
    for record in _records(sets, kind):
        assert record.mass > 0 and record.volume > 0
        assert record.mass == pytest.approx(record.density * record.volume, rel=1e-6)
        visual = trimesh.load(record.path(record.visual_mesh), force="mesh", process=False)
        assert visual.is_watertight
        assert visual.volume == pytest.approx(record.volume, rel=1e-3)
        inertia = record.inertia_matrix
        assert np.allclose(inertia, inertia.T)
        eig = np.sort(np.linalg.eigvalsh(inertia))
        assert eig[0] > 0
        assert eig[0] + eig[1] >= eig[2] * (1 - 1e-9)  # triangle inequality of principal moments
        assert 0.01 <= record.friction <= 2.0


@pytest.mark.parametrize("kind", KINDS)
def test_drops_and_rests_on_plane(sets, kind):
    for i, record in enumerate(_records(sets, kind)):
        state = drop_on_plane(record, seed=i)
        assert state["mass"] == pytest.approx(record.mass, rel=1e-6)
        assert state["time"] == pytest.approx(2.0)
        assert state["lowest"] >= -0.002, f"{record.object_id} sank {-1000 * state['lowest']:.1f} mm"
        assert state["lowest"] <= 0.002, f"{record.object_id} floats {1000 * state['lowest']:.1f} mm"
        assert state["speed"] < 0.01 and state["spin"] < 0.1, f"{record.object_id} still moving: {state}"


@pytest.mark.parametrize("kind", ["primitive", "complex"])
def test_tool_sized_graspable_convex_pieces(sets, kind):
    for record in _records(sets, kind):
        assert record.shape_rule in ("T", "L", "X")
        assert 0.12 <= max(record.extents) <= 0.40 + 1e-6
        assert 0.01 <= record.extents[2] <= 0.05  # lies flat: low profile
        assert len(record.collision_meshes) == 2
        widths = []
        for path in record.collision_paths:
            piece = trimesh.load(path, force="mesh")
            assert piece.is_convex and piece.is_watertight
            assert len(piece.vertices) <= 64
            xy = piece.vertices[:, :2]
            angles = np.linspace(0, np.pi, 90, endpoint=False)
            proj = xy @ np.stack([np.cos(angles), np.sin(angles)])
            widths.append(float((proj.max(axis=0) - proj.min(axis=0)).min()))
        assert min(widths) < 0.08, f"{record.object_id}: no part fits an 8 cm gripper ({widths})"


def test_same_id_gives_identical_files(sets, tmp_path):
    for kind in ("primitive", "complex"):
        folder, records = sets[kind]
        index = len(records) - 1
        again = generate_set(kind, "train", 1, tmp_path / kind, start=index)[0]
        original = folder / again.object_id
        names = sorted(p.name for p in original.iterdir())
        assert names == sorted(p.name for p in Path(again.folder).iterdir())
        for name in names:
            assert (original / name).read_bytes() == (Path(again.folder) / name).read_bytes(), name
    # The catalog is deterministic too: the same objects give the same bytes.
    a = generate_set("primitive", "test", 2, tmp_path / "cat_a")
    b = generate_set("primitive", "test", 2, tmp_path / "cat_b")
    assert a == b
    catalog_a, catalog_b = tmp_path / "cat_a" / "catalog.json", tmp_path / "cat_b" / "catalog.json"
    assert catalog_a.read_bytes() == catalog_b.read_bytes()
    csv_a, csv_b = tmp_path / "cat_a" / "catalog.csv", tmp_path / "cat_b" / "catalog.csv"
    assert csv_a.read_bytes() == csv_b.read_bytes() and csv_a.read_text().count("\n") == 3


def test_ids_and_seeds_never_collide_across_splits_and_kinds():
    ids, seeds = set(), set()
    n = 0
    for kind in ("primitive", "complex"):
        for split in ("train", "test"):
            for index in range(400):
                ids.add(object_id(kind, split, index))
                seeds.add(object_seed(kind, split, index))
                n += 1
    assert len(ids) == n and len(seeds) == n
    assert object_id("primitive", "train", 7) == "primitive-train-000007"
    assert object_seed("primitive", "train", 7) == object_seed("primitive", "train", 7)


def test_train_and_test_objects_differ(tmp_path):
    train = generate_object("primitive", "train", 0, tmp_path)
    test = generate_object("primitive", "test", 0, tmp_path)
    assert train.object_id != test.object_id
    assert (Path(train.folder) / "visual.obj").read_bytes() != (Path(test.folder) / "visual.obj").read_bytes()


def test_generate_set_keeps_existing_objects(tmp_path):
    generate_set("primitive", "train", 2, tmp_path)
    generate_set("primitive", "train", 2, tmp_path, start=2)
    ids = [r.object_id for r in load_catalog(tmp_path)]
    assert ids == [object_id("primitive", "train", i) for i in range(4)]
    meta = json.loads((tmp_path / "catalog.json").read_text())["meta"]
    assert meta["kinds"] == ["primitive"]


def test_rules_and_part_types_all_occur(tmp_path):
    records = generate_set("primitive", "test", 24, tmp_path)
    assert {r.shape_rule for r in records} == {"T", "L", "X"}
    assert {t for r in records for t in r.part_types} == {"cuboid", "cylinder", "polytope"}
    # Hammer-like: T objects whose head is at least as heavy per length as the handle.
    t_objects = [r for r in records if r.shape_rule == "T"]
    assert any(r.extra["extents_b"][1] >= r.extra["extents_a"][1] for r in t_objects)


def test_bad_arguments_are_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown object kind 'primitve'"):
        generate_object("primitve", "train", 0, tmp_path)
    with pytest.raises(ValueError, match="unknown split 'val'"):
        generate_set("primitive", "val", 1, tmp_path)
    with pytest.raises(ValueError, match="count must be >= 1"):
        generate_set("primitive", "train", 0, tmp_path)


@pytest.mark.skipif(not HAS_REALISTIC, reason="realistic set not available")
def test_realistic_limits(tmp_path):
    from tognet.objects.realistic import REALISTIC_NAMES

    limit = len(REALISTIC_NAMES)
    with pytest.raises(ValueError, match=f"only {limit} realistic models"):
        generate_set("realistic", "test", limit + 1, tmp_path)
    with pytest.raises(ValueError, match="test set only"):
        generate_object("realistic", "train", 0, tmp_path)
    assert not (tmp_path / "catalog.json").exists()


def test_workers_give_the_same_files(tmp_path):
    generate_set("primitive", "train", 4, tmp_path / "one")
    generate_set("primitive", "train", 4, tmp_path / "two", workers=2)
    for path in sorted((tmp_path / "one").rglob("*")):
        if path.is_file():
            assert path.read_bytes() == (tmp_path / "two" / path.relative_to(tmp_path / "one")).read_bytes()


def test_a_set_made_with_another_config_is_refused(tmp_path):
    from tognet.objects import GeneratorConfig
    from tognet.objects.primitive import PrimitiveConfig

    generate_set("primitive", "train", 1, tmp_path)
    other = GeneratorConfig(primitive=PrimitiveConfig(cylinder_sections=12))
    with pytest.raises(ValueError, match="different generator config"):
        generate_set("primitive", "train", 1, tmp_path, start=1, config=other)
    assert [r.object_id for r in load_catalog(tmp_path)] == ["primitive-train-000000"]


def test_catalog_csv_matches_the_json_catalog(sets):
    import csv

    for _kind, (folder, _records) in sets.items():
        rows = list(csv.DictReader((folder / "catalog.csv").open()))
        loaded = load_catalog(folder)
        assert [row["id"] for row in rows] == [r.object_id for r in loaded]
        for row, record in zip(rows, loaded, strict=True):
            assert row["kind"] == record.kind and row["split"] == record.split
            assert row["shape_rule"] == record.shape_rule
            assert row["part_types"].split("+") == record.part_types
            assert float(row["mass"]) == pytest.approx(record.mass, rel=1e-5)
            assert float(row["density"]) == pytest.approx(record.density, rel=1e-5)
            assert float(row["friction"]) == pytest.approx(record.friction, rel=1e-5)
            extents = [float(row[f"extent_{a}"]) for a in "xyz"]
            com = [float(row[f"com_{a}"]) for a in "xyz"]
            assert extents == pytest.approx(record.extents, rel=1e-5)
            assert com == pytest.approx(record.com, rel=1e-5, abs=1e-9)
            assert int(row["pieces"]) == len(record.collision_meshes)


def test_density_is_drawn_inside_both_ranges_without_a_mass_pile_up():
    from tognet.objects.compose import ShapeRanges, sample_density

    ranges = ShapeRanges()
    rng = np.random.default_rng(0)
    # A light tool (40 cm^3): the lightest densities would weigh under 80 g.
    masses = np.array([sample_density(rng, ranges, 40e-6) * 40e-6 for _ in range(2000)])
    densities = masses / 40e-6
    assert densities.min() >= ranges.density[0] and densities.max() <= ranges.density[1]
    assert masses.min() >= ranges.mass[0] - 1e-12 and masses.max() <= ranges.mass[1] + 1e-12
    assert np.mean(np.isclose(masses, ranges.mass[0], rtol=1e-9)) < 0.002  # no point mass at 80 g
    assert 0.05 < np.mean(masses < ranges.mass[0] + 0.002) < 0.15  # uniform over 80-100 g: ~10 % in 2 g
    # Too small for any density in the range to reach 80 g: the densest material, not a made-up one.
    assert sample_density(rng, ranges, 10e-6) == ranges.density[1]
    assert sample_density(rng, ranges, 5e-3) == ranges.density[0]


def test_a_set_from_another_generator_version_is_refused(tmp_path):
    generate_set("primitive", "train", 1, tmp_path)
    catalog = tmp_path / "catalog.json"
    payload = json.loads(catalog.read_text())
    assert payload["meta"]["generator_version"] >= 2
    payload["meta"].pop("generator_version")  # a set from version 1, which did not record it
    catalog.write_text(json.dumps(payload))
    with pytest.raises(ValueError, match="generator version 1"):
        generate_set("primitive", "train", 1, tmp_path, start=1)
    assert [r.object_id for r in load_catalog(tmp_path)] == ["primitive-train-000000"]


def _support(mesh: trimesh.Trimesh, tol: float = 1e-4):
    from shapely.geometry import MultiPoint

    v = np.asarray(mesh.vertices)
    bottom = v[v[:, 2] < v[:, 2].min() + tol]
    return MultiPoint([tuple(p) for p in bottom[:, :2]]).convex_hull


def test_flat_bottom_cuts_a_flat_face_and_keeps_the_part_convex():
    from tognet.objects.complex import flat_bottom

    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.02)
    cut = flat_bottom(ball, 0.15, max_vertices=100_000)
    assert cut.is_convex and cut.is_volume
    assert cut.bounds[0, 2] == pytest.approx(-0.02 + 0.15 * 0.04, abs=1e-9)
    # A plane 0.3 r above the sphere's bottom cuts a disc of radius r * sqrt(1 - 0.7^2).
    expected = np.pi * 0.02**2 * (1 - 0.7**2)
    assert _support(cut).area == pytest.approx(expected, rel=0.03)
    assert _support(ball).area < 0.05 * expected  # the sphere itself rests on a point
    assert flat_bottom(ball, 0.0) is ball
    capped = flat_bottom(ball, 0.15, max_vertices=48)
    assert len(capped.vertices) <= 48 and capped.is_convex
    assert _support(capped).area > 0.5 * expected


def test_complex_objects_rest_on_flat_faces(sets):
    from shapely.geometry import Point

    for record in _records(sets, "complex"):
        pieces = [trimesh.load(p, force="mesh") for p in record.collision_paths]
        lowest = min(p.bounds[0, 2] for p in pieces)
        for piece in pieces:
            assert piece.bounds[0, 2] == pytest.approx(lowest, abs=1e-5)  # both parts touch the table
            assert _support(piece).area > 1e-4, f"{record.object_id}: a part rests on less than 1 cm^2"
        visual = trimesh.load(record.path(record.visual_mesh), force="mesh")
        margin = _support(visual, 1e-4).buffer(-0.003)
        assert margin.contains(Point(record.com[0], record.com[1])), f"{record.object_id} would tip over"


def test_polytope_primitives_rest_on_a_face_in_their_generated_pose(tmp_path):
    from tognet.objects import GeneratorConfig
    from tognet.objects.primitive import PrimitiveConfig
    from tognet.objects.stats import object_stats

    config = GeneratorConfig(primitive=PrimitiveConfig(part_weights=(0.0, 0.0, 1.0)))
    records = generate_set("primitive", "train", 10, tmp_path, config=config)
    for record in records:
        assert record.part_types == ["polytope", "polytope"]
        for piece in (trimesh.load(p, force="mesh") for p in record.collision_paths):
            assert _support(piece).area > 1e-4, f"{record.object_id}: a polytope stands on < 1 cm^2"
        assert object_stats(record).rests_flat, f"{record.object_id} would tip from its generated pose"


def test_complex_objects_never_touch_the_realistic_models():
    import subprocess
    import sys

    code = (
        "import sys, numpy as np\n"
        "from tognet.objects.complex import make_complex, source_mesh, ComplexConfig\n"
        "make_complex(np.random.default_rng(3))\n"
        "print(sorted(m for m in sys.modules if m.startswith('tognet.objects.realistic')))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]", result.stdout
