"""The scripted checks (fewer seeds than benchmarks/scripted_checks.py): the grasp must matter."""

import pytest

from tognet.sim import SimConfig
from tognet.sim.scripted_checks import run_check
from tognet.tasks.hammering_props import hammer_handle_grasp

SEEDS = range(100, 108)


@pytest.mark.slow
def test_hammer_far_end_drives_the_peg_home_and_head_grasp_fails():
    far = run_check("hammering", "far_end", SEEDS)
    head = run_check("hammering", "head", SEEDS)
    assert far.invalid == 0 and far.task_successes >= 7, far.line()
    assert head.task_successes <= 2, head.line()


@pytest.mark.slow
def test_hammering_needs_momentum_not_a_slow_push():
    cfg = SimConfig()
    slow = cfg.replace(gripper=cfg.gripper.replace(yaw_speed=1.5))
    result = run_check("hammering", "far_end", range(100, 104), slow)
    assert result.grasp_successes >= 3 and result.task_successes == 0, result.line()
    # Momentum only: the head grasp with the yaw it would need (outside the action box) still falls short.
    head = run_check("hammering", "head", range(100, 104), clip=False)
    assert head.task_successes == 0, head.line()
    assert all(d["peg_out"] > 0.005 for d in head.details if "peg_out" in d)
    # Less lever, less momentum: the same grasp 13 cm along the handle falls short every time.
    middle = run_check("hammering", hammer_handle_grasp(0.13), range(100, 104))
    assert middle.task_successes == 0 and middle.grasp_successes >= 3, middle.line()


@pytest.mark.slow
def test_sweeping_needs_the_long_edge_across_the_path():
    short_end = run_check("sweeping", "short_end", SEEDS)
    middle = run_check("sweeping", "long_middle", SEEDS)
    assert short_end.invalid == 0 and short_end.task_successes >= 7, short_end.line()
    assert middle.task_successes <= 3, middle.line()
