"""A full disk (issue 35 item 2): training stopped by it says so in one line and leaves a folder that
``--resume`` continues, once space is freed, to the weights an uninterrupted run ends with. The disk is a
small tmpfs the test mounts (as root) and unmounts; skipped with the reason where it cannot."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import torch

TOGNET = str(Path(sys.executable).parent / "tognet")


def _can_mount() -> str | None:
    if os.geteuid() != 0:
        return "needs root to mount a small tmpfs"
    return None


REASON = _can_mount()
pytestmark = pytest.mark.skipif(REASON is not None, reason=f"disk-full tests: {REASON}")


def _tognet(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([TOGNET, *args], capture_output=True, text=True, timeout=600)


def _train(data: Path, out: Path, *more: str) -> subprocess.CompletedProcess[str]:
    return _tognet("train", "--data", str(data), "--task", "synthetic", "--out", str(out), "--epochs", "3",
                   "--no-progress", *more)


def _weights(path: Path) -> dict[str, torch.Tensor]:
    from tognet.model.checkpoint import load_checkpoint

    return load_checkpoint(path)["state_dict"]


@pytest.fixture
def small_disk(tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted: list[Path] = []

    def mount(size: int) -> Path:
        opts = f"size={size}" if not mounted else f"remount,size={size}"
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(disk)], capture_output=True,
                              text=True)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
        mounted.append(disk)
        return disk

    yield mount
    if mounted:
        subprocess.run(["umount", str(disk)], check=True)


def test_training_stopped_by_a_full_disk_resumes_to_the_uninterrupted_weights(tmp_path, small_disk):
    data = tmp_path / "syn"
    assert _tognet("data", "synthetic", str(data), "--episodes", "400").returncode == 0
    assert _train(data, tmp_path / "reference").returncode == 0
    one = tmp_path / "one-epoch"
    assert _train(data, one, "--epochs", "1").returncode == 0
    after_one = sum(f.stat().st_size for f in one.iterdir() if f.name != "curves.png")
    last = (one / "last.pt").stat().st_size
    disk = small_disk(after_one + last // 2)  # epoch 1 fits; epoch 2's last.pt does not
    run = disk / "run"
    stopped = _train(data, run)
    assert stopped.returncode == 2, stopped.stderr
    errors = [line for line in stopped.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in stopped.stderr
    assert "no space left" in errors[0] and str(run / "last.pt") in errors[0] and "MB free" in errors[0]
    assert (run / "last.pt").is_file() and not list(run.glob(".*tmp*"))  # epoch 1 kept, no torn file
    assert _weights(run / "last.pt").keys() == _weights(tmp_path / "reference" / "last.pt").keys()
    small_disk(64 << 20)  # space freed
    resumed = _train(data, run, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    for name in ("best.pt", "last.pt"):
        got, want = _weights(run / name), _weights(tmp_path / "reference" / name)
        for key in want:
            assert torch.equal(got[key], want[key]), (name, key)


def test_a_collection_stopped_by_a_full_disk_continues_to_the_uninterrupted_records(tmp_path, small_disk):
    import numpy as np

    from tognet.collect.config import CollectConfig
    from tognet.data.episodes import read_dataset
    from tognet.data.format import FIELDS
    from tognet.objects import generate_set

    generate_set("primitive", "train", 3, tmp_path / "objs")
    CollectConfig(trials_per_scene=3, scenes_per_job=1).save(tmp_path / "small.json")

    def command(out: Path) -> list[str]:
        return [TOGNET, "collect", "--task", "hammering", "--objects", str(tmp_path / "objs"),
                "--out", str(out), "--episodes", "60", "--config", str(tmp_path / "small.json"),
                "--workers", "1", "--no-progress"]

    def collect(out: Path) -> subprocess.CompletedProcess[str]:
        return subprocess.run(command(out), capture_output=True, text=True, timeout=600)

    assert collect(tmp_path / "reference").returncode == 0
    disk = small_disk(64 << 20)
    run = disk / "run"
    stopped = _fill_when(command(run), lambda: len(list(run.glob("shard-*.npz"))) >= 3, disk)
    _one_error(stopped, run)
    (disk / "filler").unlink()
    done = collect(run)
    assert done.returncode == 0, done.stderr
    a = read_dataset(tmp_path / "reference", keep_invalid=True)
    b = read_dataset(disk / "run", keep_invalid=True)
    assert len(a.z) == len(b.z) == 60
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def _fill(disk: Path) -> Path:
    """Take every free byte of ``disk`` with one file (another program filling the disk); returns it."""
    filler = disk / "filler"
    with open(filler, "wb") as fh:
        free = os.statvfs(disk).f_bavail * os.statvfs(disk).f_frsize
        os.posix_fallocate(fh.fileno(), 0, free)
    return filler


def _fill_when(cmd: list[str], ready: Callable[[], bool], disk: Path) -> subprocess.CompletedProcess[str]:
    """Run ``cmd``; once ``ready()``, pause it, fill ``disk`` and let it go on (so the disk is full part
    way through whatever its size estimate said); its outcome."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300
        while not ready() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        if proc.poll() is None:
            proc.send_signal(signal.SIGSTOP)
            _fill(disk)
            proc.send_signal(signal.SIGCONT)
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def _one_error(done: subprocess.CompletedProcess[str], path_under: Path) -> str:
    assert done.returncode == 2, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in done.stderr, done.stderr
    assert "no space left" in errors[0] and str(path_under) in errors[0], errors[0]
    return errors[0]


def _tree(root: Path) -> dict[str, bytes]:
    return {str(f.relative_to(root)): f.read_bytes() for f in sorted(root.rglob("*")) if f.is_file()}


def test_objects_generate_stopped_by_a_full_disk_reruns_to_the_same_files(tmp_path, small_disk):
    def generate(out: Path) -> list[str]:
        return [TOGNET, "objects", "generate", "--kind", "primitive", "--count", "60", "--out", str(out)]

    assert subprocess.run(generate(tmp_path / "reference"), capture_output=True).returncode == 0
    disk = small_disk(64 << 20)
    out = disk / "set"
    stopped = _fill_when(generate(out), lambda: len(list(out.glob("primitive-*/object.xml"))) >= 8, disk)
    _one_error(stopped, out)
    assert not [f for f in out.rglob("*") if f.is_file() and f.stat().st_size == 0]  # no empty mesh
    assert not list(out.rglob(".*tmp*"))
    made = _tree(out)
    want = _tree(tmp_path / "reference")
    assert 0 < len(made) < len(want)
    (disk / "filler").unlink()  # space freed: the same command goes on
    done = subprocess.run(generate(out), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert _tree(out) == want


@pytest.fixture(scope="module")
def toy_preset(tmp_path_factory) -> Path:
    from tognet.collect.config import CollectConfig, PipelineConfig, RoundConfig
    from tognet.model.config import TrainConfig

    root = tmp_path_factory.mktemp("toy")
    PipelineConfig(
        name="toy", objects={"primitive": 3},
        grasp_round=RoundConfig(episodes=12, policy="nms_uniform", epochs=1),
        rounds=(RoundConfig(episodes=12, policy="nms_uniform", epochs=1),
                RoundConfig(episodes=12, policy="epsilon_greedy", epochs=1)),
        collect=CollectConfig(trials_per_scene=4, scenes_per_job=1),
        train=TrainConfig(batch_size=8, val_fraction=0.34, patience=2),
    ).save(root / "toy.json")
    return root / "toy.json"


def _pipeline(preset: Path, out: Path, *more: str) -> list[str]:
    return [TOGNET, "pipeline", "--task", "sweeping", "--preset", str(preset), "--out", str(out),
            "--workers", "1", "--no-progress", *more]


@pytest.fixture(scope="module")
def toy_run(toy_preset) -> Path:
    run = toy_preset.parent / "reference"
    done = subprocess.run(_pipeline(toy_preset, run), capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return run


def test_a_pipeline_stopped_by_a_full_disk_in_round_1_training_resumes_to_the_same_models(
        toy_preset, toy_run, small_disk):
    disk = small_disk(64 << 20)
    run = disk / "run"
    model = run / "sweeping" / "round1" / "model"
    stopped = _fill_when(_pipeline(toy_preset, run), (model / "config.json").is_file, disk)
    _one_error(stopped, model)
    assert not (run / "summary.json").exists() and not list(run.rglob(".*tmp*"))
    (disk / "filler").unlink()
    resumed = subprocess.run(_pipeline(toy_preset, run, "--resume"), capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    for name in ("grasping/model/best.pt", "sweeping/round1/model/best.pt", "sweeping/round2/model/best.pt",
                 "sweeping/round2/model/last.pt"):
        got, want = _weights(run / name), _weights(toy_run / name)
        assert all(torch.equal(got[k], want[k]) for k in want), name


def test_export_models_stopped_by_a_full_disk_leaves_no_torn_checkpoint(toy_run, tmp_path, small_disk):
    reference = tmp_path / "reference"
    assert _tognet("export-models", str(toy_run), "--out", str(reference)).returncode == 0
    sizes = {f.name: f.stat().st_size for f in reference.iterdir()}
    disk = small_disk(sizes["grasping.pt"] + (64 << 10) + sizes["sweeping.pt"] // 2)  # grasping.pt fits
    out = disk / "models"
    stopped = _tognet("export-models", str(toy_run), "--out", str(out))
    _one_error(stopped, out)
    for f in out.iterdir():  # what is there is whole: each file the same as the uninterrupted export's
        assert not f.name.startswith(".") and f.read_bytes() == (reference / f.name).read_bytes(), f.name
    small_disk(64 << 20)
    assert _tognet("export-models", str(toy_run), "--out", str(out)).returncode == 0
    assert _tree(out) == _tree(reference)


def test_data_synthetic_stopped_by_a_full_disk_reruns_to_the_same_records(tmp_path, small_disk):
    def synthetic(out: Path) -> list[str]:
        return [TOGNET, "data", "synthetic", str(out), "--episodes", "6000", "--shard-size", "500"]

    assert subprocess.run(synthetic(tmp_path / "reference"), capture_output=True).returncode == 0
    disk = small_disk(64 << 20)
    out = disk / "syn"
    stopped = _fill_when(synthetic(out), lambda: len(list(out.glob("shard-*.npz"))) >= 3, disk)
    _one_error(stopped, out)
    assert not list(out.rglob(".*tmp*"))
    (disk / "filler").unlink()
    done = subprocess.run(synthetic(out), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "kept" in done.stdout  # the shards written before the disk filled are not made twice
    _same_records(out, tmp_path / "reference")


def _same_records(a: Path, b: Path) -> None:
    import numpy as np

    from tognet.data.episodes import read_dataset
    from tognet.data.format import FIELDS

    got, want = read_dataset(a, keep_invalid=True), read_dataset(b, keep_invalid=True)
    assert len(got.z) == len(want.z)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)


def _results(folder: Path) -> dict:
    def strip(x: object) -> object:
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in ("run", "timing") and "seconds" not in k}
        return [strip(v) for v in x] if isinstance(x, list) else x

    return strip(json.loads((folder / "results.json").read_text()))


def test_an_evaluation_stopped_by_a_full_disk_resumes_to_the_uninterrupted_results(tmp_path, small_disk):
    def evaluate(out: Path, *more: str) -> list[str]:
        return [TOGNET, "evaluate", "--task", "hammering", "--category", "pg-primitive", "--episodes", "8",
                "--methods", "Antipodal+Random,TOG-Net", "--out", str(out), "--workers", "1",
                "--no-progress", "--no-animations", *more]

    done = subprocess.run(evaluate(tmp_path / "reference"), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    disk = small_disk(64 << 20)
    out = disk / "eval"
    records = out / "hammering" / "pg-primitive"
    stopped = _fill_when(evaluate(out), lambda: (records / "job-000001.json").is_file(), disk)
    _one_error(stopped, out)
    assert not (out / "results.json").exists() and not list(out.rglob(".*tmp*"))
    (disk / "filler").unlink()
    resumed = subprocess.run(evaluate(out, "--resume"), capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    text = json.dumps(_results(out)).replace(str(out), str(tmp_path / "reference"))
    assert json.loads(text) == _results(tmp_path / "reference")
