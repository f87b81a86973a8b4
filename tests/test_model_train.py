import dataclasses
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
    torch.save(dict(payload, config=cfg), tmp_path / "edited.pt")  # edited under its digest: named so
    with pytest.raises(CheckpointError, match="does not match the digest written into it"):
        TOGNetPredictor.load(tmp_path / "edited.pt")
    older = {k: v for k, v in payload.items() if k != "digest"}  # an older checkpoint, no digest
    torch.save(dict(older, config=cfg), tmp_path / "cfg.pt")
    with pytest.raises(CheckpointError, match="config does not match.*unknown key 'dropout'"):
        TOGNetPredictor.load(tmp_path / "cfg.pt")
    cfg = dict(payload["config"])
    cfg["arch"] = {k: v for k, v in cfg["arch"].items() if k != "stem_stride"}
    torch.save(dict(older, config=cfg), tmp_path / "older.pt")
    with pytest.raises(CheckpointError, match=r"lacks \['arch.stem_stride'\].*older tognet"):
        TOGNetPredictor.load(tmp_path / "older.pt")
    sd = dict(payload["state_dict"])
    sd.pop(next(iter(sd)))
    torch.save(dict(older, state_dict=sd), tmp_path / "sd.pt")
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
    from tognet.data.format import DatasetError

    with pytest.raises(DatasetError, match="expected 'hammering'"):
        train([dataset], "hammering", tmp_path / "o", _cfg(), progress=False, log=lambda s: None)


@pytest.mark.parametrize("reduction", ["batch", "masked"])
def test_validation_loss_is_the_training_loss(trained, dataset, reduction):
    # evaluate() accumulates the loss over many streamed batches; it must equal tognet_loss over the whole
    # set (same masks, same reduction), or early stopping and best.pt follow a different objective.
    from tognet.data.episodes import read_dataset
    from tognet.data.stream import EpisodeStream
    from tognet.model.checkpoint import model_from_checkpoint
    from tognet.model.config import LossConfig
    from tognet.model.loss import tognet_loss
    from tognet.model.train import evaluate

    loss_cfg = LossConfig(reduction=reduction)
    cfg = _cfg(eval_batch_size=37, loss=loss_cfg)
    model = model_from_checkpoint(load_checkpoint(trained.best_path)).eval()
    ep = read_dataset([dataset])
    s_g = torch.from_numpy(ep.grasp_success.astype(np.float32))
    s_t = torch.from_numpy(ep.task_success.astype(np.float32))
    assert 0 < float(s_t.sum()) < float(s_g.sum()) < len(ep)
    stream = EpisodeStream([dataset], "sweeping")
    result = evaluate(model, stream.batches("all", cfg.eval_batch_size), cfg)
    assert result["count"] == len(ep)
    with torch.no_grad():
        out = model(torch.from_numpy(ep.crop).float(), torch.from_numpy(ep.z))
        ref = tognet_loss(out["q_g_logit"], out["q_tg_logit"], model.denormalize_action(out["action_norm"]),
                          s_g, s_t, torch.from_numpy(ep.action), loss_cfg)
    for key in ("loss", "grasp", "task", "action"):
        assert result[key] == pytest.approx(float(ref[key]), rel=1e-4), key


def test_package_exports_the_training_function_not_the_module():
    import tognet.model
    from tognet.model import train_model
    from tognet.model.train import train as train_function

    assert train_model is train_function and callable(tognet.model.train_model)


def test_truncated_shard_named_or_skipped(tmp_path):
    from tognet.data.format import DatasetError

    d = write_synthetic_dataset(tmp_path / "d", task="t", n=120, shard_size=40, seed=2, n_objects=6)
    shard = d / "shard-00001.npz"
    shard.write_bytes(shard.read_bytes()[:3000])
    with pytest.raises(DatasetError, match=r"shard-00001\.npz: corrupt(,| or) truncated"):
        train([d], "t", tmp_path / "o", _cfg(epochs=1), progress=False, log=lambda s: None)
    assert not (tmp_path / "o").exists()
    with pytest.warns(UserWarning, match=r"skipping bad shard.*shard-00001\.npz"):
        run = train([d], "t", tmp_path / "o", _cfg(epochs=1, skip_bad_shards=True), progress=False,
                    log=lambda s: None)
    split = json.loads((run.out / "data.json").read_text())["split"]
    assert split["train_episodes"] + split["val_episodes"] == 80


def _learned(state):
    return {k: v for k, v in state.items() if not k.endswith(("running_mean", "running_var",
                                                              "num_batches_tracked"))}


@pytest.fixture(scope="module")
def other_data(tmp_path_factory):
    """Episodes of the same task on other objects (other normalisation statistics than ``dataset``)."""
    return write_synthetic_dataset(tmp_path_factory.mktemp("other") / "d", task="sweeping", n=240,
                                   shard_size=60, seed=11, n_objects=12, noise=0.004)


def test_warm_start_takes_weights_and_normalization(trained, other_data, tmp_path):
    init = load_checkpoint(trained.best_path)
    # lr 0: the weights stay the checkpoint's (batch-norm running statistics still move)
    logs = []
    run = train([other_data], "sweeping", tmp_path / "o", _cfg(epochs=1, lr=0.0), init_from=trained.best_path,
                progress=False, log=logs.append)
    assert any("initialised from" in line for line in logs)
    payload = load_checkpoint(run.last_path)
    a, b = _learned(init["state_dict"]), _learned(payload["state_dict"])
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert payload["normalization"] == init["normalization"]
    fresh = train([other_data], "sweeping", tmp_path / "f", _cfg(epochs=1), progress=False,
                  log=lambda s: None)
    assert load_checkpoint(fresh.best_path)["normalization"] != init["normalization"]
    # recorded where the run came from: data.json, metrics.json and the checkpoints
    data = json.loads((run.out / "data.json").read_text())
    assert data["init_from"]["path"] == str(trained.best_path.resolve())
    assert data["init_from"]["epoch"] == init["epoch"] and len(data["init_from"]["sha256"]) == 64
    assert json.loads((run.out / "metrics.json").read_text())["init_from"] == data["init_from"]
    assert payload["data"]["init_from"] == data["init_from"]
    assert json.loads((fresh.out / "data.json").read_text())["init_from"] is None
    # warm-started training starts from a lower loss than a fresh one
    warm = train([other_data], "sweeping", tmp_path / "w", _cfg(epochs=1), init_from=trained.best_path,
                 progress=False, log=lambda s: None)
    assert warm.history[0]["train"]["loss"] < fresh.history[0]["train"]["loss"]
    assert warm.history[0]["val"]["loss"] < fresh.history[0]["val"]["loss"]


def test_warm_start_refuses_other_task_or_architecture(trained, tmp_path):
    from tognet.model.checkpoint import CheckpointError

    ham = write_synthetic_dataset(tmp_path / "h", task="hammering", n=60, seed=1, n_objects=4)
    with pytest.raises(TrainingError, match=r"best\.pt: a checkpoint of task 'sweeping', but training task "
                                            r"'hammering'"):
        train([ham], "hammering", tmp_path / "o", _cfg(), init_from=trained.best_path, progress=False,
              log=lambda s: None)
    wider = dataclasses.replace(TINY, head_hidden=16)
    sweep = write_synthetic_dataset(tmp_path / "s", task="sweeping", n=60, seed=1, n_objects=4)
    with pytest.raises(TrainingError, match=r"architecture differs from the config's in \['head_hidden'\]"):
        train([sweep], "sweeping", tmp_path / "o", _cfg(arch=wider), init_from=trained.best_path,
              progress=False, log=lambda s: None)
    with pytest.raises(CheckpointError, match="checkpoint file not found"):
        train([sweep], "sweeping", tmp_path / "o", _cfg(), init_from=tmp_path / "nope.pt", progress=False,
              log=lambda s: None)
    assert not (tmp_path / "o").exists()


def test_resume_wins_over_init_from(dataset, trained, tmp_path):
    out = tmp_path / "o"
    train([dataset], "sweeping", out, _cfg(epochs=1), progress=False, log=lambda s: None)
    logs = []
    resumed = train([dataset], "sweeping", out, _cfg(epochs=3), resume=True, init_from=trained.best_path,
                    progress=False, log=logs.append)
    assert any("init_from" in line and "ignored" in line for line in logs)
    assert json.loads((out / "data.json").read_text())["init_from"] is None
    s1 = load_checkpoint(trained.last_path)["state_dict"]
    s2 = load_checkpoint(resumed.last_path)["state_dict"]
    assert all(torch.equal(s1[k], s2[k]) for k in s1)


def test_streamed_training_over_many_small_shards_learns(tmp_path):
    # one object per few shards, a shuffle buffer of a few batches: the run must still learn the rule
    d = write_synthetic_dataset(tmp_path / "d", task="t", n=600, shard_size=20, seed=4, n_objects=30)
    run = train([d], "t", tmp_path / "o", _cfg(epochs=3, shuffle_buffer=96, patience=10), progress=False,
                log=lambda s: None)
    first, last = run.history[0], run.history[-1]
    assert first["val"]["count"] == run.history[-1]["val"]["count"] > 0
    assert all(np.isfinite(h["train"]["loss"]) and np.isfinite(h["val"]["loss"]) for h in run.history)
    assert last["train"]["loss"] < 0.5 * first["train"]["loss"]
    assert run.best["loss"] < first["val"]["loss"]
    assert last["val"]["metrics"]["grasp"]["auc"] > 0.95
    assert last["val"]["metrics"]["task_given_grasp"]["auc"] > 0.9
