"""Trials with a real arm carrying the hand (SimConfig.robot, tognet.sim.arm): the same labels as the
floating base, the grasp still matters, and what the arm cannot do is its own failure reason."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from tognet.objects.handmade import grasp_on_object
from tognet.robot.names import ROBOT_NAMES
from tognet.sim import SimConfig, Simulator
from tognet.sim.config import with_robot
from tognet.tasks import FailureReason

HAVE_EXTRA = all(importlib.util.find_spec(name) is not None for name in ("robosuite", "mink"))
pytestmark = pytest.mark.skipif(not HAVE_EXTRA, reason="the robot extra (robosuite, mink) is not installed")


def _run(sim: Simulator, grasp_name: str, seeds: range) -> list:
    """The task's scripted grasp ``grasp_name`` with its scripted action on each seed's scene."""
    props = sim.props
    results = []
    for seed in seeds:
        sim.reset(seed)
        pos, rot = sim.object_pose()
        spec = props.check_grasps[grasp_name]
        grasp = grasp_on_object(pos, rot, spec[0], spec[1])
        results.append(sim.execute(grasp, props.check_action(grasp_name), seed))
    return results


@pytest.fixture(scope="module")
def sawyer() -> SimConfig:
    return with_robot(SimConfig(), "sawyer")


def test_the_presets_scale_the_swing_by_the_wrist_speed_squared():
    base = SimConfig()
    for name in ROBOT_NAMES[1:]:
        cfg = with_robot(base, name)
        ratio = (cfg.gripper.yaw_speed / base.gripper.yaw_speed) ** 2
        assert cfg.robot.name == name and ratio < 0.3
        assert cfg.gripper.yaw_torque == pytest.approx(base.gripper.yaw_torque * ratio, rel=0.01)
        assert cfg.hammering.peg_friction == pytest.approx(base.hammering.peg_friction * ratio, rel=0.01)
    assert with_robot(base, "floating") == base
    with pytest.raises(ValueError, match="floating, sawyer, panda"):
        with_robot(base, "ur5")


def test_with_the_sawyer_the_far_end_grasp_hammers_and_the_head_grasp_does_not(sawyer, tools):
    sim = Simulator(sawyer, "hammering", tools["t_hammer"])
    far = _run(sim, "far_end", range(4))
    head = _run(sim, "head", range(4))
    assert all(r.valid for r in far + head)
    assert sum(r.task_success for r in far) >= 3, [r.failure.value for r in far]
    assert sum(r.task_success for r in head) == 0
    assert all(r.grasp_success for r in far)
    # The wrist turned the hand: the joint the swing ran on is the last one, within its speed limit.
    assert sim.scene is not None and "peg_out" in far[0].info


def test_with_the_sawyer_a_slow_push_does_not_drive_the_peg(sawyer, tools):
    """The preset scales the wrist's torque with the peg's friction: pushing at 1.5 rad/s still fails."""
    slow = sawyer.replace(gripper=sawyer.gripper.replace(yaw_speed=1.5))
    results = _run(Simulator(slow, "hammering", tools["t_hammer"]), "far_end", range(3))
    assert not any(r.task_success for r in results), [r.failure.value for r in results]


def test_with_the_sawyer_the_short_end_grasp_sweeps(sawyer, tools):
    results = _run(Simulator(sawyer, "sweeping", tools["l_tool"]), "short_end", range(3))
    assert sum(r.task_success for r in results) >= 2, [(r.failure.value, r.info.get("arm_stuck"))
                                                       for r in results]


def test_a_grasp_out_of_the_arms_reach_is_unreachable_not_a_grasp_failure(sawyer, tools):
    far = sawyer.replace(robot=sawyer.robot.replace(base_position=(0.0, 2.5, 0.0)))  # 2.5 m from the tool
    sim = Simulator(far, "hammering", tools["t_hammer"])
    result = _run(sim, "far_end", range(1))[0]
    assert result.valid and not result.grasp_success and not result.task_success
    assert result.failure is FailureReason.UNREACHABLE
    assert result.info["arm_stuck"] in ("the approach", "the grasp", "the lift")


def test_turning_the_wrist_past_its_range_is_a_joint_limit():
    from tognet.sim.arm import arm_solver, reach_steps

    solver = arm_solver(with_robot(SimConfig(), "panda"))
    p = np.array([-0.3, 0.1, 0.1])
    q = solver.ik.solve([*p, 0.0]).q
    # The Panda's wrist spans 332 degrees: from anywhere in it, 216 degrees both ways cannot both fit.
    stuck = []
    for sign in (1.0, -1.0):
        steps = [("the grasp", p, 0.0)] + [("the motion", p, sign * k * 0.3 * math.pi) for k in (1, 2, 3, 4)]
        stuck.append(reach_steps(solver, steps, q).stuck)
    assert any(s is not None and s.reason == "joint_limit" and s.what == "the motion" for s in stuck), stuck
    # A small turn is fine, and the path's last waypoint puts the hand there.
    for sign in (1.0, -1.0):
        reach = reach_steps(solver, [("the grasp", p, 0.0), ("the transport", p, sign * 0.2 * math.pi)], q)
        if reach.stuck is None:
            pos, rot = solver.hand_pose(reach.path.q[-1])
            assert np.linalg.norm(pos - p) < 0.003
            assert abs(math.atan2(rot[1, 0], rot[0, 0]) - sign * 0.2 * math.pi) < 0.02
            break
    else:
        pytest.fail("the wrist turned by 36 degrees neither way")


def test_an_arm_trial_is_seeded(sawyer, tools):
    sim = Simulator(sawyer, "pulling", tools["l_tool"])
    first = _run(sim, "far_end", range(2))
    again = _run(sim, "far_end", range(2))
    for a, b in zip(first, again, strict=True):
        assert (a.grasp_success, a.task_success, a.failure) == (b.grasp_success, b.task_success, b.failure)
        assert a.info.get("in_hand") == b.info.get("in_hand")


def test_tognet_sim_runs_an_episode_on_the_arm():
    """`tognet sim --robot sawyer`: the hand-made T hammer's known grasp hammers the peg home on the arm."""
    from typer.testing import CliRunner

    from tognet.cli import app

    result = CliRunner().invoke(app, ["sim", "--task", "hammering", "--robot", "sawyer"])
    assert result.exit_code == 0, result.output
    assert "grasp_success=True task_success=True valid=True failure=none" in result.output
