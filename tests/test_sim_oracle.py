"""The in-hand pose a trial reports and the oracle actions built from it (both jaw orientations)."""

import numpy as np

from tognet.geometry import Grasp
from tognet.objects.handmade import grasp_on_object
from tognet.sim import SimConfig, Simulator
from tognet.sim.oracle import tool_in_gripper
from tognet.tasks.hammering_props import HAMMER_GRASPS, hammer_actions
from tognet.tasks.sweeping_props import SWEEP_GRASPS, sweep_actions


def test_in_hand_pose_puts_the_grasp_point_at_the_gripper_centre(tools):
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    sim.reset(5)
    pos, rot = sim.object_pose()
    point, jaw = HAMMER_GRASPS["far_end"][:2]
    grasp = grasp_on_object(pos, rot, point, jaw)
    res = sim.execute(grasp, np.zeros(4), 1)
    assert res.grasp_success
    pose = np.asarray(res.info["in_hand"])
    assert pose.shape == (3, 4)
    # The grasped point (object frame) sits between the fingers: near the gripper-frame origin.
    at = pose[:, :3] @ np.asarray(point) + pose[:, 3]
    assert np.linalg.norm(at) < 0.012, at
    # The handle runs across the jaws (gripper y), the head at its far end ~0.3 m away.
    pts = tool_in_gripper(sim, grasp, res.info["in_hand"])
    far = pts[np.argmax(np.hypot(pts[:, 0], pts[:, 1]))]
    assert abs(far[1]) > 0.25 and abs(far[0]) < 0.07, far
    # Flipping the jaw (phi + pi) puts the tool on the other side of the hand.
    flipped = Grasp.from_array([*grasp.position, (grasp.phi + np.pi) % (2 * np.pi)])
    pts_flip = tool_in_gripper(sim, flipped)
    far_flip = pts_flip[np.argmax(np.hypot(pts_flip[:, 0], pts_flip[:, 1]))]
    assert np.sign(far_flip[1]) == -np.sign(far[1])


def test_only_the_jaw_orientation_with_the_head_leading_can_hammer(tools):
    """The start yaw is absolute: phi + pi holds the hammer the other way round, and no action in the box
    (a_phi within +-pi/4) turns its head back to strike; the oracle then misses every time."""
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    sim.reset(11)
    pos, rot = sim.object_pose()
    g = grasp_on_object(pos, rot, *HAMMER_GRASPS["far_end"][:2])
    outcomes = {}
    for flip in (0.0, np.pi):
        grasp = Grasp.from_array([*g.position, (g.phi + flip) % (2 * np.pi)])
        probe = sim.execute(grasp, np.zeros(4), 0)
        assert probe.grasp_success
        actions = hammer_actions(sim, grasp, in_hand=probe.info["in_hand"])
        outcomes[flip] = [sim.execute(grasp, a, i + 1) for i, a in enumerate(actions)]
    assert any(r.task_success for r in outcomes[0.0]), [r.failure.value for r in outcomes[0.0]]
    assert not any(r.task_success for r in outcomes[np.pi]), [r.failure.value for r in outcomes[np.pi]]


def test_oracle_sweeps_with_the_short_end_grasp(tools):
    cfg = SimConfig()
    cfg = cfg.replace(sweeping=cfg.sweeping.replace(n_cans=(2,)))
    sim = Simulator(cfg, "sweeping", tools["l_tool"])
    sim.reset(4)
    pos, rot = sim.object_pose()
    grasp = grasp_on_object(pos, rot, *SWEEP_GRASPS["short_end"])
    actions = sweep_actions(sim, grasp, yaws=(0.0,))
    assert len(actions) == 1 and np.all(actions[0] >= sim.task.action_low - 1e-12)
    assert sim.execute(grasp, actions[0], 0).task_success
