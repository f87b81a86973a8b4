"""Collection throughput: episodes/s of a round-1 collection with 1 and 2 local worker processes and
through a local Ray instance, on the same jobs (paired, alternating), plus the estimated wall-clock of
the ``paper`` preset on a cluster.

    .venv/bin/python benchmarks/bench_collect.py [--task hammering] [--episodes 1200] [--objects 24]
        [--repeats 2] [--no-ray]

Each executor is warmed up first (worker start-up, imports, object meshes) on a few jobs of another
round, then times a whole round; the figure is records written per second of wall time. Writes into a
temporary folder. Targets (issue 11): 2 workers >= 1.8 x one; Ray within 10 % of local workers.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from tognet.collect.config import CollectConfig, RoundConfig, load_preset
from tognet.collect.rounds import collect_round
from tognet.jobs.workers import Executor, LocalExecutor
from tognet.objects import generate_set
from tognet.tasks import DEFAULT_TASK, SIM_TASKS


def timed_round(executor: Executor, task: str, objects: list, episodes: int, cfg: CollectConfig, out: Path,
                round_index: int) -> float:
    """Episodes per second of one round on a warm executor."""
    t0 = time.perf_counter()
    summary = collect_round(task, round_index, objects, RoundConfig(episodes=episodes), cfg, out,
                            executor=executor, progress=False, log=lambda _m: None)
    return summary["episodes"] / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default=DEFAULT_TASK, choices=SIM_TASKS)
    ap.add_argument("--episodes", type=int, default=1200, help="Episodes per timed round.")
    ap.add_argument("--objects", type=int, default=24, help="PG-Primitive objects.")
    ap.add_argument("--repeats", type=int, default=2, help="Timed rounds per executor (alternating).")
    ap.add_argument("--no-ray", action="store_true", help="Skip the Ray executor.")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="tognet-bench-collect-"))
    objects = generate_set("primitive", "train", args.objects, work / "objects")
    cfg = CollectConfig()
    executors: dict[str, Executor] = {"local-1": LocalExecutor(1), "local-2": LocalExecutor(2)}
    if not args.no_ray:
        try:
            from tognet.jobs.workers import RayExecutor

            executors["ray-2"] = RayExecutor(workers=2)
        except Exception as exc:  # Ray missing: say so, measure the rest
            print(f"ray: not measured ({exc})")
    rates: dict[str, list[float]] = {name: [] for name in executors}
    try:
        for name, ex in executors.items():  # warm-up: start workers, imports, first meshes
            warm = 2 * ex.workers * cfg.scenes_per_job * cfg.trials_per_scene
            timed_round(ex, args.task, objects, warm, cfg, work / f"warm-{name}", 90)
        for r in range(args.repeats):
            for name, ex in executors.items():
                rate = timed_round(ex, args.task, objects, args.episodes, cfg, work / f"{name}-{r}", 100 + r)
                rates[name].append(rate)
                print(f"{name} repeat {r}: {rate:.1f} episodes/s")
    finally:
        for ex in executors.values():
            ex.close()
    med = {name: statistics.median(v) for name, v in rates.items()}
    print(f"\n{args.task}, {args.episodes} episodes per round, {cfg.trials_per_scene} trials per scene, "
          f"{cfg.scenes_per_job} scenes per job")
    for name, v in med.items():
        print(f"  {name:8s} median {v:6.1f} episodes/s  (runs: {', '.join(f'{x:.1f}' for x in rates[name])})")
    one = med["local-1"]
    print(f"  2 workers / 1 worker: {med['local-2'] / one:.2f} (target >= 1.8)")
    if "ray-2" in med:
        print(f"  Ray (2 CPUs) / local 2 workers: {med['ray-2'] / med['local-2']:.2f} (target >= 0.90)")
    paper = load_preset("paper")
    per_core = one
    trials = paper.grasp_round.episodes + sum(r.episodes for r in paper.rounds)
    efficiency = min(1.0, med["local-2"] / (2 * one))  # the scaling measured from 1 to 2 workers
    for cores in (64, 512):
        hours = trials / (per_core * cores * efficiency) / 3600
        print(f"  paper preset, {args.task}: {trials:,} trials on {cores} cores at {per_core:.1f} ep/s/core, "
              f"{efficiency:.0%} scaling: {hours:.2f} h of collection (training not included)")


if __name__ == "__main__":
    main()
