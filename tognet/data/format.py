"""The episode record: its fields, dtypes and codes, one checked column at a time (the on-disk layout of a
dataset folder: :mod:`tognet.data.episodes`).

Crops are float16 (8 KiB a record before compression; its ~3e-5 m step near 3 cm is far below the depth
noise). Format version 1 (float32 crops, no ``grasp_source``/``action_source``/``score``) and 2 (no
``progress``, the task's graded outcome :meth:`tognet.tasks.Task.progress`) are still read; missing fields
get their defaults (``progress`` -1: unknown).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tognet.errors import TognetError
from tognet.grasping.crops import CropConfig
from tognet.tasks.base import FailureReason

#: Version of the shard/manifest layout; bump on any incompatible change.
FORMAT_VERSION = 4
#: Versions this code reads (older shards get the new fields' defaults).
READABLE_VERSIONS = (1, 2, 3, 4)
#: Side of a stored crop, pixels: the default CropConfig's (the one place the crop size is set).
CROP_SIZE = CropConfig().size
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
    "lift_tilt": (np.dtype(np.float32), ()),
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
                            "score": -1.0, "progress": -1.0, "lift_tilt": -1.0}


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
    lift_tilt: np.ndarray = None  # type: ignore[assignment]  (rad; -1: not measured)

    def __post_init__(self) -> None:
        n = int(np.asarray(self.z).shape[0])
        for name in ("grasp_source", "action_source", "score", "progress", "lift_tilt"):
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


def check_column(name: str, value: Any, n: int | None) -> np.ndarray:
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
            checked[name] = check_column(name, columns[name], n)
        elif name in DEFAULTS:
            checked[name] = np.full((n,), DEFAULTS[name], dtype=FIELDS[name][0])
        else:
            raise ValueError(f"missing episode field '{name}'")
    return checked


