"""Oracle+, the stronger bound (issue 34): it tries the very plans the other methods execute, stays within
its budget, puts the scene back, and the evaluation reports every share and "beyond" count against it."""

import numpy as np
import pytest
from eval_testlib import tiny_models

from tognet.evaluate import summarise
from tognet.objects import generate_set
from tognet.planning import BoundConfig, OracleConfig, PlanConfig, make_planner
from tognet.planning.bound import BoundPlanner, _Judge
from tognet.planning.methods import BEST_FIRST
from tognet.sim import SimConfig, Simulator


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    from tognet.jobs.models import load_model

    paths = tiny_models(tmp_path_factory.mktemp("models"), search=True)
    return {name: load_model(str(p)) for name, p in paths.items()}


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    obj = generate_set("primitive", "test", 1, tmp_path_factory.mktemp("objects"))[0]
    return Simulator(SimConfig(), "hammering", obj)


def _planner(method, sim, models, config):
    return make_planner(method, sim.task, grasp_model=models["grasping"], task_model=models["hammering"],
                        config=config, sim=sim, search_model=models["hammering_search"])


def test_the_bound_proposes_the_very_plan_each_method_executes(sim, models):
    config = PlanConfig(bound=BoundConfig(alternatives=1))
    obs = sim.reset(3)
    bound = _planner("Oracle+", sim, models, config)
    assert isinstance(bound, BoundPlanner)
    proposed = {source: (g, a) for source, g, a in bound.proposals(obs, np.random.default_rng(7))}
    for method in BEST_FIRST:  # every method a robot can run, with the evaluation's generator state
        plan = _planner(method, sim, models, config).plan(obs, np.random.default_rng(7))
        np.testing.assert_array_equal(proposed[method][0], plan.grasp, err_msg=method)
        np.testing.assert_array_equal(proposed[method][1], plan.action, err_msg=method)
    oracle = _planner("Oracle", sim, models, config).plan(obs, np.random.default_rng(7))
    if oracle.info["found"]:  # the Oracle row's plan comes first
        assert next(iter(proposed)) == "Oracle"
        np.testing.assert_array_equal(proposed["Oracle"][1], oracle.action)
    learned = {"TOG-Net", "TOG-Net+ActionSearch", "TOG-Net+Twin"}
    extra = {s for s in proposed if s not in BEST_FIRST} - {"Oracle"}
    assert extra <= {f"{m} #2" for m in learned} and extra, extra  # the learned ones' next grasps too


def test_the_bound_keeps_its_budget_and_puts_the_scene_back(sim, models):
    obs = sim.reset(5)
    settled = sim.save_state()
    tiny = OracleConfig(grasps=1, seeds=1, max_trials=1)  # the Oracle's plan: one probe, nothing found
    one = PlanConfig(oracle=tiny, bound=BoundConfig(seeds=1, confirm=0, max_trials=2))
    plan = _planner("Oracle+", sim, models, one).plan(obs, np.random.default_rng(1))
    first = _planner(BEST_FIRST[0], sim, models, one).plan(obs, np.random.default_rng(1))
    assert plan.info["search_trials"] == 2 and plan.info["source"] == BEST_FIRST[0]
    np.testing.assert_array_equal(plan.grasp, first.grasp)  # its one trial: the first method's plan
    np.testing.assert_array_equal(plan.action, first.action)
    some = PlanConfig(oracle=OracleConfig(grasps=2, seeds=1, max_trials=12),
                      bound=BoundConfig(grasps=3, seeds=2, confirm=2, max_trials=40))
    plan = _planner("Oracle+", sim, models, some).plan(obs, np.random.default_rng(1))
    assert 1 <= plan.info["search_trials"] <= 40  # the Oracle's own trials counted in
    assert plan.info["source"]
    assert 0.0 <= plan.scores["choice"] <= 1.0
    np.testing.assert_array_equal(sim.save_state(), settled)
    assert sim.task.action_low.shape == plan.action.shape
    again = _planner("Oracle+", sim, models, some).plan(obs, np.random.default_rng(1))
    np.testing.assert_array_equal(plan.grasp, again.grasp)  # reproducible from the generator
    np.testing.assert_array_equal(plan.action, again.action)


def test_the_refinement_moves_the_action_a_step_and_keeps_the_better_pair(sim, models):
    obs = sim.reset(5)
    config = PlanConfig(bound=BoundConfig(seeds=2, max_trials=100, step=0.01, turn=0.1))
    bound = _planner("Oracle+", sim, models, config)
    plan = _planner("TOG-Net", sim, models, config).plan(obs, np.random.default_rng(2))
    judge = _Judge(sim, bound.config)
    judge.best.offer(1, plan.grasp, plan.action, "TOG-Net")
    bound._refine(judge)
    assert 1 <= judge.trials <= 8 * (2 + 5)  # 8 moves: 2 seeds each, 5 more to confirm one that won both
    best = judge.best
    moved = np.abs(best.action - plan.action)
    assert best.wins >= 1 and np.all(moved[:3] <= 0.01 + 1e-12) and moved[3] <= 0.1 + 1e-12
    if best.source != "TOG-Net":  # a move that won more replaced the pair
        assert best.source == "TOG-Net, refined" and best.wins >= 2 and np.count_nonzero(moved) == 1


def _record(method, scene, ok):
    return {"task": "hammering", "category": "pg-primitive", "object_id": "o", "scene_seed": scene,
            "method": method, "valid": True, "grasp_success": ok, "task_success": ok,
            "failure": "none" if ok else "task_failed", "timing": {"total": 0.1}, "execute_seconds": 0.1,
            "search_trials": {"Oracle": 10, "Oracle+": 30}.get(method), "scores": {}}


def test_shares_and_beyond_counts_are_taken_against_the_bound_with_the_oracle_kept_beside():
    from tognet.evaluate.report import oracle_table

    wins = {"TOG-Net": {0, 1, 9}, "Oracle": {0, 1, 2, 3}, "Oracle+": {0, 1, 2, 3, 4, 5, 6, 7}}
    methods = list(wins)
    records = [_record(m, s, s in w) for m, w in wins.items() for s in range(10)]
    sub = summarise(records, ["hammering"], methods, ["pg-primitive"])["tasks"]["hammering"]
    stats = sub["categories"]["pg-primitive"]["all"]
    assert stats["bound_fraction"]["TOG-Net"] == pytest.approx(3 / 8)
    assert stats["oracle_fraction"]["TOG-Net"] == pytest.approx(3 / 4)
    assert stats["beyond_bound"]["TOG-Net"] == {"scenes": 1, "pairs": 10}  # scene 9
    assert stats["beyond_bound"]["Oracle"] == {"scenes": 0, "pairs": 10}
    assert stats["methods"]["Oracle+"]["search_trials"] == 30  # the bound's cost per scene
    rows = {r[0]: r[1] for r in oracle_table({"methods": methods, "tasks": {"hammering": sub}},
                                             "hammering", "all").rows}
    # The scene bound: scenes 0-7 (Oracle+) and 9 (TOG-Net beyond it) of 10; every share is taken of it.
    scene = stats["scene_bound"]
    assert (scene["successes"], scene["valid"], scene["added"]) == (9, 10, 1)
    assert scene["fraction"]["TOG-Net"] == pytest.approx(3 / 9)
    assert rows == {"TOG-Net": "33 (37 / 75); 1 of 10", "Oracle": "44 (50); 0 of 10",
                    "Oracle+": "89; the rows add 1"}
    from tognet.evaluate.report import _levels

    levels = _levels({"methods": methods, "tasks": {"hammering": sub}})  # for the learning curves
    assert levels == {"hammering": [("Oracle+ or any row, test scenes", 0.9), ("Oracle+, test scenes", 0.8),
                                    ("TOG-Net, test scenes", 0.3)]}
    without = summarise([r for r in records if r["method"] != "Oracle+"], ["hammering"], methods[:2],
                        ["pg-primitive"])["tasks"]["hammering"]["categories"]["pg-primitive"]["all"]
    assert "beyond_bound" not in without and without["beyond_oracle"]["TOG-Net"]["scenes"] == 1
    assert (without["scene_bound"]["successes"], without["scene_bound"]["added"]) == (5, 1)  # over the Oracle


def test_no_row_solves_a_scene_the_scene_bound_does_not():
    """Random outcomes over three rows and two categories, invalid trials among them: the scene bound
    solves every scene any row solves, and each row's paired share of it is at most 1."""
    rng = np.random.default_rng(4)
    methods = ["TOG-Net", "TOG-Net+ActionSearch", "Oracle+"]
    records = []
    for m in methods:
        for cat in ("pg-primitive", "realistic"):
            for s in range(40):
                r = _record(m, s, bool(rng.random() < 0.4))
                r.update(category=cat, object_id=f"{cat}-{s % 7}", valid=bool(rng.random() < 0.9))
                records.append(r)
    res = summarise(records, ["hammering"], methods, ["pg-primitive", "realistic"])
    for cat, subs in res["tasks"]["hammering"]["categories"].items():
        scene = subs["all"]["scene_bound"]
        mine = [r for r in records if r["valid"] and cat in ("all", r["category"])]
        solved = {(r["object_id"], r["scene_seed"]) for r in mine if r["task_success"]}
        assert scene["successes"] == len(solved) > 0
        for m in methods:
            own = {(r["object_id"], r["scene_seed"]): r["task_success"] for r in mine if r["method"] == m}
            share = sum(own.values()) / len(set(own) & solved)
            assert scene["fraction"][m] == pytest.approx(share) and 0 < share <= 1


def test_a_tie_between_sure_pairs_goes_to_the_one_that_wins_more_further_trials(sim, models):
    config = PlanConfig(bound=BoundConfig(seeds=1, confirm=0, tiebreak=4, max_trials=200))
    bound = _planner("Oracle+", sim, models, config)
    oracle = _planner("Oracle", sim, models, config)
    for scene in range(6):  # a scene where the Oracle finds a working pair
        obs = sim.reset(scene)
        plan = oracle.plan(obs, np.random.default_rng(0))
        if plan.info["found"]:
            break
    assert plan.info["found"], "the Oracle found no working pair on six scenes"
    judge = _Judge(sim, bound.config)
    hopeless = np.array(sim.task.action_low, np.float64)  # far from the tool's working motion
    judge.sure = [(plan.grasp, hopeless, "hopeless"), (plan.grasp, plan.action, "Oracle")]
    judge.best.offer(1, plan.grasp, hopeless, "hopeless")
    before = judge.trials
    judge.settle()
    assert judge.trials - before == 2 * 4  # every tiebreak trial counted, failures too
    assert judge.tiebreaks[0] < judge.tiebreaks[1], judge.tiebreaks
    assert judge.best.source == "Oracle"
    np.testing.assert_array_equal(judge.best.action, plan.action)
