import json
import warnings

import numpy as np
import pytest

from tognet.data import DatasetError, EpisodeArrays, ShardWriter, read_dataset, read_shard
from tognet.data.episodes import split_indices_by_object
from tognet.data.format import FIELDS
from tognet.data.synthetic import synthetic_episodes, write_synthetic_dataset
from tognet.data.torch_dataset import EpisodeDataset


def _columns(ep: EpisodeArrays) -> dict:
    return {name: getattr(ep, name) for name in FIELDS}


def test_round_trip_and_manifest(tmp_path):
    ep = synthetic_episodes(300, n_objects=7, seed=1, invalid=0.1)
    with ShardWriter(tmp_path, "sweeping", {"round": 1, "policy": "random"}, shard_size=128) as w:
        w.add_batch(**_columns(ep.subset(np.arange(250))))
        one = ep.subset([250])
        w.add(**{k: v[0] for k, v in _columns(one).items()})
        w.add_batch(**_columns(ep.subset(np.arange(251, 300))))
    names = sorted(p.name for p in tmp_path.glob("shard-*.npz"))
    assert names == ["shard-00000.npz", "shard-00001.npz", "shard-00002.npz"]
    assert not list(tmp_path.glob(".*tmp*"))
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert [s["count"] for s in manifest["shards"]] == [128, 128, 44]
    assert manifest["totals"]["episodes"] == 300
    assert manifest["totals"]["valid"] == int(ep.valid.sum())
    valid = ep.valid.astype(bool)
    assert manifest["totals"]["grasp_success_rate"] == pytest.approx(ep.grasp_success[valid].mean())
    back = read_dataset(tmp_path, task="sweeping")
    kept = ep.subset(valid)
    assert len(back) == len(kept) < 300
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(kept, name))
    _, meta = read_shard(tmp_path / names[0])
    assert meta == {"task": "sweeping", "round": 1, "policy": "random"}


def test_append_never_overwrites_and_refuses_task_mismatch(tmp_path):
    write_synthetic_dataset(tmp_path, task="hammering", n=100, shard_size=64)
    first = (tmp_path / "shard-00000.npz").read_bytes()
    write_synthetic_dataset(tmp_path, task="hammering", n=100, shard_size=64, seed=5)
    assert sorted(p.name for p in tmp_path.glob("shard-*.npz"))[-1] == "shard-00003.npz"
    assert (tmp_path / "shard-00000.npz").read_bytes() == first
    assert json.loads((tmp_path / "manifest.json").read_text())["totals"]["episodes"] == 200
    with pytest.raises(DatasetError, match="holds task 'hammering'"):
        ShardWriter(tmp_path, "sweeping", {})


def test_bad_fields_named():
    w_ep = synthetic_episodes(4)
    cols = _columns(w_ep)
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        w = ShardWriter(d, "t", {})
        with pytest.raises(ValueError, match="field 'crop'.*shape"):
            w.add_batch(**{**cols, "crop": cols["crop"][:, :32, :32]})
        with pytest.raises(ValueError, match="missing episode field 'action'"):
            w.add_batch(**{k: v for k, v in cols.items() if k != "action"})
        bad = cols["z"].copy()
        bad[1] = np.nan
        with pytest.raises(ValueError, match="field 'z'.*NaN"):
            w.add_batch(**{**cols, "z": bad})


def test_truncated_shard_named_and_skippable(tmp_path):
    write_synthetic_dataset(tmp_path, n=300, shard_size=100)
    victim = tmp_path / "shard-00001.npz"
    victim.write_bytes(victim.read_bytes()[: victim.stat().st_size // 2])
    with pytest.raises(DatasetError, match=r"shard-00001\.npz.*(corrupt|truncated)"):
        read_dataset(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ep = read_dataset(tmp_path, skip_bad=True)
    assert len(ep) == 200
    assert any("shard-00001.npz" in str(c.message) for c in caught)
    (tmp_path / "shard-00002.npz").unlink()
    with pytest.raises(DatasetError, match="shard-00002.npz.*not found"):
        read_shard(tmp_path / "shard-00002.npz")
    victim.unlink()
    with pytest.raises(DatasetError, match="shard-00001.npz.*not found"):
        read_dataset(tmp_path)


def test_task_check_on_read(tmp_path):
    write_synthetic_dataset(tmp_path / "a", task="sweeping", n=20)
    write_synthetic_dataset(tmp_path / "b", task="hammering", n=20)
    with pytest.raises(DatasetError, match="expected 'hammering'"):
        read_dataset(tmp_path / "a", task="hammering")
    with pytest.raises(DatasetError, match="different tasks"):
        read_dataset([tmp_path / "a", tmp_path / "b"])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_split_by_object_never_shares_objects(seed):
    ep = synthetic_episodes(400, n_objects=13, seed=seed)
    train, val = EpisodeDataset(ep).split_by_object(0.25, seed=seed)
    assert len(train) + len(val) == 400 and len(val) > 0
    assert not set(train.episodes.object_id) & set(val.episodes.object_id)
    assert len(set(val.episodes.object_id)) == round(0.25 * len(set(ep.object_id)))
    a = split_indices_by_object(ep.object_id, 0.25, seed)
    b = split_indices_by_object(ep.object_id, 0.25, seed)
    np.testing.assert_array_equal(a[1], b[1])


def test_dataset_items():
    ds = EpisodeDataset(synthetic_episodes(10))
    item = ds[3]
    assert item["crop"].shape == (1, 64, 64) and item["action"].shape == (4,)
    assert float(item["grasp_success"]) == float(ds.episodes.grasp_success[3])


def test_one_writer_per_folder_and_parent_folder_reading(tmp_path):
    w = ShardWriter(tmp_path / "round1" / "worker-00", "sweeping", {"worker": 0}, shard_size=10)
    with pytest.raises(DatasetError, match="another ShardWriter"):
        ShardWriter(tmp_path / "round1" / "worker-00", "sweeping", {})
    ep = synthetic_episodes(25, seed=3)
    w.add_batch(**_columns(ep))
    w.close()
    ShardWriter(tmp_path / "round1" / "worker-00", "sweeping", {}).close()  # lock released on close
    write_synthetic_dataset(tmp_path / "round1" / "worker-01", task="sweeping", n=15)
    both = read_dataset(tmp_path / "round1")
    assert len(both) == 40


def test_configs_saved_beside_without_overwrite(tmp_path):
    from tognet.model.config import LossConfig

    ShardWriter(tmp_path, "t", {"round": 1}, configs={"loss": LossConfig()}).close()
    ShardWriter(tmp_path, "t", {"round": 1}, configs={"loss": LossConfig()}).close()
    ShardWriter(tmp_path, "t", {"round": 2}, configs={"loss": LossConfig(weight_task=2.0)}).close()
    names = sorted(p.name for p in (tmp_path / "configs").iterdir())
    assert names == ["loss-2.json", "loss.json"]
    assert LossConfig.load(tmp_path / "configs" / "loss.json") == LossConfig()
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert [c["file"] for c in manifest["configs"]] == ["configs/loss.json", "configs/loss-2.json"]


def test_failure_reasons_by_name(tmp_path):
    from tognet.data import FAILURE_CODES
    from tognet.tasks.base import FailureReason

    ep = synthetic_episodes(3, seed=2)
    cols = _columns(ep)
    with ShardWriter(tmp_path, "t", {}) as w:
        w.add_batch(**{**cols, "failure": np.array(["none", "grasp_failed", "unstable"])})
        w.add(**{**{k: v[0] for k, v in cols.items()}, "failure": FailureReason.TIMEOUT})
        with pytest.raises(ValueError, match="unknown failure reason 'exploded'"):
            w.add_batch(**{**cols, "failure": np.array(["none", "exploded", "none"])})
    back = read_dataset(tmp_path, keep_invalid=True)
    assert back.failure.tolist() == [0, 1, 7, 6]
    assert json.loads((tmp_path / "manifest.json").read_text())["failure_codes"] == FAILURE_CODES
    assert set(FAILURE_CODES) == {r.value for r in FailureReason}


def test_failure_codes_follow_the_enum_and_keep_their_stored_values():
    from tognet.data.format import FAILURE_CODES
    from tognet.tasks import FailureReason

    assert list(FAILURE_CODES) == [r.value for r in FailureReason]
    # Shards already on disk hold these integers: they must never change.
    assert FAILURE_CODES == {"none": 0, "grasp_failed": 1, "dropped": 2, "collision_before_motion": 3,
                             "missed": 4, "task_failed": 5, "timeout": 6, "unstable": 7,
                             "unreachable": 8, "joint_limit": 9}  # the arm's, added at the end
