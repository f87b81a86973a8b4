import math

import pytest
import torch

from tognet.model.config import LossConfig
from tognet.model.loss import q_task, tognet_loss


def _bce(p_logit: float, y: float) -> float:
    p = 1 / (1 + math.exp(-p_logit))
    return -(y * math.log(p) + (1 - y) * math.log(1 - p))


BATCH = {
    "q_g_logit": torch.tensor([0.3, -1.2, 2.0, 0.0]),
    "q_tg_logit": torch.tensor([1.0, 0.5, -0.7, 3.0]),
    "action_pred": torch.tensor([[0.01, 0.0, 0.0, 0.1], [0.5, 0.5, 0.5, 0.5], [0.0, 0.02, 0.0, 0.0],
                                 [0.0, 0.0, 0.0, 0.0]]),
    "grasp_success": torch.tensor([1.0, 0.0, 1.0, 1.0]),
    "task_success": torch.tensor([1.0, 0.0, 0.0, 1.0]),
    "action": torch.tensor([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0],
                            [0.03, 0.0, -0.03, 0.09]]),
}
SIGMA = (0.01, 0.02, 0.03, 0.1)


def _hand():
    s_g, s_t = [1, 0, 1, 1], [1, 0, 0, 1]
    g = [_bce(x, y) for x, y in zip([0.3, -1.2, 2.0, 0.0], s_g, strict=True)]
    t = [_bce(x, y) * m for x, y, m in zip([1.0, 0.5, -0.7, 3.0], s_t, s_g, strict=True)]
    a0 = 0.5 * ((0.01 / 0.01) ** 2 + (0.1 / 0.1) ** 2)  # episode 0: S_T = 1
    a3 = 0.5 * ((0.03 / 0.01) ** 2 + (0.03 / 0.03) ** 2 + (0.09 / 0.1) ** 2)  # episode 3: S_T = 1
    return sum(g), sum(t), a0 + a3


def test_batch_reduction_matches_hand_computation():
    g, t, a = _hand()
    out = tognet_loss(**BATCH, config=LossConfig(action_sigma=SIGMA, reduction="batch"))
    assert float(out["grasp"]) == pytest.approx(g / 4, rel=1e-5)
    assert float(out["task"]) == pytest.approx(t / 4, rel=1e-5)
    assert float(out["action"]) == pytest.approx(a / 4, rel=1e-5)
    assert float(out["loss"]) == pytest.approx((g + t + a) / 4, rel=1e-5)
    assert float(out["n_grasp_success"]) == 3 and float(out["n_task_success"]) == 2


def test_masked_reduction_matches_hand_computation():
    g, t, a = _hand()
    out = tognet_loss(**BATCH, config=LossConfig(action_sigma=SIGMA, reduction="masked"))
    assert float(out["grasp"]) == pytest.approx(g / 4, rel=1e-5)
    assert float(out["task"]) == pytest.approx(t / 3, rel=1e-5)
    assert float(out["action"]) == pytest.approx(a / 2, rel=1e-5)


@pytest.mark.parametrize("reduction", ["batch", "masked"])
def test_masks_cut_gradients(reduction):
    batch = {k: v.clone().requires_grad_(k in ("q_tg_logit", "action_pred")) for k, v in BATCH.items()}
    out = tognet_loss(**batch, config=LossConfig(action_sigma=SIGMA, reduction=reduction))
    out["loss"].backward()
    # Q_T|G gets no gradient from the failed grasp (episode 1); the action none from task failures (1, 2).
    assert float(batch["q_tg_logit"].grad[1]) == 0.0
    assert float(batch["q_tg_logit"].grad[2]) != 0.0
    assert torch.all(batch["action_pred"].grad[[1, 2]] == 0)
    assert torch.any(batch["action_pred"].grad[[0, 3]] != 0)


def test_empty_masks_and_q_task():
    batch = {**BATCH, "grasp_success": torch.zeros(4), "task_success": torch.zeros(4)}
    for reduction in ("batch", "masked"):
        out = tognet_loss(**batch, config=LossConfig(reduction=reduction))
        assert float(out["task"]) == 0.0 and float(out["action"]) == 0.0
        assert math.isfinite(float(out["loss"]))
    q_t = q_task(torch.tensor([0.5, 0.2]), torch.tensor([0.4, 1.0]))
    assert torch.allclose(q_t, torch.tensor([0.2, 0.2]))


def test_masked_rows_with_non_finite_values_carry_nothing():
    # Episode 1 (failed grasp) and 2 (failed task) hold garbage where they are masked out: a huge Q_T|G
    # logit is fine for BCE, but an infinite predicted action (0 * inf) must not turn the loss into NaN.
    batch = {k: v.clone() for k, v in BATCH.items()}
    batch["action_pred"][1] = float("inf")
    batch["action"][2] = float("nan")
    batch = {k: v.requires_grad_(k in ("q_tg_logit", "action_pred")) for k, v in batch.items()}
    g, t, a = _hand()
    out = tognet_loss(**batch, config=LossConfig(action_sigma=SIGMA, reduction="batch"))
    assert float(out["loss"].detach()) == pytest.approx((g + t + a) / 4, rel=1e-5)
    out["loss"].backward()
    assert torch.all(torch.isfinite(batch["action_pred"].grad))
    assert torch.all(batch["action_pred"].grad[[1, 2]] == 0)


def test_action_sigma_from_the_data_replaces_the_fixed_one():
    from tognet.model.loss import resolve_loss

    fixed = LossConfig(action_sigma=SIGMA)
    assert resolve_loss(fixed, torch.tensor([1.0, 2.0, 3.0, 4.0])) is fixed
    data = LossConfig(action_sigma=SIGMA, action_sigma_source="data")
    got = resolve_loss(data, torch.tensor([0.05, 0.04, 0.01, 0.6]))
    assert got.action_sigma == pytest.approx((0.05, 0.04, 0.01, 0.6))
    b = BATCH
    small = tognet_loss(b["q_g_logit"], b["q_tg_logit"], b["action_pred"], b["grasp_success"],
                        b["task_success"], b["action"], fixed)["action"]
    wide = tognet_loss(b["q_g_logit"], b["q_tg_logit"], b["action_pred"], b["grasp_success"],
                       b["task_success"], b["action"], got)["action"]
    assert float(wide) < float(small)  # wider sigma, smaller action term; the others are unchanged
