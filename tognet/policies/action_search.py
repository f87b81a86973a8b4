"""The learned action search (beyond the paper): rate a grasp by the best action it allows, then search it.

The paper's Q_T|G is the chance of success from a grasp *with the collection policy's action*, and its
policy regresses the mean of the successful actions. A model whose task stream also sees the action
(``ArchConfig.task_head = "action"``: Q_T|G,a, trained on every trial, failures included) can instead
rate each candidate grasp g by ``Q_G(g) * max_a Q_T|G,a(g, a)`` and search a for the chosen grasp, as
QT-Opt does for grasps:

1. every candidate is encoded once (the trunk and the grasp's part of the task stream);
2. each is rated on ``rate_samples`` actions: its own action mean, Gaussian draws around it and draws
   over the whole action box shared by all candidates (the head is cheap: one small MLP per pair);
3. the ``refine_grasps`` best-rated candidates get a cross-entropy search over their action
   (``iterations`` refits of a diagonal Gaussian to the ``elite_fraction`` best of ``samples`` draws,
   clipped to the box), and the best (grasp, action) pair wins.

Actions are ordered by their predicted success, less ``pessimism`` times the disagreement of the model's
members (an ensemble: a maximum over many actions otherwise finds those the model overrates where its
data is thin), plus ``progress_weight`` times the predicted progress (the task's graded outcome), which
orders actions where success is unlikely everywhere. ``trust_region`` > 0 keeps every action near the
candidate's own action mean. The final pick among the CEM's best candidates averages each one's score
over ``robust_samples`` small perturbations, so that it keeps a margin from a failure region's edge. All
draws come from the generator given, so a search is reproducible. Pure numpy around the predictor's two calls
(:meth:`tognet.model.predict.TOGNetPredictor.encode` and ``score_actions``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.data.format import ACTION_SOURCES, GRASP_SOURCES
from tognet.policies.config import ActionSearchConfig
from tognet.policies.view import ActionPick, GraspPick, SceneView


@dataclass(frozen=True)
class SearchResult:
    """The search's answer for each grasp it refined, best first: indices into the candidates, the
    actions (R, 4), their predicted success Q_T|G,a (R,), Q_G (R,), and the rating of every candidate
    (Q_G times its best rating action's success, (N,))."""

    index: NDArray[np.intp]
    actions: NDArray[np.float64]
    q_t_given_ga: NDArray[np.float64]
    q_g: NDArray[np.float64]
    rating: NDArray[np.float64]

    @property
    def q_t(self) -> NDArray[np.float64]:
        """Q_T = Q_G * Q_T|G,a of each refined pair."""
        return self.q_g * self.q_t_given_ga


def _order(scores: Any, config: ActionSearchConfig) -> NDArray[np.float64]:
    """How actions are ranked: predicted success, less ``pessimism`` times the members' spread, plus
    ``progress_weight`` times the predicted progress."""
    return (np.asarray(scores.success, np.float64) - config.pessimism * np.asarray(scores.spread, np.float64)
            + config.progress_weight * np.asarray(scores.progress, np.float64))


def _bounds(mean: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64],
            config: ActionSearchConfig) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per candidate (N, 4) lower and upper bounds of the search: the box, or its trust region."""
    n = len(mean)
    if config.trust_region <= 0:
        return np.broadcast_to(low, (n, 4)).copy(), np.broadcast_to(high, (n, 4)).copy()
    half = config.trust_region * np.asarray(config.local_std)
    return np.maximum(mean - half, low), np.minimum(mean + half, high)


def rate_candidates(model: Any, crops: NDArray[np.float32], z: NDArray[np.float32], low: NDArray[np.float64],
                    high: NDArray[np.float64], config: ActionSearchConfig, rng: np.random.Generator
                    ) -> tuple[Any, NDArray[np.float64], NDArray[np.float64], tuple[NDArray[np.float64],
                                                                                   NDArray[np.float64]]]:
    """Encode N candidates and rate each on ``rate_samples`` actions: (encoded inputs, the best rating
    action per candidate (N, 4), its predicted success (N,), the per-candidate search bounds); Q_G is in
    the encoded inputs."""
    enc = model.encode(crops, z)
    n = len(enc)
    k = max(1, config.rate_samples)
    local_share = 1.0 if config.trust_region > 0 else config.local_fraction
    k_local = min(k - 1, int(round((k - 1) * local_share)))
    k_box = k - 1 - k_local
    mean = np.clip(enc.action_mean.astype(np.float64), low, high)
    lo, hi = _bounds(mean, low, high, config)
    local = mean[:, None, :] + rng.standard_normal((n, k_local, 4)) * np.asarray(config.local_std)
    box = np.broadcast_to(rng.uniform(low, high, (k_box, 4)), (n, k_box, 4))
    actions = np.clip(np.concatenate([mean[:, None, :], local, box], axis=1), lo[:, None], hi[:, None])
    scores = model.score_actions(enc, actions)
    best = _order(scores, config).argmax(axis=1)
    rows = np.arange(n)
    return enc, actions[rows, best], scores.success[rows, best].astype(np.float64), (lo, hi)


def refine_actions(model: Any, enc: Any, rows: NDArray[np.intp], start: NDArray[np.float64],
                   low: NDArray[np.float64], high: NDArray[np.float64], config: ActionSearchConfig,
                   rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cross-entropy search of the action for the encoded candidates ``rows`` (M,), each started at its
    ``start`` action (M, 4), within per-row bounds ``low``/``high`` (M, 4): the best action found per
    row (M, 4) and its predicted success (M,)."""
    m = len(rows)
    mu = np.asarray(start, np.float64).copy()
    low, high = np.broadcast_to(low, (m, 4)), np.broadcast_to(high, (m, 4))
    std = np.maximum((high - low) / 4.0, np.asarray(config.min_std))
    best_a = mu.copy()
    s0 = model.score_actions(enc, mu[:, None, :], rows)
    best_s, best_o = s0.success[:, 0].astype(np.float64), _order(s0, config)[:, 0]
    n_elite = max(2, int(round(config.samples * config.elite_fraction)))
    floor = np.asarray(config.min_std)
    for _ in range(max(0, config.iterations)):
        draws = np.clip(mu[:, None, :] + rng.standard_normal((m, config.samples, 4)) * std[:, None, :],
                        low[:, None], high[:, None])
        draws[:, 0] = best_a  # the best so far stays in the running
        scores = model.score_actions(enc, draws, rows)
        success, order = scores.success, _order(scores, config)
        top = np.argsort(-order, axis=1)[:, :n_elite]
        elite = np.take_along_axis(draws, top[:, :, None], axis=1)
        mu, std = elite.mean(axis=1), np.maximum(elite.std(axis=1), floor)
        first = top[:, 0]
        r = np.arange(m)
        better = order[r, first] > best_o
        best_a[better] = draws[r, first][better]
        best_s[better] = success[r, first][better]
        best_o[better] = order[r, first][better]
        last = np.take_along_axis(draws, np.argsort(-order, axis=1)[:, : config.robust_candidates, None],
                                  axis=1)
    if config.robust_samples > 0 and config.iterations > 0:
        pool = np.concatenate([best_a[:, None], last], axis=1)  # (M, C, 4), the best so far first
        best_a, best_s = _robust_choice(model, enc, rows, pool, low, high, config, rng)
    return best_a, best_s


def _robust_choice(model: Any, enc: Any, rows: NDArray[np.intp], pool: NDArray[np.float64],
                   low: NDArray[np.float64], high: NDArray[np.float64], config: ActionSearchConfig,
                   rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Of each row's candidate actions ``pool`` (M, C, 4), the one whose order score averaged over
    ``robust_samples`` perturbations (the same ones for every candidate) is highest; (M, 4) and the
    averaged success (M,)."""
    m, c, _ = pool.shape
    k = config.robust_samples
    noise = rng.standard_normal((k, 4)) * np.asarray(config.robust_std)
    shaken = np.clip(pool[:, :, None, :] + noise[None, None], low[:, None, None], high[:, None, None])
    scores = model.score_actions(enc, shaken.reshape(m, c * k, 4), rows)
    order = _order(scores, config).reshape(m, c, k).mean(axis=2)
    success = np.asarray(scores.success, np.float64).reshape(m, c, k).mean(axis=2)
    pick = order.argmax(axis=1)
    r = np.arange(m)
    return pool[r, pick], success[r, pick]


def search(model: Any, crops: NDArray[np.float32], z: NDArray[np.float32], low: NDArray[np.float64],
           high: NDArray[np.float64], config: ActionSearchConfig, rng: np.random.Generator) -> SearchResult:
    """Rate every candidate by its best action, refine the actions of the best-rated ones and return
    them ranked by Q_G * Q_T|G,a (see the module docstring)."""
    low, high = np.asarray(low, np.float64), np.asarray(high, np.float64)
    enc, rate_a, rate_s, (lo, hi) = rate_candidates(model, crops, z, low, high, config, rng)
    q_g = enc.q_g.astype(np.float64)
    rating = q_g * rate_s
    rows = np.argsort(-rating, kind="stable")[: max(1, config.refine_grasps)]
    acts, success = refine_actions(model, enc, rows, rate_a[rows], lo[rows], hi[rows], config, rng)
    value = q_g[rows] * success
    order = np.argsort(-value, kind="stable")
    return SearchResult(rows[order], acts[order], success[order], q_g[rows][order], rating)


def best_actions(model: Any, crops: NDArray[np.float32], z: NDArray[np.float32], low: NDArray[np.float64],
                 high: NDArray[np.float64], config: ActionSearchConfig, rng: np.random.Generator
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The searched action of each of N given grasps (rated, then refined): (N, 4) and Q_T|G,a (N,)."""
    low, high = np.asarray(low, np.float64), np.asarray(high, np.float64)
    if len(crops) == 0:
        return np.zeros((0, 4)), np.zeros(0)
    enc, rate_a, _, (lo, hi) = rate_candidates(model, crops, z, low, high, config, rng)
    return refine_actions(model, enc, np.arange(len(enc)), rate_a, lo, hi, config, rng)


class ActionSearchGrasps:
    """Grasp policy: the learned action search's grasp for the scene (searched once per scene, cached on
    the view with its action, the same grasp for every call on that scene)."""

    def __init__(self, model: Any, config: ActionSearchConfig) -> None:
        self.model = model
        self.config = config

    def result(self, view: SceneView, rng: np.random.Generator) -> tuple[NDArray[np.float64], SearchResult]:
        """The scene's candidates and the search over them (cached on the view)."""
        key = f"action_search_{id(self.model)}"
        if key not in view.cache:
            task = view.task
            if task is None:
                raise ValueError("the action search needs a task (the grasp-only task has no actions)")
            grasps = view.candidates.grasps
            crops, z = view.crops(grasps)
            view.cache[key] = (grasps, search(self.model, crops, z, task.action_low, task.action_high,
                                              self.config, rng))
        return view.cache[key]

    def ranked(self, view: SceneView, rng: np.random.Generator) -> GraspPick:
        """The grasps the search refined (best Q_T first), then every other candidate by its rating: what
        an arm's reach check falls back on (:mod:`tognet.planning.reach`)."""
        grasps, res = self.result(view, rng)
        rest = np.argsort(-res.rating, kind="stable")
        rest = rest[~np.isin(rest, res.index)]
        order = np.concatenate([res.index, rest]).astype(np.intp)
        score = np.concatenate([res.q_t, res.rating[rest]]).astype(np.float32)
        return GraspPick(grasps[order].copy(), np.full(len(order), GRASP_SOURCES["search"], np.int8), score)

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasps, res = self.result(view, rng)
        best = grasps[res.index[0]]
        return GraspPick(np.repeat(best[None], n, axis=0), np.full(n, GRASP_SOURCES["search"], np.int8),
                         np.full(n, res.q_t[0], np.float32))


class SearchCandidateGrasps(ActionSearchGrasps):
    """Grasp policy for collection: the action search's ``count`` best candidates of the scene (each
    refined, best Q_T first), trial i taking the (i mod count)-th: the grasps the search nearly chose, so
    that its ranking within a scene learns from their outcomes. Shares the search's cache with
    :class:`ActionSearchActions`, which then executes each with its own searched action."""

    def __init__(self, model: Any, config: ActionSearchConfig, count: int) -> None:
        super().__init__(model, replace(config, refine_grasps=max(config.refine_grasps, count)))
        self.count = count

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasps, res = self.result(view, rng)
        pick = np.arange(n) % max(1, min(self.count, len(res.index)))
        return GraspPick(grasps[res.index[pick]].copy(), np.full(n, GRASP_SOURCES["search"], np.int8),
                         res.q_t[pick].astype(np.float32))


class ActionSearchActions:
    """Action policy: for each grasp the learned action search's action (the scene's search's own action
    for its grasp, else a search over that grasp's actions), plus N(0, noise^2) per dimension, clipped to
    the task's box (noise zero when planning)."""

    def __init__(self, model: Any, config: ActionSearchConfig,
                 noise: tuple[float, ...] | NDArray[np.float64] = (0.0,) * 4) -> None:
        self.model = model
        self.config = config
        self.noise = np.asarray(noise, dtype=np.float64)

    def searched(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator
                 ) -> NDArray[np.float64]:
        """The searched action of each grasp (N, 4), before noise."""
        task = view.task
        if task is None:
            raise ValueError("the action search needs a task (the grasp-only task has no actions)")
        acts = np.zeros((len(grasps), 4))
        todo = np.ones(len(grasps), bool)
        cached = view.cache.get(f"action_search_{id(self.model)}")
        if cached is not None:  # the scene's search already holds an action for its grasps
            cands, res = cached
            for row, act in zip(res.index, res.actions, strict=True):
                same = todo & np.all(grasps == cands[row], axis=1)
                acts[same], todo[same] = act, False
        if todo.any():
            uniq, inverse = np.unique(grasps[todo], axis=0, return_inverse=True)
            crops, z = view.crops(uniq)
            found, _ = best_actions(self.model, crops, z, task.action_low, task.action_high, self.config, rng)
            acts[todo] = found[inverse.reshape(-1)]
        return acts

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        assert view.task is not None
        acts = self.searched(view, grasps, rng) + rng.standard_normal((len(grasps), 4)) * self.noise
        acts = np.clip(acts, view.task.action_low, view.task.action_high)
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["search"], np.int8))
