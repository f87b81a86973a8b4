"""Task registry, action spaces and success rules (no simulator)."""

import numpy as np
import pytest

from tognet.tasks import TASK_NAMES, FailureReason, TaskOutcome, get_task


def test_registry_names_and_unknown_task():
    assert set(TASK_NAMES) == {"sweeping", "hammering", "pulling"}
    for name in TASK_NAMES:
        assert get_task(name).name == name
    with pytest.raises(ValueError, match="unknown task 'sawing'"):
        get_task("sawing")


@pytest.mark.parametrize("name", TASK_NAMES)
def test_random_action_is_within_5cm_and_pi_over_20_of_nominal(name):
    task = get_task(name)
    rng = np.random.default_rng(0)
    actions = np.array([task.random_action(rng) for _ in range(500)])
    dev = np.abs(actions - task.nominal_action)
    assert dev[:, :3].max() <= 0.05 and dev[:, 3].max() <= np.pi / 20
    assert dev[:, :3].max() > 0.04 and dev[:, 3].max() > 0.9 * np.pi / 20  # it does spread out
    # The learned policy's box contains the baseline's box and is wider than it.
    assert np.all(task.action_low <= actions.min(axis=0)) and np.all(actions.max(axis=0) <= task.action_high)
    assert np.all(task.action_high[:2] - task.action_low[:2] >= 0.2)


@pytest.mark.parametrize("name", TASK_NAMES)
def test_check_action_rejects_bad_shapes(name):
    task = get_task(name)
    with pytest.raises(ValueError, match="4 finite numbers"):
        task.check_action([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="4 finite numbers"):
        task.check_action([0.0, 0.0, np.nan, 0.0])


def test_start_pose_adds_nominal_offset_and_yaw():
    task = get_task("hammering")
    ref = np.array([0.3, -0.1, 0.045])
    pos, yaw = task.start_pose(ref, [0.01, 0.02, 0.03, 0.1])
    np.testing.assert_allclose(pos, ref + np.asarray(task.config.nominal_offset) + [0.01, 0.02, 0.03])
    assert yaw == pytest.approx(task.config.nominal_yaw + 0.1)


def test_layouts_are_seeded_and_in_the_manipulation_half():
    sweep = get_task("sweeping")
    a = sweep.sample_layout(np.random.default_rng(3))
    assert a == sweep.sample_layout(np.random.default_rng(3))
    for seed in range(50):
        layout = sweep.sample_layout(np.random.default_rng(seed))
        assert 1 <= len(layout["cans"]) <= 2
        for x, y, mass in layout["cans"]:
            assert x > 0.0 and 0.0 < y < 0.38 and 0.0 < mass < 1.0
    ham = get_task("hammering")
    for seed in range(20):
        x, y = ham.sample_layout(np.random.default_rng(seed))["slot"]
        assert x > 0.0


def test_success_rules():
    sweep = get_task("sweeping")
    both, one = {"cans_on_ground": [True, True]}, {"cans_on_ground": [True, False]}
    assert sweep.evaluate(TaskOutcome(True, False, both)) == (True, FailureReason.NONE)
    assert sweep.evaluate(TaskOutcome(True, False, one))[1] == FailureReason.TASK_FAILED
    assert sweep.evaluate(TaskOutcome(False, False, {"cans_on_ground": [False]}))[1] == FailureReason.MISSED
    assert sweep.evaluate(TaskOutcome(True, True, {"cans_on_ground": [False]}))[1] == FailureReason.TIMEOUT
    ham = get_task("hammering")
    assert ham.evaluate(TaskOutcome(True, False, {"peg_out": 0.001}))[0]
    assert ham.evaluate(TaskOutcome(True, False, {"peg_out": 0.02}))[1] == FailureReason.TASK_FAILED
    assert ham.evaluate(TaskOutcome(False, False, {"peg_out": 0.05}))[1] == FailureReason.MISSED


def test_one_check_raises_unknown_task():
    from tognet.tasks import SIM_TASKS, check_task_name

    assert check_task_name("pulling") == "pulling" and check_task_name("grasping", SIM_TASKS) == "grasping"
    with pytest.raises(ValueError, match="unknown task 'grasping'; known: sweeping, hammering, pulling$"):
        check_task_name("grasping")
    with pytest.raises(ValueError, match="unknown --task 'x'; known: .*grasping"):
        check_task_name("x", SIM_TASKS, "--task")
    with pytest.raises(KeyError, match="unknown task 'x'"):
        check_task_name("x", error=KeyError)
