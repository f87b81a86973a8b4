"""How far the tool swings in the fingers when lifted: measured by the trial, kept in every episode record
(shards of format 4; older shards read as unknown), and, with ``LossConfig.max_lift_tilt``, a grasp that
swung further counts as a failed grasp in training."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from tognet.data.episodes import read_columns
from tognet.data.stream import Batch, EpisodeStream
from tognet.data.synthetic import synthetic_episodes
from tognet.data.writer import ShardWriter
from tognet.geometry import rot_x, rot_z
from tognet.model.config import ArchConfig, LossConfig, TrainConfig
from tognet.model.train import train
from tognet.objects.handmade import grasp_on_object, make_t_hammer
from tognet.sim import SimConfig, Simulator
from tognet.sim.trial import _tilt

TINY = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=32)


def _swing(root: Path, density: float, friction: float, where: str) -> float:
    sim = Simulator(SimConfig(), "hammering", make_t_hammer(root, f"t{int(density)}", density, friction))
    sim.reset(3)
    pos, rot = sim.object_pose()
    result = sim.execute(grasp_on_object(pos, rot, *sim.props.check_grasps[where][:2]),
                         sim.task.nominal_action, seed=0)
    assert result.grasp_success
    return float(np.degrees(result.info["lift_tilt"]))


def test_a_heavy_slippery_hammer_held_by_its_end_swings_in_the_fingers(tmp_path):
    """Steel-heavy and slippery, held 26 cm from its head, the hammer swings; held at its head, or light
    and grippy, it stays as it lay."""
    assert _swing(tmp_path, 6000.0, 0.3, "far_end") > 10.0
    assert _swing(tmp_path, 6000.0, 0.3, "head") < 5.0
    assert _swing(tmp_path, 1200.0, 0.8, "far_end") < 2.0


def test_the_swing_is_the_tilt_of_the_upright_axis_not_a_turn_about_it():
    rest = rot_z(0.7) @ rot_x(0.2)  # a tool resting a little tilted, at some yaw
    assert _tilt(rest, rot_z(1.1) @ rest) == pytest.approx(0.0, abs=1e-9)  # turned in the hand: no swing
    assert np.degrees(_tilt(rest, rot_x(np.radians(30)) @ rest)) == pytest.approx(30.0)
    assert np.degrees(_tilt(rest, rot_z(0.4) @ rot_x(np.radians(-12)) @ rest)) == pytest.approx(12.0)


def _shard(out: Path, tilt: np.ndarray) -> Path:
    ep = synthetic_episodes(len(tilt), n_objects=8, seed=2)
    fields = {name: getattr(ep, name) for name in ep.__dataclass_fields__}
    fields["lift_tilt"] = tilt.astype(np.float32)
    fields["grasp_success"] = np.ones(len(tilt), np.uint8)
    with ShardWriter(out, "sweeping", {"round": 0, "policy": "synthetic"}, 1000) as writer:
        writer.add_batch(**fields)
    return out


def test_records_keep_the_swing_and_older_shards_read_it_as_unknown(tmp_path):
    tilt = np.linspace(0.0, 0.6, 40)
    path = _shard(tmp_path / "d", tilt) / "shard-00000.npz"
    cols, _ = read_columns(path, ("lift_tilt", "z"))
    np.testing.assert_allclose(cols["lift_tilt"], tilt, rtol=1e-6)
    with np.load(path, allow_pickle=False) as npz:  # the same shard as format 3 wrote it
        old = {k: npz[k] for k in npz.files if k != "lift_tilt"}
    old["format_version"] = np.array(3)
    (tmp_path / "old").mkdir()
    np.savez(tmp_path / "old" / "shard-00000.npz", **old)
    cols, _ = read_columns(tmp_path / "old" / "shard-00000.npz", ("lift_tilt", "z"))
    assert np.all(cols["lift_tilt"] == -1.0) and len(cols["z"]) == 40


def test_steady_grasps_relabels_only_the_grasps_that_swung():
    n = 4
    batch = Batch(crop=torch.zeros(n, 8, 8), z=torch.zeros(n), action=torch.zeros(n, 4),
                  s_g=torch.tensor([1.0, 1.0, 0.0, 1.0]), s_t=torch.tensor([1.0, 1.0, 0.0, 0.0]),
                  progress=torch.zeros(n), lift_tilt=torch.tensor([0.1, 0.5, 0.9, -1.0]))
    assert batch.steady_grasps(0.0) is batch
    np.testing.assert_array_equal(batch.steady_grasps(0.3).s_g.numpy(), [1.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(batch.steady_grasps(0.3).s_t.numpy(), batch.s_t.numpy())


def test_stream_batches_carry_the_swing(tmp_path):
    tilt = np.linspace(0.0, 0.6, 40)
    stream = EpisodeStream([_shard(tmp_path / "d", tilt)], "sweeping", val_fraction=0.0, seed=1)
    got = np.concatenate([b.lift_tilt.numpy() for b in stream.batches("all", 16, epoch=0)])
    np.testing.assert_allclose(np.sort(got), tilt, rtol=1e-6)


@pytest.mark.parametrize("max_tilt", [0.0, 0.3])
def test_training_counts_swung_grasps_as_failed(tmp_path, max_tilt):
    """Half of the episodes swung by 0.5 rad: with the option on, validation sees half the grasps fail."""
    tilt = np.tile([0.05, 0.5], 60)
    data = _shard(tmp_path / "d", tilt)
    cfg = TrainConfig(arch=TINY, num_threads=1, epochs=1, batch_size=32, val_fraction=0.3, seed=3,
                      loss=LossConfig(max_lift_tilt=max_tilt))
    result = train([data], "sweeping", tmp_path / "o", cfg, progress=False, log=lambda s: None)
    history = json.loads((result.out / "metrics.json").read_text())["history"]
    rate = history[-1]["val"]["metrics"]["grasp"]["positive_rate"]
    assert rate == (pytest.approx(0.5, abs=0.1) if max_tilt else 1.0)
    saved = json.loads((result.out / "config.json").read_text())["loss"]
    assert saved.get("max_lift_tilt", 0.0) == max_tilt
