"""Collection throughput on a Ray cluster whose worker node cannot see the run folder, against local
worker processes on the same cores (issue 31's target: within 10 %).

    sudo .venv/bin/python benchmarks/bench_ray_cluster.py [--pairs 5] [--episodes 192] [--cpus 2]

Both sides run the same ``tognet collect`` round (hammering, epsilon_greedy with the shipped models copied
into the hidden run folder, so objects and checkpoints travel through Ray) into a fresh folder: local with
``--workers CPUS``, the cluster with one worker node of CPUS CPUs (:mod:`tognet.jobs.localcluster`; the
head runs no tasks). Runs alternate in order pair by pair (local first, then cluster first) so drifting
load hits both alike. Prints each run's collection rate (the round's own episodes/s) and whole-command
wall time, and the median of the paired ratios. The node's file cache stays between runs (a real node's
does): the first cluster run also fills it.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tognet.jobs.localcluster import LocalCluster, unavailable

TOGNET = str(Path(sys.executable).parent / "tognet")
MODELS = Path(__file__).resolve().parents[1] / "tognet" / "models"


def _setup(run: Path, objects: int) -> None:
    from tognet.collect.config import CollectConfig
    from tognet.objects import generate_set

    generate_set("primitive", "train", objects, run / "objs")
    (run / "models").mkdir()
    for name in ("grasping", "hammering"):
        shutil.copy(MODELS / f"{name}.pt", run / "models" / f"{name}.pt")
    CollectConfig(trials_per_scene=8, scenes_per_job=2).save(run / "collect.json")


def _collect(run: Path, out: str, episodes: int, extra: list[str], cluster: LocalCluster | None
             ) -> tuple[float, float]:
    """(the round's episodes/s, the command's wall seconds)."""
    args = [TOGNET, "collect", "--task", "hammering", "--objects", str(run / "objs"), "--out", str(run / out),
            "--episodes", str(episodes), "--policy", "epsilon_greedy", "--no-progress", "--config",
            str(run / "collect.json"), "--grasp-model", str(run / "models" / "grasping.pt"),
            "--task-model", str(run / "models" / "hammering.pt"), *extra]
    env = None
    if cluster is not None:
        args, env = cluster.command(args), cluster.env
    start = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{out} failed:\n{done.stdout}\n{done.stderr[-2000:]}")
    summary = json.loads((run / out / "summary.json").read_text())
    shutil.rmtree(run / out)
    return float(summary["episodes_per_s_now"]), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=5)
    parser.add_argument("--episodes", type=int, default=192, help="trials per run (16 per job)")
    parser.add_argument("--objects", type=int, default=6)
    parser.add_argument("--cpus", type=int, default=2)
    args = parser.parse_args()
    reason = unavailable()
    if reason:
        raise SystemExit(f"cannot run: the blind-node cluster {reason}")
    run = Path(tempfile.mkdtemp(prefix="bench-ray-"))
    _setup(run, args.objects)
    print(f"load average at start: {os.getloadavg()}")
    cluster = LocalCluster([run]).start()
    rows = []
    try:
        cluster.add_node(args.cpus, cluster.temp / "cache")
        for i in range(args.pairs):
            order = ["local", "cluster"] if i % 2 == 0 else ["cluster", "local"]
            got = {}
            for side in order:
                local = side == "local"
                extra = ["--workers", str(args.cpus)] if local else ["--ray-address", cluster.address]
                got[side] = _collect(run, f"{side}-{i}", args.episodes, extra, None if local else cluster)
            rows.append(got)
            (lr, lw), (cr, cw) = got["local"], got["cluster"]
            print(f"pair {i} ({' then '.join(order)}): local {lr:6.1f} ep/s {lw:5.1f} s | cluster "
                  f"{cr:6.1f} ep/s {cw:5.1f} s | rate ratio cluster/local {cr / lr:.3f}, wall ratio "
                  f"{cw / lw:.3f}", flush=True)
    finally:
        cluster.close()
        shutil.rmtree(run, ignore_errors=True)
    rate = statistics.median(r["cluster"][0] / r["local"][0] for r in rows)
    wall = statistics.median(r["cluster"][1] / r["local"][1] for r in rows)
    print(f"median of {len(rows)} paired ratios, cluster / local: collection rate {rate:.3f}, "
          f"wall time {wall:.3f}")
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
