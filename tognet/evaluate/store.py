"""An evaluation's results on disk: one JSON file per job, written atomically, like collection's shards.

    OUT/<task>/<category>/
      meta.json            what the jobs were run with (task, category, methods, config hash, models,
                           objects); reopening with other settings is refused, so a resume never mixes them
      job-000042.json      job 42's records (every method on each of its scenes), its meta and info

Only the coordinator writes here. A job file is written whole (temporary file, fsync, rename), so a run
killed at any moment leaves whole files only; on reopening, the job files present are the jobs done (one
that does not parse or holds other settings is moved aside as ``*.corrupt`` and its job runs again).
This is :mod:`tognet.collect.store`'s pattern for records that are a few hundred bytes (no crops), so
JSON rather than episode shards.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tognet.errors import TognetError
from tognet.io import atomic_write_bytes

META = "meta.json"
JOB_NAME = "job-{:06d}.json"


class EvalStoreError(TognetError):
    """An evaluation folder holds results of other settings."""


def read_json_object(path: Path, what: str) -> dict[str, Any]:
    """The JSON object in ``path``; EvalStoreError naming the file (and ``what`` it holds) when it is not
    readable text, not JSON or not an object."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise EvalStoreError(f"{path}: not a text file (binary?); it should hold {what}") from None
    except json.JSONDecodeError as exc:
        raise EvalStoreError(f"{path}: damaged, not valid JSON ({exc}); it should hold {what}") from None
    if not isinstance(data, dict):
        raise EvalStoreError(f"{path}: damaged, a JSON {type(data).__name__} where {what} should be")
    return data


def _jsonable(meta: Mapping[str, Any]) -> Any:
    return json.loads(json.dumps(dict(meta)))


class EvalStore:
    """The job files of one (task, category) of an evaluation (see the module docstring)."""

    def __init__(self, folder: str | Path, meta: Mapping[str, Any]) -> None:
        self.folder = Path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise EvalStoreError(f"{self.folder}: exists and is not a folder")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.meta = _jsonable(meta)
        path = self.folder / META
        if path.is_file():
            try:
                old = read_json_object(path, "the settings of the jobs in this folder")
            except EvalStoreError as exc:
                raise EvalStoreError(f"{exc}; restore it, or delete it to have it written again (each job "
                                     "file is checked against the settings on its own)") from None
            if old != self.meta:
                keys = sorted(k for k in set(old) | set(self.meta) if old.get(k) != self.meta.get(k))
                raise EvalStoreError(f"{path}: this folder holds an evaluation with other settings (differs "
                                     f"in {', '.join(keys)}); use another --out")
        else:
            atomic_write_bytes(path, (json.dumps(self.meta, indent=2) + "\n").encode())
        self._records: dict[int, list[dict[str, Any]]] = {}
        self._info: dict[int, dict[str, Any]] = {}
        for file in sorted(self.folder.glob("job-*.json")):
            job = int(file.stem.removeprefix("job-"))
            try:
                payload = json.loads(file.read_text())
                if not isinstance(payload, dict):
                    raise ValueError(f"a JSON {type(payload).__name__}, not a job's record")
                if payload.get("meta") != self.meta or payload.get("job") != job:
                    raise ValueError("written with other settings")
                records = payload["records"]
                if not isinstance(records, list):
                    raise ValueError("no record list")
            except (ValueError, KeyError, UnicodeDecodeError) as exc:
                aside = file.with_name(file.name + ".corrupt")
                file.rename(aside)
                warnings.warn(f"{file}: unreadable ({exc}); moved aside to {aside.name}, its job runs again",
                              stacklevel=2)
                continue
            self._records[job] = records
            self._info[job] = payload.get("info") or {}

    @property
    def done(self) -> set[int]:
        """Indices of the jobs whose file is written."""
        return set(self._records)

    def add(self, job: int, records: list[dict[str, Any]], info: Mapping[str, Any] | None = None) -> None:
        """Write job ``job``'s records (possibly none: a job whose object failed)."""
        if job in self._records:
            raise EvalStoreError(f"{self.folder}: job {job} is already written")
        payload = {"meta": self.meta, "job": int(job), "info": dict(info or {}), "records": records}
        atomic_write_bytes(self.folder / JOB_NAME.format(job), json.dumps(payload).encode())
        self._records[job] = records
        self._info[job] = dict(info or {})

    def records(self) -> list[dict[str, Any]]:
        """Every record written, in job order."""
        return [r for j in sorted(self._records) for r in self._records[j]]

    def info(self) -> dict[int, dict[str, Any]]:
        """Each written job's info (timing, counters, an error)."""
        return dict(self._info)
