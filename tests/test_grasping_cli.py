"""``tognet grasps``: draws candidates; clear errors for bad files."""

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from tognet.cli import app
from tognet.grasping import AntipodalConfig, load_depth_file, prepare_depth
from tognet.grasping.draw import render_grasps
from tognet.grasping.synthetic import Cylinder, render_depth, t_shape, tilted_camera


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("grasps")
    camera = tilted_camera(0.9, tilt=(0.02, -0.03))
    depth = render_depth(camera, t_shape(0.02, 0.0, 0.4) + [Cylinder.lying(-0.2, 0.1, 0.015, 0.2, 1.0)])
    depth[np.random.default_rng(0).random(depth.shape) < 0.01] = 0.0
    camera.save(folder / "camera.json")
    np.save(folder / "depth.npy", depth)
    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(folder / "depth.png")
    np.savez(folder / "depth.npz", depth=depth)
    return folder, camera, depth


@pytest.mark.parametrize("name", ["depth.npy", "depth.png", "depth.npz"])
def test_grasps_command_draws_candidates(scene_files, name):
    folder, _, depth = scene_files
    out = folder / f"out_{name}.png"
    result = CliRunner().invoke(
        app,
        [
            "grasps",
            "--depth",
            str(folder / name),
            "--camera",
            str(folder / "camera.json"),
            "--out",
            str(out),
            "--max",
            "50",
            "--seed",
            "3",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "50 candidates" in result.output
    img = np.asarray(Image.open(out))
    assert img.shape == (2 * depth.shape[0], 2 * depth.shape[1], 3)
    # Coloured jaw lines are present (the depth rendering itself is grey).
    colourful = np.ptp(img.astype(int), axis=2) > 60
    assert colourful.sum() > 200


def test_png_depth_reads_millimetres(scene_files):
    folder, _, depth = scene_files
    loaded = load_depth_file(folder / "depth.png")
    valid = depth > 0
    np.testing.assert_allclose(loaded[valid], depth[valid], atol=6e-4)


def test_grasps_command_nms_and_empty(scene_files, tmp_path):
    folder, camera, _ = scene_files
    result = CliRunner().invoke(
        app,
        [
            "grasps",
            "--depth",
            str(folder / "depth.npy"),
            "--camera",
            str(folder / "camera.json"),
            "--out",
            str(tmp_path / "nms.png"),
            "--nms",
        ],
    )
    assert result.exit_code == 0, result.output
    np.save(tmp_path / "empty.npy", render_depth(camera, []))
    result = CliRunner().invoke(
        app,
        [
            "grasps",
            "--depth",
            str(tmp_path / "empty.npy"),
            "--camera",
            str(folder / "camera.json"),
            "--out",
            str(tmp_path / "empty.png"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "no grasp candidates" in result.output and (tmp_path / "empty.png").is_file()


def test_grasps_command_errors(scene_files, tmp_path):
    folder, _, _ = scene_files
    cam = str(folder / "camera.json")
    runner = CliRunner()

    def run(depth_path, camera_path=cam, extra=()):
        return runner.invoke(
            app,
            [
                "grasps",
                "--depth",
                str(depth_path),
                "--camera",
                str(camera_path),
                "--out",
                str(tmp_path / "x.png"),
                *extra,
            ],
        )

    r = run(tmp_path / "missing.npy")
    assert r.exit_code == 2 and "not found" in r.output
    np.save(tmp_path / "nan.npy", np.full((424, 512), np.nan, np.float32))
    r = run(tmp_path / "nan.npy")
    assert r.exit_code == 2 and "no valid pixels" in r.output
    np.save(tmp_path / "small.npy", np.ones((10, 10), np.float32))
    r = run(tmp_path / "small.npy")
    assert r.exit_code == 2 and "shape" in r.output
    Image.fromarray(np.zeros((424, 512), np.uint8)).save(tmp_path / "eight.png")
    r = run(tmp_path / "eight.png")
    assert r.exit_code == 2 and "16-bit" in r.output
    (tmp_path / "bad.json").write_text("{not json")
    r = run(folder / "depth.npy", tmp_path / "bad.json")
    assert r.exit_code == 2 and "JSON" in r.output
    (tmp_path / "partial.json").write_text('{"intrinsics": {"width": 512}}')
    r = run(folder / "depth.npy", tmp_path / "partial.json")
    assert r.exit_code == 2 and "partial.json" in r.output and "height" in r.output
    r = run(folder / "depth.npy", extra=("--checkpoint", str(tmp_path / "none.pt")))
    assert r.exit_code == 2 and "none.pt: checkpoint file not found" in r.output
    assert not (tmp_path / "x.png").exists()


def test_render_grasps_takes_any_scorer(scene_files, tmp_path):
    _, camera, depth = scene_files
    scene = prepare_depth(depth, camera)

    def prefer_left(g):
        return -g[:, 0]

    cands, scores, path = render_grasps(
        scene, tmp_path / "scored.png", config=AntipodalConfig(max_candidates=40), score_fn=prefer_left
    )
    np.testing.assert_allclose(scores, -cands.grasps[:, 0])
    assert path.is_file()


def test_render_grasps_cem_marks_the_best_in_red(scene_files, tmp_path):
    _, camera, depth = scene_files
    scene = prepare_depth(depth, camera)

    def prefer_left(g):
        return -g[:, 0]

    config = AntipodalConfig(max_candidates=40)
    _, _, plain = render_grasps(scene, tmp_path / "plain.png", config=config, score_fn=prefer_left)
    _, _, marked = render_grasps(
        scene, tmp_path / "cem.png", config=config, score_fn=prefer_left, use_cem=True
    )

    def red(path):
        img = np.asarray(Image.open(path)).astype(int)
        return np.sum((img[..., 0] > 200) & (img[..., 1] < 80) & (img[..., 2] < 80))

    assert red(marked) > 50 and red(plain) == 0
    with pytest.raises(Exception, match="--cem needs a scorer"):
        render_grasps(scene, tmp_path / "x.png", config=config, use_cem=True)


def test_grasps_command_refuses_a_bad_out_path_before_any_work(scene_files, tmp_path):
    folder, _, _ = scene_files
    base = ["grasps", "--depth", str(folder / "depth.npy"), "--camera", str(folder / "camera.json")]
    r = CliRunner().invoke(app, [*base, "--out", str(tmp_path)])
    assert r.exit_code == 2 and "is a folder; pass a file name" in r.output
    r = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "grasps.jpg")])
    assert r.exit_code == 2 and ".png" in r.output and not (tmp_path / "grasps.jpg").exists()
