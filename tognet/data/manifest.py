"""A dataset folder's ``manifest.json`` (format version, task, one entry per shard with its counts, rates,
sha256 and metadata) and the configs saved beside the data (``configs/<name>.json``)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from tognet.data.format import (
    ACTION_SOURCES,
    FAILURE_CODES,
    FORMAT_VERSION,
    GRASP_SOURCES,
    MANIFEST,
    READABLE_VERSIONS,
    DatasetError,
)
from tognet.io import atomic_write_bytes, sha256_file


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


_ENTRIES: dict[tuple[str, int, int], dict[str, Mapping[str, Any]]] = {}
_VERIFIED: set[tuple[str, int, int, str]] = set()


def manifest_entry(path: Path) -> Mapping[str, Any] | None:
    """The manifest's entry of the shard at ``path`` (None when its folder has no manifest or the manifest
    does not list it); the manifest is read again only when it changes."""
    manifest_path = path.parent / MANIFEST
    try:
        st = manifest_path.stat()
    except OSError:
        return None
    key = (str(manifest_path), st.st_size, st.st_mtime_ns)
    if key not in _ENTRIES:
        manifest = read_manifest(path.parent) or {"shards": []}
        _ENTRIES.clear()
        _ENTRIES[key] = {str(e.get("file")): e for e in manifest["shards"] if isinstance(e, dict)}
    return _ENTRIES[key].get(path.name)


def verify_shard(path: Path) -> Mapping[str, Any] | None:
    """DatasetError when a shard's bytes are not the ones its manifest recorded (its sha256): corrupt,
    truncated, or another shard put in its place. Each file is hashed once while it is unchanged. Returns
    the manifest's entry (None for a shard no manifest lists: nothing to check it against)."""
    entry = manifest_entry(path)
    if entry is None or not entry.get("sha256"):
        return entry
    st = path.stat()
    key = (str(path), st.st_size, st.st_mtime_ns, str(entry["sha256"]))
    if key not in _VERIFIED:
        digest = sha256_file(path)
        if digest != entry["sha256"]:
            raise DatasetError(f"{path}: corrupt, truncated or replaced: its bytes do not match the sha256 "
                               f"its manifest records ({digest[:16]} read, {str(entry['sha256'])[:16]} "
                               "recorded)")
        _VERIFIED.add(key)
    return entry


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


