"""Episode batches streamed from dataset folders with bounded memory (training never reads a dataset whole).

:class:`EpisodeStream` lists the shards of one or more dataset folders (from their manifests) and reads only
the small ``object_id`` and ``valid`` columns of every shard, to split the episodes by object (the rule
of :func:`tognet.data.episodes.split_indices_by_object` over the valid episodes, so the same objects go to
validation as with :func:`~tognet.data.episodes.read_dataset`) and to count them. Crops are read only
while iterating:

- ``batches("train", B, epoch=e)`` visits the shards in a random order drawn from ``(seed, e)`` and
  passes their training episodes through a shuffle buffer of about ``shuffle_buffer`` episodes: once the
  buffer is full, every batch is B episodes drawn at random from it (the classic streaming shuffle), and
  what is left at the end of the epoch is shuffled and emitted. Every training episode comes exactly once
  per epoch; the order depends only on ``(seed, epoch)``. Shards written by the collector hold one
  object's trials each, so the buffer is sized in episodes, not shards: many shards (objects) mix in it.
- ``batches("val" | "all", B)`` yields the episodes in a fixed order (shards as listed, rows as stored).

Batches are float32 torch tensors, made by a background thread a few batches ahead (``prefetch``), so
decoding and shuffling overlap the training step. Memory is the buffer (``shuffle_buffer`` + one shard's
episodes, 8 KiB each as float16 crops), one shard being decoded and ``prefetch`` + 2 batches, whatever
the size of the dataset; the per-shard bookkeeping (path, counts, object ids) is a few hundred bytes a
shard.

A corrupt, truncated or missing shard raises :class:`~tognet.data.format.DatasetError` naming the file,
or, with ``skip_bad``, is skipped with a warning (once; it is then left out of every later pass).
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import math
import os
import platform
import queue
import threading
import warnings
import zlib
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch

from tognet.data.episodes import dataset_shards, expand_dataset_dirs, read_columns, split_indices_by_object
from tognet.data.format import DatasetError

Split = Literal["train", "val", "all"]
#: Columns a batch carries (``scene`` is made from ``object_id`` and ``scene_seed`` when read), and the
#: columns read to select a shard's rows.
BATCH_FIELDS = ("crop", "z", "action", "grasp_success", "task_success", "progress", "lift_tilt", "scene")
_SELECT_FIELDS = ("valid", "object_id")
#: glibc's mallopt parameter for the size above which an allocation gets its own mapping.
_M_MMAP_THRESHOLD = -3
_MMAP_THRESHOLD = 128 * 1024
#: Seed stream of the shards sampled for normalisation statistics (distinct from the epochs' streams).
_SAMPLE_STREAM = 0x6E6F726D


@functools.cache  # once a process: the setting is the process's
def _fix_mmap_threshold() -> None:
    """Keep glibc's mmap threshold at its 128 KiB start (unless ``MALLOC_MMAP_THRESHOLD_`` sets it).

    glibc raises the threshold each time a large mapped block is freed, after which shard-sized arrays
    (MiB each, made by the batch thread in its own arena and freed by the consumer) come from the heaps,
    which fragment: the resident high-water mark then crept by 17-31 MiB per pass over a 60-shard set.
    With the threshold fixed, every such array is mapped and returned whole (growth under 1 MiB)."""
    if "MALLOC_MMAP_THRESHOLD_" in os.environ or platform.libc_ver()[0] != "glibc":
        return
    try:
        ctypes.CDLL(None).mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD)
    except (OSError, AttributeError):  # not glibc after all: nothing to fix
        pass


@dataclasses.dataclass
class Batch:
    """One batch of episodes as float32 tensors: crop (B, 64, 64), z (B,), action (B, 4), s_g and s_t (B,)
    (grasp and task success as 0/1), progress (B,) (the task's graded outcome in [0, 1], -1 unknown),
    scene (B,) int64, a key equal for the trials of one scene (:func:`scene_keys`; None when not read), and
    lift_tilt (B,) (how far the tool swung in the fingers when lifted, rad; -1 unknown)."""

    crop: torch.Tensor
    z: torch.Tensor
    action: torch.Tensor
    s_g: torch.Tensor
    s_t: torch.Tensor
    progress: torch.Tensor
    scene: torch.Tensor | None = None
    lift_tilt: torch.Tensor | None = None

    def __len__(self) -> int:
        return int(self.z.shape[0])

    def to(self, device: torch.device | str) -> Batch:
        """The batch on ``device`` (itself when already there)."""
        if self.z.device == torch.device(device):
            return self
        return Batch(**{f.name: None if getattr(self, f.name) is None else getattr(self, f.name).to(device)
                        for f in dataclasses.fields(self)})

    @staticmethod
    def from_columns(columns: dict[str, np.ndarray], index: np.ndarray | slice | None = None) -> Batch:
        """A batch of the rows ``index`` (all rows if None) of episode columns (see ``BATCH_FIELDS``)."""
        sl = slice(None) if index is None else index

        def f32(name: str) -> torch.Tensor:
            # gathered in numpy in the stored dtype, cast by torch (float16 -> float32 about 10x faster
            # than numpy's cast here); always a fresh tensor, never a view of the columns
            return torch.from_numpy(np.ascontiguousarray(columns[name][sl])).to(torch.float32, copy=True)

        progress = f32("progress") if "progress" in columns else torch.full_like(f32("z"), -1.0)
        scene = torch.from_numpy(np.ascontiguousarray(columns["scene"][sl])) if "scene" in columns else None
        tilt = f32("lift_tilt") if "lift_tilt" in columns else torch.full_like(f32("z"), -1.0)
        return Batch(crop=f32("crop"), z=f32("z"), action=f32("action"), s_g=f32("grasp_success"),
                     s_t=f32("task_success"), progress=progress, scene=scene, lift_tilt=tilt)

    def steady_grasps(self, max_tilt: float) -> Batch:
        """The batch with every grasp whose tool swung more than ``max_tilt`` (rad) in the fingers when
        lifted counted as failed (its task label then unused, as for any failed grasp); unmeasured swings
        (-1) keep their label. ``max_tilt`` 0: the batch itself."""
        if max_tilt <= 0 or self.lift_tilt is None:
            return self
        swung = self.lift_tilt > max_tilt
        return dataclasses.replace(self, s_g=torch.where(swung, torch.zeros_like(self.s_g), self.s_g))


def scene_keys(object_id: np.ndarray, scene_seed: np.ndarray) -> np.ndarray:
    """An int64 key per episode, equal for the trials of one scene (one object, one scene seed): the
    object id's CRC-32 shifted up by 31 bits (so the key stays positive), XOR the seed's low 32 bits. Two
    scenes share a key only by a hash collision (keys are compared within one shuffle buffer)."""
    ids, inverse = np.unique(np.asarray(object_id), return_inverse=True)
    crc = np.array([zlib.crc32(str(i).encode()) for i in ids], dtype=np.int64)[inverse.reshape(-1)]
    low = np.asarray(scene_seed, dtype=np.int64) & 0xFFFFFFFF
    return (crc << 31) ^ low


@dataclasses.dataclass(frozen=True)
class ShardInfo:
    """What the listing pass learnt about one shard (no crops read)."""

    path: Path
    episodes: int
    train: int
    val: int
    objects: tuple[str, ...]  # objects of its valid episodes


def _concat(parts: Sequence[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


class _Pool:
    """A fixed-size shuffle buffer: columns preallocated for ``capacity`` rows (pages are touched only as
    rows arrive); random draws without replacement, holes filled from the tail (O(batch) per draw)."""

    def __init__(self, capacity: int, like: dict[str, np.ndarray]) -> None:
        self.cols = {k: np.empty((capacity, *v.shape[1:]), dtype=v.dtype) for k, v in like.items()}
        self.n = 0

    def add(self, cols: dict[str, np.ndarray]) -> None:
        k = len(next(iter(cols.values())))
        for name, arr in cols.items():
            self.cols[name][self.n : self.n + k] = arr
        self.n += k

    def draw(self, k: int, rng: np.random.Generator) -> Batch:
        return self._take(rng.choice(self.n, size=k, replace=False))

    def draw_scenes(self, k: int, rng: np.random.Generator) -> Batch:
        """Whole scenes, picked at random, until the next one would pass ``k`` episodes (at least one
        scene): every trial of a scene in the buffer lands in one batch, for a within-scene loss."""
        _, group, size = np.unique(self.cols["scene"][: self.n], return_inverse=True, return_counts=True)
        group = group.reshape(-1)
        order = _first_seen(group[rng.permutation(self.n)])
        fits = max(int(np.searchsorted(np.cumsum(size[order]), k, side="right")), 1)
        return self._take(np.flatnonzero(np.isin(group, order[:fits])))

    def _take(self, sel: np.ndarray) -> Batch:
        """The batch of rows ``sel`` (distinct), removed from the buffer."""
        n, k = self.n, len(sel)
        batch = Batch.from_columns(self.cols, sel)
        tail = n - k
        holes = np.sort(sel[sel < tail])
        taken = np.zeros(k, dtype=bool)
        taken[sel[sel >= tail] - tail] = True
        movers = tail + np.flatnonzero(~taken)
        for arr in self.cols.values():
            arr[holes] = arr[movers]
        self.n = tail
        return batch

    def drain(self, batch_size: int, rng: np.random.Generator, scenes: bool = False) -> Iterator[Batch]:
        if scenes:
            while self.n:
                yield self.draw_scenes(batch_size, rng)
            return
        perm = rng.permutation(self.n)
        for lo in range(0, self.n, batch_size):
            yield Batch.from_columns(self.cols, perm[lo : lo + batch_size])
        self.n = 0


def _first_seen(values: np.ndarray) -> np.ndarray:
    """The distinct values of ``values`` in the order they first appear."""
    _, first = np.unique(values, return_index=True)
    return values[np.sort(first)]


class EpisodeStream:
    """Batches of episodes from dataset folders, split by object, read shard by shard (module docstring).

    ``task``: if given, every folder's manifest (and every shard's metadata) must name it.
    ``val_fraction``, ``seed``: the split by object (as :func:`split_indices_by_object`; ``seed`` also
    drives the training order). ``shuffle_buffer``: episodes held for shuffling training batches.
    ``skip_bad``: skip a corrupt or truncated shard with a warning instead of raising. ``progress``: a tqdm
    bar over the listing pass. ``prefetch``: batches made ahead by a background thread (0: none, made on
    demand; the batches are the same either way). ``scene_batches``: training batches are made of whole
    scenes (every trial of a scene in the buffer goes into one batch, at most ``batch_size`` episodes a
    batch unless one scene alone has more), for a loss that compares the trials of one scene.
    """

    def __init__(
        self,
        dirs: str | Path | Iterable[str | Path],
        task: str | None = None,
        *,
        val_fraction: float = 0.0,
        seed: int = 0,
        shuffle_buffer: int = 16384,
        skip_bad: bool = False,
        progress: bool = False,
        prefetch: int = 2,
        scene_batches: bool = False,
    ) -> None:
        if shuffle_buffer < 0:
            raise ValueError(f"shuffle_buffer must be >= 0, got {shuffle_buffer}")
        self.dirs = expand_dataset_dirs(dirs)
        self.task = task
        self.seed = int(seed)
        self.val_fraction = float(val_fraction)
        self.shuffle_buffer = int(shuffle_buffer)
        self.skip_bad = skip_bad
        self.prefetch = int(prefetch)
        self.scene_batches = bool(scene_batches)
        self._local = threading.local()
        self._bad: set[Path] = set()
        _fix_mmap_threshold()
        paths = self._list_paths()
        self.shards, self.val_objects, self.objects = self._scan(paths, progress)
        self._val_array = np.array(sorted(self.val_objects), dtype=str)

    # -- listing ----------------------------------------------------------------------------------------
    def _list_paths(self) -> list[Path]:
        return dataset_shards(self.dirs, self.task)

    def _scan(self, paths: list[Path], progress: bool) -> tuple[list[ShardInfo], frozenset[str], int]:
        from tqdm import tqdm

        listed: list[tuple[Path, int, np.ndarray, np.ndarray]] = []
        for path in tqdm(paths, desc="reading shards", unit="shard", disable=not progress, leave=False,
                         mininterval=1.0):
            try:
                cols, meta = read_columns(path, _SELECT_FIELDS)
            except DatasetError as exc:
                if not self.skip_bad:
                    raise
                self._skip(path, exc)
                continue
            if self.task is not None and meta.get("task") not in (None, self.task):
                raise DatasetError(f"{path}: shard holds task {meta.get('task')!r}, expected {self.task!r}")
            ids, counts = np.unique(cols["object_id"][cols["valid"].astype(bool)], return_counts=True)
            listed.append((path, len(cols["valid"]), ids, counts))
        objects = np.unique(np.concatenate([ids for _, _, ids, _ in listed])) if listed else np.array([], str)
        _, val_idx = split_indices_by_object(objects, self.val_fraction, self.seed)
        val_objects = frozenset(objects[val_idx].tolist())
        shards = []
        for path, n, ids, counts in listed:
            is_val = np.array([i in val_objects for i in ids.tolist()], dtype=bool)
            shards.append(ShardInfo(path=path, episodes=n, train=int(counts[~is_val].sum()),
                                    val=int(counts[is_val].sum()), objects=tuple(ids.tolist())))
        return shards, val_objects, len(objects)

    def _skip(self, path: Path, exc: Exception) -> None:
        if path not in self._bad:
            message = f"skipping bad shard: {exc}"
            warn = getattr(self._local, "warn", None)  # set in the batch producer thread
            if warn is not None:
                warn(message)
            else:
                warnings.warn(message, stacklevel=4)
        self._bad.add(path)

    # -- counts -----------------------------------------------------------------------------------------
    def count(self, split: Split) -> int:
        """Valid episodes of ``split`` ('train', 'val' or 'all'), from the listing pass."""
        return sum(self._shard_count(s, split) for s in self.shards)

    @staticmethod
    def _shard_count(shard: ShardInfo, split: Split) -> int:
        if split == "train":
            return shard.train
        if split == "val":
            return shard.val
        if split == "all":
            return shard.train + shard.val
        raise ValueError(f"split must be 'train', 'val' or 'all', got {split!r}")

    def counts(self) -> dict[str, int]:
        """Shards, episodes (all and valid) and objects, per split (no crop is read)."""
        train_objects = {o for s in self.shards if s.train for o in s.objects} - self.val_objects
        return {
            "shards": len(self.shards),
            "episodes": sum(s.episodes for s in self.shards),
            "valid": self.count("all"),
            "objects": self.objects,
            "train_episodes": self.count("train"),
            "val_episodes": self.count("val"),
            "train_objects": len(train_objects),
            "val_objects": len(self.val_objects),
        }

    def num_batches(self, split: Split, batch_size: int) -> int:
        """How many batches :meth:`batches` yields for ``split`` (when no shard turns out bad)."""
        return math.ceil(self.count(split) / batch_size)

    # -- reading ----------------------------------------------------------------------------------------
    def read(self, shard: ShardInfo, split: Split, fields: Sequence[str] = BATCH_FIELDS
             ) -> dict[str, np.ndarray] | None:
        """The ``split`` episodes of one shard as columns (crops float16); None for a bad shard skipped.
        A ``scene`` field is made from the stored ``object_id`` and ``scene_seed`` (:func:`scene_keys`)."""
        if shard.path in self._bad:
            return None
        stored = [f for f in fields if f != "scene"] + (["scene_seed"] if "scene" in fields else [])
        try:
            cols, _ = read_columns(shard.path, tuple(dict.fromkeys((*stored, *_SELECT_FIELDS))))
        except DatasetError as exc:
            if not self.skip_bad:
                raise
            self._skip(shard.path, exc)
            return None
        keep = cols["valid"].astype(bool)
        if split != "all":
            is_val = np.isin(cols["object_id"], self._val_array)
            keep &= is_val if split == "val" else ~is_val
        expected = self._shard_count(shard, split)
        if int(keep.sum()) != expected:
            raise DatasetError(f"{shard.path}: holds {int(keep.sum())} {split} episodes, {expected} when the "
                               "dataset was listed (was the shard rewritten meanwhile?)")
        if "scene" in fields:
            cols["scene"] = scene_keys(cols["object_id"], cols["scene_seed"])
        return {k: cols[k][keep] for k in fields}

    def _shard_columns(self, shards: Sequence[ShardInfo], split: Split) -> Iterator[dict[str, np.ndarray]]:
        for shard in shards:
            cols = self.read(shard, split)
            if cols is not None:
                yield cols

    def batches(self, split: Split, batch_size: int, *, epoch: int = 0, shuffle: bool | None = None
                ) -> Iterator[Batch]:
        """Batches of ``batch_size`` episodes of ``split`` (the last one may be smaller). ``shuffle``
        (default: for 'train' only): shards in a random order and rows through the shuffle buffer, both
        drawn from ``(seed, epoch)``; otherwise shards as listed and rows as stored."""
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        shards = [s for s in self.shards if self._shard_count(s, split) and s.path not in self._bad]
        if (split == "train") if shuffle is None else shuffle:
            rng = np.random.default_rng([self.seed, epoch])
            return self._background(lambda: self._shuffled(shards, split, batch_size, rng))
        return self._background(lambda: self._in_order(shards, split, batch_size))

    def _background(self, make: Callable[[], Iterator[Batch]]) -> Iterator[Batch]:
        """The batches of ``make()``, produced up to ``prefetch`` batches ahead by a background thread
        (shard decoding, shuffling and the float16 -> float32 cast overlap the consumer's work: zlib and
        numpy release the GIL). Errors and skipped-shard warnings surface in the consumer, in order."""
        if self.prefetch < 1:
            yield from make()
            return
        items: queue.Queue[tuple[str, Any]] = queue.Queue(maxsize=self.prefetch)
        stop = threading.Event()

        def put(item: tuple[str, Any]) -> bool:
            while not stop.is_set():
                try:
                    items.put(item, timeout=0.05)
                    return True
                except queue.Full:
                    continue
            return False

        def produce() -> None:
            self._local.warn = lambda message: put(("warn", message))
            try:
                for batch in make():
                    if not put(("batch", batch)):
                        return
                put(("end", None))
            except BaseException as exc:  # handed to the consumer, raised there
                put(("error", exc))

        thread = threading.Thread(target=produce, name="tognet-batches", daemon=True)
        thread.start()
        try:
            while True:
                kind, item = items.get()
                if kind == "batch":
                    yield item
                elif kind == "warn":
                    warnings.warn(item, stacklevel=2)
                elif kind == "error":
                    raise item
                else:
                    return
        finally:
            stop.set()
            thread.join()

    def _in_order(self, shards: list[ShardInfo], split: Split, batch_size: int) -> Iterator[Batch]:
        rest: dict[str, np.ndarray] | None = None
        for cols in self._shard_columns(shards, split):
            if rest is not None:
                cols = _concat([rest, cols])
            n = len(cols["z"])
            full = n - n % batch_size
            for lo in range(0, full, batch_size):
                yield Batch.from_columns(cols, slice(lo, lo + batch_size))
            rest = {k: v[full:].copy() for k, v in cols.items()}
        if rest is not None and len(rest["z"]):
            yield Batch.from_columns(rest)

    def _shuffled(self, shards: list[ShardInfo], split: Split, batch_size: int, rng: np.random.Generator
                  ) -> Iterator[Batch]:
        order = rng.permutation(len(shards))
        fill = max(self.shuffle_buffer, batch_size)
        largest = max((self._shard_count(s, split) for s in shards), default=0)
        pool: _Pool | None = None
        for cols in self._shard_columns([shards[i] for i in order], split):
            if pool is None:
                pool = _Pool(min(fill + largest, self.count(split)), cols)
            pool.add(cols)
            del cols
            while pool.n >= fill:
                yield pool.draw_scenes(batch_size, rng) if self.scene_batches else pool.draw(batch_size, rng)
        if pool is not None:
            yield from pool.drain(batch_size, rng, self.scene_batches)

    def sample(self, split: Split = "train", max_episodes: int = 4096,
               fields: Sequence[str] = BATCH_FIELDS) -> dict[str, np.ndarray]:
        """At most ``max_episodes`` episodes of ``split`` from shards taken in a seeded random order until
        enough are read (evenly thinned when one shard overshoots); e.g. for normalisation statistics."""
        shards = [s for s in self.shards if self._shard_count(s, split)]
        order = np.random.default_rng([self.seed, _SAMPLE_STREAM]).permutation(len(shards))
        parts: list[dict[str, np.ndarray]] = []
        got = 0
        for i in order:
            if got >= max_episodes:
                break
            cols = self.read(shards[i], split, fields)
            if cols is None:
                continue
            parts.append(cols)
            got += len(next(iter(cols.values())))
        if not parts:
            return {}
        cols = _concat(parts)
        if got > max_episodes:
            keep = np.linspace(0, got - 1, max_episodes).round().astype(np.int64)
            cols = {k: v[keep] for k, v in cols.items()}
        return cols
