import json
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest
import torch

from tognet.data.episodes import read_dataset, split_indices_by_object
from tognet.data.format import DatasetError
from tognet.data.manifest import new_manifest, write_manifest
from tognet.data.stream import EpisodeStream
from tognet.data.synthetic import bar_crop, synthetic_episodes, write_synthetic_dataset
from tognet.data.writer import write_shard


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Two folders (a parent of both is passed), 600 episodes in shards of 50, some invalid."""
    root = tmp_path_factory.mktemp("stream")
    write_synthetic_dataset(root / "w0", task="sweeping", n=300, shard_size=50, seed=1, n_objects=10,
                            invalid=0.1)
    write_synthetic_dataset(root / "w1", task="sweeping", n=300, shard_size=50, seed=2, n_objects=10,
                            invalid=0.1)
    return root


def _z(batches):
    return np.concatenate([b.z.numpy() for b in batches])


def test_split_and_epochs_cover_each_training_episode_once(data):
    stream = EpisodeStream([data], "sweeping", val_fraction=0.3, seed=5, shuffle_buffer=120)
    ep = read_dataset([data], task="sweeping")  # valid episodes only
    assert len(np.unique(ep.z)) == len(ep)  # z identifies an episode
    train_idx, val_idx = split_indices_by_object(ep.object_id, 0.3, 5)
    counts = stream.counts()
    assert counts["episodes"] == 600 and counts["valid"] == len(ep) < 600
    assert counts["train_episodes"] == len(train_idx) and counts["val_episodes"] == len(val_idx) > 0
    assert counts["train_objects"] == len(np.unique(ep.object_id[train_idx]))
    assert counts["val_objects"] == len(np.unique(ep.object_id[val_idx])) > 0
    assert stream.val_objects == set(ep.object_id[val_idx])
    orders = []
    for epoch in range(3):
        batches = list(stream.batches("train", 32, epoch=epoch))
        assert all(len(b) == 32 for b in batches[:-1]) and len(batches) == stream.num_batches("train", 32)
        z = _z(batches)
        assert len(z) == len(train_idx)  # each training episode once, no validation episode
        np.testing.assert_array_equal(np.sort(z), np.sort(ep.z[train_idx]))
        b = batches[0]
        assert b.crop.shape == (32, 64, 64) and b.action.shape == (32, 4)
        assert {t.dtype for t in (b.crop, b.z, b.action, b.s_g, b.s_t)} == {torch.float32}
        orders.append(z)
    assert not np.array_equal(orders[0], orders[1]) and not np.array_equal(orders[1], orders[2])
    # validation: fixed order, the order read_dataset gives
    np.testing.assert_array_equal(_z(stream.batches("val", 64)), ep.z[val_idx])
    np.testing.assert_array_equal(_z(stream.batches("all", 1000)), ep.z)
    # labels travel with their episode
    val = ep.subset(val_idx)
    s_g = np.concatenate([b.s_g.numpy() for b in stream.batches("val", 7)])
    np.testing.assert_array_equal(s_g, val.grasp_success.astype(np.float32))


def test_batches_deterministic_and_well_mixed(data):
    kw = dict(val_fraction=0.3, seed=5, shuffle_buffer=120)
    a = list(EpisodeStream([data], "sweeping", **kw).batches("train", 32, epoch=1))
    b = list(EpisodeStream([data], "sweeping", prefetch=0, **kw).batches("train", 32, epoch=1))
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        for name in ("crop", "z", "action", "s_g", "s_t"):
            assert np.array_equal(getattr(x, name).numpy(), getattr(y, name).numpy()), name
    epoch2 = EpisodeStream([data], "sweeping", **kw).batches("train", 32, epoch=2)
    assert not np.array_equal(_z(a), _z(epoch2))
    # a buffer spanning the whole set mixes every shard into the first batch; a buffer of one batch
    # still visits the shards in a random order
    ep = read_dataset([data])
    shard_of = dict(zip(ep.z.tolist(), (ep.trial // 50 + 6 * (ep.scene_seed >= 2_000_006)).tolist(),
                        strict=True))
    wide = EpisodeStream([data], "sweeping", val_fraction=0.0, shuffle_buffer=10_000)
    first = next(iter(wide.batches("train", 64)))
    assert len({shard_of[z] for z in first.z.tolist()}) >= 8
    narrow = EpisodeStream([data], "sweeping", val_fraction=0.0, shuffle_buffer=0)
    firsts = {shard_of[float(next(iter(narrow.batches("train", 16, epoch=e))).z[0])] for e in range(6)}
    assert len(firsts) >= 3


def test_sample_for_normalization(data):
    stream = EpisodeStream([data], "sweeping", val_fraction=0.3, seed=5)
    ep = read_dataset([data])
    train_idx, _ = split_indices_by_object(ep.object_id, 0.3, 5)
    s = stream.sample("train", 100)
    assert len(s["z"]) == 100 and s["crop"].dtype == np.float16
    assert set(s["z"].tolist()) <= set(ep.z[train_idx].tolist())
    assert len(stream.sample("train", 10_000)["z"]) == len(train_idx)
    np.testing.assert_array_equal(stream.sample("train", 100)["z"], s["z"])


def _corrupt_member(path, member):
    """Flip bytes inside one member's compressed data (the zip directory stays readable)."""
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    raw = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
    mid = start + info.compress_size // 2
    raw[mid : mid + 64] = bytes(b ^ 0xFF for b in raw[mid : mid + 64])
    path.write_bytes(bytes(raw))


def test_bad_shards_named_or_skipped(tmp_path):
    d = write_synthetic_dataset(tmp_path / "d", task="t", n=200, shard_size=50, seed=3, n_objects=8)
    good = EpisodeStream([d], "t").count("all")
    shard = d / "shard-00001.npz"
    data = shard.read_bytes()
    _corrupt_member(shard, "crop.npy")
    # its bytes are not the ones the manifest recorded: named as soon as the stream lists it
    with pytest.raises(DatasetError, match=r"shard-00001\.npz: corrupt, truncated or replaced"):
        EpisodeStream([d], "t")
    with pytest.warns(UserWarning, match=r"shard-00001\.npz"):
        assert EpisodeStream([d], "t", skip_bad=True).count("all") == good - 50
    # a dataset whose manifest records no digests (older tognet): crops corrupted, small columns intact:
    # the listing (and the counts) still work, reading fails
    manifest = json.loads((d / "manifest.json").read_text())
    for entry in manifest["shards"]:
        entry.pop("sha256", None)
    (d / "manifest.json").write_text(json.dumps(manifest))
    stream = EpisodeStream([d], "t")
    assert stream.count("all") == good
    with pytest.raises(DatasetError, match=r"shard-00001\.npz.*(corrupt|truncated)"):
        list(stream.batches("train", 16))
    skipping = EpisodeStream([d], "t", skip_bad=True)
    with pytest.warns(UserWarning, match=r"skipping bad shard.*shard-00001\.npz"):
        n0 = len(_z(skipping.batches("train", 16, epoch=0)))
    n1 = len(_z(skipping.batches("train", 16, epoch=1)))  # skipped again, without a second warning
    assert n0 == n1 == good - 50
    # truncated: the listing pass names it
    shard.write_bytes(data[: len(data) // 2])
    with pytest.raises(DatasetError, match=r"shard-00001\.npz: corrupt or truncated"):
        EpisodeStream([d], "t")
    with pytest.warns(UserWarning, match=r"shard-00001\.npz"):
        assert EpisodeStream([d], "t", skip_bad=True).count("all") == good - 50
    # wrong task and missing folders: DatasetError before any shard is read
    with pytest.raises(DatasetError, match="holds task 't', expected 'x'"):
        EpisodeStream([d], "x")
    with pytest.raises(DatasetError, match="dataset folder not found"):
        EpisodeStream([tmp_path / "nope"], "t")


def test_rewritten_shard_detected(tmp_path):
    d = write_synthetic_dataset(tmp_path / "d", task="t", n=100, shard_size=50, seed=3, n_objects=8)
    stream = EpisodeStream([d], "t")
    other = tmp_path / "o"
    write_synthetic_dataset(other, task="t", n=60, shard_size=60, seed=4, n_objects=8)
    (d / "shard-00000.npz").write_bytes((other / "shard-00000.npz").read_bytes())
    with pytest.raises(DatasetError, match=r"shard-00000\.npz: corrupt, truncated or replaced"):
        list(stream.batches("all", 16))
    manifest = json.loads((d / "manifest.json").read_text())  # without digests: its count gives it away
    for entry in manifest["shards"]:
        entry.pop("sha256", None)
    (d / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError, match=r"shard-00000\.npz: holds 60 episodes, its manifest says 50"):
        list(EpisodeStream([d], "t").batches("all", 16))


# -- memory ------------------------------------------------------------------------------------------
N_SHARDS, PER_SHARD, SMALL_SHARDS = 60, 512, 12
_MEASURE = textwrap.dedent("""
    import json, sys
    import torch  # imported before the baselines, as in training
    from tognet.data.stream import EpisodeStream

    def hwm_mib():
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024

    out = []
    for spec in sys.argv[1:]:  # run after run: the high-water mark only rises
        folder, buffer = spec.split(":")
        stream = EpisodeStream([folder], "t", shuffle_buffer=int(buffer))
        base = hwm_mib()
        n = sum(len(b) for b in stream.batches("train", 128, epoch=0))
        out.append({"episodes": n, "growth_mib": hwm_mib() - base})
    print(json.dumps(out))
""")


def _write_many_shards(folder, n_shards, per_shard, small=None, small_shards=0):
    """Many shards, fast: a few distinct noiseless crops reused (they compress well), written directly.
    ``small``: a second dataset folder holding (hard links to) the first ``small_shards`` shards."""
    from tognet.data.format import FIELDS

    folder.mkdir(parents=True)
    ep = synthetic_episodes(per_shard, n_objects=16, seed=0)
    crops = np.stack([bar_crop(4 + i, 30 - i, 3 + i % 12) for i in range(16)]).astype(np.float16)
    base = {name: getattr(ep, name) for name in FIELDS} | {"crop": crops[np.arange(per_shard) % 16],
                                                           "valid": np.ones(per_shard, np.uint8)}
    manifest = new_manifest("t")
    for k in range(n_shards):
        cols = base | {"object_id": np.array([f"obj-{k}-{i % 2}" for i in range(per_shard)])}
        manifest["shards"].append(write_shard(folder / f"shard-{k:05d}.npz", cols, {"task": "t"}))
    write_manifest(folder, manifest)
    if small is not None:
        small.mkdir(parents=True)
        for entry in manifest["shards"][:small_shards]:
            (small / entry["file"]).hardlink_to(folder / entry["file"])
        write_manifest(small, dict(manifest, shards=manifest["shards"][:small_shards]))
    return folder


@pytest.mark.slow
def test_memory_stays_flat_whatever_the_dataset_size(tmp_path):
    big, small = tmp_path / "big", tmp_path / "small"
    _write_many_shards(big, N_SHARDS, PER_SHARD, small, SMALL_SHARDS)
    in_memory_mib = N_SHARDS * PER_SHARD * 64 * 64 * 2 / 2**20  # all crops as float16: 240 MiB
    buffer, whole = 1024, N_SHARDS * PER_SHARD
    run = subprocess.run([sys.executable, "-c", _MEASURE, f"{small}:{buffer}", f"{big}:{buffer}",
                          f"{big}:{whole}"], capture_output=True, text=True, timeout=300, check=True)
    first, bigger, control = json.loads(run.stdout)
    assert first["episodes"] == SMALL_SHARDS * PER_SHARD
    assert bigger["episodes"] == control["episodes"] == whole
    # the first pass (over 12 shards) costs the buffer and a shard or two; a pass over 5x the data
    # raises the high-water mark by next to nothing, and neither comes near the dataset's size
    assert first["growth_mib"] < in_memory_mib / 4, (first, bigger)
    # (with glibc's mmap threshold fixed by the stream: 0-0.8 MiB measured; left to glibc's dynamic
    # threshold the heaps fragmented and the mark crept 17-31 MiB a pass, which this bound catches)
    assert bigger["growth_mib"] < in_memory_mib / 20, (first, bigger)
    # the measurement can fail: a buffer holding the whole set grows by about the dataset's size
    assert control["growth_mib"] > 0.6 * in_memory_mib, control
