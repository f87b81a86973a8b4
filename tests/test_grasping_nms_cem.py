"""Non-maximum suppression and the cross-entropy method."""

import numpy as np
import pytest

from tognet.grasping import (
    AntipodalConfig,
    CEMConfig,
    NMSConfig,
    angle_difference,
    cem,
    fit_gmm,
    grasp_distances,
    nms,
    sample_antipodal,
)
from tognet.grasping.synthetic import Box, render_depth, t_shape, tilted_camera


def _random_grasps(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    g = np.column_stack(
        [rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(0.01, 0.03, n), rng.uniform(0, 2 * np.pi, n)]
    )
    return g, rng.random(n)


@pytest.mark.parametrize("symmetric", [True, False])
def test_nms_output_is_pairwise_separated_ranked_and_maximal(symmetric):
    grasps, scores = _random_grasps(300, 1)
    config = NMSConfig(symmetric_jaw=symmetric)
    keep = nms(grasps, scores, config)
    assert keep.size > 5
    assert np.all(np.diff(scores[keep]) <= 0)
    assert keep[0] == np.argmax(scores)
    d = grasp_distances(grasps[keep], config)
    np.fill_diagonal(d, np.inf)
    assert d.min() >= config.radius
    # Maximal: every dropped grasp is within the radius of a kept grasp that scores at least as high.
    dropped = np.setdiff1d(np.arange(len(grasps)), keep)
    full = grasp_distances(grasps, config)
    for i in dropped:
        near = keep[(full[i, keep] < config.radius) & (scores[keep] >= scores[i])]
        assert near.size > 0


def test_nms_jaw_symmetry_and_limits():
    g = np.array([[0.0, 0.0, 0.02, 0.1], [0.0, 0.0, 0.02, 0.1 + np.pi], [0.2, 0.0, 0.02, 0.0]])
    s = np.array([0.9, 0.8, 0.1])
    np.testing.assert_array_equal(nms(g, s, NMSConfig()), [0, 2])
    np.testing.assert_array_equal(nms(g, s, NMSConfig(symmetric_jaw=False)), [0, 1, 2])
    np.testing.assert_array_equal(nms(g, s, NMSConfig(max_keep=1)), [0])
    np.testing.assert_array_equal(nms(g, s, NMSConfig(min_score=0.5)), [0])
    assert nms(np.zeros((0, 4)), np.zeros(0), NMSConfig()).shape == (0,)
    with pytest.raises(ValueError, match="scores"):
        nms(g, s[:2], NMSConfig())
    with pytest.raises(ValueError, match="finite"):
        nms(g, np.array([np.nan, 0, 0]), NMSConfig())
    np.testing.assert_allclose(angle_difference(0.1, 2 * np.pi - 0.1), 0.2)
    np.testing.assert_allclose(angle_difference(0.1, np.pi + 0.1, np.pi), 0.0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nms_leaves_10_to_30_modes_on_a_tool(seed):
    rng = np.random.default_rng(seed)
    camera = tilted_camera(0.9, tilt=(rng.uniform(-0.04, 0.04), rng.uniform(-0.04, 0.04)))
    depth = render_depth(camera, t_shape(0.0, 0.0, rng.uniform(0, 2 * np.pi)))
    cands = sample_antipodal(depth, camera, AntipodalConfig(), rng)
    keep = nms(cands.grasps, cands.quality, NMSConfig())
    assert 10 <= keep.size <= 30


def _peak_score(target: np.ndarray, sigma: float = 0.02):
    def score(g: np.ndarray) -> np.ndarray:
        d2 = np.sum((g[:, :3] - target[:3]) ** 2, axis=1) / sigma**2
        return np.exp(-0.5 * d2) * (0.5 + 0.5 * np.cos(g[:, 3] - target[3]))

    return score


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_cem_finds_the_maximum_of_a_known_function(seed):
    rng = np.random.default_rng(seed)
    target = np.array([0.06, -0.04, 0.02, 0.05])  # phi near 0: the search must wrap around 2 pi
    score = _peak_score(target)
    initial = np.column_stack(
        [rng.uniform(-0.15, 0.15, (200, 2)), rng.uniform(0.0, 0.04, 200), rng.uniform(0, 2 * np.pi, 200)]
    )
    result = cem(score, initial, CEMConfig(components=1, snap_to_candidates=False), rng)
    assert result.grasps.shape == (200 + 3 * 64, 4) and result.scores.shape == (392,)
    np.testing.assert_array_equal(np.bincount(result.iteration), [200, 64, 64, 64])
    assert result.best_score == pytest.approx(score(result.best[None])[0])
    assert result.best_score >= score(initial).max()
    assert np.linalg.norm(result.best[:3] - target[:3]) < 0.015
    assert angle_difference(result.best[3], target[3]) < 0.35
    assert result.best_score > 0.7


def test_cem_prefers_the_higher_of_two_modes():
    rng = np.random.default_rng(5)
    a, b = np.array([0.08, 0.0, 0.02, 1.0]), np.array([-0.08, 0.0, 0.02, 4.0])

    def score(g: np.ndarray) -> np.ndarray:
        return 0.6 * _peak_score(a)(g) + 1.0 * _peak_score(b)(g)

    initial = np.column_stack(
        [rng.uniform(-0.15, 0.15, (200, 2)), rng.uniform(0.0, 0.04, 200), rng.uniform(0, 2 * np.pi, 200)]
    )
    result = cem(score, initial, CEMConfig(snap_to_candidates=False), rng)
    assert np.linalg.norm(result.best[:2] - b[:2]) < 0.02
    assert angle_difference(result.best[3], b[3]) < 0.5
    assert result.best_score > 0.8  # near the higher peak's value (1.0), above the lower one's (0.6)


def test_cem_snapped_to_candidates_only_evaluates_candidates():
    rng = np.random.default_rng(3)
    target = np.array([0.03, -0.02, 0.02, 2.0])
    initial = np.column_stack(
        [rng.uniform(-0.15, 0.15, (200, 2)), rng.uniform(0.0, 0.04, 200), rng.uniform(0, 2 * np.pi, 200)]
    )
    score = _peak_score(target)
    result = cem(score, initial, CEMConfig(), rng)
    # every evaluated grasp is one of the initial candidates, and the best is the best candidate
    d = np.abs(result.grasps[:, None, :] - initial[None, :, :]).sum(-1).min(axis=1)
    assert np.all(d < 1e-12)
    assert result.best_score == pytest.approx(score(initial).max())
    # the later iterations concentrate on the best candidates (most samples near the peak)
    late = result.grasps[result.iteration == 3]
    assert np.median(np.linalg.norm(late[:, :2] - target[:2], axis=1)) < np.median(
        np.linalg.norm(initial[:, :2] - target[:2], axis=1))


def test_cem_snapped_to_candidates_scores_each_candidate_once():
    rng = np.random.default_rng(4)
    initial = np.column_stack([rng.uniform(-0.1, 0.1, (120, 2)), np.full(120, 0.02), rng.uniform(0, 6, 120)])
    calls = []

    def score(g):
        calls.append(len(g))
        return _peak_score(np.array([0.0, 0.0, 0.02, 1.0]))(g)

    result = cem(score, initial, CEMConfig(), rng)
    assert calls == [120]  # the samples are candidates: their scores are looked up, not recomputed
    np.testing.assert_array_equal(result.scores, score(result.grasps))


def test_cem_bad_inputs():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="initial"):
        cem(lambda g: g[:, 0], np.zeros((0, 4)), CEMConfig(), rng)
    with pytest.raises(ValueError, match="scores"):
        cem(lambda g: g[:1, 0], np.zeros((5, 4)), CEMConfig(), rng)
    clipped = cem(lambda g: -np.abs(g[:, 2]), np.full((10, 4), 0.02), CEMConfig(z_bounds=(0.01, 0.03)), rng)
    assert np.all((clipped.grasps[:, 2] >= 0.01) & (clipped.grasps[:, 2] <= 0.03))


def test_fit_gmm_recovers_two_clusters():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.normal([0, 0], 0.1, (200, 2)), rng.normal([3, 1], 0.2, (100, 2))])
    gmm = fit_gmm(x, 2, rng)
    order = np.argsort(gmm.means[:, 0])
    np.testing.assert_allclose(gmm.means[order], [[0, 0], [3, 1]], atol=0.08)
    np.testing.assert_allclose(gmm.weights[order], [2 / 3, 1 / 3], atol=0.05)
    samples = gmm.sample(3000, rng)
    assert abs(np.mean(samples[:, 0] > 1.5) - 1 / 3) < 0.05


def test_nms_on_box_keeps_grasps_along_its_length():
    camera = tilted_camera(0.9)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.3, 0.03, 0.03), 0.0)])
    cands = sample_antipodal(depth, camera, AntipodalConfig(), np.random.default_rng(0))
    keep = nms(cands.grasps, cands.quality, NMSConfig())
    xs = np.sort(cands.grasps[keep, 0])
    assert xs[0] < -0.1 and xs[-1] > 0.1  # spread over the 0.3 m length, not clustered


@pytest.mark.parametrize("symmetric", [False, True])
def test_cem_mixture_wraps_the_angle_around_2pi(symmetric):
    # Elites straddle phi = 0: half just above 0, half just below 2 pi (or pi, for a symmetric jaw).
    # A single Gaussian fit on the raw angle would put the mean near pi (pi / 2): the wrong side.
    rng = np.random.default_rng(3)
    period = np.pi if symmetric else 2 * np.pi
    target = np.array([0.0, 0.0, 0.02, 0.0])

    def score(g: np.ndarray) -> np.ndarray:  # sharp in angle, peak at phi = 0 (mod period)
        da = angle_difference(g[:, 3], target[3], period)
        return np.exp(-np.sum((g[:, :3] - target[:3]) ** 2, axis=1) / 0.02**2) * np.exp(-((da / 0.1) ** 2))

    phi = np.mod(rng.uniform(-0.3, 0.3, 200), period)
    initial = np.column_stack([np.zeros((200, 2)), np.full(200, 0.02), phi])
    result = cem(score, initial, CEMConfig(components=1, symmetric_jaw=symmetric), rng)
    later = result.grasps[result.iteration == 1]  # sampled from the fit on the straddling elites
    # Without the circle (or, for a symmetric jaw, without doubling the angle) about 20 % or more of
    # these samples land far from phi = 0.
    assert np.mean(angle_difference(later[:, 3], 0.0, period) < 0.25) >= 0.97
    assert angle_difference(result.best[3], 0.0, period) < 0.05
