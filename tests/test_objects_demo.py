"""``tognet demo`` (what ``make run`` runs): it writes object sets and contact sheets and says where."""

from __future__ import annotations

import json

from PIL import Image
from typer.testing import CliRunner

from tognet.cli import app


def test_demo_writes_sets_and_sheets_and_prints_their_paths(tmp_path):
    out = tmp_path / "demo"
    args = ["demo", "--out", str(out), "--count", "1", "--realistic", "2", "--no-tasks", "--no-evaluate"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    for kind, n in (("primitive", 1), ("complex", 1), ("realistic", 2)):
        sheet = out / f"sheet_{kind}.png"
        assert str(sheet) in result.output
        assert Image.open(sheet).size[0] > 300
        catalog = json.loads((out / "objects" / kind / "catalog.json").read_text())
        assert len(catalog["objects"]) == n
    assert "hammer, mallet" in result.output
    # A second run starts from scratch: a set left with other objects does not leak into the new one.
    args = ["demo", "--out", str(out), "--count", "1", "--realistic", "1", "--no-tasks", "--no-evaluate"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert len(json.loads((out / "objects" / "realistic" / "catalog.json").read_text())["objects"]) == 1
