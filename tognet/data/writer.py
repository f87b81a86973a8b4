"""Writing episodes: whole shards (temporary file, fsync, rename: a crash never leaves half a shard under
its final name) and :class:`ShardWriter`, which buffers episodes into numbered shards and keeps the
manifest. A writer opened on an existing folder appends new shard indices and never overwrites; one writer
per folder at a time (an advisory lock on ``.writer.lock``, released when the process ends).
"""

from __future__ import annotations

import fcntl
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tognet.data.format import (
    FIELDS,
    FORMAT_VERSION,
    MANIFEST,
    SHARD_PATTERN,
    DatasetError,
    check_columns,
    summarise,
)
from tognet.data.manifest import new_manifest, read_manifest, save_config, write_manifest
from tognet.io import atomic_writer, sha256_file, write_npz


def write_shard(path: Path, columns: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> dict[str, Any]:
    """Write checked episode columns as one compressed shard, atomically (temporary file, fsync, rename);
    returns its manifest entry (file, count, sha256, meta, label tallies). Refuses to overwrite."""
    path = Path(path)
    if path.exists():
        raise DatasetError(f"{path}: already exists, refusing to overwrite")
    with atomic_writer(path) as fh:
        write_npz(fh, {"meta_json": np.array(json.dumps(dict(meta))),
                       "format_version": np.array(FORMAT_VERSION), **columns})
    return shard_entry(path, columns, meta)


def shard_entry(path: Path, columns: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> dict[str, Any]:
    """The manifest entry of the shard file ``path`` holding ``columns`` and ``meta``."""
    count = int(np.asarray(columns["z"]).shape[0])
    return {
        "file": path.name,
        "count": count,
        "sha256": sha256_file(path),
        "meta": dict(meta),
        **{k: v for k, v in summarise(columns["valid"], columns["grasp_success"], columns["task_success"],
                                        columns["failure"]).items() if k != "episodes"},
    }


class ShardWriter:
    """Buffer episodes and write them as numbered shards with a manifest.

    ``meta`` (e.g. ``{"round": 1, "policy": "nms_random"}``) is stored in every shard this writer writes
    and in its manifest entries. ``configs`` are saved as ``configs/<name>.json`` beside the data (a name
    already used with different content gets a numbered suffix, never an overwrite).
    """

    def __init__(
        self,
        out_dir: str | Path,
        task: str,
        meta: Mapping[str, Any] | None = None,
        shard_size: int = 4096,
        configs: Mapping[str, Any] | None = None,
    ) -> None:
        if shard_size < 1:
            raise ValueError(f"shard_size must be >= 1, got {shard_size}")
        if not task:
            raise ValueError("task name must not be empty")
        self.out_dir = Path(out_dir)
        self.task = task
        self.meta = {"task": task, **dict(meta or {})}
        if self.meta["task"] != task:
            raise ValueError(f"meta['task']={self.meta['task']!r} disagrees with task={task!r}")
        json.dumps(self.meta)  # metadata must be JSON-serialisable; fail now, not at the first flush
        self.shard_size = int(shard_size)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self._lock = open(self.out_dir / ".writer.lock", "a")  # noqa: SIM115 (held until close)
        try:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._lock.close()
            raise DatasetError(f"{self.out_dir}: another ShardWriter is writing to this folder") from None
        try:
            self._open()
            for name, cfg in (configs or {}).items():
                self._save_config(name, cfg)
            self._write_manifest()
        except BaseException:
            self._release()
            raise

    def _release(self) -> None:
        if not self._lock.closed:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_UN)
            self._lock.close()

    def _open(self) -> None:
        task = self.task
        manifest = read_manifest(self.out_dir)
        if manifest is None:
            manifest = new_manifest(task)
        elif manifest.get("task") != task:
            raise DatasetError(
                f"{self.out_dir / MANIFEST}: holds task {manifest.get('task')!r}, refusing to add {task!r}"
            )
        self._manifest = manifest
        on_disk = [int(m.group(1)) for p in self.out_dir.iterdir() if (m := SHARD_PATTERN.match(p.name))]
        listed = [int(SHARD_PATTERN.match(s["file"]).group(1)) for s in manifest["shards"]]  # type: ignore[union-attr]
        self._adopt(sorted(set(on_disk) - set(listed)))
        self._next_index = max([-1, *on_disk, *listed]) + 1
        self._buffer: dict[str, list[np.ndarray]] = {name: [] for name in FIELDS}
        self._buffered = 0
        self._closed = False
        self.written: list[Path] = []

    def listed(self, meta: Mapping[str, Any]) -> int:
        """How many episodes the folder's manifest lists in shards of exactly this ``meta``."""
        return sum(int(s["count"]) for s in self._manifest["shards"] if s.get("meta") == dict(meta))

    def _adopt(self, orphans: list[int]) -> None:
        """List the whole shards a writer stopped between renaming a shard into place and rewriting the
        manifest (a full disk, a kill) left unlisted, so what was written is kept; an unreadable one stays
        unlisted (readers ignore it) and its index is not reused."""
        from tognet.data.episodes import read_columns

        for index in orphans:
            path = self.out_dir / f"shard-{index:05d}.npz"
            try:
                columns, meta = read_columns(path, tuple(FIELDS))
            except DatasetError:
                continue
            if meta.get("task") == self.task:
                self._manifest["shards"].append(shard_entry(path, columns, meta))

    # -- adding episodes --------------------------------------------------------------------------------
    def add(self, **episode: Any) -> None:
        """Add one episode given as keyword fields (see :data:`FIELDS`; valid/failure/trial optional)."""
        self.add_batch(**{k: np.asarray(v)[None] for k, v in episode.items()})

    def add_batch(self, **columns: Any) -> None:
        """Add N episodes given as column arrays with a leading dimension N."""
        if self._closed:
            raise DatasetError(f"{self.out_dir}: writer already closed")
        checked = check_columns(columns)
        n = int(checked["z"].shape[0])
        for name, arr in checked.items():
            self._buffer[name].append(arr)
        self._buffered += n
        while self._buffered >= self.shard_size:
            self._flush(self.shard_size)

    # -- writing ----------------------------------------------------------------------------------------
    def _flush(self, count: int) -> None:
        columns = {name: np.concatenate(parts) for name, parts in self._buffer.items()}
        head = {name: arr[:count] for name, arr in columns.items()}
        self._buffer = {name: [arr[count:]] for name, arr in columns.items()}
        self._buffered -= count
        path = self.out_dir / f"shard-{self._next_index:05d}.npz"
        entry = write_shard(path, head, self.meta)
        self._next_index += 1
        self.written.append(path)
        self._manifest["shards"].append(entry)
        self._write_manifest()

    def _write_manifest(self) -> None:
        write_manifest(self.out_dir, self._manifest)

    def _save_config(self, name: str, cfg: Any) -> None:
        save_config(self.out_dir, self._manifest, name, cfg, self.meta)

    def close(self) -> list[Path]:
        """Write the remaining buffered episodes as a last (smaller) shard; returns all shards written."""
        if not self._closed:
            try:
                if self._buffered:
                    self._flush(self._buffered)
            finally:
                self._closed = True
                self._release()
        return self.written

    def __enter__(self) -> ShardWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- reading ------------------------------------------------------------------------------------------
