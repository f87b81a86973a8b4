"""The action-conditioned task stream (the learned action search's model) and the graded outcome."""

import dataclasses

import numpy as np
import pytest
import torch

from tognet.data.synthetic import write_synthetic_dataset
from tognet.model.config import ArchConfig, LossConfig, TrainConfig
from tognet.model.loss import progress_sum, tognet_loss
from tognet.model.network import TOGNet
from tognet.model.predict import TOGNetPredictor
from tognet.model.train import train
from tognet.tasks import get_task

TINY = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=32, task_head="action", action_features=8, action_hidden=32)


def _inputs(n=6, seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.randn(n, 64, 64, generator=g) * 0.01, 0.8 + 0.01 * torch.randn(n, generator=g)


def test_scoring_many_actions_matches_the_forward_pass():
    torch.manual_seed(0)
    model = TOGNet(TINY).eval()
    model.action_in_std.fill_(0.05)
    crop, z = _inputs()
    actions = torch.randn(6, 5, 4) * 0.05
    enc = model.encode_task(crop, z)
    many = model.score_actions(enc["encoded"], actions)[:, :, 0]  # one member
    assert many.shape == (6, 5, 2)
    for k in range(5):
        out = model(crop, z, actions[:, k])
        torch.testing.assert_close(many[:, k, 0], out["q_tg_logit"])
        torch.testing.assert_close(many[:, k, 1], out["progress_logit"])
    # the action changes the score (the stream sees it), and without one the model scores its own mean
    assert not torch.allclose(many[:, 0, 0], many[:, 1, 0])
    own = model(crop, z)
    mean = model.denormalize_action(own["action_norm"])
    torch.testing.assert_close(own["q_tg_logit"], model(crop, z, mean)["q_tg_logit"])


def test_the_papers_model_has_no_action_input():
    model = TOGNet(ArchConfig()).eval()
    crop, z = _inputs()
    with pytest.raises(ValueError, match="does not see the action"):
        model.encode_task(crop, z)
    assert "progress_logit" not in model(crop, z)
    assert "action_in_mean" not in model.state_dict()  # old checkpoints keep loading strictly


def test_progress_term_counts_only_held_trials_with_a_known_progress():
    logit = torch.tensor([0.0, 2.0, -1.0, 5.0])
    prog = torch.tensor([0.5, 1.0, -1.0, 0.2])
    s_g = torch.tensor([1.0, 1.0, 1.0, 0.0])
    total, count = progress_sum(logit, prog, s_g)
    assert count == 2
    ref = torch.nn.functional.binary_cross_entropy_with_logits(logit[:2], prog[:2], reduction="sum")
    torch.testing.assert_close(total, ref)
    args = (torch.zeros(4), torch.zeros(4), torch.zeros(4, 4), s_g, torch.zeros(4), torch.zeros(4, 4))
    with_p = tognet_loss(*args, LossConfig(weight_progress=2.0), logit, prog)
    without = tognet_loss(*args, LossConfig(weight_progress=2.0))
    torch.testing.assert_close(with_p["progress"], 2.0 * ref / 4)
    torch.testing.assert_close(with_p["loss"] - without["loss"], with_p["progress"])


def test_train_and_search_inputs(tmp_path):
    data = write_synthetic_dataset(tmp_path / "d", task="t", n=96, shard_size=96, seed=1, n_objects=6)
    cfg = TrainConfig(arch=TINY, epochs=2, batch_size=32, val_fraction=0.25, monitor="classification",
                      num_threads=1)
    result = train([data], "t", tmp_path / "o", cfg, progress=False, log=lambda s: None)
    assert result.best["monitor"] == "val classification"
    assert "classification" in result.history[-1]["val"]
    pred = TOGNetPredictor.load(result.best_path)
    assert pred.action_conditioned
    crops = np.random.default_rng(0).normal(0, 0.01, (3, 64, 64)).astype(np.float32)
    z = np.full(3, 0.8, np.float32)
    enc = pred.encode(crops, z)
    scores = pred.score_actions(enc, np.zeros((3, 7, 4)))
    assert scores.success.shape == scores.progress.shape == scores.spread.shape == (3, 7)
    assert np.all((scores.success >= 0) & (scores.success <= 1))
    assert np.all(scores.spread == 0)  # one member
    # the predictor's own Q_T|G scores the action mean, as the eager model does
    p = pred.predict(crops, z)
    s_mean = pred.score_actions(enc, p.action_mean[:, None, :].astype(np.float64)).success
    np.testing.assert_allclose(p.q_t_given_g, s_mean[:, 0], rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("values, expected", [({"peg_out": 0.05}, 0.0), ({"peg_out": 0.003}, 1.0),
                                              ({"peg_out": 0.0265}, 0.5), ({}, None)])
def test_hammering_progress(values, expected):
    p = get_task("hammering").progress(values)
    assert np.isnan(p) if expected is None else p == pytest.approx(expected)


def test_sweeping_and_pulling_progress():
    assert get_task("sweeping").progress({"cans_on_ground": [True, False]}) == 0.5
    pull = get_task("pulling")
    start = 0.4
    end = pull.config.target_x[1]
    half = {"can_in_target": False, "can_xy": [0.5 * (start + end), 0.0], "can_start_x": start,
            "can_on_table": True}
    assert pull.progress(half) == pytest.approx(0.5)
    assert pull.progress({**half, "can_in_target": True}) == 1.0
    assert pull.progress({**half, "can_on_table": False}) == 0.0


def test_members_learn_each_label_and_disagree_off_the_data(tmp_path):
    arch = dataclasses.replace(TINY, action_members=3)
    torch.manual_seed(1)
    model = TOGNet(arch).eval()
    crop, z = _inputs(4)
    out = model(crop, z, torch.zeros(4, 4))
    assert out["q_tg_logit"].shape == out["progress_logit"].shape == (4, 3)
    # the task term averages the members' cross-entropies
    s_g, s_t = torch.ones(4), torch.tensor([1.0, 0.0, 1.0, 0.0])
    args = (out["q_g_logit"], out["q_tg_logit"], torch.zeros(4, 4), s_g, s_t, torch.zeros(4, 4))
    got = tognet_loss(*args)["task"]
    bce = torch.nn.functional.binary_cross_entropy_with_logits
    ref = sum(bce(out["q_tg_logit"][:, k], s_t, reduction="sum") for k in range(3)) / 3 / 4
    torch.testing.assert_close(got, ref)
    data = write_synthetic_dataset(tmp_path / "d", task="t", n=96, shard_size=96, seed=2, n_objects=6)
    cfg = TrainConfig(arch=arch, epochs=1, batch_size=32, val_fraction=0.25, num_threads=1)
    pred = TOGNetPredictor.load(train([data], "t", tmp_path / "o", cfg, progress=False,
                                      log=lambda s: None).best_path)
    crops = np.random.default_rng(0).normal(0, 0.01, (2, 64, 64)).astype(np.float32)
    scores = pred.score_actions(pred.encode(crops, np.full(2, 0.8, np.float32)),
                                np.random.default_rng(1).normal(0, 0.05, (2, 5, 4)))
    assert scores.spread.shape == (2, 5) and np.all(scores.spread > 0)  # members initialised apart
