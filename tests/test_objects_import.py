"""Importing your own meshes: good files become objects, each bad case gives its own clear error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from objects_testlib import drop_on_plane

from tognet.objects import generate_set, import_meshes, load_catalog


def _write_cases(src: Path) -> None:
    src.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.2, 0.03, 0.02)).export(src / "good_bar.stl")
    handle = trimesh.creation.box(extents=(0.2, 0.03, 0.02))
    head = trimesh.creation.box(extents=(0.03, 0.1, 0.03))
    head.apply_translation((0.1, 0.0, 0.005))
    trimesh.boolean.union([handle, head], engine="manifold").export(src / "good_hammer.obj")
    trimesh.creation.annulus(r_min=0.02, r_max=0.04, height=0.03).export(src / "Good Ring.ply")
    box = trimesh.creation.box(extents=(0.12, 0.04, 0.02))
    trimesh.Trimesh(box.vertices, box.faces[1:]).export(
        src / "holed_box.obj"
    )  # one triangle missing: repaired
    box.invert()
    box.export(src / "inside_out.stl")  # inward normals: repaired
    tube = trimesh.creation.cylinder(radius=0.02, height=0.2, sections=32)
    side = np.abs(tube.face_normals[:, 2]) < 0.5
    trimesh.Trimesh(tube.vertices, tube.faces[side]).export(src / "open_tube.obj")
    square = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]]
    trimesh.Trimesh(square, [[0, 1, 2], [1, 3, 2]]).export(src / "flat.obj")
    (src / "empty.obj").write_text("")
    (src / "garbage.ply").write_text("ply\nformat nonsense\n#$%\n")
    trimesh.creation.box(extents=(3.0, 0.1, 0.1)).export(src / "huge.stl")
    trimesh.creation.box(extents=(0.003, 0.002, 0.002)).export(src / "tiny.stl")
    (src / "notes.txt").write_text("not a mesh, ignored")


EXPECTED_ERRORS = {
    "open_tube.obj": "not watertight",
    "flat.obj": "degenerate",
    "empty.obj": "empty",
    "garbage.ply": "unreadable",
    "huge.stl": "absurd size: longest side 3 m",
    "tiny.stl": "absurd size: longest side 0.003 m",
}


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    root = tmp_path_factory.mktemp("import")
    src, out = root / "src", root / "out"
    _write_cases(src)
    generate_set("primitive", "test", 1, out)  # an existing object that must survive the import
    report = import_meshes(src, out, density=800.0, friction=0.9)
    return src, out, report


def test_each_bad_mesh_gets_its_error(imported):
    src, _out, report = imported
    errors = {path.name: message for path, message in report.errors}
    assert set(errors) == set(EXPECTED_ERRORS)
    for name, reason in EXPECTED_ERRORS.items():
        assert str(src / name) in errors[name], errors[name]
        assert reason in errors[name], errors[name]


def test_good_files_are_imported_and_existing_objects_kept(imported):
    _src, out, report = imported
    ids = sorted(r.object_id for r in report.records)
    assert ids == [
        "imported-good_bar",
        "imported-good_hammer",
        "imported-good_ring",
        "imported-holed_box",
        "imported-inside_out",
    ]
    catalog = {r.object_id: r for r in load_catalog(out)}
    for name in ("imported-holed_box", "imported-inside_out"):
        assert catalog[name].volume == pytest.approx(0.12 * 0.04 * 0.02, rel=1e-6)
    assert set(catalog) == {*ids, "primitive-test-000000"}
    assert not (out / ".importing").exists()
    bar = catalog["imported-good_bar"]
    assert bar.kind == "imported" and bar.density == 800.0 and bar.friction == 0.9
    assert bar.mass == pytest.approx(800.0 * 0.2 * 0.03 * 0.02, rel=1e-6)
    assert sorted(bar.extents) == pytest.approx([0.02, 0.03, 0.2])
    ring = catalog["imported-good_ring"]
    assert len(ring.collision_meshes) >= 3  # a non-convex ring needs several convex pieces
    for path in ring.collision_paths:
        piece = trimesh.load(path, force="mesh")
        assert piece.is_convex and len(piece.vertices) <= 48


def test_imported_objects_rest_on_a_plane(imported):
    _src, _out, report = imported
    for i, record in enumerate(report.records):
        state = drop_on_plane(record, seed=i)
        assert state["mass"] == pytest.approx(record.mass, rel=1e-6)
        assert -0.002 <= state["lowest"] <= 0.002, (record.object_id, state)
        assert state["speed"] < 0.01 and state["spin"] < 0.1, (record.object_id, state)


def test_scale_and_reimport_replace_only_that_object(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    trimesh.creation.box(extents=(150.0, 20.0, 20.0)).export(src / "mm_bar.stl")
    out = tmp_path / "out"
    report = import_meshes(src, out, scale=0.001)
    assert not report.errors
    assert max(report.records[0].extents) == pytest.approx(0.15)
    first = (out / "imported-mm_bar" / "object.xml").read_text()
    kept = import_meshes(src, out, scale=0.001, density=2000.0)  # other settings: kept without replace
    assert not kept.records and "settings differ" in kept.errors[0][1] and "--replace" in kept.errors[0][1]
    assert (out / "imported-mm_bar" / "object.xml").read_text() == first
    report = import_meshes(src, out, scale=0.001, density=2000.0, replace=True)
    assert report.records[0].mass == pytest.approx(2000.0 * 0.15 * 0.02 * 0.02, rel=1e-6)
    assert [r.object_id for r in load_catalog(out)] == ["imported-mm_bar"]
    assert (out / "imported-mm_bar" / "object.xml").read_text() != first


def test_missing_or_empty_folder_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="mesh file or folder not found"):
        import_meshes(tmp_path / "nope", tmp_path / "out")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="no OBJ/STL/PLY files"):
        import_meshes(tmp_path / "empty", tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("keep", [0.3, 0.8])
def test_a_truncated_obj_is_refused_by_name_and_the_rest_imported(tmp_path, keep):
    src, out = tmp_path / "src", tmp_path / "out"
    src.mkdir()
    trimesh.creation.box(extents=(0.2, 0.03, 0.02)).export(src / "bar.stl")
    whole = trimesh.creation.cylinder(radius=0.02, height=0.15, sections=24).export(file_type="obj")
    (src / "cut.obj").write_text(whole[: int(keep * len(whole))])  # cut in the vertices / in the faces
    generate_set("primitive", "test", 1, out)
    before = (out / "primitive-test-000000" / "visual.obj").read_bytes()
    report = import_meshes(src, out)
    assert [r.object_id for r in report.records] == ["imported-bar"]
    [(path, message)] = report.errors
    assert path.name == "cut.obj" and str(src / "cut.obj") in message
    assert any(reason in message for reason in ("unreadable", "not watertight", "empty")), message
    assert {r.object_id for r in load_catalog(out)} == {"imported-bar", "primitive-test-000000"}
    assert (out / "primitive-test-000000" / "visual.obj").read_bytes() == before
