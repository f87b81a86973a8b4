"""Episode records on disk: numbered ``.npz`` shards plus a ``manifest.json`` per dataset folder.

One *episode* is one simulated trial: a grasp candidate's depth crop and gripper depth, the grasp and the
action that were executed, and the labels the simulator produced. A dataset folder holds one task::

    out_dir/
      manifest.json          format version, task, one entry per shard (counts, rates, sha256, metadata)
      shard-00000.npz        arrays named as in :data:`FIELDS`, plus ``meta_json`` (per-shard metadata)
      shard-00001.npz
      configs/<name>.json    configs saved beside the data (simulator, task, policy, ...)

Crops are stored as float16 (8 KiB a record before compression; its ~3e-5 m step near 3 cm is far below the
depth noise) in compressed ``.npz`` files; readers hand them out as float16 too (cast to float32 per batch).
Format version 1 (float32 crops, no ``grasp_source``/``action_source``/``score``) and 2 (no ``progress``,
the task's graded outcome :meth:`tognet.tasks.Task.progress`) are still read; missing fields get their
defaults (``progress`` -1: unknown).

Shards are written to a temporary file and renamed, so a crash never leaves a half-written shard under
its final name. A writer opened on an existing folder appends new shard indices and never overwrites.
One writer per folder at a time (an advisory lock on ``.writer.lock``, released when the process ends);
parallel workers write to sibling folders, e.g. ``round1/worker-00``, and readers accept the parent
folder (every sub-folder holding a ``manifest.json`` is read).
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import re
import warnings
import zipfile
import zlib
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tognet.errors import TognetError
from tognet.io import sha256_file
from tognet.tasks.base import FailureReason

#: Version of the shard/manifest layout; bump on any incompatible change.
FORMAT_VERSION = 3
#: Versions this code reads (older shards get the new fields' defaults).
READABLE_VERSIONS = (1, 2, 3)
CROP_SIZE = 64
MANIFEST = "manifest.json"
SHARD_PATTERN = re.compile(r"^shard-(\d{5,})\.npz$")

#: name -> (dtype, per-episode shape). ``object_id`` is a unicode string.
FIELDS: dict[str, tuple[np.dtype, tuple[int, ...]]] = {
    "crop": (np.dtype(np.float16), (CROP_SIZE, CROP_SIZE)),
    "z": (np.dtype(np.float32), ()),
    "grasp": (np.dtype(np.float32), (4,)),
    "action": (np.dtype(np.float32), (4,)),
    "grasp_success": (np.dtype(np.uint8), ()),
    "task_success": (np.dtype(np.uint8), ()),
    "valid": (np.dtype(np.uint8), ()),
    "failure": (np.dtype(np.int8), ()),
    "object_id": (np.dtype("U"), ()),
    "scene_seed": (np.dtype(np.int64), ()),
    "trial": (np.dtype(np.int32), ()),
    "grasp_source": (np.dtype(np.int8), ()),
    "action_source": (np.dtype(np.int8), ()),
    "score": (np.dtype(np.float32), ()),
    "progress": (np.dtype(np.float32), ()),
}
#: int8 codes of where an episode's grasp came from (``grasp_source``) and its action (``action_source``);
#: stored in every manifest. Collection policies name themselves with these.
GRASP_SOURCES: dict[str, int] = {"unknown": 0, "nms": 1, "cem": 2, "given": 3, "search": 4}
ACTION_SOURCES: dict[str, int] = {"unknown": 0, "uniform": 1, "baseline_random": 2, "policy": 3, "given": 4,
                                  "none": 5, "expert": 6, "search": 7}
#: int8 code of each failure reason, by name: its position in ``tognet.tasks.FailureReason`` (append new
#: reasons at the end of the enum so stored codes keep their meaning); stored in every manifest so a
#: dataset explains its own codes. ``failure`` may also be given as these names.
FAILURE_CODES: dict[str, int] = {reason.value: code for code, reason in enumerate(FailureReason)}


def failure_code(reason: object) -> int:
    """The int8 code of a failure reason given by name (str or StrEnum) or already as an integer."""
    if isinstance(reason, int | np.integer) and not isinstance(reason, bool):
        return int(reason)
    name = str(getattr(reason, "value", reason))
    if name not in FAILURE_CODES:
        raise ValueError(f"field 'failure': unknown failure reason {name!r}; known: {list(FAILURE_CODES)}")
    return FAILURE_CODES[name]


#: Fields a caller may leave out of :meth:`ShardWriter.add`, with their default value.
DEFAULTS: dict[str, Any] = {"valid": 1, "failure": 0, "trial": 0, "grasp_source": 0, "action_source": 0,
                            "score": -1.0, "progress": -1.0}


class DatasetError(TognetError):
    """A dataset folder, manifest or shard is missing, corrupt or inconsistent."""


@dataclasses.dataclass
class EpisodeArrays:
    """Episodes as column arrays (length N each); see :data:`FIELDS` for dtypes and shapes."""

    crop: np.ndarray
    z: np.ndarray
    grasp: np.ndarray
    action: np.ndarray
    grasp_success: np.ndarray
    task_success: np.ndarray
    valid: np.ndarray
    failure: np.ndarray
    object_id: np.ndarray
    scene_seed: np.ndarray
    trial: np.ndarray
    grasp_source: np.ndarray = None  # type: ignore[assignment]  (None: the default for every episode)
    action_source: np.ndarray = None  # type: ignore[assignment]
    score: np.ndarray = None  # type: ignore[assignment]
    progress: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        n = int(np.asarray(self.z).shape[0])
        for name in ("grasp_source", "action_source", "score", "progress"):
            if getattr(self, name) is None:
                setattr(self, name, np.full((n,), DEFAULTS[name], dtype=FIELDS[name][0]))

    def __len__(self) -> int:
        return int(self.z.shape[0])

    def subset(self, index: np.ndarray | Sequence[int]) -> EpisodeArrays:
        """The episodes at ``index`` (an integer or boolean array)."""
        index = np.asarray(index)
        return EpisodeArrays(**{name: getattr(self, name)[index] for name in FIELDS})

    @staticmethod
    def empty() -> EpisodeArrays:
        """An EpisodeArrays with zero episodes and the right dtypes and shapes."""
        return EpisodeArrays(**{n: np.zeros((0, *shape), dtype=dt) for n, (dt, shape) in FIELDS.items()})

    @staticmethod
    def concatenate(parts: Sequence[EpisodeArrays]) -> EpisodeArrays:
        """Join several EpisodeArrays end to end."""
        if not parts:
            return EpisodeArrays.empty()
        return EpisodeArrays(**{n: np.concatenate([getattr(p, n) for p in parts]) for n in FIELDS})

    def summary(self) -> dict[str, Any]:
        """Counts and success rates (over valid episodes), as JSON-ready numbers."""
        return summarise(self.valid, self.grasp_success, self.task_success, self.failure)


def summarise(valid: np.ndarray, s_g: np.ndarray, s_t: np.ndarray, failure: np.ndarray) -> dict[str, Any]:
    """Counts and success rates (over valid episodes) of label columns, as a manifest's shard entry has."""
    ok = valid.astype(bool)
    n_valid = int(ok.sum())
    n_grasp = int((s_g.astype(bool) & ok).sum())
    n_task = int((s_t.astype(bool) & ok).sum())
    codes, counts = np.unique(failure[ok], return_counts=True)
    return {
        "episodes": int(valid.shape[0]),
        "valid": n_valid,
        "grasp_success": n_grasp,
        "task_success": n_task,
        "grasp_success_rate": n_grasp / n_valid if n_valid else None,
        "task_success_rate": n_task / n_valid if n_valid else None,
        "task_given_grasp_rate": n_task / n_grasp if n_grasp else None,
        "failures": {str(int(c)): int(k) for c, k in zip(codes, counts, strict=True)},
    }


def _check_column(name: str, value: Any, n: int | None) -> np.ndarray:
    """Convert one column to its declared dtype and check its shape; ValueError names the field."""
    dtype, shape = FIELDS[name]
    arr = np.asarray(value)
    if name == "failure" and arr.dtype.kind in "UO":
        arr = np.vectorize(failure_code, otypes=[np.int64])(arr) if arr.size else arr.astype(np.int64)
    if name == "object_id":
        if arr.dtype.kind not in "UO":
            raise ValueError(f"field 'object_id': expected strings, got dtype {arr.dtype}")
        arr = arr.astype(str)
    else:
        if arr.dtype.kind not in "biuf":
            raise ValueError(f"field '{name}': expected numbers, got dtype {arr.dtype}")
        integral = dtype.kind not in "iu" or arr.dtype.kind != "f" or bool(
            np.all(np.isfinite(arr) & (arr == np.round(arr))))  # only integer fields need the check
        if not integral:
            raise ValueError(f"field '{name}': expected integers, got non-integer values")
        arr = arr.astype(dtype, copy=False)
    if arr.shape[1:] != shape or (n is not None and arr.shape[0] != n):
        want = (n if n is not None else "N", *shape)
        raise ValueError(f"field '{name}': expected shape {want}, got {arr.shape}")
    if dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"field '{name}': contains NaN or infinite values")
    return arr


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all (temporary file, fsync, rename)."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def read_manifest(folder: Path) -> dict[str, Any] | None:
    """A dataset folder's manifest, checked to be a readable tognet one (None when the folder has none)."""
    path = folder / MANIFEST
    if not path.is_file():
        return None
    try:
        manifest = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: not a valid manifest ({exc})") from exc
    if not isinstance(manifest, dict) or "shards" not in manifest:
        raise DatasetError(f"{path}: not a tognet episode manifest (no 'shards')")
    version = manifest.get("format_version")
    if version not in READABLE_VERSIONS:
        raise DatasetError(f"{path}: format_version {version!r}, this tognet reads {list(READABLE_VERSIONS)}")
    return manifest


def manifest_totals(shards: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Counts, rates and failure tallies summed over a manifest's shard entries."""
    totals: dict[str, Any] = {"shards": len(shards), "episodes": sum(s["count"] for s in shards)}
    for key in ("valid", "grasp_success", "task_success"):
        totals[key] = sum(s[key] for s in shards)
    totals["grasp_success_rate"] = totals["grasp_success"] / totals["valid"] if totals["valid"] else None
    totals["task_success_rate"] = totals["task_success"] / totals["valid"] if totals["valid"] else None
    totals["task_given_grasp_rate"] = (
        totals["task_success"] / totals["grasp_success"] if totals["grasp_success"] else None
    )
    failures: dict[str, int] = {}
    for s in shards:
        for code, k in s.get("failures", {}).items():
            failures[code] = failures.get(code, 0) + k
    totals["failures"] = failures
    return totals


def new_manifest(task: str) -> dict[str, Any]:
    """An empty manifest for a dataset folder of ``task``."""
    return {"format_version": FORMAT_VERSION, "task": task, "failure_codes": FAILURE_CODES,
            "grasp_sources": GRASP_SOURCES, "action_sources": ACTION_SOURCES, "shards": [], "configs": []}


def write_manifest(folder: Path, manifest: dict[str, Any]) -> None:
    """Recompute the manifest's totals and write it atomically (a reader never sees half a manifest)."""
    manifest["format_version"] = FORMAT_VERSION
    manifest["totals"] = manifest_totals(manifest["shards"])
    data = json.dumps(manifest, indent=2) + "\n"
    atomic_write_bytes(Path(folder) / MANIFEST, data.encode())


def save_config(folder: Path, manifest: dict[str, Any], name: str, cfg: Any, meta: Mapping[str, Any]) -> None:
    """Save a config (a :class:`tognet.config.Config` or a dict) as ``configs/<name>.json`` beside the data
    and list it in ``manifest`` (not written here); a name already used with different content gets a
    numbered suffix, never an overwrite."""
    if hasattr(cfg, "to_dict"):
        payload = {"config_type": type(cfg).__name__, **cfg.to_dict()}
    elif isinstance(cfg, Mapping):
        payload = dict(cfg)
    else:
        raise ValueError(f"config '{name}': expected a Config or a dict, got {type(cfg).__name__}")
    text = json.dumps(payload, indent=2) + "\n"
    configs = Path(folder) / "configs"
    configs.mkdir(exist_ok=True)
    stem, k = name, 1
    while (configs / f"{stem}.json").exists():
        if (configs / f"{stem}.json").read_text() == text:
            return
        k += 1
        stem = f"{name}-{k}"
    atomic_write_bytes(configs / f"{stem}.json", text.encode())
    entry = {"file": f"configs/{stem}.json", "name": name, "meta": dict(meta)}
    manifest.setdefault("configs", []).append(entry)


def check_columns(columns: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Episode columns in their declared dtypes, defaults filled in; ValueError names a bad field."""
    unknown = sorted(set(columns) - set(FIELDS))
    if unknown:
        raise ValueError(f"unknown episode field(s) {unknown}; known: {list(FIELDS)}")
    if "z" not in columns:
        raise ValueError("missing episode field 'z'")
    n = int(np.asarray(columns["z"]).shape[0])
    checked: dict[str, np.ndarray] = {}
    for name in FIELDS:
        if name in columns:
            checked[name] = _check_column(name, columns[name], n)
        elif name in DEFAULTS:
            checked[name] = np.full((n,), DEFAULTS[name], dtype=FIELDS[name][0])
        else:
            raise ValueError(f"missing episode field '{name}'")
    return checked


def write_shard(path: Path, columns: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> dict[str, Any]:
    """Write checked episode columns as one compressed shard, atomically (temporary file, fsync, rename);
    returns its manifest entry (file, count, sha256, meta, label tallies). Refuses to overwrite."""
    path = Path(path)
    if path.exists():
        raise DatasetError(f"{path}: already exists, refusing to overwrite")
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, meta_json=np.array(json.dumps(dict(meta))),
                                format_version=np.array(FORMAT_VERSION), **columns)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
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
        self._next_index = max([-1, *on_disk, *listed]) + 1
        self._buffer: dict[str, list[np.ndarray]] = {name: [] for name in FIELDS}
        self._buffered = 0
        self._closed = False
        self.written: list[Path] = []

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
def read_shard(path: str | Path) -> tuple[EpisodeArrays, dict[str, Any]]:
    """One shard's episodes (all of them, valid or not) and its metadata; DatasetError names the file."""
    columns, meta = read_columns(path, tuple(FIELDS))
    return EpisodeArrays(**columns), meta


def read_columns(path: str | Path, fields: Sequence[str]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Some columns of one shard (checked, converted to their declared dtypes) and its metadata. Reading
    only small columns (``object_id``, labels) skips decompressing the crops."""
    path = Path(path)
    unknown = [f for f in fields if f not in FIELDS]
    if unknown:
        raise ValueError(f"unknown episode field(s) {unknown}; known: {list(FIELDS)}")
    if not path.is_file():
        raise DatasetError(f"{path}: shard file not found")
    try:
        with np.load(path, allow_pickle=False) as npz:
            version = int(npz["format_version"]) if "format_version" in npz.files else None
            if version not in READABLE_VERSIONS:
                raise DatasetError(f"{path}: shard format_version {version!r}, this tognet reads "
                                   f"{list(READABLE_VERSIONS)}")
            required = [f for f in FIELDS if f not in DEFAULTS or version == FORMAT_VERSION]
            missing = [name for name in (*required, "meta_json") if name not in npz.files]
            if missing:
                raise DatasetError(f"{path}: not a tognet episode shard (missing {missing})")
            n = int(npz["z"].shape[0])
            columns = {name: npz[name] if name in npz.files else np.full((n,), DEFAULTS[name])
                       for name in fields}
            meta = json.loads(str(npz["meta_json"]))
    except DatasetError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError, zipfile.LargeZipFile,
            zlib.error, json.JSONDecodeError) as exc:
        raise DatasetError(f"{path}: corrupt or truncated shard ({type(exc).__name__}: {exc})") from exc
    try:
        checked = {name: _check_column(name, arr, n) for name, arr in columns.items()}
    except ValueError as exc:
        raise DatasetError(f"{path}: {exc}") from exc
    return checked, meta


def shard_paths(folder: str | Path) -> list[Path]:
    """The shard files of one dataset folder, from its manifest (or, without one, by file name)."""
    folder = Path(folder)
    if not folder.is_dir():
        what = "is a file, not a dataset folder" if folder.exists() else "dataset folder not found"
        raise DatasetError(f"{folder}: {what}")
    manifest = read_manifest(folder)
    if manifest is not None:
        listed = [folder / s["file"] for s in manifest["shards"]]
        orphans = sorted({p.name for p in folder.iterdir() if SHARD_PATTERN.match(p.name)}
                         - {p.name for p in listed})
        if orphans:
            warnings.warn(f"{folder}: shard files not in the manifest are ignored: {orphans} (a writer "
                          "stopped between writing a shard and updating the manifest?)", stacklevel=3)
        return listed
    return sorted(p for p in folder.iterdir() if SHARD_PATTERN.match(p.name))


def dataset_task(folder: str | Path) -> str | None:
    """The task name recorded in a dataset folder's manifest (None without a manifest)."""
    manifest = read_manifest(Path(folder))
    return None if manifest is None else str(manifest.get("task"))


def expand_dataset_dirs(dirs: str | Path | Iterable[str | Path]) -> list[Path]:
    """Dataset folders: each given folder itself if it holds a manifest or shards, else every sub-folder
    (recursively, sorted) that holds a ``manifest.json``; a folder with neither is kept (and fails later
    with a clear error)."""
    if isinstance(dirs, str | Path):
        dirs = [dirs]
    out: list[Path] = []
    for d in map(Path, dirs):
        if d.is_dir() and not (d / MANIFEST).is_file() and not any(SHARD_PATTERN.match(p.name)
                                                                    for p in d.iterdir()):
            subs = sorted(m.parent for m in d.rglob(MANIFEST))
            if subs:
                out.extend(subs)
                continue
        out.append(d)
    return out


def describe_dataset(dirs: str | Path | Iterable[str | Path]) -> dict[str, Any]:
    """A JSON-ready description of dataset folders (task, shard names, counts, sha256) for checkpoints."""
    out = []
    for folder in expand_dataset_dirs(dirs):
        folder = Path(folder)
        manifest = read_manifest(folder) or {}
        shards = [
            {k: s.get(k) for k in ("file", "count", "sha256")} for s in manifest.get("shards", [])
        ] or [{"file": p.name, "count": None, "sha256": None} for p in shard_paths(folder)]
        out.append({
            "dir": str(folder.resolve()),
            "task": manifest.get("task"),
            "shards": shards,
            "totals": manifest.get("totals"),
        })
    return {"format_version": FORMAT_VERSION, "datasets": out}


def dataset_configs(
    dirs: str | Path | Iterable[str | Path], config_type: str
) -> list[tuple[Path, dict[str, Any]]]:
    """The configs of type ``config_type`` (e.g. ``"CropConfig"``) saved beside the data of dataset folders
    (``configs/<name>.json`` listed in each manifest), as (file, fields without ``config_type``)."""
    out: list[tuple[Path, dict[str, Any]]] = []
    for folder in expand_dataset_dirs(dirs):
        manifest = read_manifest(Path(folder)) or {}
        for entry in manifest.get("configs", []):
            path = Path(folder) / str(entry.get("file"))
            try:
                payload = json.loads(path.read_text())
            except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise DatasetError(f"{path}: unreadable config listed in the manifest ({exc})") from exc
            if isinstance(payload, dict) and payload.get("config_type") == config_type:
                out.append((path, {k: v for k, v in payload.items() if k != "config_type"}))
    return out


def dataset_shards(dirs: str | Path | Iterable[str | Path], task: str | None = None) -> list[Path]:
    """The shard files of dataset folders, every folder checked first (it exists, holds shards, and holds
    ``task`` when given; all folders hold one task): DatasetError names the first that does not."""
    dirs = expand_dataset_dirs(dirs)
    if not dirs:
        raise DatasetError("no dataset folders given")
    tasks: dict[str, Path] = {}
    paths: list[Path] = []
    for folder in dirs:
        folder_task = dataset_task(folder) if folder.is_dir() else None
        if folder_task is not None:
            tasks.setdefault(folder_task, folder)
            if task is not None and folder_task != task:
                raise DatasetError(f"{folder}: holds task {folder_task!r}, expected {task!r}")
        found = shard_paths(folder)
        if not found:
            raise DatasetError(f"{folder}: no shards found")
        paths.extend(found)
    if len(tasks) > 1:
        raise DatasetError(f"dataset folders hold different tasks: {sorted(tasks)}")
    return paths


def read_dataset(
    dirs: str | Path | Iterable[str | Path],
    *,
    task: str | None = None,
    skip_bad: bool = False,
    keep_invalid: bool = False,
    progress: bool = False,
) -> EpisodeArrays:
    """All episodes of one or more dataset folders, invalid ones (valid=0) dropped.

    ``task``: if given, every folder's manifest must name it. ``skip_bad``: a corrupt, truncated or missing
    shard is skipped with a warning instead of raising :class:`DatasetError`. ``progress``: a tqdm bar
    over the shards.
    """
    paths = dataset_shards(dirs, task)
    parts: list[EpisodeArrays] = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(paths), desc="reading shards", unit="shard", mininterval=1.0, leave=False)
    try:
        for path in paths:
            try:
                episodes, meta = read_shard(path)
            except DatasetError as exc:
                if not skip_bad:
                    raise
                warnings.warn(f"skipping bad shard: {exc}", stacklevel=2)
                continue
            finally:
                if bar is not None:
                    bar.update(1)
            if task is not None and meta.get("task") not in (None, task):
                raise DatasetError(f"{path}: shard holds task {meta.get('task')!r}, expected {task!r}")
            parts.append(episodes)
    finally:
        if bar is not None:
            bar.close()
    episodes = EpisodeArrays.concatenate(parts)
    if not keep_invalid:
        episodes = episodes.subset(episodes.valid.astype(bool))
    return episodes


def split_indices_by_object(
    object_id: np.ndarray, val_fraction: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """Train and validation episode indices such that no object appears in both.

    Objects are shuffled with ``seed`` and taken into validation until it holds about ``val_fraction`` of
    the *objects* (at least one when there are two or more objects and val_fraction > 0).
    """
    if not 0.0 <= val_fraction < 1.0:
        raise ValueError(f"val_fraction must be in [0, 1), got {val_fraction}")
    objects = np.unique(object_id)
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(objects))
    n_val = int(round(val_fraction * len(objects)))
    if val_fraction > 0 and len(objects) >= 2:
        n_val = min(max(n_val, 1), len(objects) - 1)
    val_objects = objects[order[:n_val]]
    is_val = np.isin(object_id, val_objects)
    return np.flatnonzero(~is_val), np.flatnonzero(is_val)
