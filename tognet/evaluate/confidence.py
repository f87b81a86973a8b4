"""Calibrating a method's low-confidence warning: where its plans' success, as a function of its own score,
reaches a level (one half: a plan warns unless plans of its score succeed more often than not).

The success rate is fitted as a non-decreasing step function of the score by isotonic regression (pool
adjacent violators, :func:`isotonic_fit`; plans of equal score always share a block, and so do neighbouring
blocks of equal rate, so that the blocks are as few as the step function allows), and the warning
threshold is the lowest score from which the fitted rate reaches the level, over at least
:data:`MIN_PLANS` plans (:func:`warn_threshold`).
Pure numpy; ``benchmarks/calibrate_confidence.py`` fits the shipped models' thresholds with it
(``tognet/models/confidence.json``, read by :mod:`tognet.planning.confidence`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: ``warn_below`` in JSON when the fit never reaches the level: every plan warns.
ALWAYS = "always"


@dataclass(frozen=True)
class IsotonicFit:
    """A non-decreasing step function of the score: block ``i`` covers the observed scores
    ``lower[i]``..``upper[i]`` (both included), holds ``count[i]`` plans and has success rate ``rate[i]``."""

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    rate: NDArray[np.float64]
    count: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.rate)


def _checked(scores: ArrayLike, successes: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Scores and successes as float arrays of the same non-zero length (ValueError otherwise)."""
    s = np.asarray(scores, dtype=np.float64).reshape(-1)
    y = np.asarray(successes, dtype=np.float64).reshape(-1)
    if len(s) != len(y):
        raise ValueError(f"{len(s)} scores but {len(y)} successes")
    if len(s) == 0:
        raise ValueError("no plans to fit")
    if not np.all(np.isfinite(s)):
        raise ValueError("scores must be finite")
    if not np.all((y == 0) | (y == 1)):
        raise ValueError("successes must be 0/1 or booleans")
    return s, y


def _tied_groups(s: NDArray[np.float64], y: NDArray[np.float64]) -> list[list[float]]:
    """One ``[successes, count, lowest, highest]`` per distinct score, in increasing score."""
    values, inverse = np.unique(s, return_inverse=True)
    wins = np.bincount(inverse, weights=y, minlength=len(values))
    counts = np.bincount(inverse, minlength=len(values)).astype(np.float64)
    return [[float(w), float(n), float(v), float(v)] for w, n, v in zip(wins, counts, values, strict=True)]


def isotonic_fit(scores: ArrayLike, successes: ArrayLike) -> IsotonicFit:
    """The success rate as a non-decreasing function of the score, by pool-adjacent-violators: blocks of
    adjacent scores whose rates would decrease are pooled (their rate: their plans' success rate), and so
    are neighbours of equal rate (the same function in fewer blocks: each block's rate above the last's)."""
    s, y = _checked(scores, successes)
    blocks: list[list[float]] = []
    for group in _tied_groups(s, y):
        blocks.append(group)
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] >= blocks[-1][0] / blocks[-1][1]:
            wins, count, _, high = blocks.pop()
            blocks[-1][0] += wins
            blocks[-1][1] += count
            blocks[-1][3] = high
    b = np.array(blocks, dtype=np.float64)
    return IsotonicFit(lower=b[:, 2], upper=b[:, 3], rate=b[:, 0] / b[:, 1], count=b[:, 1].astype(np.int64))


#: Plans at or above a threshold at the least: a fitted rate that reaches the level only on fewer plans
#: (one or two lucky successes at the top of the score's range) sets no threshold.
MIN_PLANS = 10


def warn_limit(fit: IsotonicFit, level: float = 0.5, min_plans: int = MIN_PLANS) -> float:
    """The lowest score from which ``fit``'s rate is >= ``level`` (its first such block's lowest score);
    +inf when no block reaches it, or when the blocks from there on hold fewer than ``min_plans`` plans."""
    reached = np.flatnonzero(fit.rate >= level)
    if not len(reached) or int(fit.count[reached[0]:].sum()) < min_plans:
        return math.inf
    return float(fit.lower[reached[0]])


def _rate(y: NDArray[np.float64]) -> float | None:
    """The success rate of ``y`` (None for no plans)."""
    return float(y.mean()) if len(y) else None


def _share(mask: NDArray[np.bool_], among: NDArray[np.bool_]) -> float | None:
    """The share of ``among`` that ``mask`` holds (None when ``among`` is empty)."""
    return float(mask[among].mean()) if among.any() else None


def _json_limit(limit: float, lowest: float) -> float | str | None:
    """``warn_below`` as written: "always" for +inf, None (never warn) at or below the lowest score."""
    if math.isinf(limit):
        return ALWAYS
    return None if limit <= lowest else limit


def warn_threshold(scores: ArrayLike, successes: ArrayLike, level: float = 0.5, min_plans: int = MIN_PLANS
                   ) -> dict[str, Any]:
    """The warning threshold of plans scoring ``scores`` that succeeded as ``successes``, and how it splits
    them. ``warn_below``: plans scoring below it warn; "always" (every plan warns) when the fitted rate
    never reaches ``level`` (or only on fewer than ``min_plans`` plans), None (never warn) when it does from
    the lowest score on. Also ``scenes``, the
    overall ``success`` rate, ``below`` and ``above`` (``n`` plans below the threshold and at or above it,
    their ``success`` rate, None for none), and the shares of the successes and of the failures that would
    warn (``successes_warned``, ``failures_warned``; None when there are none)."""
    if not 0.0 <= level <= 1.0:
        raise ValueError(f"level must be in [0, 1], got {level}")
    s, y = _checked(scores, successes)
    limit = warn_limit(isotonic_fit(s, y), level, min_plans)
    warned = s < limit
    won = y == 1
    return {
        "warn_below": _json_limit(limit, float(s.min())),
        "scenes": len(s),
        "success": float(y.mean()),
        "below": {"n": int(warned.sum()), "success": _rate(y[warned])},
        "above": {"n": int((~warned).sum()), "success": _rate(y[~warned])},
        "successes_warned": _share(warned, won),
        "failures_warned": _share(warned, ~won),
    }


def score_auc(scores: ArrayLike, successes: ArrayLike) -> float | None:
    """The chance that a success scores above a failure (ties count one half): 0.5 for a score that says
    nothing of success, 1 for one that separates them; None without both successes and failures."""
    s, y = _checked(scores, successes)
    n_win = int(y.sum())
    n_fail = len(y) - n_win
    if n_win == 0 or n_fail == 0:
        return None
    values, inverse, counts = np.unique(s, return_inverse=True, return_counts=True)
    mid_rank = (np.cumsum(counts) - (counts - 1) / 2.0)[inverse]  # 1-based ranks, ties averaged
    return float((mid_rank[y == 1].sum() - n_win * (n_win + 1) / 2.0) / (n_win * n_fail))


__all__ = ["ALWAYS", "IsotonicFit", "isotonic_fit", "score_auc", "warn_limit", "warn_threshold"]
