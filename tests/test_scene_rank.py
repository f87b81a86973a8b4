"""The within-scene ranking term: batches of whole scenes, the pairwise loss, its metric, and training."""

import json
import math

import numpy as np
import pytest
import torch

from tognet.data.stream import EpisodeStream, scene_keys
from tognet.data.synthetic import synthetic_episodes
from tognet.data.writer import ShardWriter
from tognet.model.config import ArchConfig, LossConfig, TrainConfig
from tognet.model.loss import scene_rank_sum, tognet_loss
from tognet.model.metrics import within_scene_auc
from tognet.model.train import train

TINY = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                  z_features=8, head_hidden=32)
PER_SCENE = 6


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """240 synthetic episodes as 40 scenes of 6 trials (one object each), in shards of 30."""
    ep = synthetic_episodes(240, n_objects=12, seed=4)
    group = np.arange(240) // PER_SCENE
    fields = {name: getattr(ep, name) for name in ep.__dataclass_fields__}
    fields["object_id"] = ep.object_id[group * PER_SCENE]
    fields["scene_seed"] = (1000 + group).astype(np.int64)
    out = tmp_path_factory.mktemp("scenes") / "d"
    with ShardWriter(out, "sweeping", {"round": 0, "policy": "synthetic"}, 30) as writer:
        writer.add_batch(**fields)
    return out


def _scene_batches(stream, epoch):
    return [b.scene.numpy() for b in stream.batches("train", 32, epoch=epoch)]


def test_scene_batches_keep_each_scene_in_one_batch(scenes):
    grouped = EpisodeStream([scenes], "sweeping", val_fraction=0.25, seed=1, shuffle_buffer=60,
                            scene_batches=True)
    mixed = EpisodeStream([scenes], "sweeping", val_fraction=0.25, seed=1, shuffle_buffer=60)
    for epoch in range(2):
        batches = _scene_batches(grouped, epoch)
        keys = np.concatenate(batches)
        assert len(keys) == grouped.count("train") and all(len(b) <= 32 for b in batches)
        home = {}
        for i, b in enumerate(batches):
            for k in np.unique(b):
                assert home.setdefault(int(k), i) == i, "a scene was split over two batches"
        assert np.all(np.unique(keys, return_counts=True)[1] == PER_SCENE)
    plain = _scene_batches(mixed, 0)
    assert sum(len(np.unique(b)) for b in plain) > len(np.unique(np.concatenate(plain)))  # plain ones split


def test_scene_keys_tell_objects_and_seeds_apart():
    keys = scene_keys(np.array(["a", "a", "b", "a"]), np.array([1, 1, 1, 2]))
    assert keys[0] == keys[1] and len({int(k) for k in keys}) == 3


def _log_q(g, t):
    return math.log(1 / (1 + math.exp(-g))) + math.log(1 / (1 + math.exp(-t)))


def test_rank_sum_counts_only_pairs_of_one_scene():
    g = torch.tensor([0.2, 1.0, -0.5, 0.3, 0.1])
    t = torch.tensor([0.4, 2.0, 0.0, -1.0, 0.5])
    s_t = torch.tensor([1.0, 0.0, 0.0, 1.0, 1.0])
    scene = torch.tensor([7, 7, 7, 9, 9])
    total, pairs = scene_rank_sum(g, t, s_t, scene)
    s = [_log_q(float(a), float(b)) for a, b in zip(g, t, strict=True)]
    hand = math.log1p(math.exp(s[1] - s[0])) + math.log1p(math.exp(s[2] - s[0]))
    assert int(pairs) == 2 and float(total) == pytest.approx(hand, rel=1e-6)
    members = torch.stack([t, t - 1.0], dim=1)  # members: log of their mean probability
    total_m, _ = scene_rank_sum(g, members, s_t, scene)
    mean_p = [(1 / (1 + math.exp(-float(a))) + 1 / (1 + math.exp(-float(a) + 1))) / 2 for a in t]
    s = [math.log(1 / (1 + math.exp(-float(a)))) + math.log(p) for a, p in zip(g, mean_p, strict=True)]
    hand = math.log1p(math.exp(s[1] - s[0])) + math.log1p(math.exp(s[2] - s[0]))
    assert float(total_m) == pytest.approx(hand, rel=1e-6)


def test_rank_term_in_the_loss_raises_the_success_over_the_failure():
    g = torch.zeros(4, requires_grad=True)
    t = torch.zeros(4, requires_grad=True)
    s_g = torch.tensor([1.0, 1.0, 1.0, 1.0])
    s_t = torch.tensor([1.0, 0.0, 1.0, 0.0])
    scene = torch.tensor([1, 1, 2, 3])
    args = (g, t, torch.zeros(4, 4), s_g, s_t, torch.zeros(4, 4))
    off = tognet_loss(*args, config=LossConfig(), scene=scene)
    assert float(off["rank"]) == 0.0
    on = tognet_loss(*args, config=LossConfig(weight_rank=2.0), scene=scene)
    assert float(on["rank"].detach()) == pytest.approx(2.0 * math.log(2.0))  # one pair, equal scores
    assert float(on["loss"].detach()) == pytest.approx(float(off["loss"].detach()) + 2.0 * math.log(2.0))
    on["rank"].backward()
    assert float(t.grad[0]) < 0 < float(t.grad[1]) and float(t.grad[2]) == float(t.grad[3]) == 0.0


def test_within_scene_auc():
    scene = np.array([1, 1, 1, 2, 2, 3, 3])
    labels = np.array([1, 0, 0, 1, 0, 1, 1])
    scores = np.array([0.9, 0.5, 0.95, 0.1, 0.2, 0.3, 0.4])
    auc, pairs = within_scene_auc(scene, labels, scores)
    assert pairs == 3 and auc == pytest.approx(1 / 3)  # scene 1: 1 of 2 pairs right, scene 2: 0 of 1
    assert within_scene_auc(np.array([1, 1]), np.array([1, 1]), np.array([0.1, 0.2])) == (None, 0)


def test_training_with_the_rank_term_reports_it(scenes, tmp_path):
    cfg = TrainConfig(arch=TINY, num_threads=1, epochs=2, batch_size=32, val_fraction=0.25, seed=3,
                      lr=3e-3, loss=LossConfig(weight_rank=1.0))
    result = train([scenes], "sweeping", tmp_path / "o", cfg, progress=False, log=lambda s: None)
    history = json.loads((result.out / "metrics.json").read_text())["history"]
    assert all(h["train"]["rank"] > 0 and h["val"]["rank"] > 0 for h in history)
    task = history[-1]["val"]["metrics"]["task"]
    assert 0.0 <= task["scene_auc"] <= 1.0 and task["scene_pairs"] > 0
    saved = json.loads((result.out / "config.json").read_text())
    assert saved["loss"]["weight_rank"] == 1.0
