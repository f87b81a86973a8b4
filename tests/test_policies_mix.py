"""The mixing policies on a real simulated scene: epsilon-greedy grasps and actions and the expert mix
choose per trial, with the coin and the draws in the order their docstrings declare (collection's records
depend on that order)."""

from __future__ import annotations

import numpy as np
import pytest

from tognet.data.format import ACTION_SOURCES, GRASP_SOURCES
from tognet.grasping import AntipodalConfig, CropConfig, prepare_depth, sample_antipodal
from tognet.grasping.cem import CEMConfig
from tognet.policies.action import ExpertActions, PolicyActions, UniformActions
from tognet.policies.config import PolicyConfig
from tognet.policies.grasp import CEMGrasp, NMSGrasps
from tognet.policies.mix import EpsilonGreedyActions, EpsilonGreedyGrasps, ExpertMixActions
from tognet.policies.view import SceneView

N = 120
POLICY = PolicyConfig(cem=CEMConfig(iterations=1, samples=16))


@pytest.fixture(scope="module")
def scene(hammer_sim):
    obs = hammer_sim.reset(3)
    depth = prepare_depth(obs.depth, obs.camera)
    cands = sample_antipodal(depth, None, AntipodalConfig(axis_direction="both"), np.random.default_rng(0))
    assert len(cands) > 0
    return depth, cands


def fresh_view(scene, sim):
    """A new view of the scene (an empty cache: a CEM search draws again)."""
    return SceneView(scene[0], scene[1], sim.task, CropConfig())


@pytest.fixture(scope="module")
def model():
    from tognet.model.predict import TOGNetPredictor
    from tognet.models import default_checkpoint

    return TOGNetPredictor.load(default_checkpoint("hammering"))


@pytest.mark.parametrize("epsilon", [0.0, 0.3, 1.0])
def test_epsilon_greedy_grasps_explore_per_trial_with_probability_epsilon(scene, hammer_sim, model, epsilon):
    greedy, explore = CEMGrasp(POLICY, model), NMSGrasps(POLICY)
    pick = EpsilonGreedyGrasps(greedy, explore, epsilon)(fresh_view(scene, hammer_sim), N,
                                                         np.random.default_rng(7))
    # as declared: the exploring pick, then one coin per trial, then the greedy pick, all from one generator
    rng = np.random.default_rng(7)
    view = fresh_view(scene, hammer_sim)
    explored = explore(view, N, rng)
    coin = rng.random(N) < epsilon
    best = greedy(view, N, rng)
    np.testing.assert_array_equal(pick.grasps, np.where(coin[:, None], explored.grasps, best.grasps))
    np.testing.assert_array_equal(pick.score, np.where(coin, explored.score, best.score))
    np.testing.assert_array_equal(pick.source == GRASP_SOURCES["nms"], coin)
    np.testing.assert_array_equal(pick.source == GRASP_SOURCES["cem"], ~coin)
    assert pick.grasps.shape == (N, 4) and pick.source.dtype == np.int8 and pick.score.dtype == np.float32
    if 0 < epsilon < 1:  # both kinds of trial, in about the declared share (binomial, 4 sigma)
        sigma = np.sqrt(N * epsilon * (1 - epsilon))
        assert abs(coin.sum() - N * epsilon) < 4 * sigma and 0 < coin.sum() < N
        assert len(np.unique(pick.grasps[~coin], axis=0)) == 1  # the greedy grasp: one per scene
    else:
        assert coin.all() == (epsilon == 1.0) and coin.any() == (epsilon == 1.0)


def test_epsilon_greedy_actions_explore_per_trial(scene, hammer_sim, model):
    view = fresh_view(scene, hammer_sim)
    grasps = NMSGrasps(POLICY)(view, N, np.random.default_rng(1)).grasps
    greedy, explore = PolicyActions(model, POLICY.action_noise), UniformActions()
    acts = EpsilonGreedyActions(greedy, explore, 0.4)(view, grasps, np.random.default_rng(9))
    rng = np.random.default_rng(9)
    explored = explore(view, grasps, rng)
    coin = rng.random(N) < 0.4
    noisy = greedy(view, grasps, rng)
    np.testing.assert_array_equal(acts.actions, np.where(coin[:, None], explored.actions, noisy.actions))
    np.testing.assert_array_equal(acts.source == ACTION_SOURCES["uniform"], coin)
    np.testing.assert_array_equal(acts.source == ACTION_SOURCES["policy"], ~coin)
    assert 0 < coin.sum() < N
    task = hammer_sim.task
    assert np.all(acts.actions >= task.action_low) and np.all(acts.actions <= task.action_high)


class Counting:
    """The real expert policy, counting the grasps it is asked about."""

    def __init__(self, policy: ExpertActions) -> None:
        self.policy = policy
        self.asked = 0

    def __call__(self, view, grasps, rng):
        self.asked += len(grasps)
        return self.policy(view, grasps, rng)


def test_the_expert_mix_asks_the_simulator_only_for_the_trials_it_replaces(scene, hammer_sim):
    n = 8
    view = fresh_view(scene, hammer_sim)
    grasps = NMSGrasps(POLICY)(view, n, np.random.default_rng(2)).grasps
    expert = Counting(ExpertActions(hammer_sim))
    acts = ExpertMixActions(UniformActions(), expert, 0.5)(view, grasps, np.random.default_rng(4))
    rng = np.random.default_rng(4)
    base = UniformActions()(view, grasps, rng)
    coin = rng.random(n) < 0.5
    assert 0 < coin.sum() < n and expert.asked == coin.sum()
    np.testing.assert_array_equal(acts.source == ACTION_SOURCES["expert"], coin)
    np.testing.assert_array_equal(acts.actions[~coin], base.actions[~coin])
    assert not np.array_equal(acts.actions[coin], base.actions[coin])
    # probability 0: the base policy's pick, and no coin drawn (the generator is where the base left it)
    expert.asked = 0
    rng_a, rng_b = np.random.default_rng(4), np.random.default_rng(4)
    plain = ExpertMixActions(UniformActions(), expert, 0.0)(view, grasps, rng_a)
    np.testing.assert_array_equal(plain.actions, UniformActions()(view, grasps, rng_b).actions)
    assert expert.asked == 0 and rng_a.random() == rng_b.random()
