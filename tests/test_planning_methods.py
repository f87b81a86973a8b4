"""Every method's planner (the paper's baselines, TOG-Net and the Oracle) returns a plan the simulator can
run, on a PG-Primitive, a PG-Complex and a realistic test object, for every task."""

import numpy as np
import pytest
from eval_testlib import tiny_models

from tognet.objects import generate_set
from tognet.planning import METHODS, BoundConfig, OracleConfig, PlanConfig, check_methods, make_planner
from tognet.planning.method_names import DIAGNOSTIC_NAMES
from tognet.sim import SimConfig, Simulator
from tognet.tasks import TASK_NAMES, FailureReason

FAST = PlanConfig(oracle=OracleConfig(grasps=2, seeds=1, max_trials=12),
                  bound=BoundConfig(grasps=2, seeds=1, max_trials=16))


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    from tognet.jobs.models import load_model

    paths = tiny_models(tmp_path_factory.mktemp("models"), search=True)
    return {name: load_model(str(p)) for name, p in paths.items()}


@pytest.fixture(scope="module")
def objects(tmp_path_factory):
    root = tmp_path_factory.mktemp("objects")
    kinds = ("primitive", "complex", "realistic")
    return {kind: generate_set(kind, "test", 1, root / kind)[0] for kind in kinds}


@pytest.mark.parametrize("task", TASK_NAMES)
@pytest.mark.parametrize("kind", ["primitive", "complex", "realistic"])
def test_every_planner_returns_a_plan_the_simulator_runs(models, objects, kind, task):
    sim = Simulator(SimConfig(), task, objects[kind])
    obs = sim.reset(11)
    pos, _ = sim.object_pose()
    settled = sim.save_state()
    plans = {}
    for method in METHODS:
        planner = make_planner(method, sim.task, grasp_model=models["grasping"], task_model=models[task],
                               config=FAST, sim=sim, search_model=models[f"{task}_search"])
        plan = planner.plan(obs, np.random.default_rng(5))
        plans[method] = plan
        assert plan.method == method
        assert plan.grasp.shape == (4,) and plan.action.shape == (4,)
        assert np.all(np.isfinite(plan.grasp)) and np.all(np.isfinite(plan.action))
        assert 0 <= plan.grasp[3] < 2 * np.pi
        # on the object (within its reach of the centre of mass), at most a few cm above the table
        assert np.hypot(*(plan.grasp[:2] - pos[:2])) < 0.5 * max(objects[kind].extents) + 0.03
        assert 0.0 < plan.grasp[2] < max(objects[kind].extents) + 0.02
        assert np.all(plan.action >= sim.task.action_low - 1e-9)
        assert np.all(plan.action <= sim.task.action_high + 1e-9)
        if method.endswith("Random"):  # the paper's random action: +-5 cm, +-pi/20 about the nominal
            assert np.all(np.abs(plan.action[:3]) <= 0.05) and abs(plan.action[3]) <= np.pi / 20
        assert plan.timing["total"] > 0
        np.testing.assert_array_equal(sim.save_state(), settled)  # the Oracle's search put the scene back
        result = sim.execute(plan.grasp_pose, plan.action, seed=0)
        assert result.failure in FailureReason
    # generators in the same state: the same candidates, so the same CEM grasp for the same scorer
    np.testing.assert_array_equal(plans["Task_Agn+Random"].grasp, plans["Task_Agn+Trained"].grasp)
    np.testing.assert_array_equal(plans["Task_Ori+Random"].grasp, plans["TOG-Net"].grasp)
    np.testing.assert_allclose(plans["TOG-Net"].scores["q_t"], plans["TOG-Net"].scores["choice"], rtol=1e-4)
    assert plans["Oracle"].info["search_trials"] <= FAST.oracle.max_trials


def test_planners_are_deterministic_given_the_generator(models, objects):
    sim = Simulator(SimConfig(), "hammering", objects["primitive"])
    obs = sim.reset(2)
    for method in ("Antipodal+Random", "TOG-Net", "Oracle"):
        planner = make_planner(method, sim.task, grasp_model=models["grasping"],
                               task_model=models["hammering"], config=FAST, sim=sim)
        a, b = planner(obs, np.random.default_rng(9)), planner(obs, np.random.default_rng(9))
        np.testing.assert_array_equal(a.grasp, b.grasp)
        np.testing.assert_array_equal(a.action, b.action)


def test_planner_arguments_are_checked(models, objects):
    sim = Simulator(SimConfig(), "sweeping", objects["primitive"])
    assert check_methods("all") == METHODS
    assert check_methods("tog-net, oracle") == ("TOG-Net", "Oracle")
    with pytest.raises(ValueError, match="unknown method 'Dex-Net'"):
        check_methods("Dex-Net")
    with pytest.raises(ValueError, match="needs the sweeping model"):
        make_planner("TOG-Net", sim.task, grasp_model=models["grasping"])
    with pytest.raises(ValueError, match="trained for hammering"):
        make_planner("TOG-Net", sim.task, task_model=models["hammering"])
    with pytest.raises(ValueError, match="needs the simulator"):
        make_planner("Oracle", sim.task)
    other = Simulator(SimConfig(), "sweeping", objects["primitive"])
    obs = other.reset(4)
    sim.reset(5)
    with pytest.raises(ValueError, match="does not hold the observation's scene"):
        make_planner("Oracle", sim.task, sim=sim, config=FAST)(obs, np.random.default_rng(0))


def test_each_method_is_one_row_of_the_table_and_a_new_row_plans(models, objects):
    """METHODS and NEEDS come from the table; a row says what kind of method it is; a diagnostic row
    (here the TOG-Net grasp with the simulator's expert motion) needs the simulator and then plans."""
    from tognet.data.format import ACTION_SOURCES
    from tognet.planning import METHOD_TABLE, NEEDS, Method, get_method
    from tognet.policies.action import ExpertActions
    from tognet.policies.grasp import CEMGrasp

    assert METHODS == tuple(m.name for m in METHOD_TABLE) and len(set(METHODS)) == len(METHODS)
    assert NEEDS == {m.name: m.needs for m in METHOD_TABLE}
    assert [m.name for m in METHOD_TABLE if m.baseline] == [
        "Antipodal+Random", "Task_Agn+Random", "Task_Agn+Trained", "Task_Ori+Random"]
    assert [m.name for m in METHOD_TABLE if m.uses_sim] == ["Oracle", "Oracle+", *DIAGNOSTIC_NAMES]
    assert get_method("tog-net").kind == "ours" and get_method("Oracle").planner is not None
    with pytest.raises(ValueError, match="a grasp and an action policy, or a planner"):
        Method("half", "baseline", grasp=lambda i: CEMGrasp(i.config.policy, i.task_model))
    row = Method("TOG-Net grasp + expert motion", "diagnostic", ("task",),
                 grasp=lambda i: CEMGrasp(i.config.policy, i.task_model),
                 action=lambda i: ExpertActions(i.sim))
    assert row.uses_sim and not row.baseline
    sim = Simulator(SimConfig(), "hammering", objects["primitive"])
    with pytest.raises(ValueError, match="needs the simulator"):
        make_planner(row, sim.task, task_model=models["hammering"])
    obs = sim.reset(2)
    plan = make_planner(row, sim.task, task_model=models["hammering"], config=FAST, sim=sim)(
        obs, np.random.default_rng(3))
    ours = make_planner("TOG-Net", sim.task, task_model=models["hammering"], config=FAST)(
        obs, np.random.default_rng(3))
    assert plan.method == row.name and plan.info["action_source"] == ACTION_SOURCES["expert"]
    np.testing.assert_array_equal(plan.grasp, ours.grasp)
    assert sim.execute(plan.grasp_pose, plan.action, seed=0).failure in FailureReason


def test_the_oracles_cache_lets_a_finished_simulator_go(objects):
    """One Oracle planner per simulator, cached beside it: once a job drops its simulator, the cache must
    not keep it (and its world) alive for the rest of the worker's life."""
    import gc
    import weakref

    from tognet.planning import methods

    sim = Simulator(SimConfig(), "hammering", objects["primitive"])
    oracle = methods.oracle_for(sim, PlanConfig())
    assert methods.oracle_for(sim, PlanConfig()) is oracle  # cached
    gone = weakref.ref(sim)
    del sim, oracle
    gc.collect()
    assert gone() is None
