"""Input hygiene across the commands, each case found by trying them as a new user would (issue 13)."""

import json
import sys

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from tognet.cli import app
from tognet.geometry import Camera, CameraIntrinsics


def _run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture()
def no_text_detectors(monkeypatch):
    """A machine without charset_normalizer/chardet (tognet does not install them; ray pulls one in)."""
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)
    monkeypatch.setitem(sys.modules, "chardet", None)


@pytest.mark.parametrize("kind", ["random", "truncated"])
def test_a_damaged_stl_is_named_as_such_not_as_a_missing_module(tmp_path, no_text_detectors, kind):
    src = tmp_path / "src"
    src.mkdir()
    whole = trimesh.creation.box((0.1, 0.03, 0.02)).export(file_type="stl")
    data = np.random.default_rng(0).bytes(3000) if kind == "random" else whole[:500]
    (src / "tool.stl").write_bytes(data)
    result = _run("objects", "import", src, "--out", tmp_path / "set")
    assert result.exit_code == 1, result.output
    assert "charset_normalizer" not in result.output and "module" not in result.output.lower()
    expected = "not an STL file" if kind == "random" else "truncated binary STL: its header announces 12"
    assert expected in result.output, result.output


def _camera_files(tmp_path):
    camera = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 0.7])
    return camera.save(tmp_path / "camera.json")


def test_a_garbage_npy_is_named_without_advice_to_unpickle(tmp_path):
    cam = _camera_files(tmp_path)
    garbage = tmp_path / "depth.npy"
    garbage.write_bytes(np.random.default_rng(1).bytes(4000))
    objects = tmp_path / "objects.npy"
    np.save(objects, np.array([{"depth": 1}], dtype=object))
    for path, message in ((garbage, "not a .npy file (no NumPy header)"),
                          (objects, "holds Python objects, not a numeric depth array")):
        result = _run("grasps", "--depth", path, "--camera", cam, "--out", tmp_path / "o.png")
        assert result.exit_code == 2 and message in result.output, result.output
        assert "pickle" not in result.output
    assert not (tmp_path / "o.png").exists()


def test_grasps_config_with_an_impossible_value_names_it_inline_or_from_a_file(tmp_path):
    from tognet.grasping.synthetic import render_depth, t_shape

    camera = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 0.7])
    cam = camera.save(tmp_path / "camera.json")
    depth = tmp_path / "d.npy"
    np.save(depth, render_depth(camera, t_shape(0.0, 0.0, yaw=0.3)))
    (tmp_path / "cfg.json").write_text('{"max_width": -1}')
    for config in ('{"max_width": -1}', str(tmp_path / "cfg.json")):
        result = _run("grasps", "--depth", depth, "--camera", cam, "--out", tmp_path / "o.png",
                      "--config", config)
        assert result.exit_code == 2, result.output
        assert "max_width must be > 0 and <= 0.5 (m), got -1" in result.output, result.output
    ok = _run("grasps", "--depth", depth, "--camera", cam, "--out", tmp_path / "o.png", "--config",
              '{"max_width": 0.07, "max_candidates": 30}')
    assert ok.exit_code == 0 and "30 candidates" in ok.output, ok.output


def test_grasps_checkpoint_help_says_what_it_does():
    result = _run("grasps", "--help")
    assert "needs the model package" not in result.output
    assert "Q_T" in result.output


def test_objects_import_takes_a_single_file(tmp_path):
    mesh = tmp_path / "box.obj"
    trimesh.creation.box((0.1, 0.03, 0.02)).export(mesh)
    result = _run("objects", "import", mesh, "--out", tmp_path / "set")
    assert result.exit_code == 0, result.output
    assert "ok      imported-box" in result.output and "imported 1 of 1 files" in result.output
    other = _run("objects", "import", tmp_path / "notes.txt", "--out", tmp_path / "set")
    assert other.exit_code == 2 and "not found" in other.output


def _mass(set_dir):
    catalog = json.loads((set_dir / "catalog.json").read_text())
    entries = catalog["objects"] if isinstance(catalog, dict) else catalog
    return {e["object_id"]: e["mass"] for e in entries}["imported-box"]


def test_reimporting_a_changed_mesh_keeps_the_object_unless_replace(tmp_path):
    mesh, out = tmp_path / "box.obj", tmp_path / "set"
    trimesh.creation.box((0.1, 0.03, 0.02)).export(mesh)
    assert _run("objects", "import", mesh, "--out", out).exit_code == 0
    first = _mass(out)
    same = _run("objects", "import", mesh, "--out", out)
    assert same.exit_code == 0 and "kept    imported-box" in same.output, same.output
    trimesh.creation.box((0.12, 0.03, 0.02)).export(mesh)
    changed = _run("objects", "import", mesh, "--out", out)
    assert changed.exit_code == 1, changed.output
    assert "already in" in changed.output and "the file changed" in changed.output
    assert "--replace" in changed.output
    assert _mass(out) == pytest.approx(first)  # kept, as the help says
    replaced = _run("objects", "import", mesh, "--out", out, "--replace")
    assert replaced.exit_code == 0, replaced.output
    assert _mass(out) == pytest.approx(1.2 * first, rel=1e-3)


def test_data_info_without_a_manifest_reads_the_shards(tmp_path):
    from tognet.data.synthetic import write_synthetic_dataset

    folder = write_synthetic_dataset(tmp_path / "d", task="sweeping", n=60, shard_size=25, seed=2)
    expected = json.loads((folder / "manifest.json").read_text())["totals"]
    (folder / "manifest.json").unlink()
    result = _run("data", "info", folder)
    assert result.exit_code == 0, result.output
    assert "no manifest.json" in result.output
    body = json.loads(result.output[result.output.index("{"):])
    assert body["task"] == "sweeping" and body["shards"] == 3
    assert body["totals"] == expected


_AS = ["--methods", "TOG-Net+ActionSearch", "--task-model"]


@pytest.mark.parametrize("args, message", [
    (["--methods", "TOG-Net+ActionSerch"], "unknown method 'TOG-Net+ActionSerch'"),
    ([*_AS, "hammering_search=tognet/models/hammering.pt"], "its task stream does not see the action"),
    ([*_AS, "hammering_search=tognet/models/sweeping_search.pt"], "a sweeping model, given as"),
    ([*_AS, "hammering_search=nope.pt"], "checkpoint not found"),
])
def test_evaluate_refuses_a_bad_method_or_action_search_model_in_one_line(tmp_path, args, message):
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    args = [a.replace("tognet/models/", f"{root}/tognet/models/") for a in args]
    out = tmp_path / "eval"
    result = _run("evaluate", "--task", "hammering", "--episodes", "1", "--out", out, *args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert "Traceback" not in result.output and not out.exists()  # refused before anything is written
