"""File I/O shared by every package: whole-or-nothing writes and file digests.

A reader (a resumed run, a second process, a user) never sees half a file: every write goes to a
temporary file beside the target and is renamed over it; a failure leaves the old file (or none) and no
temporary behind. Digests name datasets' shards and the checkpoints that run settings refer to.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO


@contextmanager
def atomic_writer(path: str | Path, *, fsync: bool = True) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through: renamed over ``path`` when the block ends without an
    error (flushed to disk first with ``fsync``), deleted when it raises. The parent folder is made."""
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
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` whole or not at all (:func:`atomic_writer`); returns the path."""
    with atomic_writer(path, fsync=fsync) as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str, *, fsync: bool = True) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all; returns the path."""
    return atomic_write_bytes(path, text.encode("utf-8"), fsync=fsync)


def sha256_file(path: str | Path) -> str:
    """The sha256 of a file's bytes (hex), read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_digest(path: str | Path | None) -> str | None:
    """The first 16 hex digits of a file's sha256 (how run settings name a checkpoint), or None."""
    return None if path is None else sha256_file(path)[:16]


__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text", "atomic_writer", "file_digest",
           "sha256_file"]
