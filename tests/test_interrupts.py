"""Ctrl-C and SIGTERM (issue 35 item 4): the command stops its workers, prints one line naming what was
kept and the exact command that continues, and that command ends with the records an uninterrupted run
writes."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

TOGNET = str(Path(sys.executable).parent / "tognet")


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    from tognet.collect.config import CollectConfig
    from tognet.objects import generate_set

    root = tmp_path_factory.mktemp("interrupts")
    generate_set("primitive", "train", 3, root / "objs")
    CollectConfig(trials_per_scene=3, scenes_per_job=4).save(root / "long.json")
    return root


def _ctrl_c_default() -> None:
    """In the child before exec: SIGINT back to its default. A shell without job control starts background
    commands with SIGINT ignored, children inherit that, and Python then installs no Ctrl-C handler: run so
    (e.g. ``(./.ci/run &)``), the command would rightly ignore the test's Ctrl-C and finish."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _args(root: Path, out: str) -> list[str]:
    return ["collect", "--task", "hammering", "--objects", str(root / "objs"), "--out", str(root / out),
            "--episodes", "120", "--config", str(root / "long.json"), "--workers", "2", "--no-progress"]


def _records(folder: Path) -> dict[str, np.ndarray]:
    from tognet.data.episodes import read_dataset
    from tognet.data.format import FIELDS

    ep = read_dataset(folder, keep_invalid=True)
    return {name: getattr(ep, name) for name in FIELDS}


def _alive_children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2:].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry.name))
    return found


def _communicate_or_dump(proc: subprocess.Popen, timeout: float) -> tuple[str, str]:
    """The command's output; if it has not ended in ``timeout`` s, fail with where its threads are
    (SIGUSR1 makes tognet print its stacks) and end it."""
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.kill(proc.pid, signal.SIGUSR1)
        time.sleep(2)
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate(timeout=30)
        pytest.fail(f"still running {timeout:.0f} s after the signal; its stacks:\n{err}")


@pytest.mark.parametrize("how", ["SIGINT to the group (Ctrl-C)", "SIGTERM to the process"])
def test_an_interrupted_collection_says_how_to_continue_and_continuing_loses_nothing(setup, how):
    root = setup
    tag = "int" if "SIGINT" in how else "term"
    reference = root / "reference"
    if not reference.exists():
        subprocess.run([TOGNET, *_args(root, "reference")], check=True, capture_output=True, timeout=600)
    proc = subprocess.Popen([TOGNET, *_args(root, tag)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, preexec_fn=_ctrl_c_default)
    deadline = time.monotonic() + 300
    while not list((root / tag).glob("shard-*.npz")):
        assert proc.poll() is None and time.monotonic() < deadline, "ended before any shard"
        time.sleep(0.02)
    if "SIGINT" in how:
        os.killpg(proc.pid, signal.SIGINT)
    else:
        os.kill(proc.pid, signal.SIGTERM)
    _, err = _communicate_or_dump(proc, 120)
    assert proc.returncode == (130 if "SIGINT" in how else 143), err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("interrupted (SIG"), err  # no traceback, no warning
    assert "is whole and kept" in lines[0] and str(root / tag) in lines[0]
    assert len(list((root / tag).glob("shard-*.npz"))) < 10, "the round finished before the signal"
    again = shlex.split(lines[0].split("continue with: ", 1)[1])
    assert again[0] == "tognet"
    subprocess.run([TOGNET, *again[1:]], check=True, capture_output=True, timeout=600)
    a, b = _records(reference), _records(root / tag)
    assert len(a["z"]) == len(b["z"]) == 120
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_the_line_adds_resume_where_the_command_needs_it():
    from tognet.cli.interrupt import Terminated, interrupted_line

    args = ["train", "--data", "d", "--task", "hammering", "--out", "m"]
    line = interrupted_line(args, KeyboardInterrupt())
    assert line.endswith("continue with: tognet train --data d --task hammering --out m --resume")
    line = interrupted_line(["evaluate", "--out=r", "--resume"], Terminated())
    assert line.startswith("interrupted (SIGTERM)") and line.endswith("tognet evaluate --out=r --resume")
    assert interrupted_line(["plan", "--depth", "x.npy"], KeyboardInterrupt()) == "interrupted (SIGINT)"
