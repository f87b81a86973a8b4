"""A collection round's dataset folder: one shard per job, named after the job, and a manifest.

    round1/data/
      manifest.json          the usual dataset manifest (tognet.data.episodes), shards sorted by job
      shard-000042.npz       job 42's records (possibly none: a job whose object failed)
      configs/*.json         the collection, simulator, task, crop and policy configs

Only the coordinator writes here. A shard is written atomically (temporary file, fsync, rename) before
its manifest entry, so a run killed at any moment leaves whole shards only; on reopening, shards the
manifest does not list yet are checked and listed (a corrupt one is moved aside as ``*.corrupt`` and its
job runs again), so a resumed round ends with exactly the jobs of an uninterrupted one.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tognet.data.episodes import read_columns
from tognet.data.format import MANIFEST, DatasetError, check_columns, summarise
from tognet.data.manifest import new_manifest, read_manifest, save_config, verify_shard, write_manifest
from tognet.data.writer import write_shard
from tognet.io import sha256_file

SHARD_NAME = "shard-{:06d}.npz"


def job_of(file: str) -> int:
    """The job index of a shard file name."""
    return int(file.removeprefix("shard-").removesuffix(".npz"))


class RoundStore:
    """Writes a round's job shards and keeps its manifest (see the module docstring).

    ``meta`` identifies the collection (task, round, config hash, models); reopening a folder written with
    other meta is refused, so a resume never mixes settings."""

    def __init__(self, folder: str | Path, task: str, meta: Mapping[str, Any],
                 configs: Mapping[str, Any] | None = None, flush_seconds: float = 10.0) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.task = task
        self.meta = {"task": task, **dict(meta)}
        self.flush_seconds = flush_seconds
        manifest = read_manifest(self.folder)
        self.new = manifest is None  # this store wrote the manifest (see discard_if_unused)
        if manifest is None:
            manifest = new_manifest(task)
            manifest["collection"] = self.meta
        else:
            old = manifest.get("collection")
            if manifest.get("task") != task:
                raise DatasetError(f"{self.folder / MANIFEST}: holds a dataset of task "
                                   f"{manifest.get('task')!r}, not {task!r}; use another folder")
            if old != json.loads(json.dumps(self.meta)):
                raise DatasetError(
                    f"{self.folder / MANIFEST}: holds another collection ({_differences(old, self.meta)}); "
                    "use another folder"
                )
        self.manifest = manifest
        for name, cfg in (configs or {}).items():
            save_config(self.folder, manifest, name, cfg, self.meta)
        self._entries = {job_of(e["file"]): e for e in manifest["shards"]}
        self._recover()
        self._dirty = True
        self._discarded = False
        self._last_flush = 0.0
        self.flush(force=True)

    def _recover(self) -> None:
        for job, entry in list(self._entries.items()):
            path = self.folder / entry["file"]
            if not path.is_file():
                warnings.warn(f"{path}: listed in the manifest but missing; its job runs again", stacklevel=3)
                del self._entries[job]
                continue
            try:
                verify_shard(path)
            except DatasetError as exc:  # corrupt: set aside, and collected again like a missing one
                aside = path.with_name(path.name + ".corrupt")
                path.rename(aside)
                warnings.warn(f"{exc}; moved aside to {aside.name}, its job runs again", stacklevel=3)
                del self._entries[job]
        for path in sorted(self.folder.glob("shard-*.npz")):
            job = job_of(path.name)
            if job in self._entries:
                continue
            try:
                cols, meta = read_columns(path, ("z", "valid", "grasp_success", "task_success", "failure"))
                if {k: v for k, v in meta.items() if k != "job"} != json.loads(json.dumps(self.meta)):
                    raise DatasetError(f"{path}: written by another collection")
            except DatasetError as exc:
                aside = path.with_name(path.name + ".corrupt")
                path.rename(aside)
                warnings.warn(f"{exc}; moved aside to {aside.name}, its job runs again", stacklevel=3)
                continue
            self._entries[job] = {
                "file": path.name, "count": int(cols["z"].shape[0]), "sha256": sha256_file(path),
                "meta": meta,
                **{k: v for k, v in summarise(cols["valid"], cols["grasp_success"], cols["task_success"],
                                              cols["failure"]).items() if k != "episodes"},
            }

    def discard_if_unused(self) -> bool:
        """Remove the manifest and configs this store wrote when no job was written into it (a round that
        stopped before its first job then leaves no empty dataset behind, which a run with other settings
        would be refused on); whether it did. The store takes no writes afterwards."""
        if not self.new or self._entries:
            return False
        for entry in self.manifest.get("configs", []):
            (self.folder / entry["file"]).unlink(missing_ok=True)
        (self.folder / MANIFEST).unlink(missing_ok=True)
        try:
            (self.folder / "configs").rmdir()
        except OSError:  # not empty: files of someone else's
            pass
        self.new = False
        self._dirty = False
        self._discarded = True
        return True

    @property
    def done(self) -> set[int]:
        """Indices of the jobs whose shard is written."""
        return set(self._entries)

    def add(self, job: int, columns: Mapping[str, Any], info: Mapping[str, Any] | None = None
            ) -> dict[str, Any]:
        """Write job ``job``'s records (columns; empty for a job without records) as its shard; ``info``
        (timings, counters, an error) goes into its manifest entry only, so shards stay deterministic."""
        if job in self._entries:
            raise DatasetError(f"{self.folder}: job {job} is already written")
        if self._discarded:
            raise DatasetError(f"{self.folder}: this round's store was discarded")
        checked = check_columns(columns) if columns else _empty_columns()
        meta = {**self.meta, "job": int(job)}
        entry = write_shard(self.folder / SHARD_NAME.format(job), checked, meta)
        if info:
            entry["info"] = dict(info)
        self._entries[job] = entry
        self._dirty = True
        self.flush()
        return entry

    def flush(self, force: bool = False) -> None:
        """Rewrite the manifest (at most every ``flush_seconds`` unless ``force``)."""
        now = time.monotonic()
        if self._dirty and not self._discarded and (force or now - self._last_flush >= self.flush_seconds):
            self.manifest["shards"] = [self._entries[j] for j in sorted(self._entries)]
            write_manifest(self.folder, self.manifest)
            self._dirty = False
            self._last_flush = now

    def totals(self) -> dict[str, Any]:
        """Counts and rates over every written job."""
        self.flush(force=True)
        return dict(self.manifest["totals"])


def _empty_columns() -> dict[str, np.ndarray]:
    from tognet.data.format import EpisodeArrays

    empty = EpisodeArrays.empty()
    return {name: getattr(empty, name) for name in empty.__dataclass_fields__}


def _differences(old: Any, new: Mapping[str, Any]) -> str:
    if not isinstance(old, dict):
        return "no collection description"
    keys = sorted(k for k in set(old) | set(new) if old.get(k) != json.loads(json.dumps(new)).get(k))
    return "differs in " + ", ".join(keys)
