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
