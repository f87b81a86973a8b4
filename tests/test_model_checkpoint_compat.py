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


def _older(checkpoint):
    """The checkpoint's payload as an older tognet wrote it: without the content digest."""
    payload = torch.load(checkpoint, weights_only=True)
    return {k: v for k, v in payload.items() if k != "digest"}


def test_missing_training_loop_field_takes_its_default(checkpoint, tmp_path):
    payload = _older(checkpoint)
    cfg = {k: v for k, v in payload["config"].items() if k not in ("patience", "eval_batch_size")}
    torch.save(dict(payload, config=cfg), tmp_path / "older.pt")
    loaded = load_checkpoint(tmp_path / "older.pt")
    assert sorted(loaded["defaults_filled"]) == ["eval_batch_size", "patience"]
    assert loaded["config_obj"].patience == TrainConfig().patience
    assert TOGNetPredictor.load(tmp_path / "older.pt").task == "sweeping"


def test_missing_architecture_or_loss_is_still_refused(checkpoint, tmp_path):
    payload = _older(checkpoint)
    for drop in ("arch", "loss"):
        cfg = {k: v for k, v in payload["config"].items() if k != drop}
        torch.save(dict(payload, config=cfg), tmp_path / f"no-{drop}.pt")
        with pytest.raises(CheckpointError, match=f"lacks .*'{drop}"):
            load_checkpoint(tmp_path / f"no-{drop}.pt")


def test_a_changed_byte_anywhere_in_the_weights_is_named_before_use(checkpoint, tmp_path):
    """64 bytes inverted inside a tensor's data (torch still loads the file): the digest written into the
    checkpoint names it; an older checkpoint without one loads, and says so."""
    data = bytearray(checkpoint.read_bytes())
    payload = torch.load(checkpoint, weights_only=True)
    assert payload["digest"] and load_checkpoint(checkpoint)["verified"] == "digest"
    weights = payload["state_dict"]["trunk.layers.3.conv2.weight"].numpy().tobytes()
    at = bytes(data).find(weights[:256])
    assert at > 0  # the tensor's bytes are stored as they are
    data[at + 64:at + 128] = bytes(255 - b for b in data[at + 64:at + 128])
    (tmp_path / "flipped.pt").write_bytes(bytes(data))
    torch.load(tmp_path / "flipped.pt", weights_only=True)  # torch does not notice
    with pytest.raises(CheckpointError, match="does not match the digest written into it"):
        load_checkpoint(tmp_path / "flipped.pt")
    with pytest.raises(CheckpointError, match="does not match the digest"):
        TOGNetPredictor.load(tmp_path / "flipped.pt")
    torch.save(_older(checkpoint), tmp_path / "older.pt")
    assert load_checkpoint(tmp_path / "older.pt")["verified"] == "none"


def test_a_shipped_model_is_checked_against_its_recorded_sha256():
    from tognet.models import default_checkpoint

    assert load_checkpoint(default_checkpoint("hammering"))["verified"] == "shipped"
