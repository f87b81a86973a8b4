"""What batches of whole scenes cost the training data path: one epoch of training batches of a dataset,
plain (rows drawn at random from the shuffle buffer) against ``scene_batches`` (whole scenes drawn), in
alternating pairs in one process, and the rank term's cost in the loss on one batch.

    .venv/bin/python benchmarks/bench_scene_batches.py DATA_DIR [DATA_DIR ...] [--pairs 5] [--batch 128]

Prints per pair both epochs' seconds, then the medians and the median of the per-pair ratios (scene /
plain), and the batches' mean size and scenes per batch. The data must be collected trials (several per
scene, e.g. ``tognet collect`` with ``trials_per_scene`` 8).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from tognet.data.stream import EpisodeStream
from tognet.model.loss import scene_rank_sum


def epoch(dirs: list[Path], batch: int, scenes: bool, seed: int) -> tuple[float, list[int], list[int]]:
    """Seconds for one epoch of training batches, the batches' sizes and their distinct scenes."""
    stream = EpisodeStream(dirs, val_fraction=0.15, seed=seed, scene_batches=scenes)
    t0 = time.perf_counter()
    sizes, distinct = [], []
    for b in stream.batches("train", batch, epoch=0):
        sizes.append(len(b))
        distinct.append(len(torch.unique(b.scene)))
    return time.perf_counter() - t0, sizes, distinct


def rank_cost(batch: int, repeats: int = 200) -> float:
    """Median microseconds of :func:`scene_rank_sum` with its backward pass on one batch of 16 scenes, on
    one torch thread as training runs (``TrainConfig.num_threads``; two threads on a loaded 2-core machine
    took 100 times longer)."""
    torch.set_num_threads(1)
    g = torch.randn(batch, requires_grad=True)
    t = torch.randn(batch, requires_grad=True)
    s_t = (torch.rand(batch) < 0.4).float()
    scene = torch.arange(batch) // 8
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        total, _ = scene_rank_sum(g, t, s_t, scene)
        total.backward()
        times.append(time.perf_counter() - t0)
    return 1e6 * statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", type=Path, nargs="+", help="dataset folders of collected trials")
    ap.add_argument("--pairs", type=int, default=5, help="alternating (plain, scene) epoch pairs")
    ap.add_argument("--batch", type=int, default=128, help="batch size")
    args = ap.parse_args()
    missing = [str(d) for d in args.data if not d.is_dir()]
    if missing:
        raise SystemExit(f"bench_scene_batches: not a folder: {', '.join(missing)}")
    plain_s, scene_s, ratios = [], [], []
    for i in range(args.pairs):
        p, p_sizes, p_scenes = epoch(args.data, args.batch, False, i)
        s, s_sizes, s_scenes = epoch(args.data, args.batch, True, i)
        plain_s.append(p)
        scene_s.append(s)
        ratios.append(s / p)
        print(f"pair {i + 1}: plain {p:.2f} s ({len(p_sizes)} batches, {np.mean(p_scenes):.1f} scenes each), "
              f"scene {s:.2f} s ({len(s_sizes)} batches of {np.mean(s_sizes):.1f}, "
              f"{np.mean(s_scenes):.1f} scenes each)")
    print(f"median epoch: plain {statistics.median(plain_s):.2f} s, "
          f"scene {statistics.median(scene_s):.2f} s; "
          f"median ratio scene / plain {statistics.median(ratios):.2f}")
    print(f"rank term with backward, batch {args.batch} (16 scenes): {rank_cost(args.batch):.0f} us median")


if __name__ == "__main__":
    main()
