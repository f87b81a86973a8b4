"""``tognet objects`` CLI smoke tests (typer's CliRunner, real generation on tiny sets)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image
from typer.testing import CliRunner

from tognet.cli import app

runner = CliRunner()


@pytest.mark.parametrize("command", [[], ["generate"], ["import"], ["sheet"], ["list"]])
def test_help(command):
    result = runner.invoke(app, ["objects", *command, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output


def test_typo_option_is_a_usage_error(tmp_path):
    result = runner.invoke(
        app, ["objects", "generate", "--kind", "primitive", "--cuont", "2", "--out", str(tmp_path)]
    )
    assert result.exit_code == 2
    assert "--cuont" in result.output
    result = runner.invoke(
        app, ["objects", "generate", "--kind", "primitve", "--count", "1", "--out", str(tmp_path)]
    )
    assert result.exit_code == 2
    assert not (tmp_path / "catalog.json").exists()


def test_generate_list_sheet(tmp_path):
    out = tmp_path / "set"
    result = runner.invoke(
        app,
        ["objects", "generate", "--kind", "primitive", "--split", "test", "--count", "3", "--out", str(out)],
    )
    assert result.exit_code == 0, result.output
    assert "3 primitive objects (test)" in result.output
    result = runner.invoke(app, ["objects", "list", str(out)])
    assert result.exit_code == 0, result.output
    for i in range(3):
        assert f"primitive-test-{i:06d}" in result.output
    png = tmp_path / "sheet.png"
    result = runner.invoke(app, ["objects", "sheet", str(out), "--out", str(png)])
    assert result.exit_code == 0, result.output
    image = np.asarray(Image.open(png).convert("L"))
    assert image.shape[0] > 200 and image.shape[1] > 400
    assert (image < 200).mean() > 0.01  # something is drawn


def test_list_missing_catalog_is_a_clear_error(tmp_path):
    result = runner.invoke(app, ["objects", "list", str(tmp_path)])
    assert result.exit_code == 2
    assert "no object catalog" in result.output


def test_import_exit_codes(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    trimesh.creation.box(extents=(0.2, 0.03, 0.02)).export(src / "bar.stl")
    result = runner.invoke(app, ["objects", "import", str(src), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "imported 1 of 1" in result.output
    (src / "empty.obj").write_text("")
    result = runner.invoke(app, ["objects", "import", str(src), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "empty.obj: empty" in result.output
    assert "imported 0 of 2" in result.output and "(1 unchanged, kept)" in result.output  # bar.stl again
    result = runner.invoke(app, ["objects", "import", str(tmp_path / "nope"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2


def test_generate_with_a_config_file(tmp_path):
    from tognet.objects import GeneratorConfig
    from tognet.objects.compose import ShapeRanges
    from tognet.objects.primitive import PrimitiveConfig

    ranges = ShapeRanges(rule_weights=(1.0, 0.0, 0.0))
    path = GeneratorConfig(primitive=PrimitiveConfig(ranges=ranges)).save(tmp_path / "gen.json")
    out = tmp_path / "set"
    args = ["objects", "generate", "--kind", "primitive", "--count", "3", "--out", str(out)]
    result = runner.invoke(app, [*args, "--config", str(path)])
    assert result.exit_code == 0, result.output
    assert "rules {'T': 3}" in result.output
    (tmp_path / "bad.json").write_text('{"primitve": {}}')
    result = runner.invoke(app, [*args, "--config", str(tmp_path / "bad.json")])
    assert result.exit_code == 2
    assert "unknown key 'primitve'" in result.output


def _one_line_error(result, *needles: str) -> None:
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1, result.output
    for needle in needles:
        assert needle in lines[0], lines[0]


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "set"
    args = ["objects", "generate", "--kind", "primitive", "--count", "2", "--out", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return out


BAD_CATALOGS = {
    "truncated": ('{"catalog_version": 1, "objects": [', "not valid JSON"),
    "list": ("[1, 2]", "expected a JSON object"),
    "objects_not_list": ('{"catalog_version": 1, "objects": {}}', "'objects' must be a list"),
    "entry_not_object": ('{"catalog_version": 1, "objects": [5]}', "object entry 0: expected a JSON object"),
    "missing_fields": ('{"catalog_version": 1, "objects": [{"object_id": "a"}]}', "missing field(s) kind"),
    "old_version": ('{"catalog_version": 0, "objects": []}', "catalog version 0"),
}


@pytest.mark.parametrize("case", sorted(BAD_CATALOGS))
@pytest.mark.parametrize("command", ["list", "sheet", "generate"])
def test_a_corrupt_catalog_is_a_one_line_error_and_nothing_is_lost(small_set, tmp_path, case, command):
    import shutil

    text, needle = BAD_CATALOGS[case]
    folder = tmp_path / "set"
    shutil.copytree(small_set, folder)
    (folder / "catalog.json").write_text(text)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    args = {
        "list": ["objects", "list", str(folder)],
        "sheet": ["objects", "sheet", str(folder), "--out", str(tmp_path / "s.png")],
        "generate": ["objects", "generate", "--kind", "primitive", "--count", "1", "--start", "5", "--out",
                     str(folder)],
    }[command]  # fmt: skip
    _one_line_error(runner.invoke(app, args), "catalog.json", needle)
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before
    assert not (tmp_path / "s.png").exists()


def test_a_bad_field_names_the_object_and_field(small_set, tmp_path):
    import json
    import shutil

    folder = tmp_path / "set"
    shutil.copytree(small_set, folder)
    payload = json.loads((folder / "catalog.json").read_text())
    payload["objects"][1]["mass"] = "heavy"
    (folder / "catalog.json").write_text(json.dumps(payload))
    _one_line_error(runner.invoke(app, ["objects", "list", str(folder)]), "primitive-train-000001", "mass")
    payload["objects"][1]["mass"] = 0.2
    payload["objects"][0]["visual_mesh"] = "../../elsewhere.obj"
    (folder / "catalog.json").write_text(json.dumps(payload))
    _one_line_error(runner.invoke(app, ["objects", "list", str(folder)]), "plain name")


@pytest.mark.parametrize("keep", [0, 60, 900])
def test_a_truncated_mesh_names_the_file(small_set, tmp_path, keep):
    import shutil

    folder = tmp_path / "set"
    shutil.copytree(small_set, folder)
    visual = folder / "primitive-train-000001" / "visual.obj"
    visual.write_bytes(visual.read_bytes()[:keep])
    result = runner.invoke(app, ["objects", "sheet", str(folder), "--out", str(tmp_path / "s.png")])
    _one_line_error(result, str(visual))


def test_folders_that_are_not_sets(tmp_path):
    (tmp_path / "afile").write_text("x")
    _one_line_error(runner.invoke(app, ["objects", "list", str(tmp_path / "nope")]), "no such folder")
    _one_line_error(runner.invoke(app, ["objects", "sheet", str(tmp_path)]), "no object catalog")
    _one_line_error(runner.invoke(app, ["objects", "list", str(tmp_path / "afile")]), "is a file")
    gen = ["objects", "generate", "--kind", "primitive", "--count", "1", "--out", str(tmp_path / "afile")]
    _one_line_error(runner.invoke(app, gen), "is a file")
    imp = ["objects", "import", str(tmp_path), "--out", str(tmp_path / "afile")]
    (tmp_path / "bar.stl").write_bytes(b"")
    _one_line_error(runner.invoke(app, imp), "is a file")
    assert (tmp_path / "afile").read_text() == "x"


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--kind", "primitive", "--count", "0"], "--count"),
        (["--kind", "primitive", "--count", "-3"], "--count"),
        (["--kind", "primitive", "--count", "1", "--start", "-1"], "--start"),
        (["--kind", "hammer", "--count", "1"], "--kind"),
        (["--kind", "primitive", "--count", "1", "--split", "val"], "--split"),
    ],
)
def test_bad_option_values_are_usage_errors(tmp_path, args, needle):
    result = runner.invoke(app, ["objects", "generate", *args, "--out", str(tmp_path / "set")])
    assert result.exit_code == 2, result.output
    assert needle in result.output
    assert not (tmp_path / "set").exists()


def test_realistic_train_is_refused_before_any_work(tmp_path):
    args = ["objects", "generate", "--kind", "realistic", "--count", "1", "--out", str(tmp_path / "r")]
    result = runner.invoke(app, args)
    _one_line_error(result, "test set only")
    assert "0/1" not in result.output  # refused before the progress bar starts
    assert not (tmp_path / "r").exists()


def test_another_config_into_an_existing_set_keeps_it(small_set, tmp_path):
    import shutil

    from tognet.objects import GeneratorConfig
    from tognet.objects.primitive import PrimitiveConfig

    folder = tmp_path / "set"
    shutil.copytree(small_set, folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    cfg = GeneratorConfig(primitive=PrimitiveConfig(cylinder_sections=12)).save(tmp_path / "c.json")
    args = ["objects", "generate", "--kind", "primitive", "--count", "1", "--start=2", "--config", str(cfg)]
    _one_line_error(runner.invoke(app, [*args, "--out", str(folder)]), "different generator config")
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


def test_sheet_side_view_is_readable(tmp_path):
    """A 30 x 3 x 2 cm bar: its side view is a band tall enough to see (2/3 of its top view's width)."""
    from tognet.objects import assemble_object, write_catalog
    from tognet.objects.sheet import write_contact_sheet

    bar = trimesh.creation.box(extents=(0.30, 0.03, 0.02))
    record = assemble_object(
        tmp_path / "set", object_id="bar", kind="primitive", split="test", shape_rule="T",
        part_types=["cuboid"], visual=bar, collision_pieces=[bar], density=700.0, friction=0.8,
    )  # fmt: skip
    write_catalog(tmp_path / "set", [record])
    png = write_contact_sheet(tmp_path / "set", tmp_path / "sheet.png")
    rgb = np.asarray(Image.open(png).convert("RGB")).astype(int)
    blue = (rgb[:, :, 2] - rgb[:, :, 0] > 40).any(axis=1)
    rows = np.flatnonzero(blue)
    bands = np.split(rows, np.flatnonzero(np.diff(rows) > 3) + 1)
    assert len(bands) == 2, [(b[0], b[-1]) for b in bands]  # top view, then side view
    top_px, side_px = (len(b) for b in bands)
    assert side_px == pytest.approx(top_px * 2 / 3, rel=0.2)  # same scale in both views
    assert side_px >= 25  # 2 cm is readable (the first layout gave it 17 px)
    with pytest.raises(ValueError, match="PNG"):
        write_contact_sheet(tmp_path / "set", tmp_path / "sheet.jpg")
