"""The per-item disk estimates the commands check before long work (issue 35) match the files they write:
a small real set of each kind takes, per item, between half and twice the estimate (so a format change that
grows the files fails here), and a count that cannot fit is refused in one line naming the shortfall."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.cli.collect import trial_bytes
from tognet.cli.data import SYNTHETIC_BYTES
from tognet.cli.evaluate import scene_bytes
from tognet.cli.objects import OBJECT_BYTES_BY_KIND


def _run(*args: str) -> None:
    result = CliRunner().invoke(app, list(args))
    assert result.exit_code == 0, result.output


def _disk_bytes(paths: list[Path]) -> int:
    """What ``paths`` and everything under them take on the disk (allocated blocks, folders included)."""
    total = 0
    for path in paths:
        for p in [path, *path.rglob("*")] if path.is_dir() else [path]:
            total += p.lstat().st_blocks * 512
    return total


def _assert_near(measured: float, estimate: float) -> None:
    assert estimate / 2 <= measured <= 2 * estimate, f"{measured:.0f} B per item, estimate {estimate:.0f} B"


@pytest.mark.parametrize("kind, split, count", [("primitive", "train", 4), ("complex", "train", 2),
                                                ("realistic", "test", 4)])
def test_an_object_takes_about_its_estimate(tmp_path, kind, split, count):
    out = tmp_path / "objs"
    _run("objects", "generate", "--kind", kind, "--split", split, "--count", str(count), "--out", str(out))
    folders = [p for p in out.iterdir() if p.is_dir()]
    assert len(folders) == count
    _assert_near(_disk_bytes(folders) / count, OBJECT_BYTES_BY_KIND[kind])


@pytest.mark.parametrize("trials_per_scene, episodes", [(8, 64), (1, 16)])
def test_a_collected_trial_takes_about_its_estimate(tmp_path, trials_per_scene, episodes):
    from tognet.collect.config import CollectConfig

    _run("objects", "generate", "--kind", "primitive", "--count", "2", "--out", str(tmp_path / "objs"))
    config = CollectConfig(trials_per_scene=trials_per_scene, scenes_per_job=4)  # 8: the default
    config.save(tmp_path / "collect.json")
    out = tmp_path / "data"
    _run("collect", "--task", "hammering", "--objects", str(tmp_path / "objs"), "--out", str(out),
         "--episodes", str(episodes), "--config", str(tmp_path / "collect.json"), "--workers", "0",
         "--no-progress")
    per_job = 4 * trials_per_scene
    shards = sorted(out.glob("shard-*.npz"))
    assert len(shards) == episodes // per_job  # one shard per job
    _assert_near(_disk_bytes(shards) / episodes, trial_bytes(per_job))


def test_a_synthetic_episode_takes_about_its_estimate(tmp_path):
    out = tmp_path / "syn"
    _run("data", "synthetic", str(out), "--episodes", "1024", "--shard-size", "512", "--no-progress")
    shards = sorted(out.glob("shard-*.npz"))
    assert len(shards) == 2
    _assert_near(_disk_bytes(shards) / 1024, SYNTHETIC_BYTES)


@pytest.mark.parametrize("methods", ["all", "Antipodal+Random,TOG-Net"])
def test_an_evaluated_scene_takes_about_its_estimate_for_the_methods_run(tmp_path, methods):
    out = tmp_path / "eval"
    _run("evaluate", "--task", "hammering", "--category", "pg-primitive", "--methods", methods,
         "--episodes", "4", "--out", str(out), "--no-animations", "--workers", "0", "--no-progress")
    jobs = sorted((out / "hammering" / "pg-primitive").glob("job-*.json"))
    assert len(jobs) == 2  # 2 scenes per job
    _assert_near(_disk_bytes(jobs) / 4, scene_bytes(methods))


def test_a_count_that_cannot_fit_names_the_folder_and_the_shortfall(tmp_path):
    out = tmp_path / "objs"
    result = CliRunner().invoke(app, ["objects", "generate", "--kind", "primitive", "--count", str(10**12),
                                      "--out", str(out)])
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in result.output
    assert str(out) in errors[0] and "short" in errors[0] and "--count 1000000000000" in errors[0]
    assert not out.exists() or not any(out.iterdir())
