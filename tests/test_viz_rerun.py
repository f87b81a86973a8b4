"""Rerun recordings (issue 32): `tognet plan --rerun` and `tognet sim --rerun` write .rrd files that Rerun's
own reader opens, with the entities the README lists."""

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("rerun", reason="the rerun extra (pip install 'tognet[rerun]')")

from rerun.chunk import RrdReader  # noqa: E402

from tognet.cli import app  # noqa: E402
from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics  # noqa: E402


def _entities(path):
    """{entity: (rows, timelines, components)} of an .rrd, read back with Rerun's reader."""
    out = {}
    for chunk in RrdReader(path).stream():
        names = {n for n in chunk.to_record_batch().schema.names if ":" in n}
        rows, lines, comps = out.get(str(chunk.entity_path), (0, set(), set()))
        out[str(chunk.entity_path)] = (rows + chunk.num_rows, lines | set(chunk.timeline_names),
                                       comps | names)
    return out


def test_a_plan_recording_holds_the_cloud_candidates_grasp_motion_and_the_arm(hammer_sim, tmp_path):
    obs = hammer_sim.reset(3)
    d = save_depth_png(tmp_path / "d.png", obs.depth)
    k = save_intrinsics(tmp_path / "k.json", obs.camera.intrinsics)
    pose = save_camera_pose(tmp_path / "pose.json", obs.camera.pose)
    out = tmp_path / "plan.rrd"
    run = CliRunner().invoke(app, ["plan", "--depth", str(d), "--intrinsics", str(k), "--camera-pose",
                                   str(pose), "--task", "hammering", "--reference", "0.3", "-0.1", "0.045",
                                   "--robot", "sawyer", "--rerun", str(out)])
    assert run.exit_code == 0, run.output
    e = _entities(out)
    assert "Points3D:positions" in e["/world/table/depth"][2] and "Transform3D:mat3x3" in e["/world/table"][2]
    for name in ("/world/table/candidates", "/world/table/objects", "/world/table/grasp",
                 "/world/table/alternatives", "/world/motion", "/world/motion/reference"):
        assert name in e, name
    joints = [n for n in e if n.startswith("/world/arm/joints/")]
    assert len(joints) == 7 and all(e[j][0] == 6 and "time" in e[j][1] for j in joints)  # 6 waypoints
    # the cloud: the scene's measured pixels, at the table's heights (world frame through world/table)
    chunk = next(c for c in RrdReader(out).stream() if str(c.entity_path) == "/world/table/depth")
    pts = np.array(chunk.to_record_batch().column("Points3D:positions")[0].values.to_numpy(
        zero_copy_only=False).tolist())
    assert len(pts) > 10_000 and np.median(pts[:, 2]) == pytest.approx(0.0, abs=0.005)


def test_an_episode_recording_moves_the_tool_over_time(tmp_path):
    out = tmp_path / "episode.rrd"
    run = CliRunner().invoke(app, ["sim", "--task", "hammering", "--seed", "3", "--rerun", str(out)])
    assert run.exit_code == 0, run.output
    e = _entities(out)
    tool = e["/world/bodies/object"]
    assert tool[0] > 50 and "sim_time" in tool[1] and "Transform3D:translation" in tool[2]
    parts = [v[2] for k, v in e.items() if k.startswith("/world/bodies/object/")]
    assert any("Mesh3D:vertex_positions" in p for p in parts)
    assert "/world/bodies/peg" in e and "/world/bodies/hand" in e
    assert "TextDocument:text" in e["/outcome"][2]


def test_a_wrong_suffix_is_one_line(tmp_path):
    run = CliRunner().invoke(app, ["sim", "--task", "hammering", "--rerun", str(tmp_path / "e.txt")])
    assert run.exit_code == 2 and ".rrd" in run.output and len(run.output.strip().splitlines()) == 1
