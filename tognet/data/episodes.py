"""Episode records on disk: numbered ``.npz`` shards plus a ``manifest.json`` per dataset folder.

One *episode* is one simulated trial: a grasp candidate's depth crop and gripper depth, the grasp and the
action that were executed, and the labels the simulator produced. A dataset folder holds one task::

    out_dir/
      manifest.json          format version, task, one entry per shard (counts, rates, sha256, metadata)
      shard-00000.npz        the fields of :mod:`tognet.data.format`, plus ``meta_json`` (per-shard metadata)
      shard-00001.npz
      configs/<name>.json    configs saved beside the data (simulator, task, policy, ...)

Reading them: one shard, a folder, several rounds' folders (parallel workers write to sibling folders,
e.g. ``round1/worker-00``, and a reader given the parent reads every sub-folder holding a
``manifest.json``), and the train/validation split by object. The record's fields and codes:
:mod:`tognet.data.format`; the manifest: :mod:`tognet.data.manifest`; writing: :mod:`tognet.data.writer`.
Crops are handed out as float16 (cast to float32 per batch).
"""

from __future__ import annotations

import json
import warnings
import zipfile
import zlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tognet.data.format import (
    DEFAULTS,
    FIELDS,
    FORMAT_VERSION,
    MANIFEST,
    READABLE_VERSIONS,
    SHARD_PATTERN,
    DatasetError,
    EpisodeArrays,
    check_column,
)
from tognet.data.manifest import read_manifest, verify_shard


def read_shard(path: str | Path) -> tuple[EpisodeArrays, dict[str, Any]]:
    """One shard's episodes (all of them, valid or not) and its metadata; DatasetError names the file."""
    columns, meta = read_columns(path, tuple(FIELDS))
    return EpisodeArrays(**columns), meta


def read_columns(path: str | Path, fields: Sequence[str]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Some columns of one shard (checked, converted to their declared dtypes) and its metadata. Reading
    only small columns (``object_id``, labels) skips decompressing the crops. A shard its folder's manifest
    lists is checked against the manifest first: its sha256 and its number of episodes (DatasetError)."""
    path = Path(path)
    unknown = [f for f in fields if f not in FIELDS]
    if unknown:
        raise ValueError(f"unknown episode field(s) {unknown}; known: {list(FIELDS)}")
    if not path.is_file():
        raise DatasetError(f"{path}: shard file not found")
    entry = verify_shard(path)
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
        checked = {name: check_column(name, arr, n) for name, arr in columns.items()}
    except ValueError as exc:
        raise DatasetError(f"{path}: {exc}") from exc
    if entry is not None and entry.get("count") is not None and int(entry["count"]) != n:
        raise DatasetError(f"{path}: holds {n} episodes, its manifest says {entry['count']}")
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
