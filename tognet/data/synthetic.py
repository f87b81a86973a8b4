"""Synthetic episodes with a known rule, for tests, benchmarks and smoke runs (no simulator needed).

Each object is a bar through the grasp centre, lying along the crop's x axis (columns), raised 1 cm above
the gripper depth over a table 3 cm below it. Per object: the bar's reach to the left and to the right of
the grasp. Per episode: the bar's width at the grasp (the grasp slides along a tapered tool), pixel noise
and z. The labels follow a rule a network can learn:

- grasp success S_G = 1 when the bar is narrow at the grasp (width <= ``narrow_px`` pixels);
- task success S_T = 1 (only if S_G = 1) when the bar reaches further to the right than to the left;
- the action (recorded for every episode) depends on the bar's total length and its asymmetry.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tognet.data.format import CROP_SIZE, FAILURE_CODES, EpisodeArrays
from tognet.data.writer import ShardWriter

TABLE = 0.03  # metres below the gripper depth
BAR = -0.01  # metres: the bar's top surface is above the gripper depth


def bar_crop(left: int, right: int, width: int, size: int = CROP_SIZE) -> np.ndarray:
    """A (size, size) float32 crop: a bar of ``width`` rows, columns centre-left .. centre+right."""
    crop = np.full((size, size), TABLE, dtype=np.float32)
    c = size // 2
    top = c - width // 2
    crop[top : top + width, max(c - left, 0) : min(c + right, size)] = BAR
    return crop


def action_rule(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The rule's action (N, 4): a_x from total length, a_y from asymmetry, constant a_z, a_phi sign."""
    length = (left + right).astype(np.float32)
    asym = (right - left).astype(np.float32)
    return np.stack(
        [0.001 * length - 0.03, 0.002 * asym, np.full_like(length, 0.02), 0.05 * np.sign(asym)], axis=1
    ).astype(np.float32)


#: Episodes generated at a time by :func:`write_synthetic_dataset` (memory stays flat in the count).
CHUNK = 4096


def synthetic_episodes(
    n: int, n_objects: int = 20, seed: int = 0, narrow_px: int = 8, noise: float = 0.002,
    invalid: float = 0.0, chunk: int = 0, start: int = 0,
) -> EpisodeArrays:
    """``n`` episodes over ``n_objects`` bar objects, labelled by the rule in the module docstring.

    The objects depend on ``seed`` only; the episodes on (``seed``, ``chunk``): chunk 0 draws them from the
    seed's own stream, a later chunk from its own, so a long dataset is made chunk by chunk.
    ``start``: the index of the first episode (its scene seed and trial number)."""
    rng = np.random.default_rng(seed)
    obj_left = rng.integers(4, 31, size=n_objects)
    obj_right = rng.integers(4, 31, size=n_objects)
    obj_right = np.where(obj_right == obj_left, obj_right + 1, obj_right)
    if chunk:
        rng = np.random.default_rng([seed, chunk])
    obj = rng.integers(0, n_objects, size=n)
    left, right = obj_left[obj], obj_right[obj]
    width = rng.integers(3, 15, size=n)
    crops = np.stack([bar_crop(int(a), int(b), int(w)) for a, b, w in zip(left, right, width, strict=True)])
    crops += rng.normal(0.0, noise, size=crops.shape).astype(np.float32)
    s_g = (width <= narrow_px).astype(np.uint8)
    s_t = (s_g.astype(bool) & (right > left)).astype(np.uint8)
    action = action_rule(left, right) + rng.normal(0.0, 0.001, size=(n, 4)).astype(np.float32)
    valid = (rng.random(n) >= invalid).astype(np.uint8)
    return EpisodeArrays(
        crop=crops.astype(np.float16),
        z=rng.uniform(0.6, 1.0, size=n).astype(np.float32),
        grasp=rng.normal(0.0, 0.1, size=(n, 4)).astype(np.float32),
        action=action,
        grasp_success=s_g,
        task_success=s_t,
        valid=valid,
        failure=np.where(valid == 0, FAILURE_CODES["unstable"], np.where(
            s_g == 0, FAILURE_CODES["grasp_failed"], np.where(s_t == 0, FAILURE_CODES["task_failed"], 0))
        ).astype(np.int8),
        object_id=np.array([f"bar-{i:04d}" for i in obj]),
        scene_seed=(seed * 1_000_003 + start + np.arange(n)).astype(np.int64),
        trial=(start + np.arange(n)).astype(np.int32),
    )


def _meta(seed: int, kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """What names one synthetic stream in its shards: the seed and any generator setting not the default."""
    return {"round": 0, "policy": "synthetic", "seed": seed, **dict(sorted(kwargs.items()))}


def write_synthetic_dataset(
    out_dir: str | Path, task: str = "synthetic", n: int = 512, shard_size: int = 256, seed: int = 0,
    configs: Mapping[str, Any] | None = None, progress: Callable[[int], None] | None = None,
    resumed: Callable[[int], None] | None = None, **kwargs: Any,
) -> Path:
    """Write the first ``n`` :func:`synthetic_episodes` of the stream (``seed``, ``kwargs``) as a dataset
    folder and return it, :data:`CHUNK` episodes at a time (``progress(k)`` is called with each chunk's
    count). A folder that already lists some of this stream's episodes (a run stopped part way, by an
    interrupt or a full disk) is continued after them, never given them twice; another stream is appended.
    ``resumed(k)`` is called with how many of the ``n`` were there already; ``configs`` are saved beside
    the data (see :class:`ShardWriter`)."""
    with ShardWriter(out_dir, task, _meta(seed, kwargs), shard_size, configs=configs) as writer:
        done = min(writer.listed(writer.meta), n)
        for report in (resumed, progress if done else None):
            if report is not None:
                report(done)
        for chunk, start in enumerate(range(0, n, CHUNK)):
            k = min(CHUNK, n - start)
            if start + k <= done:
                continue
            episodes = synthetic_episodes(k, seed=seed, chunk=chunk, start=start, **kwargs)
            skip = max(done - start, 0)
            writer.add_batch(**{name: getattr(episodes, name)[skip:]
                                for name in episodes.__dataclass_fields__})
            if progress is not None:
                progress(k - skip)
    return Path(out_dir)
