"""The low-confidence calibration (tognet.evaluate.confidence): isotonic fit and warning threshold."""

import json
import math

import numpy as np
import pytest

from tognet.evaluate.confidence import ALWAYS, isotonic_fit, score_auc, warn_limit, warn_threshold


def test_a_monotone_step_is_fitted_as_one():
    scores = [0.6, 0.1, 0.5, 0.2, 0.4, 0.3]  # any order in
    fit = isotonic_fit(scores, [1, 0, 1, 0, 1, 0])
    assert fit.lower.tolist() == [0.1, 0.4] and fit.upper.tolist() == [0.3, 0.6]
    assert fit.rate.tolist() == [0, 1] and fit.count.tolist() == [3, 3]


def test_an_increasing_sequence_keeps_its_steps():
    fit = isotonic_fit([0.1, 0.2, 0.2, 0.3, 0.4, 0.4, 0.4, 0.4], [0, 1, 0, 1, 1, 1, 1, 1])
    assert fit.lower.tolist() == [0.1, 0.2, 0.3] and fit.upper.tolist() == [0.1, 0.2, 0.4]
    assert fit.rate.tolist() == [0.0, 0.5, 1.0] and fit.count.tolist() == [1, 2, 5]


def test_a_known_step_gives_its_threshold():
    rng = np.random.default_rng(0)
    scores = rng.permutation(np.linspace(0.0, 1.0, 40))
    wins = scores >= 0.6
    out = warn_threshold(scores, wins)
    assert out["warn_below"] == pytest.approx(scores[wins].min())
    assert out["below"] == {"n": int((~wins).sum()), "success": 0.0}
    assert out["above"] == {"n": int(wins.sum()), "success": 1.0}
    assert out["successes_warned"] == 0.0 and out["failures_warned"] == 1.0
    assert out["scenes"] == 40 and out["success"] == pytest.approx(wins.mean())


def test_violations_are_pooled():
    # success rates by score 0.5, 0, 1, 0.5, 1: the second pair (0 after 0.5) and the fourth (0.5 after 1)
    # violate monotonicity and are pooled with their left neighbours
    scores = [1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
    wins = [1, 0, 0, 0, 1, 1, 1, 0, 1, 1]
    fit = isotonic_fit(scores, wins)
    assert fit.lower.tolist() == [1, 3, 5] and fit.upper.tolist() == [2, 4, 5]
    assert fit.rate.tolist() == pytest.approx([0.25, 0.75, 1.0])
    assert fit.count.tolist() == [4, 4, 2]
    assert warn_limit(fit, 0.5, min_plans=1) == 3
    out = warn_threshold(scores, wins, min_plans=6)
    assert out["warn_below"] == 3.0
    assert out["below"] == {"n": 4, "success": 0.25}
    assert out["above"] == {"n": 6, "success": pytest.approx(5 / 6)}
    assert out["successes_warned"] == pytest.approx(1 / 6) and out["failures_warned"] == pytest.approx(3 / 4)


def test_a_fit_is_never_decreasing_and_keeps_the_counts():
    rng = np.random.default_rng(3)
    scores = rng.random(500)
    wins = rng.random(500) < scores ** 2
    fit = isotonic_fit(scores, wins)
    assert np.all(np.diff(fit.rate) > 0) and np.all(fit.lower <= fit.upper)
    assert np.all(fit.upper[:-1] < fit.lower[1:])
    assert fit.count.sum() == 500
    assert (fit.rate * fit.count).sum() == pytest.approx(wins.sum())


def test_tied_scores_share_a_block():
    fit = isotonic_fit([0.3, 0.3, 0.3, 0.7], [1, 0, 0, 1])
    assert fit.lower.tolist() == [0.3, 0.7] and fit.count.tolist() == [3, 1]
    assert warn_threshold([0.3, 0.3, 0.3, 0.7], [1, 0, 0, 1], min_plans=1)["warn_below"] == 0.7


def test_all_fail_always_warns():
    out = warn_threshold([0.1, 0.5, 0.9], [False, False, False])
    assert out["warn_below"] == ALWAYS and warn_limit(isotonic_fit([0.1, 0.5, 0.9], [0, 0, 0])) == math.inf
    assert out["below"] == {"n": 3, "success": 0.0} and out["above"] == {"n": 0, "success": None}
    assert out["successes_warned"] is None and out["failures_warned"] == 1.0
    assert json.loads(json.dumps(out))["warn_below"] == "always"


def test_all_succeed_never_warns():
    out = warn_threshold([0.1, 0.5, 0.9], [True, True, True], min_plans=1)
    assert out["warn_below"] is None
    assert out["below"] == {"n": 0, "success": None} and out["above"] == {"n": 3, "success": 1.0}
    assert out["successes_warned"] == 0.0 and out["failures_warned"] is None


def test_the_level_moves_the_threshold():
    scores = [1, 2, 3, 4]
    wins = [0, 1, 0, 1]  # pooled: 0 | 0.5 (2, 3) | 1
    assert warn_threshold(scores, wins, 0.5, min_plans=1)["warn_below"] == 2.0
    assert warn_threshold(scores, wins, 0.6, min_plans=1)["warn_below"] == 4.0
    assert warn_threshold(scores, wins, 0.0, min_plans=1)["warn_below"] is None
    assert warn_threshold(scores, wins, 0.6, min_plans=2)["warn_below"] == ALWAYS  # one plan from 4 on


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError):
        warn_threshold([], [])
    with pytest.raises(ValueError):
        warn_threshold([0.1, 0.2], [1])
    with pytest.raises(ValueError):
        warn_threshold([0.1, float("nan")], [1, 0])
    with pytest.raises(ValueError):
        warn_threshold([0.1], [2])
    with pytest.raises(ValueError):
        warn_threshold([0.1], [1], level=1.5)


def test_score_auc():
    assert score_auc([1, 2, 3, 4], [0, 0, 1, 1]) == 1.0
    assert score_auc([1, 2, 3, 4], [1, 1, 0, 0]) == 0.0
    assert score_auc([1, 1, 1, 1], [1, 0, 1, 0]) == 0.5
    assert score_auc([1, 2], [1, 1]) is None


def test_a_level_reached_on_a_few_plans_only_sets_no_threshold():
    """Two lucky successes at the top of the range: the fit reaches one half only on them, too few to set
    a threshold (every plan warns); with ten such plans it does."""
    scores = np.linspace(0.0, 1.0, 100)
    few = np.r_[np.zeros(98), 1, 1]
    assert warn_threshold(scores, few)["warn_below"] == "always"
    assert warn_threshold(scores, few, min_plans=2)["warn_below"] == pytest.approx(scores[98])
    ten = np.r_[np.zeros(90), np.ones(10)]
    assert warn_threshold(scores, ten)["warn_below"] == pytest.approx(scores[90])
