"""Nothing trusted that was not verified (issue 35): a shard is checked against its manifest's sha256 and
count when it is read, `data info --check` names every mismatch, and a collection rerun sets a corrupt
shard aside and collects its job again."""

import json
import shutil

import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.data.format import FIELDS
from tognet.data.synthetic import write_synthetic_dataset


@pytest.fixture
def dataset(tmp_path):
    return write_synthetic_dataset(tmp_path / "d", task="sweeping", n=120, shard_size=40, seed=5, n_objects=6)


def _check(folder):
    return CliRunner().invoke(app, ["data", "info", str(folder), "--check"])


def _flip(path, at=0.6, n=16):
    data = bytearray(path.read_bytes())
    i = int(len(data) * at)
    data[i:i + n] = bytes(255 - b for b in data[i:i + n])
    path.write_bytes(bytes(data))


def _edit_manifest(folder, edit):
    manifest = json.loads((folder / "manifest.json").read_text())
    edit(manifest["shards"])
    (folder / "manifest.json").write_text(json.dumps(manifest))


def test_a_whole_dataset_checks_out(dataset):
    result = _check(dataset)
    assert result.exit_code == 0 and "each matching its manifest" in result.output


@pytest.mark.parametrize("case", ["flipped bytes", "zeroed sha256", "swapped shards", "a count that lies"])
def test_every_kind_of_mismatch_is_named(case, dataset):
    names = sorted(p.name for p in dataset.glob("shard-*.npz"))
    if case == "flipped bytes":
        _flip(dataset / names[1])
        bad = [names[1]]
    elif case == "zeroed sha256":
        _edit_manifest(dataset, lambda shards: shards[2].update(sha256="0" * 64))
        bad = [names[2]]
    elif case == "swapped shards":
        a, b = dataset / names[0], dataset / names[1]
        tmp = a.with_suffix(".tmp")
        shutil.move(a, tmp), shutil.move(b, a), shutil.move(tmp, b)
        bad = names[:2]
    else:
        _edit_manifest(dataset, lambda shards: shards[0].update(count=39))
        bad = [names[0]]
    result = _check(dataset)
    assert result.exit_code != 0, result.output
    for name in bad:
        assert f"bad: {dataset / name}" in result.output, (case, result.output)
    assert "readable" not in result.output.splitlines()[-1]


def test_a_corrupt_shard_is_collected_again_on_rerun(tmp_path):
    """A round's store reopened over a shard whose bytes changed: the shard is set aside (.corrupt) and its
    job is no longer counted as written, so the rerun collects it like a missing one."""
    from tognet.collect.store import RoundStore
    from tognet.data.episodes import read_columns

    source = write_synthetic_dataset(tmp_path / "src", task="sweeping", n=60, shard_size=20, seed=1,
                                     n_objects=3)
    shards = sorted(source.glob("shard-*.npz"))
    store = RoundStore(tmp_path / "round", "sweeping", {"round": 1})
    for job, path in enumerate(shards):
        columns, _ = read_columns(path, tuple(FIELDS))
        store.add(job, columns)
    store.flush(force=True)
    assert store.done == {0, 1, 2}
    _flip(tmp_path / "round" / "shard-000001.npz")
    with pytest.warns(UserWarning, match=r"shard-000001\.npz: corrupt, truncated or replaced.*runs again"):
        again = RoundStore(tmp_path / "round", "sweeping", {"round": 1})
    assert again.done == {0, 2}
    assert (tmp_path / "round" / "shard-000001.npz.corrupt").is_file()
    assert not (tmp_path / "round" / "shard-000001.npz").exists()


@pytest.mark.parametrize("name", ["grasping", "hammering_search"])
def test_a_copy_of_a_shipped_model_with_flipped_bytes_is_refused_by_name(name, tmp_path):
    from tognet.models import MODELS_DIR

    copy = tmp_path / f"{name}.pt"
    shutil.copyfile(MODELS_DIR / f"{name}.pt", copy)
    good = CliRunner().invoke(app, ["model", "info", str(copy)])
    assert good.exit_code == 0 and "content matches the digest written into it" in good.output, good.output
    _flip(copy, at=0.5, n=64)  # inside the tensors: torch itself reads such a file without a word
    bad = CliRunner().invoke(app, ["model", "info", str(copy)])
    assert bad.exit_code != 0, bad.output
    assert str(copy) in bad.output and "digest" in bad.output, bad.output
    assert "Traceback" not in bad.output
