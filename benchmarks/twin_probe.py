"""TOG-Net+ActionSearch against its twin-checked variant, paired scene by scene (issue 34).

For each object of the given sets and each scene, both planners plan on the same observation with
generators in the same state; each plan is executed once in the scene (execution seed 0, as the
evaluation does) and the outcomes are paired. Prints success rates, the paired difference with a
bootstrap 95 % interval, what the twin cost per plan and how often it was skipped.

    python benchmarks/twin_probe.py --task hammering --sets DIR [DIR ...] --scenes 4 [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np


def _job(args: tuple[str, str, str, int, dict[str, Any]]) -> list[dict[str, Any]]:
    import torch

    torch.set_num_threads(1)
    from tognet.grasping.crops import resolve_crop
    from tognet.jobs.models import load_model
    from tognet.models import default_checkpoint
    from tognet.objects.record import load_object
    from tognet.planning import PlanningError
    from tognet.planning.config import PlanConfig, TwinConfig
    from tognet.planning.planners import PolicyPlanner
    from tognet.planning.twin import TwinGrasps
    from tognet.policies.action_search import ActionSearchActions, ActionSearchGrasps
    from tognet.sim import Simulator
    from tognet.sim.config import SimConfig

    task, set_dir, object_id, scenes, twin_kw = args
    model = load_model(str(default_checkpoint(f"{task}_search")))
    config = PlanConfig()
    twin = TwinConfig(**twin_kw)
    sim_config = SimConfig()
    sim = Simulator(sim_config, task, load_object(set_dir, object_id))
    crop = resolve_crop([model], None)
    acfg = config.policy.action_search
    plain = PolicyPlanner("AS", sim.task, ActionSearchGrasps(model, acfg), ActionSearchActions(model, acfg),
                          config, crop, models={"search": model})
    checked = PolicyPlanner("Twin", sim.task, TwinGrasps(model, acfg, twin, sim_config),
                            ActionSearchActions(model, acfg), config, crop, models={"search": model})
    rows = []
    for s in range(scenes):
        seed = 1000 * (sum(map(ord, object_id)) % 997) + s
        try:
            obs = sim.reset(seed)
        except Exception:
            continue
        row: dict[str, Any] = {"object": object_id, "scene": s}
        for name, planner in (("as", plain), ("twin", checked)):
            rng = np.random.default_rng([seed, 2])
            t0 = time.perf_counter()
            try:
                plan = planner(obs, rng)
            except PlanningError:
                row[name] = 0
                continue
            row[f"{name}_s"] = time.perf_counter() - t0
            r = sim.execute(plan.grasp_pose, plan.action, 0)
            row[name] = int(r.task_success)
            row[f"{name}_why"] = str(r.failure.value)
            if name == "twin":
                row["twin_info"] = {k: v for k, v in plan.info.items() if k == "twin"}
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", required=True)
    ap.add_argument("--sets", nargs="+", required=True, help="object set folders")
    ap.add_argument("--scenes", type=int, default=4, help="scenes per object")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--twin", default="{}", help="TwinConfig fields as JSON")
    ap.add_argument("--out", default="", help="write the rows here (JSON)")
    a = ap.parse_args()
    from tognet.objects.record import load_catalog

    jobs = [(a.task, d, r.object_id, a.scenes, json.loads(a.twin)) for d in a.sets for r in load_catalog(d)]
    rows: list[dict[str, Any]] = []
    t0 = time.time()
    with ProcessPoolExecutor(a.workers) as ex:
        for out in ex.map(_job, jobs):
            rows += out
    asr = np.array([r["as"] for r in rows])
    tw = np.array([r["twin"] for r in rows])
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(rows), (2000, len(rows)))
    diff = (tw[idx] - asr[idx]).mean(axis=1) * 100
    lo, hi = np.percentile(diff, [2.5, 97.5])
    print(f"{a.task}: {len(rows)} scenes in {time.time() - t0:.0f} s")
    print(f"  ActionSearch {asr.mean() * 100:.1f} %, Twin {tw.mean() * 100:.1f} %, paired "
          f"{(tw - asr).mean() * 100:+.1f} [{lo:+.1f}, {hi:+.1f}]"
          f"; only twin {int(((tw == 1) & (asr == 0)).sum())}, only AS {int(((tw == 0) & (asr == 1)).sum())}")
    secs = [r["twin_s"] for r in rows if "twin_s" in r]
    skipped = sum("skipped" in r.get("twin_info", {}).get("twin", {}) for r in rows)
    print(f"  plan time: twin median {np.median(secs):.2f} s; AS median "
          f"{np.median([r['as_s'] for r in rows if 'as_s' in r]):.2f} s; twin skipped on {skipped} scenes")
    if a.out:
        with open(a.out, "w") as f:
            json.dump(rows, f)


if __name__ == "__main__":
    main()
