"""``tognet sim``: one episode from the command line, with an animation when a GL backend exists."""

import numpy as np
import pytest
from typer.testing import CliRunner

from tognet.cli import app


def test_sim_command_runs_an_episode_and_writes_the_depth_image(tmp_path):
    out = tmp_path / "depth.png"
    result = CliRunner().invoke(app, ["sim", "--task", "sweeping", "--depth-png", str(out), "--seed", "2"])
    assert result.exit_code == 0, result.output
    assert "default grasp" in result.output and "grasp_success=" in result.output
    assert out.stat().st_size > 1000


def test_sim_command_rejects_unknown_objects(tmp_path):
    result = CliRunner().invoke(app, ["sim", "--object", "nope"])
    assert result.exit_code == 2 and "t_hammer" in result.output


def test_sim_command_writes_a_gif(tmp_path):
    import mujoco

    from tognet.sim import SimConfig  # noqa: F401  (sets MUJOCO_GL before the renderer starts)

    try:
        probe = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8)
        probe.close()
    except Exception as exc:  # no EGL/OSMesa on this machine: .ci/run installs them when it can
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
    ],
)
def test_sim_command_refuses_bad_input_before_any_work(tmp_path, args, message):
    args = [a.format(tmp=tmp_path) for a in args]
    result = CliRunner().invoke(app, ["sim", *args])
    assert result.exit_code == 2 and message in result.output, result.output
    assert "grasp_success" not in result.output and not list(tmp_path.iterdir())
