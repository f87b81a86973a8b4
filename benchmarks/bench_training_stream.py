"""Streamed training data: bytes per record on disk, streaming and training throughput, peak memory.

    .venv/bin/python benchmarks/bench_training_stream.py [--records 1000000] [--shard-size 1024]
        [--train] [--train-records 50000] [--dir DIR] [--keep]

Writes ``--records`` synthetic records as real shards (``write_shard``: float16 crops, compressed) into a
temporary folder. To write fast, a few hundred distinct noisy crops (``--distinct``) are drawn and reused
in random order (too far apart for the compressor to see the repeats, so the size per record is that of
noisy crops); the other columns are random. Two processes write.

Then, each in a fresh process (so that each peak RSS, VmHWM, is its own and not the writer's):

- ``stream``: :class:`tognet.data.stream.EpisodeStream` listing pass (object ids and validity of every
  shard), one epoch of training batches (batch 128, default shuffle buffer) and one validation pass,
  without a model: samples/s of the data path alone.
- ``--train``: :func:`tognet.model.train.train` for one epoch on the first ``--train-records`` records
  (a folder of hard links to the first shards), default TrainConfig (batch 128, 1 torch thread), and
  the model's training step alone on one fixed batch.

Peak RSS growth should not depend on ``--records``: compare a run at 100k with one at 1M.
"""

from __future__ import annotations

import argparse
import functools
import json
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from tognet.data.format import FIELDS
from tognet.data.manifest import new_manifest, write_manifest
from tognet.data.synthetic import synthetic_episodes
from tognet.data.writer import write_shard


def _status(key: str) -> float:
    """A /proc/self/status memory figure (VmHWM, VmRSS) in MiB."""
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


@functools.lru_cache(maxsize=1)
def _distinct_crops(n: int) -> np.ndarray:
    return synthetic_episodes(n, n_objects=50, seed=12345, noise=0.002).crop  # float16, noisy


def _write_shard(args: tuple[Path, int, int, int, int]) -> dict:
    folder, index, start, count, distinct = args
    crops = _distinct_crops(distinct)
    rng = np.random.default_rng([7, index])
    n_objects = 200
    obj = (start + np.arange(count)) // 32 % n_objects  # runs of 32 episodes per object, as the collector
    s_g = rng.random(count) < 0.5
    cols = {
        "crop": crops[rng.integers(0, distinct, count)],
        "z": rng.uniform(0.6, 1.0, count).astype(np.float32),
        "grasp": rng.normal(0, 0.1, (count, 4)).astype(np.float32),
        "action": rng.normal(0, 0.02, (count, 4)).astype(np.float32),
        "grasp_success": s_g.astype(np.uint8),
        "task_success": (s_g & (rng.random(count) < 0.4)).astype(np.uint8),
        "valid": np.ones(count, np.uint8),
        "failure": np.zeros(count, np.int8),
        "object_id": np.array([f"obj-{o:04d}" for o in obj]),
        "scene_seed": (start + np.arange(count)).astype(np.int64),
        "trial": np.zeros(count, np.int32),
        "grasp_source": np.ones(count, np.int8),
        "action_source": np.ones(count, np.int8),
        "score": np.full(count, -1.0, np.float32),
        "progress": np.full(count, -1.0, np.float32),
        "lift_tilt": np.full(count, -1.0, np.float32),
    }
    assert set(cols) == set(FIELDS)
    return write_shard(folder / f"shard-{index:05d}.npz", cols, {"task": "bench"})


def write_dataset(folder: Path, records: int, shard_size: int, distinct: int, workers: int) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    jobs = [(folder, i, start, min(shard_size, records - start), distinct)
            for i, start in enumerate(range(0, records, shard_size))]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        entries = list(pool.map(_write_shard, jobs, chunksize=4))
    manifest = new_manifest("bench")
    manifest["shards"] = entries
    write_manifest(folder, manifest)
    seconds = time.perf_counter() - t0
    size = sum((folder / e["file"]).stat().st_size for e in entries)
    return {"records": records, "shards": len(entries), "write_s": seconds, "bytes": size,
            "bytes_per_record": size / records}


def subset(folder: Path, out: Path, records: int) -> Path:
    """A dataset folder of hard links to the first shards of ``folder`` holding >= ``records``."""
    manifest = json.loads((folder / "manifest.json").read_text())
    out.mkdir(parents=True, exist_ok=True)
    shards, n = [], 0
    for entry in manifest["shards"]:
        if n >= records:
            break
        target = out / entry["file"]
        if not target.exists():
            target.hardlink_to(folder / entry["file"])
        shards.append(entry)
        n += entry["count"]
    write_manifest(out, dict(manifest, shards=shards))
    return out


def phase_stream(folder: Path, batch: int) -> dict:
    import torch

    from tognet.data.stream import EpisodeStream
    from tognet.model.config import TrainConfig

    torch.set_num_threads(1)
    base = _status("VmHWM")
    t0 = time.perf_counter()
    stream = EpisodeStream([folder], "bench", val_fraction=0.1, seed=0,
                           shuffle_buffer=TrainConfig().shuffle_buffer)
    listing = time.perf_counter() - t0
    counts = stream.counts()
    after_listing = _status("VmHWM")
    t0 = time.perf_counter()
    n = sum(len(b) for b in stream.batches("train", batch, epoch=0))
    train_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    n_val = sum(len(b) for b in stream.batches("val", 1024))
    val_s = time.perf_counter() - t0
    assert n == counts["train_episodes"] and n_val == counts["val_episodes"], (n, n_val, counts)
    return {"shards": counts["shards"], "listing_s": listing,
            "listing_shards_per_s": counts["shards"] / listing,
            "train_episodes": n, "train_epoch_s": train_s, "train_stream_samples_per_s": n / train_s,
            "val_pass_s": val_s, "records_read_per_s_in_val_pass": counts["episodes"] / val_s,
            "vmhwm_base_mib": base, "vmhwm_listing_growth_mib": after_listing - base,
            "vmhwm_growth_mib": _status("VmHWM") - base, "vmhwm_mib": _status("VmHWM")}


def phase_train(folder: Path, batch: int) -> dict:
    import torch

    from tognet.data.stream import EpisodeStream
    from tognet.model.config import TrainConfig
    from tognet.model.loss import tognet_loss
    from tognet.model.network import TOGNet
    from tognet.model.train import train

    base = _status("VmHWM")
    cfg = TrainConfig(epochs=1, batch_size=batch, num_threads=1, device="cpu")
    out = Path(tempfile.mkdtemp(prefix="bench-train-"))
    try:
        t0 = time.perf_counter()
        result = train([folder], "bench", out / "run", cfg, progress=False, log=lambda s: None)
        wall = time.perf_counter() - t0
    finally:
        shutil.rmtree(out, ignore_errors=True)
    h = result.history[0]
    grown = _status("VmHWM") - base
    # the model's step alone, on one fixed batch (what the data path is hidden behind)
    torch.set_num_threads(cfg.num_threads)  # train() restored the process's default
    torch.manual_seed(0)
    b = next(iter(EpisodeStream([folder], "bench", shuffle_buffer=batch).batches("train", batch)))
    model = TOGNet(cfg.arch).train()
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    for i in range(43):
        if i == 3:
            t0 = time.perf_counter()
        out_b = model(b.crop, b.z)
        a_pred = model.denormalize_action(out_b["action_norm"])
        loss = tognet_loss(out_b["q_g_logit"], out_b["q_tg_logit"], a_pred, b.s_g, b.s_t, b.action,
                           cfg.loss)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
    step_rate = 40 * batch / (time.perf_counter() - t0)
    return {"records": json.loads((Path(folder) / "manifest.json").read_text())["totals"]["episodes"],
            "epoch_s": h["seconds"], "train_samples_per_s": h["train"]["samples_per_s"],
            "val_count": h["val"]["count"], "train_call_s": wall,
            "model_step_alone_samples_per_s": step_rate,
            "vmhwm_growth_mib": grown, "vmhwm_mib": _status("VmHWM")}


def _run_phase(phase: str, folder: Path, batch: int) -> dict:
    cmd = [sys.executable, __file__, "--phase", phase, "--dir", str(folder), "--batch", str(batch)]
    run = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise SystemExit(f"phase {phase} failed:\n{run.stderr}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--records", type=int, default=1_000_000)
    ap.add_argument("--shard-size", type=int, default=1024)
    ap.add_argument("--distinct", type=int, default=384, help="distinct crops reused")
    ap.add_argument("--batch", type=int, default=128)
    ap.add_argument("--train", action="store_true", help="also run train() for one epoch on a subset")
    ap.add_argument("--train-records", type=int, default=50_000)
    ap.add_argument("--workers", type=int, default=2, help="writer processes")
    ap.add_argument("--dir", type=Path, default=None, help="dataset folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the dataset folder")
    ap.add_argument("--phase", choices=["stream", "train"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.phase:  # a child process: one measurement, printed as JSON
        fn = phase_stream if args.phase == "stream" else phase_train
        print(json.dumps(fn(args.dir, args.batch)))
        return

    root = args.dir or Path(tempfile.mkdtemp(prefix="bench-stream-"))
    folder = root / "data"
    try:
        if (folder / "manifest.json").exists():
            totals = json.loads((folder / "manifest.json").read_text())["totals"]
            if totals["episodes"] != args.records:
                raise SystemExit(f"{folder}: holds {totals['episodes']} records, not {args.records}")
            size = sum(p.stat().st_size for p in folder.glob("shard-*.npz"))
            w = {"records": args.records, "shards": totals["shards"], "write_s": None, "bytes": size,
                 "bytes_per_record": size / args.records}
        else:
            w = write_dataset(folder, args.records, args.shard_size, args.distinct, args.workers)
        written = "reused" if w["write_s"] is None else f"written in {w['write_s']:.0f} s"
        print(f"records {w['records']:,} in {w['shards']} shards of {args.shard_size}: "
              f"{w['bytes'] / 2**30:.2f} GiB, {w['bytes_per_record']:.0f} bytes/record on disk "
              f"(a raw float16 crop is 8192); {written} ({args.workers} processes)")
        s = _run_phase("stream", folder, args.batch)
        print(f"stream: listing {s['listing_s']:.1f} s ({s['listing_shards_per_s']:.0f} shards/s, VmHWM "
              f"+{s['vmhwm_listing_growth_mib']:.0f} MiB); one training epoch of {s['train_episodes']:,} "
              f"in batches of {args.batch}: {s['train_epoch_s']:.1f} s = "
              f"{s['train_stream_samples_per_s']:,.0f} samples/s; validation pass "
              f"{s['val_pass_s']:.1f} s ({s['records_read_per_s_in_val_pass']:,.0f} records decoded/s)")
        print(f"stream: peak RSS (VmHWM) {s['vmhwm_mib']:.0f} MiB = {s['vmhwm_base_mib']:.0f} after imports "
              f"+ {s['vmhwm_growth_mib']:.0f} MiB while streaming")
        if args.train:
            sub = subset(folder, root / f"subset-{args.train_records}", args.train_records)
            t = _run_phase("train", sub, args.batch)
            print(f"train(): 1 epoch on {t['records']:,} records (batch {args.batch}, 1 thread): "
                  f"{t['train_samples_per_s']:,.0f} samples/s end to end (epoch {t['epoch_s']:.1f} s, "
                  f"whole call {t['train_call_s']:.1f} s); model step alone "
                  f"{t['model_step_alone_samples_per_s']:,.0f} samples/s; peak RSS {t['vmhwm_mib']:.0f} MiB "
                  f"(+{t['vmhwm_growth_mib']:.0f} MiB during train())")
    finally:
        if not args.keep and args.dir is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
