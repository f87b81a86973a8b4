"""``tognet sim``: one episode from the command line, with an animation when a GL backend exists."""

import os

import numpy as np
import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.tasks import TASK_NAMES


def test_sim_command_runs_an_episode_and_writes_what_plan_reads(tmp_path):
    from PIL import Image

    from tognet.planning.camera import load_camera_pose, load_intrinsics

    out = tmp_path / "depth.png"
    result = CliRunner().invoke(app, ["sim", "--task", "sweeping", "--depth-png", str(out), "--seed", "2"])
    assert result.exit_code == 0, result.output
    assert "grasp_success=" in result.output and "tognet plan --depth" in result.output
    with Image.open(out) as img:  # 16-bit millimetres, not a picture
        assert img.mode.startswith("I;16") or img.mode == "I"
        mm = np.asarray(img)
    k = load_intrinsics(tmp_path / "depth.intrinsics.json")
    pose = load_camera_pose(tmp_path / "depth.pose.json")
    assert mm.shape == k.shape and 600 < np.median(mm[mm > 0]) < 800
    assert 0.6 < pose[2, 3] < 0.8


@pytest.mark.parametrize("task", TASK_NAMES)
def test_a_first_run_with_default_arguments_shows_a_success_and_what_it_did(task):
    args = ["sim"] if task == "hammering" else ["sim", "--task", task]  # hammering is the default task
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "task_success=True" in result.output, result.output
    grasp = [line for line in result.output.splitlines() if line.startswith("grasp: ")]
    action = [line for line in result.output.splitlines() if line.startswith("action: ")]
    assert len(grasp) == 1 and len(action) == 1, result.output
    assert len(grasp[0].split()[1:5]) == 4 and len(action[0].split()[1:5]) == 4


def test_sim_command_rejects_unknown_objects(tmp_path):
    result = CliRunner().invoke(app, ["sim", "--object", "nope"])
    assert result.exit_code == 2 and "t_hammer" in result.output


def test_sim_command_writes_a_gif(tmp_path):
    import mujoco

    from tognet.sim import SimConfig  # noqa: F401  (sets MUJOCO_GL before the renderer starts)

    try:
        probe = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8)
        probe.close()
    except Exception as exc:  # no EGL on this machine (`make system-deps` installs it)
        if os.environ.get("TOGNET_REQUIRE_GL") == "1":  # set by .ci/run after installing it
            pytest.fail(f"TOGNET_REQUIRE_GL=1 but MuJoCo's offscreen renderer does not start: {exc}")
        pytest.skip(f"no offscreen GL backend: {exc}")
    out = tmp_path / "ep.gif"
    result = CliRunner().invoke(app, ["sim", "--task", "hammering", "--gif", str(out)])
    assert result.exit_code == 0, result.output
    import imageio.v2 as imageio

    frames = imageio.mimread(out)
    assert 30 <= len(frames) <= 120  # a whole episode (the default grasp lifts the hammer)
    assert "grasp_success=True" in result.output
    assert np.std(np.asarray(frames[0], dtype=float)) > 5  # not a blank frame


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--task", "hammerin"], "unknown --task 'hammerin'"),
        (["--gif", "{tmp}/episode.png"], "--gif must name a .gif file"),
        (["--depth-png", "{tmp}/depth.jpg"], "--depth-png must name a .png file"),
        (["--action", "0", "0", "inf", "0"], "--action takes 4 finite numbers"),
        (["--grasp", "nan", "0", "0", "0"], "--grasp takes 4 finite numbers"),
        (["--task", "grasping", "--action", "0", "0", "0", "0"], "--action has no use with --task grasping"),
    ],
)
def test_sim_command_refuses_bad_input_before_any_work(tmp_path, args, message):
    args = [a.format(tmp=tmp_path) for a in args]
    result = CliRunner().invoke(app, ["sim", *args])
    assert result.exit_code == 2 and message in result.output, result.output
    assert "grasp_success" not in result.output and not list(tmp_path.iterdir())


def test_sim_command_refuses_a_grasp_out_of_reach_and_warns_off_the_table(tmp_path):
    far = CliRunner().invoke(app, ["sim", "--task", "sweeping", "--grasp", "5", "5", "0.1", "0"])
    assert far.exit_code == 2 and "out of the gripper's reach: x = 5.000" in far.output, far.output
    assert "grasp_success" not in far.output
    beside = CliRunner().invoke(app, ["sim", "--task", "grasping", "--grasp", "0.9", "0", "0.1", "0"])
    assert beside.exit_code == 0 and "off the table top" in beside.output
    assert "failure=grasp_failed" in beside.output


def test_sim_gif_without_a_gl_backend_says_what_to_install(tmp_path):
    """No renderer (MUJOCO_GL=disable stands in for a machine without EGL): a clear error, no file."""
    import subprocess
    import sys

    out = tmp_path / "ep.gif"
    env = {**os.environ, "MUJOCO_GL": "disable"}
    code = "from tognet.cli import main; main()"
    proc = subprocess.run(
        [sys.executable, "-c", code, "sim", "--task", "grasping", "--gif", str(out)],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "offscreen renderer did not start" in proc.stderr and "make system-deps" in proc.stderr
    assert not out.exists()
