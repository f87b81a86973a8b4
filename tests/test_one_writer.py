"""One writer per folder (issue 35 item 3): a second run into a folder another live run writes is refused
with one line naming the first; a lock left by a dead run is taken over; a refused command leaves nothing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tognet.io import LOCK_NAME, FolderBusy, FolderLock

TOGNET = str(Path(sys.executable).parent / "tognet")


def _holder(folder: Path) -> subprocess.Popen[str]:
    """Another process that holds ``folder`` until killed."""
    code = ("import sys, time\nfrom tognet.io import FolderLock\n"
            f"held = FolderLock({str(folder)!r})\nprint('held', flush=True)\ntime.sleep(600)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_writer_is_refused_naming_the_first_and_a_dead_ones_lock_is_taken_over(tmp_path):
    out = tmp_path / "syn"
    holder = _holder(out)
    try:
        refused = subprocess.run([TOGNET, "data", "synthetic", str(out), "--episodes", "64"],
                                 capture_output=True, text=True, timeout=300)
        assert refused.returncode == 2
        lines = refused.stderr.strip().splitlines()
        assert len(lines) == 1 and f"PID {holder.pid}" in lines[0] and "another tognet run" in lines[0]
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]  # nothing of the refused run
    finally:
        os.killpg(holder.pid, signal.SIGKILL)
        holder.wait()
    assert f"PID {holder.pid}" in (out / LOCK_NAME).read_text()  # the dead run's lock file is still there
    done = subprocess.run([TOGNET, "data", "synthetic", str(out), "--episodes", "64"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert not (out / LOCK_NAME).exists() and list(out.glob("shard-*.npz"))


def test_two_commands_at_once_one_runs_and_the_other_is_refused(tmp_path):
    out = tmp_path / "syn"
    first = subprocess.Popen([TOGNET, "data", "synthetic", str(out), "--episodes", "20000"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / LOCK_NAME).is_file() or not (out / LOCK_NAME).read_text():
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        second = subprocess.run([TOGNET, "data", "synthetic", str(out), "--episodes", "64"],
                                capture_output=True, text=True, timeout=300)
        still = first.poll() is None
    finally:
        _, err = first.communicate(timeout=600)
    assert still, "the first run ended before the second was tried: make it longer"
    assert second.returncode == 2 and f"PID {first.pid}" in second.stderr
    assert "`tognet data synthetic`" in second.stderr
    assert first.returncode == 0, err


def test_a_lock_in_this_process_refuses_a_second_and_a_refused_command_leaves_no_folder(tmp_path):
    held = FolderLock(tmp_path / "a")
    with pytest.raises(FolderBusy, match=f"PID {os.getpid()}"):
        FolderLock(tmp_path / "a")
    held.release()
    assert not (tmp_path / "a").exists()  # made for the lock and left empty: removed
    again = FolderLock(tmp_path / "a")
    (tmp_path / "a" / "kept.txt").write_text("x")
    again.release()
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["kept.txt"]
