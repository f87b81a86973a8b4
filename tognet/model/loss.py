"""The TOG-Net objective (paper, "Learning Objectives and Optimization").

Per episode i::

    L_i = CE(S_G, Q_G) + 1[S_G = 1] * CE(S_T, Q_T|G) + 1[S_T = 1] * 1/2 * ||f(o, g) - a||^2_Sigma

with ||d||^2_Sigma = sum_k (d_k / sigma_k)^2, Sigma = diag(sigma^2) constant (``LossConfig.action_sigma``),
and f, a in the stored action units (the network's normalised output is denormalised first). The paper's
text once writes the action term weighted by S_G, but its equation (and the policy-gradient argument
with task success as reward) uses 1[S_T = 1]; we follow the equation. S_T = 1 implies S_G = 1.

An action-conditioned task stream (``ArchConfig.task_head = "action"``, beyond the paper) adds a graded term:
``weight_progress * 1[S_G = 1, progress known] * CE(progress, P)`` (:func:`progress_sum`), P its predicted
progress; its Q_T|G is then Q_T|G,a at the trial's own action, so the task term is trained on every trial
that held the tool, failures included, as before.

A within-scene ranking term (``LossConfig.weight_rank``, beyond the paper; :func:`scene_rank_sum`): the
cross-entropies score each trial alone, but a planner only compares the candidates of one scene, so a model
can be well calibrated across scenes and still rank a scene's candidates badly. Over pairs (i, j) of one
scene with S_T,i = 1 and S_T,j = 0 it adds ``weight_rank * mean log(1 + exp(s_j - s_i))``, s = log Q_G +
log Q_T|G (members: log of their mean probability, as the planner averages them).

Reductions over a batch of N episodes:

- ``"batch"`` (default): each term is summed over its masked episodes and divided by N, i.e. the paper's
  sum over episodes scaled by 1/N; rare successes weigh as in the data.
- ``"masked"``: each term is the mean over its own masked subset (0 when the subset is empty).

The action angle a_phi is regressed as a plain number, without wrap-around. That is right for this action
space: a_phi is the start yaw *relative to the task's nominal yaw*, drawn from a small box around 0
(+-pi/20 for the random baseline, at most +-pi/4 for the action box), so targets never come near +-pi
where an angle would wrap. An action space spanning a full turn would need a periodic term instead
(e.g. regress (cos, sin) or use 1 - cos(d_phi)).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
import torch.nn.functional as F

from tognet.model.config import LossConfig


def masked_sums(
    q_g_logit: torch.Tensor,
    q_tg_logit: torch.Tensor,
    action_pred: torch.Tensor,
    grasp_success: torch.Tensor,
    task_success: torch.Tensor,
    action: torch.Tensor,
    action_sigma: Sequence[float],
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """Unweighted per-term sums over the batch and the mask sizes: (sum CE(S_G, Q_G) over every episode,
    sum CE(S_T, Q_T|G) over S_G = 1, sum 1/2 ||f - a||^2_Sigma over S_T = 1, #S_G=1, #S_T=1).

    The masked terms are computed on the selected rows only, so unselected episodes get exactly zero
    gradient even when their values are huge or not finite (0 * inf would be NaN). Shared by the training
    loss and the validation pass (which adds these sums up over many batches)."""
    m_g = grasp_success > 0.5
    m_t = task_success > 0.5
    sigma = torch.as_tensor(action_sigma, dtype=action_pred.dtype, device=action_pred.device)
    ce_g = F.binary_cross_entropy_with_logits(q_g_logit, grasp_success.to(q_g_logit.dtype), reduction="sum")
    ce_t = _member_ce(q_tg_logit[m_g], task_success[m_g])
    sq = 0.5 * (((action_pred[m_t] - action[m_t]) / sigma) ** 2).sum()
    return ce_g, ce_t, sq, m_g.sum().to(ce_g.dtype), m_t.sum().to(ce_g.dtype)


def tognet_loss(
    q_g_logit: torch.Tensor,
    q_tg_logit: torch.Tensor,
    action_pred: torch.Tensor,
    grasp_success: torch.Tensor,
    task_success: torch.Tensor,
    action: torch.Tensor,
    config: LossConfig | None = None,
    progress_logit: torch.Tensor | None = None,
    progress: torch.Tensor | None = None,
    scene: torch.Tensor | None = None,
) -> dict[str, torch.Tensor]:
    """The loss and its components (all scalars): ``loss``, ``grasp``, ``task``, ``action``, ``progress``,
    ``rank`` (weighted terms before summing; ``progress`` 0 without ``progress_logit``, ``rank`` 0 without
    ``scene`` or with ``weight_rank`` 0) and the mask sizes ``n_grasp_success``, ``n_task_success``.

    ``action_pred`` and ``action`` are (N, 4) in the same (stored) units.
    """
    config = config or LossConfig()
    n = max(int(grasp_success.shape[0]), 1)
    rank = torch.zeros((), dtype=q_g_logit.dtype, device=q_g_logit.device)
    if config.weight_rank > 0 and scene is not None:
        s_r, n_r = scene_rank_sum(q_g_logit, q_tg_logit, task_success, scene)
        rank = config.weight_rank * s_r / n_r.clamp_min(1.0)
    s_g, s_t, s_a, n_g, n_t = masked_sums(q_g_logit, q_tg_logit, action_pred, grasp_success, task_success,
                                          action, config.action_sigma)
    grasp, task, act = reduce_sums(s_g, s_t, s_a, n, n_g, n_t, config)
    prog = torch.zeros((), dtype=grasp.dtype, device=grasp.device)
    if progress_logit is not None and progress is not None:
        s_p, n_p = progress_sum(progress_logit, progress, grasp_success)
        prog = config.weight_progress * s_p / (n if config.reduction == "batch" else n_p.clamp_min(1.0))
    return {
        "loss": grasp + task + act + prog + rank,
        "grasp": grasp,
        "task": task,
        "action": act,
        "progress": prog,
        "rank": rank,
        "n_grasp_success": n_g,
        "n_task_success": n_t,
    }


def log_q_task(q_g_logit: torch.Tensor, q_tg_logit: torch.Tensor) -> torch.Tensor:
    """log(Q_G * Q_T|G) per episode from logits (N,) and (N,) or (N, members) (the members' mean
    probability), computed without leaving log space."""
    log_tg = F.logsigmoid(q_tg_logit)
    if log_tg.dim() == 2:
        log_tg = torch.logsumexp(log_tg, dim=1) - math.log(log_tg.shape[1])
    return F.logsigmoid(q_g_logit) + log_tg


def scene_rank_sum(q_g_logit: torch.Tensor, q_tg_logit: torch.Tensor, task_success: torch.Tensor,
                   scene: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Sum over the pairs (i, j) of one scene with S_T,i = 1 and S_T,j = 0 of log(1 + exp(s_j - s_i)),
    s = log Q_G Q_T|G (:func:`log_q_task`), and the number of such pairs. O(N^2) in the batch size."""
    s = log_q_task(q_g_logit, q_tg_logit)
    won = task_success > 0.5
    pairs = (scene[:, None] == scene[None, :]) & won[:, None] & ~won[None, :]
    total = F.softplus(s[None, :] - s[:, None])[pairs].sum()
    return total, pairs.sum().to(total.dtype)


def progress_sum(progress_logit: torch.Tensor, progress: torch.Tensor, grasp_success: torch.Tensor
                 ) -> tuple[torch.Tensor, torch.Tensor]:
    """Sum of CE(progress, sigmoid(progress_logit)) over the trials that held the tool and whose progress
    is known (in [0, 1]; -1 is unknown), and their number."""
    m = (grasp_success > 0.5) & (progress >= 0.0)
    ce = _member_ce(progress_logit[m], progress[m])
    return ce, m.sum().to(ce.dtype)


def _member_ce(logit: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Summed cross-entropy of logits (M,) or (M, members) against targets (M,): with several members,
    each member's term, averaged over the members (each member learns every label)."""
    t = target.to(logit.dtype)
    if logit.dim() == 2:
        t = t[:, None].expand_as(logit)
        return F.binary_cross_entropy_with_logits(logit, t, reduction="sum") / logit.shape[1]
    return F.binary_cross_entropy_with_logits(logit, t, reduction="sum")


def reduce_sums(
    sum_grasp: torch.Tensor,
    sum_task: torch.Tensor,
    sum_action: torch.Tensor,
    n: int | torch.Tensor,
    n_grasp_success: torch.Tensor,
    n_task_success: torch.Tensor,
    config: LossConfig,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Weighted (grasp, task, action) terms from per-term sums over masked episodes and the mask sizes;
    shared by the training loss and the validation pass (which accumulates sums over many batches)."""
    if config.reduction == "batch":
        grasp, task, act = sum_grasp / n, sum_task / n, sum_action / n
    elif config.reduction == "masked":
        grasp = sum_grasp / n
        task = sum_task / torch.as_tensor(n_grasp_success).clamp_min(1.0)
        act = sum_action / torch.as_tensor(n_task_success).clamp_min(1.0)
    else:
        raise ValueError(f"unknown loss reduction {config.reduction!r}")
    return config.weight_grasp * grasp, config.weight_task * task, config.weight_action * act


def resolve_loss(config: LossConfig, action_std: Sequence[float] | torch.Tensor) -> LossConfig:
    """``config`` with ``action_sigma`` set to ``action_std`` (the model's action normalisation) when its
    ``action_sigma_source`` is 'data'; unchanged otherwise. The training loop and the validation pass use
    the result, so the loss a checkpoint reports is the loss it was trained on."""
    if config.action_sigma_source != "data":
        return config
    std = torch.as_tensor(action_std, dtype=torch.float64).flatten().tolist()
    return config.replace(action_sigma=tuple(float(v) for v in std))


def q_task(q_g: torch.Tensor, q_tg: torch.Tensor) -> torch.Tensor:
    """Q_T = Q_T|G * Q_G (probabilities)."""
    return q_tg * q_g


COMPONENTS: Sequence[str] = ("loss", "grasp", "task", "action", "progress", "rank")
