"""Evaluation metrics per head: ROC-AUC, accuracy, calibration (ECE), action error. Pure numpy."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.stats import rankdata


def roc_auc(labels: np.ndarray, scores: np.ndarray) -> float | None:
    """Area under the ROC curve (Mann-Whitney U, ties counted half); None if only one class is present."""
    labels = np.asarray(labels).astype(bool)
    scores = np.asarray(scores, dtype=np.float64)
    n_pos = int(labels.sum())
    n_neg = labels.size - n_pos
    if n_pos == 0 or n_neg == 0:
        return None
    ranks = rankdata(scores)
    return float((ranks[labels].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def accuracy(labels: np.ndarray, probs: np.ndarray, threshold: float = 0.5) -> float | None:
    """Fraction of episodes where (prob >= threshold) equals the label; None for no episodes."""
    labels = np.asarray(labels).astype(bool)
    if labels.size == 0:
        return None
    return float(((np.asarray(probs) >= threshold) == labels).mean())


def expected_calibration_error(labels: np.ndarray, probs: np.ndarray, bins: int = 10) -> float | None:
    """ECE: mean over equal-width probability bins of |accuracy - confidence|, weighted by bin size."""
    labels = np.asarray(labels, dtype=np.float64)
    probs = np.asarray(probs, dtype=np.float64)
    if labels.size == 0:
        return None
    which = np.clip((probs * bins).astype(int), 0, bins - 1)
    ece = 0.0
    for b in range(bins):
        sel = which == b
        if sel.any():
            ece += sel.mean() * abs(labels[sel].mean() - probs[sel].mean())
    return float(ece)


def within_scene_auc(scene: np.ndarray, labels: np.ndarray, scores: np.ndarray) -> tuple[float | None, int]:
    """The share of (success, failure) pairs of one scene where the success scores higher (ties half),
    over all such pairs of all scenes, and their number: how well a score ranks the candidates a planner
    compares. (None, 0) when no scene has both outcomes."""
    scene = np.asarray(scene)
    labels = np.asarray(labels).astype(bool)
    scores = np.asarray(scores, dtype=np.float64)
    wins = pairs = 0.0
    order = np.argsort(scene, kind="stable")
    bounds = np.flatnonzero(np.diff(scene[order])) + 1
    for rows in np.split(order, bounds):
        y, x = labels[rows], scores[rows]
        if y.any() and not y.all():
            d = x[y][:, None] - x[~y][None, :]
            wins += (d > 0).sum() + 0.5 * (d == 0).sum()
            pairs += d.size
    return (float(wins / pairs), int(pairs)) if pairs else (None, 0)


def binary_metrics(labels: np.ndarray, probs: np.ndarray) -> dict[str, Any]:
    """AUC, accuracy, ECE, positive rate and count for one head."""
    labels = np.asarray(labels)
    return {
        "auc": roc_auc(labels, probs),
        "accuracy": accuracy(labels, probs),
        "ece": expected_calibration_error(labels, probs),
        "positive_rate": float(labels.mean()) if labels.size else None,
        "count": int(labels.size),
    }


def head_metrics(
    q_g: np.ndarray,
    q_tg: np.ndarray,
    action_pred: np.ndarray,
    grasp_success: np.ndarray,
    task_success: np.ndarray,
    action: np.ndarray,
    scene: np.ndarray | None = None,
) -> dict[str, Any]:
    """Metrics of the three heads: ``grasp`` (Q_G on all episodes), ``task_given_grasp`` (Q_T|G on
    episodes with S_G = 1), ``task`` (Q_T = Q_T|G * Q_G on all episodes; with ``scene`` keys also its
    ``scene_auc``, :func:`within_scene_auc`) and ``action`` (error of the predicted mean on episodes with
    S_T = 1, per dim: mean absolute error and RMSE, stored units)."""
    s_g = np.asarray(grasp_success).astype(bool)
    s_t = np.asarray(task_success).astype(bool)
    out: dict[str, Any] = {
        "grasp": binary_metrics(s_g, q_g),
        "task_given_grasp": binary_metrics(s_t[s_g], q_tg[s_g]),
        "task": binary_metrics(s_t, q_g * q_tg),
    }
    if scene is not None:
        out["task"]["scene_auc"], out["task"]["scene_pairs"] = within_scene_auc(scene, s_t, q_g * q_tg)
    if s_t.any():
        err = action_pred[s_t] - action[s_t]
        out["action"] = {
            "mae": np.abs(err).mean(0).tolist(),
            "rmse": np.sqrt((err**2).mean(0)).tolist(),
            "count": int(s_t.sum()),
        }
    else:
        out["action"] = {"mae": None, "rmse": None, "count": 0}
    return out
