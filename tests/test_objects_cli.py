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
    assert "imported 1 of 2" in result.output
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
