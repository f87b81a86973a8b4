"""File I/O shared by every package: whole-or-nothing writes and file digests.

A reader (a resumed run, a second process, a user) never sees half a file: every write goes to a
temporary file beside the target and is renamed over it; a failure leaves the old file (or none) and no
temporary behind. Digests name datasets' shards and the checkpoints that run settings refer to.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import os
import shutil
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

from tognet.errors import TognetError


class DiskFull(TognetError):
    """A write ran out of space; the message names the file, what it needed and what is free."""


def _disk_full(path: Path, needed: int | None) -> DiskFull:
    free = shutil.disk_usage(path.parent).free if path.parent.exists() else 0
    size = "" if needed is None else f"{needed / 1e6:.1f} MB to write, "
    return DiskFull(f"no space left on the device writing {path} ({size}{free / 1e6:.1f} MB free there): "
                    "nothing was written to it; free some space, then run the same command again (with "
                    "--resume where it takes one)")


@contextmanager
def atomic_writer(path: str | Path, *, fsync: bool = True, size: int | None = None) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through: renamed over ``path`` when the block ends without an
    error (flushed to disk first with ``fsync``), deleted when it raises. The parent folder is made. A
    full disk is :class:`DiskFull` naming the file (``size``: what it was to hold, when known)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, "wb") as fh:
            yield fh
            fh.flush()
            if fsync:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise _disk_full(path, size) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` for a writer that opens files itself (e.g. a recording library):
    renamed over ``path`` when the block ends without an error, deleted when it raises."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise _disk_full(path, None) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` whole or not at all (:func:`atomic_writer`); returns the path."""
    with atomic_writer(path, fsync=fsync, size=len(data)) as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str, *, fsync: bool = True) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all; returns the path."""
    return atomic_write_bytes(path, text.encode("utf-8"), fsync=fsync)


def atomic_copy(src: str | Path, dst: str | Path, *, fsync: bool = True) -> Path:
    """Copy the file ``src`` to ``dst`` whole or not at all (:func:`atomic_writer`): a full disk leaves
    the old ``dst`` (or none), never a truncated copy beside complete ones. Returns ``dst``."""
    src = Path(src)
    with open(src, "rb") as fin, atomic_writer(dst, fsync=fsync, size=src.stat().st_size) as fout:
        shutil.copyfileobj(fin, fout, 1 << 20)
    return Path(dst)


def write_npz(fh: BinaryIO, arrays: dict[str, Any]) -> None:
    """Write ``arrays`` to the open binary file ``fh`` as a compressed ``.npz`` that ``numpy.load`` reads,
    byte for byte the same for the same arrays: unlike ``numpy.savez_compressed`` no member carries the
    time it was written, so a shard re-made after an interruption has the digest of the uninterrupted
    run's."""
    import zipfile

    import numpy as np

    with zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, value in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)


def sha256_file(path: str | Path) -> str:
    """The sha256 of a file's bytes (hex), read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def short_digest(data: bytes) -> str:
    """The first 16 hex digits of the sha256 of ``data``: how records and settings name a state, an
    image or a config (collisions are not a concern at these counts)."""
    return hashlib.sha256(data).hexdigest()[:16]


def file_digest(path: str | Path | None) -> str | None:
    """The first 16 hex digits of a file's sha256 (how run settings name a checkpoint), or None."""
    return None if path is None else sha256_file(path)[:16]


#: The file in a folder that a tognet command writes which says who holds it.
LOCK_NAME = ".tognet.lock"


class FolderBusy(TognetError):
    """Another live process writes the folder."""


class FolderLock:
    """One writer per folder: an advisory ``flock`` on ``<folder>/.tognet.lock``, which also names the
    holder (PID, command, start time) for whoever is refused. The kernel drops the lock when its process
    ends however it ends, so a dead run's lock is simply taken over."""

    def __init__(self, folder: str | Path, option: str = "--out") -> None:
        self.folder = Path(folder)
        self.created = not self.folder.exists()
        self.folder.mkdir(parents=True, exist_ok=True)
        self.path = self.folder / LOCK_NAME
        self._fh = self._take(option)
        started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
        self._fh.truncate(0)
        self._fh.write(f"PID {os.getpid()}, `{_command_name()}`, started {started}\n")
        self._fh.flush()

    def _take(self, option: str) -> Any:
        while True:
            fh = open(self.path, "a+")  # noqa: SIM115 (held until release)
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                fh.seek(0)
                holder = fh.read().strip() or "a process that has not said who it is yet"
                fh.close()
                raise FolderBusy(f"{option} {self.folder}: another tognet run writes this folder ({holder}); "
                                 "wait for it to end or choose another folder") from None
            try:  # the holder before us may have removed the file between our open and our lock
                if os.fstat(fh.fileno()).st_ino == os.stat(self.path).st_ino:
                    return fh
            except FileNotFoundError:
                pass
            fh.close()

    def release(self) -> None:
        """Remove the lock file, unlock, and remove the folder again if this lock made it and it is empty
        (a command refused after taking the lock leaves nothing behind)."""
        if self._fh is None:
            return
        self.path.unlink(missing_ok=True)
        self._fh.close()
        self._fh = None
        if self.created:
            try:
                self.folder.rmdir()
            except OSError:  # not empty: the command wrote something
                pass


def _command_name() -> str:
    """``tognet train``-like: the program and its subcommand words, without the options."""
    words = [Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python"]
    for arg in sys.argv[1:3]:
        if arg.startswith("-"):
            break
        words.append(arg)
    return " ".join(words)


__all__ = ["LOCK_NAME", "DiskFull", "FolderBusy", "FolderLock", "atomic_path", "atomic_write_bytes",
           "atomic_write_text", "atomic_writer", "file_digest", "sha256_file", "short_digest"]
