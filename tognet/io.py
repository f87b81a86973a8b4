"""File digests shared across packages (datasets' shards, checkpoints named in run settings)."""

from __future__ import annotations

import hashlib
from pathlib import Path


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
