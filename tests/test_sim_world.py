"""The simulated world: depth image, grasp and lift, determinism, state round-trips, invalid episodes."""

import mujoco
import numpy as np
import pytest
from sim_testlib import far_end_grasp

from tognet.geometry import Camera, CameraIntrinsics, Grasp
from tognet.geometry.transforms import make_pose, rot_x
from tognet.objects.handmade import grasp_on_object
from tognet.sim import FailureReason, SimConfig, Simulator
from tognet.tasks import TASK_NAMES, get_props, get_task
from tognet.tasks.hammering_props import hammer_action


def full_ray_cast(sim, cam):
    """Every pixel cast with MuJoCo's ray caster at the table, the ground and the object (NaN: no hit)."""
    dirs = cam.pixel_directions().reshape(-1, 3) @ cam.pose[:3, :3].T
    n = len(dirs)
    geomid, dist = np.empty(n, np.int32), np.empty(n)
    groups = np.array([1, 1, 0, 0, 0, 0], np.uint8)
    mujoco.mj_multiRay(
        sim.model,
        sim.data,
        cam.position,
        np.ascontiguousarray(dirs).ravel(),
        groups,
        1,
        -1,
        geomid,
        dist,
        None,
        n,
        4.5,
    )
    return np.where(geomid >= 0, dist, np.nan).reshape(cam.intrinsics.height, cam.intrinsics.width)


def test_depth_image_matches_full_ray_casting_and_sees_the_object(hammer_sim):
    obs = hammer_sim.reset(3)
    cam = obs.camera
    assert obs.depth.shape == (424, 512) and obs.depth.dtype == np.float32
    # Every pixel agrees with MuJoCo's ray caster over the whole image (table, ground and object).
    np.testing.assert_allclose(obs.depth, full_ray_cast(hammer_sim, cam), atol=1e-5)
    # Deprojected, the image shows the table top at z = 0 and the tool up to 3 cm above it.
    pts = cam.deproject(obs.depth).reshape(-1, 3)
    on_table = (np.abs(pts[:, 0]) < 0.6) & (np.abs(pts[:, 1]) < 0.37)
    heights = pts[on_table, 2]
    assert np.median(heights) == pytest.approx(0.0, abs=1e-4)
    tool = pts[on_table & (pts[:, 2] > 0.01)]
    assert 300 < len(tool) < 20000 and tool[:, 2].max() == pytest.approx(0.03, abs=0.004)
    com = hammer_sim.data.xipos[hammer_sim.object_body]
    assert np.linalg.norm(tool[:, :2].mean(axis=0) - com[:2]) < 0.05


@pytest.mark.parametrize(
    "offset, tilt", [((0.0, 0.0, 0.02), 0.0), ((0.05, -0.3, -0.1), 0.6)], ids=["in-the-tool", "below-table"]
)
def test_depth_image_from_odd_camera_poses_matches_full_ray_casting(hammer_sim, offset, tilt):
    # A camera inside the tool's handle has mesh vertices behind it (the mesh rasteriser declines and
    # MuJoCo's rays take over); one below the table top cannot use the table's outline. Both still match.
    hammer_sim.reset(5)
    com = hammer_sim.data.xipos[hammer_sim.object_body]
    intr = CameraIntrinsics(width=64, height=48, fx=40.0, fy=40.0, cx=31.5, cy=23.5)
    down = Camera.looking_down(intr, (0, 0, 1)).pose[:3, :3]
    cam = Camera(intr, make_pose(rot_x(tilt) @ down, (com[0] + offset[0], com[1] + offset[1], offset[2])))
    depth = hammer_sim.render_depth(cam)
    want = full_ray_cast(hammer_sim, cam)
    assert np.isfinite(want).sum() > 100
    np.testing.assert_allclose(depth, want, atol=1e-5)


def test_camera_is_disturbed_per_scene_but_seeded(hammer_sim):
    a = hammer_sim.reset(1).camera
    b = hammer_sim.reset(2).camera
    c = hammer_sim.reset(1).camera
    assert not np.allclose(a.pose, b.pose)
    np.testing.assert_array_equal(a.pose, c.pose)
    assert a.intrinsics == c.intrinsics and a.intrinsics != b.intrinsics
    assert np.linalg.norm(a.position - np.array([-0.305, 0.0, 0.72])) < 0.13


def test_grasp_lifts_the_tool_and_a_grasp_in_the_air_fails(hammer_sim):
    hammer_sim.reset(0)
    res = hammer_sim.execute(far_end_grasp(hammer_sim), np.zeros(4), 0)
    assert res.valid and res.grasp_success and res.info["object_lift"] > 0.15
    pos, _ = hammer_sim.object_pose()
    # After the trial the scene is restored for the next one: a grasp 15 cm beside the tool lifts nothing.
    empty = hammer_sim.execute(Grasp(pos[0], pos[1] + 0.25, 0.02, 0.0), np.zeros(4), 0)
    assert empty.valid and not empty.grasp_success and empty.failure == FailureReason.GRASP_FAILED
    assert not empty.task_success


def _obj_vertices(path):
    rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
    return np.asarray(rows, dtype=np.float64)


@pytest.mark.parametrize("tool", ["t_hammer", "l_tool"])
def test_object_body_moves_its_centre_of_mass_and_object_pose_is_the_objects_own_frame(tools, tool):
    # The free joint's origin at the centre of mass: with it off the centre of mass, Euler steps lagged on
    # the centripetal coupling and a hammer's blow came out weaker than at 1 ms.
    rec = tools[tool]
    sim = Simulator(SimConfig(), "sweeping", rec)
    sim.reset(3)
    d, b = sim.data, sim.model.body("object").id
    np.testing.assert_allclose(d.xpos[b], d.xipos[b], atol=1e-12)
    pos, rot = sim.object_pose()
    np.testing.assert_allclose(pos + rot @ np.asarray(rec.com), d.xipos[b], atol=1e-12)
    # The visual mesh placed by object_pose() is where MuJoCo put it (its compiled mesh is recentred).
    ours = _obj_vertices(rec.path(rec.visual_mesh)) @ rot.T + pos
    g = sim.model.geom("object_visual").id
    mid = sim.model.geom_dataid[g]
    va, vn = sim.model.mesh_vertadr[mid], sim.model.mesh_vertnum[mid]
    theirs = sim.model.mesh_vert[va : va + vn] @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
    np.testing.assert_allclose(ours.min(axis=0), theirs.min(axis=0), atol=1e-5)
    np.testing.assert_allclose(ours.max(axis=0), theirs.max(axis=0), atol=1e-5)
    # The dropped object rests on the table, its lowest collision vertex on the top (z = 0).
    lowest = float(np.min(_obj_vertices(rec.collision_paths[0]) @ rot.T[:, 2] + pos[2]))
    assert -0.003 < lowest < 0.01


def test_same_inputs_same_labels_and_state_round_trip(hammer_sim):
    hammer_sim.reset(5)
    saved = hammer_sim.save_state()
    grasp = far_end_grasp(hammer_sim)
    action = hammer_action(hammer_sim, "far_end")
    first = hammer_sim.execute(grasp, action, 7)
    assert first.info["sim_time"] > 1.0  # the trial ran...
    np.testing.assert_array_equal(saved, hammer_sim.save_state())  # ...and the scene is back
    second = hammer_sim.execute(grasp, action, 7)
    assert (first.grasp_success, first.task_success, first.failure) == (
        second.grasp_success,
        second.task_success,
        second.failure,
    )
    assert first.info["peg_out"] == second.info["peg_out"]
    # save_state / restore_state round-trip through a changed world.
    hammer_sim.data.qpos[:3] += 0.1
    hammer_sim.restore_state(saved)
    np.testing.assert_array_equal(saved, hammer_sim.save_state())
    # A fresh simulator with the same scene seed gives the same labels too.
    other = Simulator(SimConfig(), "hammering", hammer_sim.obj)
    other.reset(5)
    third = other.execute(grasp, action, 7)
    assert third.info["peg_out"] == first.info["peg_out"]


@pytest.mark.parametrize("task", TASK_NAMES)
def test_every_task_is_seeded_and_round_trips_its_state(tools, task):
    """Same scene seed, grasp, action and trial seed: the same labels and outcome values, on the same
    simulator (which is back in its settled scene after a trial) and on a fresh one."""
    props = get_props(get_task(task))
    sim = Simulator(SimConfig(), task, tools[props.check_object])
    sim.reset(5)
    saved = sim.save_state()
    point, jaw = props.check_grasps[props.demo_grasp][:2]
    pos, rot = sim.object_pose()
    grasp = grasp_on_object(pos, rot, point, jaw)
    action = sim.props.check_action(props.demo_grasp)
    first = sim.execute(grasp, action, 7)
    assert first.info["sim_time"] > 1.0
    np.testing.assert_array_equal(saved, sim.save_state())
    second = sim.execute(grasp, action, 7)
    keys = ("grasp_success", "task_success", "failure")
    assert [getattr(first, k) for k in keys] == [getattr(second, k) for k in keys]
    values = {k: first.info.get(k) for k in props.outcome_keys}
    assert values == {k: second.info.get(k) for k in props.outcome_keys}
    sim.data.qpos[:3] += 0.1
    sim.restore_state(saved)
    np.testing.assert_array_equal(saved, sim.save_state())
    other = Simulator(SimConfig(), task, tools[props.check_object])
    other.reset(5)
    third = other.execute(grasp, action, 7)
    assert [getattr(third, k) for k in keys] == [getattr(first, k) for k in keys]
    assert values == {k: third.info.get(k) for k in props.outcome_keys}


def test_unstable_episode_is_invalid_never_a_success_or_failure(tools):
    cfg = SimConfig()
    cfg = cfg.replace(episode=cfg.episode.replace(max_speed=2.0))  # the swing turns faster than this
    sim = Simulator(cfg, "hammering", tools["t_hammer"])
    sim.reset(0)
    res = sim.execute(far_end_grasp(sim), hammer_action(sim, "far_end"), 0)
    assert not res.valid and res.failure == FailureReason.UNSTABLE
    assert not res.task_success and not res.grasp_success


def test_bad_inputs_raise_clear_errors(tools, hammer_sim):
    with pytest.raises(ValueError, match="unknown task"):
        Simulator(SimConfig(), "juggling", tools["t_hammer"])
    fresh = Simulator(SimConfig(), "sweeping", tools["l_tool"])
    with pytest.raises(Exception, match="reset"):
        fresh.execute(Grasp(0, 0, 0.02, 0), np.zeros(4), 0)
    hammer_sim.reset(0)
    with pytest.raises(ValueError, match="4 finite numbers"):
        hammer_sim.execute(Grasp(0, 0, 0.02, 0), np.zeros(3), 0)


def test_peg_friction_does_not_creep_below_its_threshold(hammer_sim):
    """MuJoCo's dry friction is a soft constraint; the peg's is stiff enough that a slow push fails."""
    m, d = hammer_sim.model, hammer_sim.data
    dof = m.jnt_dofadr[m.joint("peg").id]
    friction = hammer_sim.config.hammering.peg_friction
    moved = {}
    for fraction in (0.9, 1.2):
        hammer_sim.reset(0)
        start = d.qpos[hammer_sim.props._peg_qadr]
        d.qfrc_applied[dof] = fraction * friction
        mujoco.mj_step(m, d, 1000)  # 2 s
        moved[fraction] = d.qpos[hammer_sim.props._peg_qadr] - start
        d.qfrc_applied[dof] = 0.0
    assert abs(moved[0.9]) < 0.0005  # under half a millimetre in 2 s at 90 % of the friction
    assert moved[1.2] > 0.04  # above it the peg slides home
    hammer_sim.reset(0)


def _close_in_the_air(tools, timestep):
    """Finger position and speed every 10 ms while closing on nothing, and the config."""
    cfg = SimConfig()
    cfg = cfg.replace(physics=cfg.physics.replace(timestep=timestep))
    sim = Simulator(cfg, "grasping", tools["t_hammer"])
    sim.reset(0)
    sim._set_gripper(np.array([0.0, 0.3, 0.3]), 0.0, cfg.gripper.max_opening)  # in the air, open
    d = sim.data
    d.ctrl[4] = d.ctrl[5] = -0.02
    q, v = sim._qadr["finger_l"], sim._dadr["finger_l"]
    per = round(0.01 / timestep)
    pos, speeds = [], []
    for k in range(6 * per):
        mujoco.mj_step(sim.model, d)
        speeds.append(d.qvel[v])
        if (k + 1) % per == 0:
            pos.append(d.qpos[q])
    return np.asarray(pos), np.asarray(speeds), cfg


def test_fingers_close_smoothly_and_alike_at_any_time_step(tools):
    # A stiff servo's damping is stepped explicitly (always with Euler; with implicit whenever the force
    # limit is hit); a bare 30 g finger then chattered between +-60 N every step, so how a grasp closed
    # depended on dt.
    runs = {dt: _close_in_the_air(tools, dt) for dt in (0.002, 0.001)}
    for pos, speeds, cfg in runs.values():
        g = cfg.gripper
        assert np.all(speeds <= 1e-9), "the finger never moves back while closing"
        assert np.all(np.abs(np.diff(np.sign(speeds[speeds < -1e-3]))) == 0)
        # About 0.5 m/s: the servo's kp (q - ctrl) / kv, from 0.6 m/s fully open, 0.4 at 2 cm.
        assert 0.35 < np.abs(speeds).max() <= g.finger_kp * (0.5 * g.max_opening + 0.02) / g.finger_kv + 0.01
        assert pos[-1] < 0.5 * g.max_opening - 0.02  # it got somewhere
    (p2, _, _), (p1, _, _) = runs[0.002], runs[0.001]
    np.testing.assert_allclose(p2, p1, atol=0.001)  # the same closing at either time step


def test_a_hard_blow_stops_the_peg_at_the_slot_floor(hammer_sim):
    """The peg's travel ends at the slot's floor (1 mm past flush), not a few millimetres beyond it."""
    outs = []
    for seed in range(3):
        hammer_sim.reset(seed)
        res = hammer_sim.execute(far_end_grasp(hammer_sim), hammer_action(hammer_sim, "far_end"), seed)
        assert res.task_success
        outs.append(res.info["peg_out"])
    assert min(outs) > -0.0018, outs
