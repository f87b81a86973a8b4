import json

import numpy as np
import pytest
import torch

from tognet.data.synthetic import synthetic_episodes, write_synthetic_dataset
from tognet.model.checkpoint import FORMAT_VERSION, CheckpointError, load_checkpoint
from tognet.model.config import ArchConfig, TrainConfig
from tognet.model.predict import TOGNetPredictor
from tognet.model.train import TrainingError, train

TINY = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=32)


def _cfg(**kw):
    base = dict(arch=TINY, num_threads=1, epochs=3, batch_size=32, val_fraction=0.25, seed=3, lr=3e-3,
                lr_decay=1.0)
    return TrainConfig(**{**base, **kw})


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data")
    return write_synthetic_dataset(root / "d", task="sweeping", n=240, shard_size=100, seed=7, n_objects=12)


@pytest.fixture(scope="module")
def trained(dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "out"
    return train([dataset], "sweeping", out, _cfg(), progress=False, log=lambda s: None)


def test_overfits_tiny_dataset(tmp_path):
    d = write_synthetic_dataset(tmp_path / "d", task="t", n=96, shard_size=96, seed=1, n_objects=6, noise=0.0)
    with pytest.warns(UserWarning, match="no validation objects"):
        result = train([d], "t", tmp_path / "o", _cfg(epochs=30, val_fraction=0.0, lr=1e-2, batch_size=32,
                                                      patience=30), progress=False, log=lambda s: None)
    losses = [h["train"]["loss"] for h in result.history]
    assert losses[-1] < 0.2 * losses[0]
    ep = synthetic_episodes(96, n_objects=6, seed=1, noise=0.0)
    pred = TOGNetPredictor.load(result.best_path).predict(ep.crop, ep.z)
    s_g = ep.grasp_success.astype(bool)
    assert np.mean((pred.q_g >= 0.5) == s_g) >= 0.97
    assert np.mean((pred.q_t_given_g[s_g] >= 0.5) == ep.task_success[s_g].astype(bool)) >= 0.95
    ok = ep.task_success.astype(bool)
    err = np.abs(pred.action_mean[ok] - ep.action[ok]).mean(0)
    assert np.all(err < 0.5 * ep.action[ok].std(0) + 0.003), err


def test_outputs_and_self_description(trained):
    out = trained.out
    for name in ("best.pt", "last.pt", "metrics.json", "curves.png", "config.json", "data.json"):
        assert (out / name).is_file(), name
    metrics = json.loads((out / "metrics.json").read_text())
    assert len(metrics["history"]) == 3
    val = metrics["history"][-1]["val"]["metrics"]
    assert set(val) == {"grasp", "task_given_grasp", "task", "action"}
    assert 0.0 <= val["grasp"]["auc"] <= 1.0 and val["grasp"]["ece"] is not None
    payload = load_checkpoint(out / "best.pt")
    assert payload["task"] == "sweeping"
    assert payload["config_obj"] == _cfg()
    assert payload["normalization"]["crop_std"] > 0
    assert payload["data"]["datasets"][0]["shards"][0]["sha256"]
    assert payload["code"]["tognet"]
    assert payload["split"]["train_objects"] + payload["split"]["val_objects"] == 12
    from tognet.model.checkpoint import describe
    from tognet.model.network import TOGNet

    assert describe(payload)["parameters"] == sum(p.numel() for p in TOGNet(TINY).parameters())


def test_checkpoint_round_trip_identical_outputs(trained):
    ep = synthetic_episodes(50, seed=99)
    payload = load_checkpoint(trained.best_path)
    from tognet.model.checkpoint import model_from_checkpoint

    model = model_from_checkpoint(payload).eval()
    with torch.no_grad():
        raw = model(torch.from_numpy(ep.crop).float(), torch.from_numpy(ep.z))
    a = TOGNetPredictor.load(trained.best_path).predict(ep.crop, ep.z)
    b = TOGNetPredictor.load(trained.best_path).predict(ep.crop, ep.z)
    for field in ("q_g", "q_t_given_g", "q_t", "action_mean"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    np.testing.assert_allclose(a.q_g, torch.sigmoid(raw["q_g_logit"]).numpy(), rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(a.q_t, a.q_g * a.q_t_given_g, rtol=1e-6)
    np.testing.assert_allclose(a.action_mean, model.denormalize_action(raw["action_norm"]).detach().numpy(),
                               rtol=1e-4, atol=1e-6)
    scores = TOGNetPredictor.load(trained.best_path).score_fn("grasp")(ep.crop, ep.z)
    np.testing.assert_array_equal(scores, a.q_g)


def test_seeded_training_is_deterministic(dataset, trained, tmp_path):
    again = train([dataset], "sweeping", tmp_path / "o", _cfg(), progress=False, log=lambda s: None)
    s1 = load_checkpoint(trained.last_path)["state_dict"]
    s2 = load_checkpoint(again.last_path)["state_dict"]
    assert all(torch.equal(s1[k], s2[k]) for k in s1)
    other = train([dataset], "sweeping", tmp_path / "o2", _cfg(seed=4), progress=False, log=lambda s: None)
    s3 = load_checkpoint(other.last_path)["state_dict"]
    assert not all(torch.equal(s1[k], s3[k]) for k in s1)


def test_resume_continues_exactly(dataset, trained, tmp_path):
    out = tmp_path / "o"
    train([dataset], "sweeping", out, _cfg(epochs=1), progress=False, log=lambda s: None)
    with pytest.raises(TrainingError, match="already holds a training run"):
        train([dataset], "sweeping", out, _cfg(epochs=3), progress=False, log=lambda s: None)
    with pytest.raises(CheckpointError, match=r"config differs.*\['lr'\]"):
        train([dataset], "sweeping", out, _cfg(epochs=3, lr=0.1), resume=True, progress=False,
              log=lambda s: None)
    resumed = train([dataset], "sweeping", out, _cfg(epochs=3), resume=True, progress=False,
                    log=lambda s: None)
    assert resumed.epochs_run == 3
    s1 = load_checkpoint(trained.last_path)["state_dict"]
    s2 = load_checkpoint(resumed.last_path)["state_dict"]
    assert all(torch.equal(s1[k], s2[k]) for k in s1)


def test_bad_checkpoints_give_clear_errors(trained, tmp_path):
    with pytest.raises(CheckpointError, match="not found"):
        TOGNetPredictor.load(tmp_path / "missing.pt")
    truncated = tmp_path / "trunc.pt"
    data = trained.best_path.read_bytes()
    truncated.write_bytes(data[: len(data) // 3])
    with pytest.raises(CheckpointError, match=r"trunc\.pt: not a readable checkpoint"):
        TOGNetPredictor.load(truncated)
    other = tmp_path / "other.pt"
    torch.save({"weights": torch.zeros(3)}, other)
    with pytest.raises(CheckpointError, match="not a tognet checkpoint"):
        TOGNetPredictor.load(other)
    payload = torch.load(trained.best_path, weights_only=True)
    old = dict(payload, format_version=FORMAT_VERSION - 1)
    torch.save(old, tmp_path / "old.pt")
    with pytest.raises(CheckpointError, match="format version 0.*reads version 1"):
        TOGNetPredictor.load(tmp_path / "old.pt")
    cfg = dict(payload["config"])
    cfg["dropout"] = 0.5
    torch.save(dict(payload, config=cfg), tmp_path / "cfg.pt")
    with pytest.raises(CheckpointError, match="config does not match.*unknown key 'dropout'"):
        TOGNetPredictor.load(tmp_path / "cfg.pt")
    cfg = dict(payload["config"])
    cfg["arch"] = {k: v for k, v in cfg["arch"].items() if k != "stem_stride"}
    torch.save(dict(payload, config=cfg), tmp_path / "older.pt")
    with pytest.raises(CheckpointError, match=r"lacks \['arch.stem_stride'\].*older tognet"):
        TOGNetPredictor.load(tmp_path / "older.pt")
    sd = dict(payload["state_dict"])
    sd.pop(next(iter(sd)))
    torch.save(dict(payload, state_dict=sd), tmp_path / "sd.pt")
    with pytest.raises(CheckpointError, match="weights do not match"):
        TOGNetPredictor.load(tmp_path / "sd.pt")


def test_predictor_input_errors(trained):
    pred = TOGNetPredictor.load(trained.best_path)
    with pytest.raises(ValueError, match=r"crops: expected shape \(N, 64, 64\), got \(3, 32, 32\)"):
        pred.predict(np.zeros((3, 32, 32), np.float32), np.zeros(3))
    with pytest.raises(ValueError, match="z: expected shape"):
        pred.predict(np.zeros((3, 64, 64), np.float32), np.zeros(2))
    bad = np.zeros((2, 64, 64), np.float32)
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        pred.predict(bad, np.ones(2))
    assert len(pred.predict(np.zeros((0, 64, 64), np.float32), np.zeros(0))) == 0
    with pytest.raises(ValueError, match="kind must be"):
        pred.score_fn("nope")


def test_early_stopping(dataset, tmp_path):
    result = train([dataset], "sweeping", tmp_path / "o", _cfg(epochs=20, patience=1, min_delta=1e3),
                   progress=False, log=lambda s: None)
    assert result.stopped_early and result.epochs_run == 2 and result.best["epoch"] == 1


def test_wrong_task_refused(dataset, tmp_path):
    from tognet.data.episodes import DatasetError

    with pytest.raises(DatasetError, match="expected 'hammering'"):
        train([dataset], "hammering", tmp_path / "o", _cfg(), progress=False, log=lambda s: None)


@pytest.mark.parametrize("reduction", ["batch", "masked"])
def test_validation_loss_is_the_training_loss(trained, dataset, reduction):
    # evaluate() accumulates the loss over many batches; it must equal tognet_loss over the whole set
    # (same masks, same reduction), or early stopping and best.pt follow a different objective.
    from tognet.data.episodes import read_dataset
    from tognet.model.checkpoint import model_from_checkpoint
    from tognet.model.config import LossConfig
    from tognet.model.loss import tognet_loss
    from tognet.model.train import _Tensors, evaluate

    loss_cfg = LossConfig(reduction=reduction)
    cfg = _cfg(eval_batch_size=37, loss=loss_cfg)
    model = model_from_checkpoint(load_checkpoint(trained.best_path)).eval()
    data = _Tensors(read_dataset([dataset]), torch.device("cpu"))
    assert 0 < float(data.s_t.sum()) < float(data.s_g.sum()) < len(data)
    result = evaluate(model, data, cfg)
    with torch.no_grad():
        out = model(data.crop.float(), data.z)
        ref = tognet_loss(out["q_g_logit"], out["q_tg_logit"], model.denormalize_action(out["action_norm"]),
                          data.s_g, data.s_t, data.action, loss_cfg)
    for key in ("loss", "grasp", "task", "action"):
        assert result[key] == pytest.approx(float(ref[key]), rel=1e-4), key


def test_package_exports_the_training_function_not_the_module():
    import tognet.model
    from tognet.model import train_model
    from tognet.model.train import train as train_function

    assert train_model is train_function and callable(tognet.model.train_model)
