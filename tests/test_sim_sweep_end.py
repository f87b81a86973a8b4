"""The sweep's wait ends early: a can wholly below the table top counts as down, cans at rest end it."""

import numpy as np

from tognet.objects.handmade import grasp_on_object, make_l_tool
from tognet.sim import FailureReason, SimConfig, Simulator
from tognet.tasks.sweeping_props import SWEEP_GRASPS, sweep_action


def _run(tmp_path, grasp_name, settle_time, seed=3, fallen_margin=0.01):
    cfg = SimConfig()
    sw = cfg.sweeping.replace(n_cans=(2,), settle_time=settle_time, fallen_margin=fallen_margin)
    cfg = cfg.replace(sweeping=sw)
    sim = Simulator(cfg, "sweeping", make_l_tool(tmp_path))
    sim.reset(seed)
    pos, rot = sim.object_pose()
    grasp = grasp_on_object(pos, rot, *SWEEP_GRASPS[grasp_name])
    return sim.execute(grasp, sweep_action(sim, grasp_name), 0)


def test_sweep_success_does_not_wait_for_the_fall_nor_a_failure_for_the_time_limit(tmp_path):
    ok = _run(tmp_path / "a", "short_end", 1.0)
    assert ok.task_success and ok.info["cans_on_ground"] == [True, True]
    # A can falling from the table edge takes ~0.39 s to reach the ground: waiting for the ground
    # contact (a margin no can reaches) takes that much longer, with the same labels.
    ground = _run(tmp_path / "b", "short_end", 1.0, fallen_margin=10.0)
    assert ground.task_success and ground.info["cans_on_ground"] == [True, True]
    assert ground.info["sim_time"] - ok.info["sim_time"] > 0.2
    bad = _run(tmp_path / "c", "long_middle", 3.0, seed=0)
    bad_short = _run(tmp_path / "d", "long_middle", 1.0, seed=0)
    assert not bad.task_success and bad.failure.value in ("task_failed", "missed")
    # Cans left standing come to rest: the wait ends long before the 3 s limit, same labels as with 1 s.
    assert np.isclose(bad.info["sim_time"], bad_short.info["sim_time"])
    assert bad.info["cans_on_ground"] == bad_short.info["cans_on_ground"]


def test_parked_cans_touch_nothing_and_every_trial_gets_its_cans_back(tmp_path):
    cfg = SimConfig()
    cfg = cfg.replace(sweeping=cfg.sweeping.replace(n_cans=(1,)))
    sim = Simulator(cfg, "sweeping", make_l_tool(tmp_path))
    sim.reset(3)
    spare = sim.model.geom("can_1").id
    in_play = sim.model.geom("can_0").id
    geoms = sim.data.contact.geom[: sim.data.ncon]
    assert not np.any(geoms == spare)  # the unused can floats, parked, without ground contacts
    assert np.any(geoms == in_play)  # the can in play stands on the table
    assert sim.model.geom_contype[spare] == 0 and sim.model.geom_contype[in_play] == 1
    pos, rot = sim.object_pose()
    grasp = grasp_on_object(pos, rot, *SWEEP_GRASPS["short_end"])
    first = sim.execute(grasp, sweep_action(sim, "short_end"), 0)
    assert first.task_success and first.info["cans_on_ground"] == [True]
    # The can swept off was parked during the trial; the scene (and the next trial) has it back.
    assert sim.model.geom_contype[in_play] == 1
    again = sim.execute(grasp, sweep_action(sim, "short_end"), 0)
    assert again.task_success and again.info["sim_time"] == first.info["sim_time"]


def _hold_run(tmp_path, margin, action_shift=(0.0, 0.0, 0.0, 0.0), lite=True, lite_steps=None):
    cfg = SimConfig()
    cfg = cfg.replace(sweeping=cfg.sweeping.replace(n_cans=(2,), can_hold_margin=margin))
    sim = Simulator(cfg, "sweeping", make_l_tool(tmp_path))
    assert sim._lite is not None
    if not lite:
        sim._lite = None  # the fallback: cans kept in the full model, contact-free and floating
    sim.reset(5)
    held_steps = [0]
    step = sim._step

    def counting_step(n):
        step(n)
        held_steps[0] += n if sim.props.held else 0
        if lite_steps is not None:
            lite_steps[0] += n if sim.model is not sim._full[0] else 0

    sim._step = counting_step
    pos, rot = sim.object_pose()
    grasp = grasp_on_object(pos, rot, *SWEEP_GRASPS["short_end"])
    action = sweep_action(sim, "short_end") + np.asarray(action_shift)
    return sim.execute(grasp, action, 0), held_steps[0]


def test_cans_on_hold_while_the_tool_is_far_and_back_before_it_arrives(tmp_path):
    held, n_held = _hold_run(tmp_path / "a", 0.1)
    always, n_always = _hold_run(tmp_path / "b", 10.0)  # a margin so wide the cans are never on hold
    assert n_held > 300 and n_always == 0
    assert held.task_success and always.task_success
    assert held.info["cans_on_ground"] == always.info["cans_on_ground"] == [True, True]
    # Brought down onto the cans, the tool still hits them before the motion: they are back in time.
    onto = (0.0, 0.15, 0.0, 0.0)
    hit, n_hit = _hold_run(tmp_path / "c", 0.1, onto)
    hit_always, _ = _hold_run(tmp_path / "d", 10.0, onto)
    assert n_hit > 0
    assert hit.failure == hit_always.failure == FailureReason.COLLISION_BEFORE_MOTION


def test_world_without_the_cans_moves_everything_else_exactly_as_the_full_world(tmp_path):
    # While the cans are on hold the world is stepped without them; the full world with the cans kept
    # floating and contact-free (what a GIF recorder gets) must give the very same trial, to the last bit.
    lite_steps = [0]
    lite, n_held = _hold_run(tmp_path / "a", 0.1, lite_steps=lite_steps)
    full, n_full = _hold_run(tmp_path / "b", 0.1, lite=False)
    assert n_held == n_full > 300 and lite_steps[0] == n_held
    assert lite.task_success and full.task_success
    for key in ("sim_time", "in_hand", "in_hand_start", "start_pose", "cans_on_ground"):
        assert lite.info[key] == full.info[key], key
