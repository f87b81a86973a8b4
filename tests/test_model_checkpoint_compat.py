"""Checkpoints written before a training-loop setting existed still load; architecture changes do not."""

from __future__ import annotations

import pytest
import torch

from tognet.data.synthetic import write_synthetic_dataset
from tognet.model.checkpoint import CheckpointError, load_checkpoint
from tognet.model.config import TrainConfig
from tognet.model.predict import TOGNetPredictor
from tognet.model.train import train


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    root = tmp_path_factory.mktemp("compat")
    write_synthetic_dataset(root / "data", task="sweeping", n=64, shard_size=32)
    result = train([root / "data"], "sweeping", root / "run", TrainConfig(epochs=1, batch_size=16),
                   progress=False, log=lambda _m: None)
    return result.best_path


def test_missing_training_loop_field_takes_its_default(checkpoint, tmp_path):
    payload = torch.load(checkpoint, weights_only=True)
    cfg = {k: v for k, v in payload["config"].items() if k not in ("patience", "eval_batch_size")}
    torch.save(dict(payload, config=cfg), tmp_path / "older.pt")
    loaded = load_checkpoint(tmp_path / "older.pt")
    assert sorted(loaded["defaults_filled"]) == ["eval_batch_size", "patience"]
    assert loaded["config_obj"].patience == TrainConfig().patience
    assert TOGNetPredictor.load(tmp_path / "older.pt").task == "sweeping"


def test_missing_architecture_or_loss_is_still_refused(checkpoint, tmp_path):
    payload = torch.load(checkpoint, weights_only=True)
    for drop in ("arch", "loss"):
        cfg = {k: v for k, v in payload["config"].items() if k != drop}
        torch.save(dict(payload, config=cfg), tmp_path / f"no-{drop}.pt")
        with pytest.raises(CheckpointError, match=f"lacks .*'{drop}"):
            load_checkpoint(tmp_path / f"no-{drop}.pt")
