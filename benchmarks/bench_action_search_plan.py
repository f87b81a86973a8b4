"""Plan time of TOG-Net+ActionSearch against TOG-Net inside the evaluation, stage by stage, one torch thread.

    .venv/bin/python benchmarks/bench_action_search_plan.py [--tasks all] [--scenes 30] [--repeats 3]
                        [--work /tmp/tognet-bench-search] [--save-plans PLANS.json] [--compare PLANS.json]

The scenes are the evaluation's own (``tognet evaluate``'s default settings, as
``benchmarks/closed_loop_plan.py::run_job`` and :func:`tognet.evaluate.jobs._run_eval_job` build them): per
task, ``--scenes / 3`` per category (PG-Primitive, PG-Complex, Realistic), the unseen test objects
(:func:`tognet.evaluate.harness.test_objects`, generated into ``--work`` once) and the scene seeds of the
evaluation's first jobs (:func:`tognet.evaluate.jobs.plan_eval_jobs`); a scene the simulator cannot set up
is skipped and the next job's taken instead. On each observation both planners (the shipped models) plan
in turn, ``--repeats`` times, each time with a generator in the evaluation's state for that scene
(``job.seed(scene, 2)``), so both see the same antipodal candidates; a warm-up plan runs first.

Prints per task and method the medians over scenes (each scene's median over its repeats) of the plan's
stages (``plan.timing``: depth, candidates, grasp, action, total), the candidate count, and the median of
the per-scene ratio of the action search's total to TOG-Net's, with the load average. ``--save-plans``
writes the action search's (and TOG-Net's) grasp and action per scene to a JSON; ``--compare`` reads such a
file and counts the scenes whose plans are identical, equal within ``--atol``, or different.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

METHODS = ("TOG-Net", "TOG-Net+ActionSearch")
STAGES = ("depth", "candidates", "grasp", "action", "total")


def _scenes(task: str, count: int, work: Path) -> list[tuple[Any, int, Any]]:
    """``count`` evaluation scenes of ``task`` (a third per category): (job, scene index, observation)."""
    from collections import Counter

    from tognet.evaluate.config import CATEGORIES, EvalConfig
    from tognet.evaluate.harness import test_objects
    from tognet.evaluate.jobs import plan_eval_jobs
    from tognet.jobs.scenes import reset_scene
    from tognet.sim import Simulator

    config = EvalConfig()
    per_cat = -(-count // len(CATEGORIES))
    spare = 2 * config.scenes_per_job  # in case scenes cannot be set up
    n_objects = -(-(per_cat + spare) // config.scenes_per_job)
    out: list[tuple[Any, int, Any]] = []
    for cat in CATEGORIES:
        objects = test_objects(cat, n_objects, work, progress=False, log=lambda s: print(s, flush=True))
        have = 0
        for job in plan_eval_jobs(task, cat, objects, per_cat + spare, METHODS, config):
            sim = Simulator(job.config.sim, job.task, job.obj)
            for s in range(job.scenes):
                obs = reset_scene(sim, job.scene_seed(s), Counter())
                if obs is not None and have < per_cat:
                    out.append((job, s, (sim, obs)))
                    have += 1
    return out


def _planners(task: str, sim: Any, config: Any) -> dict[str, Any]:
    """Both methods' planners as the evaluation builds them (the shipped models, loaded once)."""
    from tognet.jobs.models import load_model
    from tognet.models import default_checkpoint
    from tognet.planning import make_planner

    task_model = load_model(str(default_checkpoint(task)))
    search_model = load_model(str(default_checkpoint(f"{task}_search")))
    return {"TOG-Net": make_planner("TOG-Net", sim.task, task_model=task_model, config=config, sim=sim),
            "TOG-Net+ActionSearch": make_planner("TOG-Net+ActionSearch", sim.task, search_model=search_model,
                                                 config=config, sim=sim)}


def _runs(planners: dict[str, Any], obs: Any, seed: list[int], repeats: int
          ) -> dict[str, list[tuple[Any, float]]]:
    """Each planner on ``obs`` ``repeats`` times, interleaved (the machine's load moves both alike), each
    with a generator in the same state: (plan, wall seconds) per method."""
    runs: dict[str, list[tuple[Any, float]]] = {m: [] for m in planners}
    for _ in range(repeats):
        for method, planner in planners.items():
            t0 = time.perf_counter()
            plan = planner(obs, np.random.default_rng(seed))
            runs[method].append((plan, time.perf_counter() - t0))
    return runs


def _time_task(task: str, scenes: list[tuple[Any, int, Any]], repeats: int
               ) -> tuple[dict[str, list[dict[str, float]]], list[dict[str, Any]]]:
    """Per method, each scene's median stage times (s) and candidate count; and each scene's plans."""
    from tognet.planning import PlanningError

    stages: dict[str, list[dict[str, float]]] = {m: [] for m in METHODS}
    plans: list[dict[str, Any]] = []
    warm = True
    for job, s, (sim, obs) in scenes:
        planners = _planners(task, sim, job.config.plan)
        try:
            if warm:  # TorchScript's first calls profile and optimise: not timed
                _runs(planners, obs, job.seed(s, 2), 2)
                warm = False
            runs = _runs(planners, obs, job.seed(s, 2), repeats)
        except PlanningError:  # no candidate: no plan for either method, nothing to time
            continue
        record: dict[str, Any] = {"task": task, "category": job.category, "job": job.index, "scene": s}
        for method, done in runs.items():
            row = {k: float(np.median([p.timing.get(k, 0.0) for p, _ in done])) for k in STAGES}
            row["wall"] = float(np.median([w for _, w in done]))
            row["n_candidates"] = float(done[0][0].info["candidates"])
            stages[method].append(row)
            first = done[0][0]
            record[method] = {"grasp": [float(v) for v in first.grasp],
                              "action": [float(v) for v in first.action],
                              "repeatable": all(np.array_equal(p.grasp, first.grasp)
                                                and np.array_equal(p.action, first.action) for p, _ in done)}
        plans.append(record)
    return stages, plans


def _report(task: str, stages: dict[str, list[dict[str, float]]]) -> None:
    """The table of one task: median ms per stage, candidates, and the ratio to TOG-Net."""
    search, base = ([r["total"] for r in stages[m]] for m in METHODS[::-1])
    ratio = np.median(np.asarray(search) / np.asarray(base))
    print(f"\n{task}: {len(stages['TOG-Net'])} scenes, load average {os.getloadavg()[0]:.2f}")
    print(f"  {'method':<22}" + "".join(f"{k:>11}" for k in (*STAGES, "wall")) + f"{'cands':>7}")
    for method, rows in stages.items():
        cells = "".join(f"{1000 * np.median([r[k] for r in rows]):11.1f}" for k in (*STAGES, "wall"))
        print(f"  {method:<22}{cells}{np.median([r['n_candidates'] for r in rows]):7.0f}")
    print(f"  action search / TOG-Net total: median of per-scene ratios {ratio:.2f}, ratio of medians "
          f"{np.median(search) / np.median(base):.2f}")


def _compare(plans: list[dict[str, Any]], before: list[dict[str, Any]], atol: float) -> None:
    """Count scenes whose action-search (and TOG-Net) plans are identical to / near those saved before."""
    key = {(p["task"], p["category"], p["job"], p["scene"]): p for p in before}
    for method in METHODS:
        counts = {"identical": 0, "within atol": 0, "different": 0, "missing": 0}
        for p in plans:
            old = key.get((p["task"], p["category"], p["job"], p["scene"]))
            if old is None:
                counts["missing"] += 1
                continue
            a = np.array(p[method]["grasp"] + p[method]["action"])
            b = np.array(old[method]["grasp"] + old[method]["action"])
            kind = ("identical" if np.array_equal(a, b) else
                    "within atol" if np.allclose(a, b, rtol=0.0, atol=atol) else "different")
            counts[kind] += 1
        print(f"  {method}: plans against the saved ones: "
              + ", ".join(f"{k} {v}" for k, v in counts.items()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default="all", help="comma-separated task names, or all")
    ap.add_argument("--scenes", type=int, default=30, help="scenes per task (a third per category)")
    ap.add_argument("--repeats", type=int, default=3, help="plans per method and scene (median taken)")
    ap.add_argument("--work", type=Path, default=Path("/tmp/tognet-bench-search"),
                    help="folder of the generated test objects (reused)")
    ap.add_argument("--save-plans", type=Path, default=None, help="write each scene's plans to this JSON")
    ap.add_argument("--compare", type=Path, default=None, help="compare the plans with this saved JSON")
    ap.add_argument("--atol", type=float, default=1e-5, help="tolerance of --compare's 'within atol'")
    args = ap.parse_args()
    from tognet.cli.util import task_list

    torch.set_num_threads(1)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, torch {torch.__version__} "
          f"(1 thread), load average {os.getloadavg()[0]:.2f}", flush=True)
    all_plans: list[dict[str, Any]] = []
    for task in task_list(args.tasks):
        scenes = _scenes(task, args.scenes, args.work)
        stages, plans = _time_task(task, scenes, args.repeats)
        _report(task, stages)
        all_plans += plans
        if args.compare is not None:
            _compare(plans, json.loads(args.compare.read_text()), args.atol)
        unrepeatable = sum(not p[m]["repeatable"] for p in plans for m in METHODS)
        if unrepeatable:
            print(f"  warning: {unrepeatable} plans changed between repeats of the same scene")
    if args.save_plans is not None:
        args.save_plans.write_text(json.dumps(all_plans, indent=1))
        print(f"\nplans written to {args.save_plans}")


if __name__ == "__main__":
    main()
