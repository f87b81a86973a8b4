"""The learned action search on real simulated trials: the action-scoring head, trained on a small dataset
of T-hammer trials this test collects, ranks the scripted good hammering action above scripted bad ones
from the same far-end grasp; the search finds a working action; the policies are deterministic."""

from pathlib import Path

import numpy as np
import pytest

from tognet.collect.jobs import trial_records
from tognet.data.writer import ShardWriter
from tognet.grasping.antipodal import AntipodalConfig, sample_antipodal
from tognet.grasping.crops import CropConfig
from tognet.grasping.depth import prepare_depth
from tognet.model.config import ArchConfig, LossConfig, TrainConfig
from tognet.model.predict import TOGNetPredictor
from tognet.model.train import train
from tognet.objects.handmade import grasp_on_object, make_t_hammer
from tognet.policies.action_search import (
    ActionSearchActions,
    ActionSearchConfig,
    ActionSearchGrasps,
    SearchCandidateGrasps,
    search,
)
from tognet.policies.view import SceneView
from tognet.sim import SimConfig, Simulator
from tognet.tasks import get_props, get_task

ARCH = ArchConfig(stem_channels=8, block_channels=(16,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=32, task_head="action", action_features=16, action_hidden=64)
#: Offsets from the scripted far-end action (a_x, a_y, a_z, a_phi): which fail is measured by the trials
#: themselves (labels from the simulator); on this hammer y+6 cm and z+5 cm miss the peg, y-6 cm and
#: phi+0.5 touch it without driving it home, x+-6 cm and phi-0.5 still work.
BAD = {"y+6": (0, 0.06, 0, 0), "y-6": (0, -0.06, 0, 0), "z+5": (0, 0, 0.05, 0), "phi+.5": (0, 0, 0, 0.5)}
OK = {"good": (0, 0, 0, 0), "x+6": (0.06, 0, 0, 0), "x-6": (-0.06, 0, 0, 0), "phi-.5": (0, 0, 0, -0.5)}


def _sim(root: Path) -> Simulator:
    cfg = SimConfig()
    props = get_props(get_task("hammering", cfg.task_config("hammering")))
    cfg = cfg.replace(hammering=props.check_config(cfg.task_config("hammering")))
    return Simulator(cfg, "hammering", make_t_hammer(root))


def _scene(sim: Simulator, seed: int, crop: CropConfig):
    obs = sim.reset(seed)
    scene = prepare_depth(obs.depth, obs.camera)
    cands = sample_antipodal(scene, None, AntipodalConfig(axis_direction="both"), np.random.default_rng(seed))
    pos, rot = sim.object_pose()
    grasps = {name: grasp_on_object(pos, rot, *sim.props.check_grasps[name][:2])
              for name in ("far_end", "head")}
    return SceneView(scene, cands, sim.task, crop), grasps


@pytest.fixture(scope="module")
def hammer(tmp_path_factory):
    """A T-hammer simulator, a small dataset of its trials and an action-conditioned model trained on it."""
    root = tmp_path_factory.mktemp("hammer")
    sim = _sim(root / "objects")
    crop = CropConfig()
    low, high = sim.task.action_low, sim.task.action_high
    with ShardWriter(root / "data", "hammering", configs={"crop": crop}) as writer:
        rng = np.random.default_rng(0)
        for seed in range(28):
            view, grasps = _scene(sim, seed, crop)
            good = sim.props.check_action("far_end")
            rows, acts = [], []
            for off in (*OK.values(), *BAD.values()):
                rows.append(grasps["far_end"].as_array())
                acts.append(np.clip(good + np.asarray(off), low, high))
            for _ in range(3):  # the rest of the box, as collection's uniform exploration sees it
                rows.append(grasps["far_end"].as_array())
                acts.append(sim.task.uniform_action(rng))
            rows.append(grasps["head"].as_array())
            acts.append(sim.props.check_action("head"))
            g = np.asarray(rows, np.float32).astype(np.float64)
            a = np.asarray(acts, np.float32).astype(np.float64)
            results = [sim.execute(grasps["far_end"] if i < len(rows) - 1 else grasps["head"], a[i], seed)
                       for i in range(len(rows))]
            n = len(results)
            cols = trial_records(view, g, a, results, np.zeros(n, np.int8), np.zeros(n, np.int8),
                                 np.zeros(n, np.float32), f"t_hammer_{seed % 7}", seed, np.arange(n))
            writer.add_batch(**cols)
    cfg = TrainConfig(arch=ARCH, loss=LossConfig(action_sigma_source="data"), epochs=40, patience=40,
                      batch_size=32, val_fraction=0.0, lr=3e-3, lr_decay=0.97, seed=1, num_threads=1)
    with pytest.warns(UserWarning, match="no validation objects"):
        result = train([root / "data"], "hammering", root / "model", cfg, progress=False, log=lambda s: None)
    return sim, TOGNetPredictor.load(result.best_path), crop


def test_scripted_bad_actions_fail_and_good_ones_work(hammer):
    sim, _, crop = hammer
    view, grasps = _scene(sim, 500, crop)
    good = sim.props.check_action("far_end")
    assert sim.execute(grasps["far_end"], good, 0).task_success
    for name, off in BAD.items():
        a = np.clip(good + np.asarray(off), sim.task.action_low, sim.task.action_high)
        assert not sim.execute(grasps["far_end"], a, 0).task_success, name


def test_head_ranks_the_good_action_above_bad_ones_on_an_unseen_scene(hammer):
    sim, model, crop = hammer
    for seed in (500, 501):
        view, grasps = _scene(sim, seed, crop)
        good = sim.props.check_action("far_end")
        acts = np.stack([good] + [np.clip(good + np.asarray(o), sim.task.action_low, sim.task.action_high)
                                  for o in BAD.values()])
        crops, z = view.crops(grasps["far_end"].as_array()[None])
        success = model.score_actions(model.encode(crops, z), acts[None]).success
        assert np.all(success[0, 0] > success[0, 1:]), (seed, success)


def test_search_finds_a_working_action_for_the_far_end_grasp(hammer):
    # This dataset covers a few actions around the scripted one and 3 random ones per scene, not the box:
    # the search is held to a trust region around the action mean (the part of the box the data covers).
    sim, model, crop = hammer
    view, grasps = _scene(sim, 502, crop)
    g = grasps["far_end"].as_array()[None]
    crops, z = view.crops(g)
    res = search(model, crops, z, sim.task.action_low, sim.task.action_high,
                 ActionSearchConfig(trust_region=3.0), np.random.default_rng(0))
    assert sim.execute(grasps["far_end"], res.actions[0], 0).task_success, res.actions[0]
    assert 0.0 <= res.q_t[0] <= 1.0 and len(res.rating) == 1


def test_policies_are_seeded_and_share_the_scene_search(hammer):
    sim, model, crop = hammer
    view, _ = _scene(sim, 503, crop)
    cfg = ActionSearchConfig()
    picks = []
    for _ in range(2):
        v = SceneView(view.scene, view.candidates, view.task, view.crop)
        rng = np.random.default_rng(7)
        gp = ActionSearchGrasps(model, cfg)(v, 3, rng)
        ap = ActionSearchActions(model, cfg)(v, gp.grasps, rng)
        picks.append((gp, ap))
    (g1, a1), (g2, a2) = picks
    np.testing.assert_array_equal(g1.grasps, g2.grasps)
    np.testing.assert_array_equal(a1.actions, a2.actions)
    assert np.all(g1.grasps == g1.grasps[0]) and np.all(a1.actions == a1.actions[0])
    # the action policy reuses the scene search's action for its grasp
    _, res = v.cache[f"action_search_{id(model)}"]
    np.testing.assert_allclose(a2.actions[0], res.actions[0])
    noisy = ActionSearchActions(model, cfg, noise=(0.01, 0.01, 0.01, 0.05))(v, g2.grasps,
                                                                            np.random.default_rng(1))
    assert not np.allclose(noisy.actions, a2.actions)
    assert np.all(noisy.actions >= sim.task.action_low) and np.all(noisy.actions <= sim.task.action_high)


def test_search_candidates_cycle_through_the_searchs_best_grasps_each_with_its_own_action(hammer):
    sim, model, crop = hammer
    view, _ = _scene(sim, 504, crop)
    cfg = ActionSearchConfig()  # refines 4; the policy widens that to its count
    rng = np.random.default_rng(3)
    pick = SearchCandidateGrasps(model, cfg, 6)(view, 8, rng)
    grasps, res = view.cache[f"action_search_{id(model)}"]
    assert len(res.index) == 6  # the search refined as many as the policy cycles through
    np.testing.assert_array_equal(pick.grasps[:6], grasps[res.index])
    np.testing.assert_array_equal(pick.grasps[6:], grasps[res.index[:2]])  # then from the best again
    assert len(np.unique(pick.grasps, axis=0)) == 6
    assert np.all(np.diff(pick.score[:6]) <= 0)  # best Q_T first
    acts = ActionSearchActions(model, cfg)(view, pick.grasps, rng)
    np.testing.assert_allclose(acts.actions[:6], res.actions)  # each with the search's own action
    single = SearchCandidateGrasps(model, cfg, 1)(SceneView(view.scene, view.candidates, view.task, crop),
                                                  3, np.random.default_rng(3))
    assert np.all(single.grasps == single.grasps[0])
