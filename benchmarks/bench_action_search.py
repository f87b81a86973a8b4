"""One plan of TOG-Net+ActionSearch against one of TOG-Net, on simulated depth images, on one core.

    .venv/bin/python benchmarks/bench_action_search.py [--task hammering] [--scenes 30] [--repeats 3]
                                                       [--search-model PATH] [--task-model PATH]

A plan = depth preparation, the antipodal candidates (the planner's config: up to 200), then the method:
TOG-Net's CEM on Q_T and its action mean, or the action search (every candidate encoded once and rated on
its best of ``rate_samples`` actions, CEM over the actions of the best few; see
:mod:`tognet.policies.action_search`). The two planners alternate on the same observations with the same
generator state, so their medians come from one sitting; the machine is shared, so compare the ratio
and the medians, not lone figures. torch runs on one thread (as the planners load models). Prints the
median and p90 per method, the search's stages and the load average.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from tognet.jobs.models import load_model
from tognet.models import default_checkpoint
from tognet.objects.generate import generate_set
from tognet.planning import make_planner
from tognet.sim import SimConfig, Simulator


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--task", default="hammering")
    parser.add_argument("--scenes", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--search-model", type=Path, default=None,
                        help="action-conditioned checkpoint (default: the shipped <task>_search.pt)")
    parser.add_argument("--task-model", type=Path, default=None,
                        help="TOG-Net checkpoint (default: the shipped <task>.pt)")
    args = parser.parse_args()
    search_model = load_model(str(args.search_model or default_checkpoint(f"{args.task}_search")))
    task_model = load_model(str(args.task_model or default_checkpoint(args.task)))
    times: dict[str, list[float]] = {"TOG-Net": [], "TOG-Net+ActionSearch": []}
    stages: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        objects = generate_set("primitive", "test", args.scenes, Path(tmp) / "o", progress=False)
        for i, obj in enumerate(objects):
            sim = Simulator(SimConfig(), args.task, obj)
            obs = sim.reset(i)
            planners = {m: make_planner(m, sim.task, task_model=task_model, search_model=search_model)
                        for m in times}
            for _ in range(args.repeats):
                for name, planner in planners.items():  # alternating, same observation and rng state
                    t0 = time.perf_counter()
                    plan = planner.plan(obs, np.random.default_rng(i))
                    times[name].append(time.perf_counter() - t0)
                    if name == "TOG-Net+ActionSearch":
                        stages.append(plan.timing)
    print(f"{args.task}: {args.scenes} scenes x {args.repeats} repeats, one torch thread, load average "
          f"{os.getloadavg()[0]:.2f}")
    for name, t in times.items():
        ms = 1000 * np.asarray(t)
        print(f"  {name:<22} median {np.median(ms):6.1f} ms   p90 {np.percentile(ms, 90):6.1f} ms")
    ratio = np.median(times["TOG-Net+ActionSearch"]) / np.median(times["TOG-Net"])
    print(f"  ratio of medians (search / TOG-Net): {ratio:.2f}")
    keys = sorted({k for s in stages for k in s})
    print("  action search stages, median ms: " + ", ".join(
        f"{k} {1000 * np.median([s.get(k, 0.0) for s in stages]):.1f}" for k in keys))


if __name__ == "__main__":
    main()
