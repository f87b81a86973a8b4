"""Pulling: the grasp matters (scripted checks at a few seeds), its config round-trips, its rule."""

import numpy as np
import pytest

from tognet.sim import SimConfig
from tognet.sim.scripted_checks import run_check
from tognet.tasks import FailureReason, TaskOutcome, get_task
from tognet.tasks.pulling import Pulling, PullingConfig
from tognet.tasks.pulling_props import PULL_GRASPS

SEEDS = range(4)


def test_the_l_tool_held_at_its_long_end_pulls_and_held_near_its_hook_cannot():
    far = run_check("pulling", "far_end", SEEDS)
    near = run_check("pulling", "near_hook", SEEDS)
    assert far.invalid == 0 and far.task_successes == far.trials, far.details
    assert near.task_successes == 0, near.details
    assert near.grasp_successes == near.trials  # the grasp holds: the task, not the grasp, fails
    for d in far.details:
        x, _ = d["can_xy"]
        assert x <= SimConfig().pulling.target_x[1]


def test_pulled_cans_end_upright_near_their_starting_line():
    result = run_check("pulling", "far_end", range(20, 22))
    for d in result.details:
        assert d["can_tilt"] < 0.1


def test_config_round_trips_and_sits_in_the_sim_config(tmp_path):
    cfg = PullingConfig(pull=0.25, can_x=(0.35, 0.45))
    assert PullingConfig.from_dict(cfg.to_dict()) == cfg
    sim = SimConfig().replace(pulling=cfg)
    path = sim.save(tmp_path / "sim.json")
    again = SimConfig.load(path)
    assert again.task_config("pulling") == cfg
    assert isinstance(get_task("pulling", again.task_config("pulling")), Pulling)


def test_layout_is_seeded_and_out_of_reach():
    task = get_task("pulling")
    c = task.config
    a = task.sample_layout(np.random.default_rng(3))
    assert a == task.sample_layout(np.random.default_rng(3))
    for seed in range(50):
        layout = task.sample_layout(np.random.default_rng(seed))
        ref = task.reference(layout)
        start, _ = task.start_pose(ref, task.action_high)
        # Even at the box's far corner the gripper's centre stays 2 cm or more short of the can.
        assert start[0] < ref[0] - c.can_radius - 0.02
        assert c.target_x[1] < c.can_x[0] - c.can_radius  # the target region is nearer than any start


@pytest.mark.parametrize(
    ("values", "touched", "moving", "expected"),
    [
        ({"can_in_target": True}, True, False, (True, FailureReason.NONE)),
        ({"can_in_target": False}, False, False, (False, FailureReason.MISSED)),
        ({"can_in_target": False}, True, True, (False, FailureReason.TIMEOUT)),
        ({"can_in_target": False}, True, False, (False, FailureReason.TASK_FAILED)),
    ],
)
def test_success_rule(values, touched, moving, expected):
    outcome = TaskOutcome(touched_targets=touched, still_moving=moving, values=values)
    assert get_task("pulling").evaluate(outcome) == expected


def test_the_check_grasps_differ_only_in_where_they_hold():
    far, near = PULL_GRASPS["far_end"], PULL_GRASPS["near_hook"]
    assert far[1:] == near[1:] and far[0][0] > near[0][0]


def test_the_oracle_finds_a_pull_for_the_far_end_grasp_only(tools):
    from tognet.objects.handmade import grasp_on_object
    from tognet.sim import Simulator
    from tognet.tasks.pulling_props import pull_actions

    sim = Simulator(SimConfig(), "pulling", tools["l_tool"])
    for seed in (0, 1):
        sim.reset(seed)
        pos, rot = sim.object_pose()
        found = {}
        for name in ("far_end", "near_hook"):
            grasp = grasp_on_object(pos, rot, *PULL_GRASPS[name][:2])
            actions = pull_actions(sim, grasp)
            low, high = sim.task.action_low, sim.task.action_high
            assert all(np.all(a >= low) and np.all(a <= high) for a in actions)
            found[name] = [sim.execute(grasp, a, seed).task_success for a in actions[:3]]
        # The best-ranked pull works from the far end; held near the hook no pull is found at all.
        assert found["far_end"][0] and not any(found["near_hook"]), found


def test_the_oracle_ranks_pulls_by_the_face_that_meets_the_can():
    from tognet.tasks.pulling_props import _pull_positions

    r = 0.033
    bar = np.array([[0.0, -0.01], [0.3, -0.01], [0.3, 0.01], [0.0, 0.01]])  # along x, 2 cm wide
    hook = np.array([[0.28, 0.01], [0.3, 0.01], [0.3, 0.11], [0.28, 0.11]])  # across it at the far end
    cans = np.array([[x, y] for x in np.arange(0.05, 0.27, 0.01) for y in np.arange(-0.15, 0.16, 0.01)])
    # A straight bar along the pull has no face toward the can: nothing.
    assert _pull_positions([bar], cans, r) == []
    found = _pull_positions([bar, hook], cans, r)
    assert found
    for _, off, (x, y) in found:
        # Beside the bar on the hook's side, just short of the hook, meeting it near the can's centre line.
        assert 0.01 + r < y < 0.11 + 0.5 * r and 0.28 - r - 0.061 <= x < 0.28 - r and off <= 0.5 * r
    # The best meet the hook's face across most of the can's width, well inside the hook's end.
    score, _, (_, y) = max(found, key=lambda f: f[0])
    assert score >= 0.8 and y < 0.11 - 0.5 * r
