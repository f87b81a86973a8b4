"""The real arms (optional extra ``robot``): the Panda and the Sawyer load from robosuite's installed model
files with their grippers and limits, and inverse kinematics reaches a grasp on the table and reports a
pose far outside the workspace as unreachable. Skipped where the extra is not installed, except the check
that its absence is one clear error."""

import importlib.util
import math

import mujoco
import numpy as np
import pytest

from tognet.robot import (
    ARM_NAMES,
    ArmIK,
    IKStatus,
    RobotExtraMissing,
    arm_xml,
    grasp_frame,
    load_arm,
)
from tognet.robot import arms as arms_module
from tognet.robot import ik as ik_module
from tognet.robot.ik import tcp_errors

HAVE_EXTRA = all(importlib.util.find_spec(name) is not None for name in ("robosuite", "mink"))
needs_extra = pytest.mark.skipif(not HAVE_EXTRA, reason="the robot extra (robosuite, mink) is not installed")

#: A grasp on the grasping half of the table (x < 0), 2 cm above the top: every arm reaches it.
ON_TABLE = (-0.3, 0.0, 0.02)


def test_a_missing_extra_is_one_clear_error(monkeypatch):
    monkeypatch.setattr(arms_module.importlib.util, "find_spec", lambda _name: None)
    with pytest.raises(RobotExtraMissing, match=r"pip install 'tognet\[robot\]'"):
        load_arm("panda")
    monkeypatch.setattr(ik_module, "mink", None)
    with pytest.raises(RobotExtraMissing, match=r"mink is not installed.*tognet\[robot\]"):
        ArmIK(None)


def test_an_unknown_arm_names_the_choices():
    with pytest.raises(ValueError, match="panda, sawyer"):
        load_arm("ur5")


@pytest.fixture(scope="module", params=ARM_NAMES)
def arm(request):
    if not HAVE_EXTRA:
        pytest.skip("the robot extra (robosuite, mink) is not installed")
    return load_arm(request.param, ground_z=-0.75)


@needs_extra
def test_the_arm_loads_with_its_gripper_and_limits(arm):
    assert len(arm.joint_names) == 7
    assert arm.joint_limits.shape == (7, 2) and np.all(arm.joint_limits[:, 0] < arm.joint_limits[:, 1])
    assert np.all(arm.joint_speed_limits > 0) and arm.joint_speed_limits.shape == (7,)
    assert len(arm.finger_dofs) == 2  # the parallel gripper's two slide joints
    # The limits are the model's own (two values from robosuite's MJCF of each arm).
    expected = {"panda": ("arm_joint4", (-3.0718, -0.0698)), "sawyer": ("arm_right_j1", (-3.8095, 2.2736))}
    joint, limits = expected[arm.spec.name]
    np.testing.assert_allclose(arm.joint_limits[arm.joint_names.index(joint)], limits, atol=1e-3)
    # The base stands beside the table (off its 0.76 m wide top), and at home the hand points down.
    data = mujoco.MjData(arm.model)
    data.qpos[:] = arm.home
    mujoco.mj_kinematics(arm.model, data)
    assert abs(data.body("arm_mount").xpos[1]) > 0.38
    z_axis = data.site_xmat[arm.tcp_site].reshape(3, 3)[:, 2]
    assert z_axis[2] < -0.9


@needs_extra
def test_the_arm_compiles_with_the_visual_meshes_too():
    model = mujoco.MjModel.from_xml_string(arm_xml("sawyer", visual=True))
    assert model.nmesh > 0 and model.site("arm_tcp").id >= 0


@needs_extra
@pytest.mark.parametrize("phi", [0.0, math.pi / 2, 3.0])
def test_ik_reaches_a_grasp_on_the_table(arm, phi):
    pose = (*ON_TABLE, phi)
    result = ArmIK(arm).solve(pose)
    assert result.status is IKStatus.REACHED and result.reached
    # The returned joints put the TCP there (checked on fresh data), within the model's joint limits.
    data = mujoco.MjData(arm.model)
    data.qpos[:] = arm.home
    data.qpos[arm.qpos_adr] = result.q
    mujoco.mj_kinematics(arm.model, data)
    pos_err, ang_err = tcp_errors(arm, data, grasp_frame(pose))
    assert pos_err < 1e-3 and ang_err < 1e-2
    lo, hi = arm.joint_limits.T
    assert np.all(result.q >= lo - 1e-6) and np.all(result.q <= hi + 1e-6)
    # The jaw axis is along the grasp's yaw, the gripper pointing down.
    frame = data.site_xmat[arm.tcp_site].reshape(3, 3)
    np.testing.assert_allclose(frame[:, 0], (math.cos(phi), math.sin(phi), 0.0), atol=1e-2)


@needs_extra
def test_a_pose_far_outside_the_workspace_is_unreachable(arm):
    result = ArmIK(arm).solve((2.0, 2.0, 0.5, 0.0))
    assert result.status is IKStatus.UNREACHABLE and not result.reached
    assert result.position_error > 1.0


@needs_extra
def test_a_pose_too_close_to_the_base_is_a_joint_limit():
    """20 cm in front of the Panda's base, 15 cm above the table: the elbow would have to fold past its limit
    (joint 4's -3.07 rad; without limits the solve converges at about -3.3 rad)."""
    arm = load_arm("panda")
    result = ArmIK(arm).solve((-0.25, 0.25, 0.15, -math.pi / 2))
    assert result.status is IKStatus.JOINT_LIMIT and not result.reached
    lo, hi = arm.joint_limits.T
    assert np.all(result.q >= lo - 1e-6) and np.all(result.q <= hi + 1e-6)  # the closest within limits


@needs_extra
def test_the_arm_stands_in_tognets_world_and_reaches_over_the_table(arm, tools):
    """Placed into the simulator's own world MJCF: it compiles, and at home and at an IK grasp 5 cm above
    the table no arm geom touches the table or the ground (the arm's own links may touch each other)."""
    from tognet.robot import place_arm
    from tognet.sim import SimConfig
    from tognet.sim.world import world_xml
    from tognet.tasks.props import PropsMJCF

    cfg = SimConfig()
    world = world_xml(cfg, tools["t_hammer"], PropsMJCF())
    model = mujoco.MjModel.from_xml_string(place_arm(world, arm.spec.name, ground_z=-cfg.world.table_height))
    data = mujoco.MjData(model)
    adr = [model.jnt_qposadr[model.joint(j).id] for j in arm.joint_names]
    pose = (-0.3, 0.05, 0.05, 1.0)
    grasp = ArmIK(arm).solve(pose)
    assert grasp.reached
    static = {model.geom("table").id, model.geom("ground").id}
    for q in (np.array(arm.spec.home), grasp.q):
        data.qpos[:] = model.qpos0
        data.qpos[adr] = q
        mujoco.mj_forward(model, data)
        hits = [(model.geom(c.geom1).name, model.geom(c.geom2).name) for c in data.contact[:data.ncon]
                if {c.geom1, c.geom2} & static]
        assert not [h for h in hits if any(n.startswith("arm_") for n in h)], hits
    np.testing.assert_allclose(data.site("arm_tcp").xpos, pose[:3], atol=1e-3)


@needs_extra
def test_a_wrist_swing_is_timed_by_the_wrist_speed_limit(arm):
    """A quarter turn about the vertical at a start pose over the manipulation half: the joints follow it
    continuously, and its shortest time is set by the wrist's speed limit (far slower than the floating
    gripper's 9 rad/s swing)."""
    from tognet.robot import joint_path

    poses = [(0.2, 0.05, 0.15, 0.3 + a) for a in np.linspace(0.0, math.pi / 2, 10)]
    path = joint_path(ArmIK(arm), poses)
    assert path.status is IKStatus.REACHED and path.failed_at is None and path.q.shape == (10, 7)
    assert np.all(path.limiting_joint == 6)  # the last joint, the wrist
    assert np.abs(np.diff(path.q, axis=0)).max() < 0.5  # no jump between waypoints
    # The other joints take a share of the turn (the Sawyer's base joint turns too), so the wrist's own
    # turn, and the time, can be shorter than a quarter turn at its limit; still far slower than 9 rad/s.
    wrist = arm.joint_speed_limits[6]
    assert 1.5 * (math.pi / 2) / 9.0 < path.min_duration < 1.5 * (math.pi / 2) / wrist


@needs_extra
def test_the_servos_follow_a_straight_line_to_within_a_millimetre(arm):
    """The arm with its joint servos (speed-capped setpoints, the model's torque limits, gravity
    compensated) follows the joint path of a 30 cm line over the table and ends on its last pose."""
    from tognet.robot import joint_path
    from tognet.robot.control import follow, set_joints

    driven = load_arm(arm.spec.name, servos=True)
    model, data = driven.model, mujoco.MjData(driven.model)
    assert model.nu == 9  # seven joint servos and the gripper's two finger servos
    poses = [(x, 0.0, 0.15, 0.0) for x in np.linspace(0.0, 0.3, 31)]
    path = joint_path(ArmIK(driven), poses)
    assert path.status is IKStatus.REACHED
    set_joints(driven, model, data, path.q[0])
    tracking = follow(driven, model, data, path, slack=1.25)
    # Each segment's time, rounded up to whole timesteps.
    slowest = 1.25 * path.min_duration + len(path.min_times) * model.opt.timestep
    assert 1.25 * path.min_duration - 1e-9 <= tracking.move_time <= slowest
    assert tracking.final_error < 1e-3 and tracking.settle_time < 0.3
    assert tracking.max_speed_ratio < 1.5  # the servos overshoot the setpoints' capped speed a little
    mujoco.mj_kinematics(model, data)
    pos_err, ang_err = tcp_errors(driven, data, grasp_frame(poses[-1]))
    assert pos_err < 1e-3 and ang_err < 1e-2
