"""TOG-Net+Twin (issue 34): the solid built from the depth image matches the object it saw, stands still in
its world, and the planner takes the searched pair that wins most there, reading nothing of the scene but
the image, its camera and the reference point."""

import numpy as np
import pytest
from eval_testlib import tiny_models

from tognet.grasping.depth import prepare_depth
from tognet.objects import generate_set
from tognet.objects.columns import column_pieces
from tognet.planning import PlanConfig, make_planner
from tognet.planning.config import TwinConfig
from tognet.planning.twin import build_twin, object_pixels, twin_wins
from tognet.policies.view import SceneView
from tognet.sim import SimConfig, Simulator
from tognet.sim.simulator import Observation
from tognet.tasks import get_task


def test_columns_of_a_box_seen_from_above_fill_its_volume():
    xs, ys = np.meshgrid(np.arange(-0.05, 0.05, 0.0025) + 0.00125, np.arange(-0.02, 0.02, 0.0025) + 0.00125)
    points = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.03)])
    pieces = column_pieces(points, np.full(len(points), 0.00125), cell=0.02)
    volume = sum(p.volume for p in pieces)
    assert volume == pytest.approx(0.1 * 0.04 * 0.03, rel=0.02)
    assert all(p.is_convex for p in pieces) and len(pieces) == 12  # x cells -3..2, y cells -1..0


@pytest.mark.parametrize("name", ["hammering", "pulling"])
def test_the_told_layout_gives_back_the_reference_point(name):
    task = get_task(name)
    layout = task.sample_layout(np.random.default_rng(0))
    ref = task.reference(layout)
    np.testing.assert_allclose(task.reference(task.told_layout(ref)), ref)
    assert get_task("sweeping").told_layout(ref) is None  # the cans' places do not follow from their mean


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    obj = generate_set("primitive", "test", 1, tmp_path_factory.mktemp("objects"))[0]
    return Simulator(SimConfig(), "hammering", obj)


def test_the_twin_stands_where_the_image_saw_the_object(sim, tmp_path):
    obs = sim.reset(3)
    view = SceneView(prepare_depth(obs.depth, obs.camera), None, sim.task, None)
    twin = build_twin(view, obs.reference, sim.config, TwinConfig(), str(tmp_path))
    pos, rot = sim.object_pose()
    seen = (sim.vertices @ rot.T + pos)[:, :2]
    pts, _ = object_pixels(view, TwinConfig())
    built = twin.vertices[:, :2]
    assert np.all(np.abs(built.min(axis=0) - seen.min(axis=0)) < 0.01)
    assert np.all(np.abs(built.max(axis=0) - seen.max(axis=0)) < 0.01)
    before = twin.scene["object_com"]
    twin.execute(twin.default_grasp(), np.zeros(4), 0)  # a trial restores the settled twin
    np.testing.assert_allclose(twin.data.xipos[twin.object_body], before, atol=1e-9)
    assert len(pts) > 50


@pytest.fixture(scope="module")
def search_model(tmp_path_factory):
    from tognet.jobs.models import load_model

    return load_model(str(tiny_models(tmp_path_factory.mktemp("models"), search=True)["hammering_search"]))


def test_the_twin_takes_the_pair_that_wins_most_from_the_image_alone(sim, search_model, tmp_path):
    config = PlanConfig(twin=TwinConfig(pairs=4, seeds=2))
    planner = make_planner("TOG-Net+Twin", sim.task, config=config, sim=sim, search_model=search_model)
    obs = sim.reset(3)
    plan = planner.plan(obs, np.random.default_rng(5))
    wins = plan.info["twin"]["wins"]
    assert len(wins) == 4
    # The same plan from the image, its camera and the reference point alone (no simulator's scene).
    bare = Observation(obs.depth.copy(), obs.camera, obs.reference.copy(), "hammering", "unknown", -1)
    again = planner.plan(bare, np.random.default_rng(5))
    np.testing.assert_array_equal(again.grasp, plan.grasp)
    assert again.info["twin"]["wins"] == wins
    # The chosen pair is the first of those that won most in the twin, with the search's action for it.
    rng = np.random.default_rng(5)
    view = planner.view(obs, rng, {})
    view.cache["reference"] = obs.reference
    grasps, res, row = planner.grasp_policy.checked(view, rng)
    assert row == int(np.argmax(wins))
    np.testing.assert_array_equal(plan.grasp, grasps[res.index[row]])
    np.testing.assert_allclose(plan.action, res.actions[row])
    twin = build_twin(view, obs.reference, sim.config, config.twin, str(tmp_path))
    assert twin_wins(twin, grasps[res.index[:4]], res.actions[:4], 2).tolist() == wins


def test_without_a_reference_point_the_search_chooses(sim, search_model):
    planner = make_planner("TOG-Net+Twin", sim.task, sim=sim, search_model=search_model)
    obs = sim.reset(4)
    view = planner.view(obs, np.random.default_rng(1), {})
    grasps, res, row = planner.grasp_policy.checked(view, np.random.default_rng(1))
    assert row == 0 and view.cache["twin"]["skipped"] == "no reference point"
