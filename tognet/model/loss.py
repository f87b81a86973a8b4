"""The TOG-Net objective (paper, "Learning Objectives and Optimization").

Per episode i::

    L_i = CE(S_G, Q_G) + 1[S_G = 1] * CE(S_T, Q_T|G) + 1[S_T = 1] * 1/2 * ||f(o, g) - a||^2_Sigma

with ||d||^2_Sigma = sum_k (d_k / sigma_k)^2, Sigma = diag(sigma^2) constant (``LossConfig.action_sigma``),
and f, a in the stored action units (the network's normalised output is denormalised first). The paper's
text once writes the action term weighted by S_G, but its equation (and the policy-gradient argument
with task success as reward) uses 1[S_T = 1]; we follow the equation. S_T = 1 implies S_G = 1.

Reductions over a batch of N episodes:

- ``"batch"`` (default): each term is summed over its masked episodes and divided by N, i.e. the paper's
  sum over episodes scaled by 1/N; rare successes weigh as in the data.
- ``"masked"``: each term is the mean over its own masked subset (0 when the subset is empty).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F

from tognet.model.config import LossConfig


def tognet_loss(
    q_g_logit: torch.Tensor,
    q_tg_logit: torch.Tensor,
    action_pred: torch.Tensor,
    grasp_success: torch.Tensor,
    task_success: torch.Tensor,
    action: torch.Tensor,
    config: LossConfig | None = None,
) -> dict[str, torch.Tensor]:
    """The loss and its components (all scalars): ``loss``, ``grasp``, ``task``, ``action`` (weighted
    terms before summing) and the mask sizes ``n_grasp_success``, ``n_task_success``.

    ``action_pred`` and ``action`` are (N, 4) in the same (stored) units.
    """
    config = config or LossConfig()
    s_g = grasp_success.float()
    s_t = task_success.float()
    n = max(int(s_g.shape[0]), 1)
    sigma = torch.as_tensor(config.action_sigma, dtype=action_pred.dtype, device=action_pred.device)
    ce_g = F.binary_cross_entropy_with_logits(q_g_logit, s_g, reduction="none")
    ce_t = F.binary_cross_entropy_with_logits(q_tg_logit, s_t, reduction="none")
    sq = 0.5 * (((action_pred - action) / sigma) ** 2).sum(dim=1)
    m_g, m_t = s_g, s_t
    grasp, task, act = reduce_sums(
        ce_g.sum(), (m_g * ce_t).sum(), (m_t * sq).sum(), n, m_g.sum(), m_t.sum(), config
    )
    return {
        "loss": grasp + task + act,
        "grasp": grasp,
        "task": task,
        "action": act,
        "n_grasp_success": m_g.sum(),
        "n_task_success": m_t.sum(),
    }


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


def q_task(q_g: torch.Tensor, q_tg: torch.Tensor) -> torch.Tensor:
    """Q_T = Q_T|G * Q_G (probabilities)."""
    return q_tg * q_g


COMPONENTS: Sequence[str] = ("loss", "grasp", "task", "action")
