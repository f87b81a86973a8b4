"""Policies made of two policies, chosen per trial by a coin: epsilon-greedy grasps and actions, and the
simulator's expert actions mixed into exploration.

Each one draws from ``rng`` in a fixed, documented order (collection's records depend on it: the same
seeds give the same records).
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from tognet.policies.view import ActionPick, ActionPolicy, GraspPick, GraspPolicy, SceneView

Pick = TypeVar("Pick", GraspPick, ActionPick)


def mix_picks(first: Pick, second: Pick, use_second: NDArray[np.bool_]) -> Pick:
    """Per trial, the second pick where ``use_second`` else the first."""
    if isinstance(first, GraspPick) and isinstance(second, GraspPick):
        return GraspPick(np.where(use_second[:, None], second.grasps, first.grasps),
                         np.where(use_second, second.source, first.source).astype(np.int8),
                         np.where(use_second, second.score, first.score).astype(np.float32))
    assert isinstance(first, ActionPick) and isinstance(second, ActionPick)
    return ActionPick(np.where(use_second[:, None], second.actions, first.actions),
                      np.where(use_second, second.source, first.source).astype(np.int8))


class EpsilonGreedyGrasps:
    """Per trial, the ``explore`` policy's grasp with probability ``epsilon``, else the ``greedy`` one's.

    Draws, in this order: the exploring pick (all n), n coins ``rng.random(n) < epsilon``, the greedy pick
    (all n)."""

    def __init__(self, greedy: GraspPolicy, explore: GraspPolicy, epsilon: float) -> None:
        self.greedy = greedy
        self.explore = explore
        self.epsilon = epsilon

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        explore = self.explore(view, n, rng)
        coin = rng.random(n) < self.epsilon
        return mix_picks(self.greedy(view, n, rng), explore, coin)


class EpsilonGreedyActions:
    """Per trial, the ``explore`` policy's action with probability ``epsilon``, else the ``greedy`` one's.

    Draws, in this order: the exploring pick (every grasp), one coin per grasp, the greedy pick (every
    grasp)."""

    def __init__(self, greedy: ActionPolicy, explore: ActionPolicy, epsilon: float) -> None:
        self.greedy = greedy
        self.explore = explore
        self.epsilon = epsilon

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        explore = self.explore(view, grasps, rng)
        coin = rng.random(len(grasps)) < self.epsilon
        return mix_picks(self.greedy(view, grasps, rng), explore, coin)


class ExpertMixActions:
    """Per trial, the ``expert`` policy's action with probability ``probability``, else the ``base`` one's
    (``PolicyConfig.expert_actions``: the simulator's actions mixed into exploration).

    Draws, in this order: the base pick (every grasp), one coin per grasp, the expert pick for the grasps
    whose coin came up only (an expert's action costs simulation). ``probability <= 0`` draws nothing
    beyond the base pick."""

    def __init__(self, base: ActionPolicy, expert: ActionPolicy, probability: float) -> None:
        self.base = base
        self.expert = expert
        self.probability = probability

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        pick = self.base(view, grasps, rng)
        if self.probability <= 0:
            return pick
        use = rng.random(len(grasps)) < self.probability
        if not use.any():
            return pick
        chosen = self.expert(view, grasps[use], rng)
        actions, source = pick.actions.copy(), pick.source.copy()
        actions[use], source[use] = chosen.actions, chosen.source
        return ActionPick(actions, source)
