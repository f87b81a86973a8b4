"""Planning with an arm (issue 25): the planners drop the grasps an arm beside the table cannot reach and take
the next one where their choice is out of its reach, the floating gripper's plans are untouched, and
``tognet plan --robot`` returns a joint trajectory the arm's kinematics follow to the plan's poses. Skipped
where the robot extra (robosuite's models, mink) is not installed."""

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tognet.grasping.antipodal import GraspCandidates

HAVE_EXTRA = all(importlib.util.find_spec(name) is not None for name in ("robosuite", "mink"))
pytestmark = pytest.mark.skipif(not HAVE_EXTRA, reason="the robot extra (robosuite, mink) is not installed")

MODELS = Path(__file__).resolve().parent.parent / "tognet" / "models"
#: A Panda beside the manipulation half, facing +y: the simulator's hammering scene 3 (the T hammer) lies at
#: the edge of its reach, and TOG-Net's choice for it on the floating gripper just past it.
EDGE_BASE = (0.35, -0.6, 0.0)


#: The near side of the table (y < 0), facing +y: where the tests put the arms (their defaults stand at the
#: far side, facing -y).
NEAR = {"sawyer": (0.0, -0.6, 0.0), "panda": (0.0, -0.5, 0.0)}


def _sim_config(name, base=None, yaw=None):
    from tognet.sim.config import SimConfig, with_robot

    config = with_robot(SimConfig(), name)
    if base is None:
        return config
    return config.replace(robot=config.robot.replace(base_position=base, base_yaw=yaw))


def _reach(name, base=None, yaw=None, task=None):
    from tognet.planning.reach import ArmReach

    return ArmReach(_sim_config(name, base, yaw), task)


def _candidates(grasps):
    g = np.asarray(grasps, dtype=np.float64)
    n = len(g)
    return GraspCandidates(g, np.full(n, 0.7), np.zeros((n, 2)), np.full(n, 0.03), np.ones(n),
                           np.zeros((n, 2, 3)))


@pytest.fixture(scope="module")
def hammering(tools):
    from tognet.model.predict import TOGNetPredictor
    from tognet.sim import SimConfig, Simulator

    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    return sim, sim.reset(3), TOGNetPredictor.load(MODELS / "hammering.pt", num_threads=1)


def _fk(reach, q):
    """The TCP's position and yaw for joint angles ``q`` of ``reach``'s arm (MuJoCo's kinematics)."""
    import mujoco

    arm = reach.arm
    data = mujoco.MjData(arm.model)
    data.qpos[:] = arm.home
    data.qpos[arm.qpos_adr] = q
    mujoco.mj_kinematics(arm.model, data)
    rot = data.site_xmat[arm.tcp_site].reshape(3, 3)
    return data.site_xpos[arm.tcp_site].copy(), math.atan2(rot[1, 0], rot[0, 0]), rot[:, 2].copy()


def _angle(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


# --- the filter ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("name", "slack"), [("panda", 0.03), ("sawyer", 0.2)])
def test_the_envelope_holds_what_the_arm_reaches_and_drops_what_it_does_not(name, slack):
    """Along the arm's front at the table's height: grasps 1 cm and 10 cm beyond the envelope's edge are out
    of reach for inverse kinematics (the envelope drops only the unreachable), and one ``slack`` inside it is
    reached (it is that close to the arm's reach: the Panda's within 3 cm, the Sawyer's, whose links are
    offset from one another, within 20 cm)."""
    reach = _reach(name, NEAR[name], math.pi / 2)
    env = reach.envelope
    x0, y0, _ = reach.base_position
    for phi in (0.0, math.pi / 2):
        def at(excess, phi=phi):  # the distance along +y whose approach is `excess` beyond the envelope
            lo, hi = 0.0, 2.0
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                _, poses = reach.grasp_step_poses([(x0, y0 + mid, 0.02, phi)])
                lo, hi = (mid, hi) if env.excess(poses[0]).max() < excess else (lo, mid)
            return np.array([x0, y0 + lo, 0.02, phi])

        inside, beyond, far = at(-slack), at(0.01), at(0.10)
        assert not reach.beyond(inside)[0][0] and reach.beyond(beyond)[0][0]
        assert reach.own_steps(inside).stuck is None, (name, phi, inside)
        for g in (beyond, far):
            stuck = reach.own_steps(g).stuck
            assert stuck is not None and stuck.reason == "unreachable", (name, phi, g, stuck)


def test_candidates_beyond_the_arm_are_dropped_before_scoring_and_the_rest_kept():
    from tognet.planning.reach import OutOfReach

    reach = _reach("sawyer", NEAR["sawyer"], math.pi / 2)
    near = [(-0.3, 0.0, 0.02, 0.0), (0.1, -0.2, 0.05, 2.0), (0.2, 0.1, 0.02, 4.0)]
    far = [(0.0, 1.2, 0.02, 0.0), (-1.4, -0.6, 0.02, 1.0)]
    cands = _candidates(near + far)
    kept, dropped = reach.filter(cands)
    np.testing.assert_array_equal(kept.grasps, np.array(near))
    assert dropped.candidates == 5 and dropped.count == 2 and set(dropped.by_step) <= {"the approach",
                                                                                     "the grasp", "the lift"}
    same, none = reach.filter(_candidates(near))
    assert same.grasps is not None and len(same) == 3 and none.count == 0
    with pytest.raises(OutOfReach, match=r"no grasp within the sawyer's reach \(base at \(0.00, -0.60, "
                                         r"0.00\) m, yaw 1.57 rad\): the \w+ is out of reach for 2 of 2 "):
        reach.filter(_candidates(far))


def test_a_choice_out_of_reach_is_passed_over_for_the_next_and_the_plan_says_why():
    from tognet.planning.reach import Dropped, Option, OutOfReach

    reach = _reach("panda", NEAR["panda"], math.pi / 2)
    close = np.array([0.05, -0.3, 0.1, math.pi / 2])  # 20 cm from the base: its lift folds joint 4 too far
    twin = close + np.array([0.005, 0.0, 0.0, 0.05])  # as close: passed over without a check of its own
    good = np.array([-0.3, 0.0, 0.02, 0.3])
    asked = []

    def option(g):
        return Option(g, lambda g=g: (asked.append(g) or np.zeros(4), float(g[0])))

    got = reach.choose([option(close), option(twin), option(good)], None, Dropped(3))[0]
    np.testing.assert_array_equal(got.grasp, good)
    assert got.rank == 2 and got.skipped == 1 and got.checked == 2 and not got.with_task
    assert [(p.what, p.reason) for p in got.passed] == [("the lift", "joint_limit")]
    assert len(asked) == 1  # an action is asked only for a grasp the arm reaches
    assert "the lift is past a joint's limit" in got.summary()
    info = got.info()
    assert info["rank"] == 2 and info["passed_over"][0]["reason"] == "joint_limit"
    with pytest.raises(OutOfReach, match="of the planner's 1 best grasps checked against the arm's "
                                         "kinematics, the lift is past a joint's limit for 1"):
        reach.choose([option(close), option(twin)], None, Dropped(2))


# --- the planners ----------------------------------------------------------------------------------------
def test_every_planner_plans_within_the_arm_and_takes_the_next_grasp_when_its_own_is_beyond(hammering):
    from tognet.planning import make_planner
    from tognet.planning.config import OracleConfig, PlanConfig
    from tognet.sim.arm import plan_reach

    sim, obs, model = hammering
    reach = _reach("panda", EDGE_BASE, math.pi / 2, sim.task)
    floating = make_planner("TOG-Net", sim.task, task_model=model)(obs, np.random.default_rng(0))
    assert reach.own_steps(floating.grasp).stuck is not None  # TOG-Net's own choice is past the arm
    config = PlanConfig(oracle=OracleConfig(grasps=2, seeds=1, max_trials=6))
    for method in ("TOG-Net", "Antipodal+Random", "Oracle"):
        planner = make_planner(method, sim.task, task_model=model, sim=sim, reach=reach, config=config)
        plan = planner(obs, np.random.default_rng(0))
        info = plan.info["reach"]
        assert 0 < info["dropped"] < info["candidates"] == 200, (method, info)
        if method == "Oracle":  # only grasps within the arm's reach are tried in the simulator
            assert info["reached"] >= 1 and reach.own_steps(plan.grasp).stuck is None
            continue
        trial = plan_reach(reach.sim_config, sim.task, reach.solver, plan.grasp[:3], plan.grasp[3],
                           obs.reference, plan.action)  # checked again, apart from the planner
        assert trial.stuck is None, (method, trial.stuck)
        assert plan.info["candidates"] == 200 - info["dropped"]
    assert not np.allclose(plan.grasp, floating.grasp)


def test_the_simulators_arm_is_every_methods_filter_and_the_floating_gripper_plans_as_before(hammering,
                                                                                            tools):
    from tognet.planning import make_planner
    from tognet.sim import Simulator

    sim, obs, model = hammering
    rng = np.random.default_rng
    for method in ("TOG-Net", "Antipodal+Random", "Task_Ori+Random"):
        with_sim = make_planner(method, sim.task, task_model=model, sim=sim)
        assert with_sim.reach is None  # the floating gripper: no filter
        a, b = with_sim(obs, rng(1)), make_planner(method, sim.task, task_model=model)(obs, rng(1))
        assert "reach" not in a.info and a.scores == b.scores
        assert np.array_equal(a.grasp, b.grasp) and np.array_equal(a.action, b.action)
    # An arm that reaches the whole scene (the Sawyer at its default base) plans what the floating gripper
    # does, and says it checked.
    arm_sim = Simulator(_sim_config("sawyer"), "hammering", tools["t_hammer"])
    arm_obs = arm_sim.reset(3)
    planners = {m: make_planner(m, arm_sim.task, task_model=model, sim=arm_sim) for m in ("TOG-Net",
                                                                                          "Antipodal+Random")}
    assert planners["TOG-Net"].reach is planners["Antipodal+Random"].reach is not None  # one filter, shared
    for method, planner in planners.items():
        plan = planner(arm_obs, rng(1))
        floating = make_planner(method, sim.task, task_model=model)(obs, rng(1))
        np.testing.assert_array_equal(plan.grasp, floating.grasp)
        np.testing.assert_array_equal(plan.action, floating.action)
        assert plan.info["reach"]["rank"] == 0 and plan.info["reach"]["dropped"] == 0


# --- tognet plan --robot ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def image(tmp_path_factory):
    from tognet.geometry import Camera, CameraIntrinsics
    from tognet.grasping.synthetic import render_depth, t_shape
    from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics

    root = tmp_path_factory.mktemp("arm-plan")
    camera = Camera.looking_down(CameraIntrinsics.kinect2(), [0.06, -0.04, 0.7])
    depth = render_depth(camera, t_shape(-0.05, 0.02, yaw=0.4))
    (root / "base.json").write_text(json.dumps({"position": [0.05, -0.65, 0.0], "yaw": 1.5}))
    return {"depth": save_depth_png(root / "d.png", depth),
            "intrinsics": save_intrinsics(root / "d.intrinsics.json", camera.intrinsics),
            "pose": save_camera_pose(root / "d.pose.json", camera.pose), "root": root}


def _plan_cli(image, *extra):
    from typer.testing import CliRunner

    from tognet.cli import app

    args = ["plan", "--depth", image["depth"], "--intrinsics", image["intrinsics"], "--camera-pose",
            image["pose"], "--task", "hammering", *extra]
    return CliRunner().invoke(app, [str(a) for a in args])


def test_tognet_plan_with_a_robot_returns_the_joint_trajectory_to_the_plans_poses(image):
    from tognet.tasks import get_task

    out = image["root"] / "plan.json"
    reference = (0.3, 0.05, 0.045)
    run = _plan_cli(image, "--robot", "sawyer", "--base-pose", image["root"] / "base.json", "--reference",
                    *reference, "--out", out)
    assert run.exit_code == 0, run.output
    line = "arm: sawyer, base at (+0.050, -0.650, +0.000) m, yaw +1.500 rad (world frame): 6 joint waypoints"
    assert line in run.output
    plan = json.loads(out.read_text())
    robot = plan["robot"]
    assert robot["frame"] == "world" and robot["with_task"] and len(robot["joint_names"]) == 7
    steps = robot["trajectory"]
    assert [s["step"] for s in steps] == ["the approach", "the grasp", "the lift", "the transport",
                                          "the start pose", "the motion"]
    reach = _reach("sawyer", (0.05, -0.65, 0.0), 1.5)
    # The grasp's waypoint: the plan's world grasp, where the joints put the TCP.
    g = plan["grasp"]["world"]
    grasp = np.array([g["x"], g["y"], g["z"], g["phi"]])
    tcp, yaw, down = _fk(reach, steps[1]["q"])
    assert np.linalg.norm(tcp - grasp[:3]) < 0.002 and _angle(yaw, grasp[3]) < 0.01 and down[2] < -0.999
    # The last waypoint: the start pose the plan gives, moved by the task's motion.
    start = np.array(plan["grasp"]["start_pose"]["position"])
    np.testing.assert_allclose(start, np.add(reference, plan["grasp"]["start_pose"]["offset_from_reference"]),
                               atol=1e-3)
    end, end_yaw = start.copy(), plan["grasp"]["start_pose"]["yaw"]
    for motion in get_task("hammering").primitive():
        end, end_yaw = end + np.asarray(motion.delta), end_yaw + motion.dyaw
    tcp, yaw, _ = _fk(reach, steps[-1]["q"])
    assert np.linalg.norm(tcp - end) < 0.002, (tcp, end)
    assert _angle(yaw, end_yaw) < 0.01
    # The times: from the first waypoint, each segment no faster than the slowest joint's speed limit allows.
    times = np.array([s["time_s"] for s in steps])
    q = np.array([s["q"] for s in steps])
    assert times[0] == 0 and np.all(np.diff(times) >= 0)
    need = np.max(np.abs(np.diff(q, axis=0)) / reach.arm.joint_speed_limits, axis=1)
    np.testing.assert_allclose(np.diff(times), need, atol=2e-4)
    assert robot["duration_s"] == pytest.approx(times[-1], abs=1e-3)


def test_tognet_plan_without_a_reference_checks_the_grasp_and_says_so(image):
    out = image["root"] / "grasp-only.json"
    run = _plan_cli(image, "--robot", "panda", "--out", out)
    assert run.exit_code == 0, run.output
    robot = json.loads(out.read_text())["robot"]
    assert [s["step"] for s in robot["trajectory"]] == ["the approach", "the grasp", "the lift"]
    assert not robot["with_task"] and robot["base"]["position"] == [-0.2, 0.45, 0.0]  # the Panda's own
    assert "without a reference point (--reference)" in run.output


@pytest.mark.parametrize("method", ["TOG-Net", "Task_Agn+Trained", "Task_Ori+Random", "Task_Agn+Random",
                                    "Antipodal+Random", "TOG-Net+ActionSearch"])
def test_tognet_plan_with_a_robot_works_with_every_method(image, method):
    """Every method a robot can run plans for the arm: the joints of the grasp's waypoint put the TCP on the
    plan's world grasp, and the whole trial was checked (the task's steps with the reference point)."""
    out = image["root"] / f"plan-{method}.json"
    run = _plan_cli(image, "--robot", "sawyer", "--reference", 0.3, 0.05, 0.045, "--method", method, "--out",
                    out)  # the Sawyer's own base, across the table
    assert run.exit_code == 0, run.output
    plan = json.loads(out.read_text())
    assert plan["method"] == method and plan["robot"]["with_task"]
    steps = plan["robot"]["trajectory"]
    g = plan["grasp"]["world"]
    tcp, yaw, _ = _fk(_reach("sawyer", (-0.2, 0.6, 0.0), -math.pi / 2), steps[1]["q"])
    assert np.linalg.norm(tcp - np.array([g["x"], g["y"], g["z"]])) < 0.002 and _angle(yaw, g["phi"]) < 0.01
