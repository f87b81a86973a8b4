"""Calibrate the low-confidence warning of every method a robot can run, per task, on held-out scenes.

    .venv/bin/python benchmarks/calibrate_confidence.py [--tasks all] [--scenes 300] [--workers 2]
                        [--out /tmp/tognet-calibrate] [--json tognet/models/confidence.json] [--fit-only]

Runs the evaluation's jobs (:func:`tognet.evaluate.jobs.run_eval_job`: every method on the same scenes,
each plan executed in the simulator) for Antipodal+Random, Task_Agn+Random, Task_Agn+Trained,
Task_Ori+Random, TOG-Net and TOG-Net+ActionSearch with the shipped models, ``--scenes`` per task (a third
per category: PG-Primitive, PG-Complex, Realistic) drawn with ``EvalConfig(seed=1)``: held-out scenes, as
the README's evaluation and ``closed_loop_plan.py`` use seed 0. Records go to OUT/records.jsonl, one job's
at a time; killed and run again with the same settings, it runs only the jobs not there yet (OUT/settings.json
refuses other settings).

Then, per task and method, it fits the plans' success as a non-decreasing function of the method's own
score (``Plan.scores["choice"]``; :mod:`tognet.evaluate.confidence`) and writes ``--json`` (default
``tognet/models/confidence.json``, read by :mod:`tognet.planning.confidence`): a plan warns when it scores
below the lowest score from which the fitted success rate reaches ``--level`` (0.5). Plans that found no
grasp (no plan to warn about) and invalid trials are left out of the fit. Prints a markdown table per task.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import defaultdict
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

EVAL_SEED = 1
LEVEL = 0.5
RECORDS = "records.jsonl"
EMPTY = "empty_jobs.jsonl"
SETTINGS = "settings.json"


def robot_methods() -> tuple[str, ...]:
    """The methods a robot can run, in the method table's order."""
    from tognet.planning.methods import METHOD_TABLE

    return tuple(m.name for m in METHOD_TABLE if not m.uses_sim)


def model_paths(tasks: list[str]) -> dict[str, Path]:
    """The shipped checkpoints the methods use: the grasp-only model, each task's and its action search's."""
    from tognet.models import default_checkpoint
    from tognet.tasks import GRASP_ONLY

    names = [GRASP_ONLY] + [n for t in tasks for n in (t, f"{t}_search")]
    return {n: default_checkpoint(n) for n in names}


def check_settings(out: Path, settings: dict[str, Any]) -> None:
    """Write OUT/settings.json, or refuse to mix records with those of a run with other settings."""
    path = out / SETTINGS
    if path.is_file():
        old = json.loads(path.read_text())
        if old != settings:
            diff = sorted(k for k in set(old) | set(settings) if old.get(k) != settings.get(k))
            raise SystemExit(f"{out}: holds records of other settings (differs in {', '.join(diff)}); "
                             "use another --out")
        return
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(settings, indent=2) + "\n")


def read_lines(path: Path) -> list[dict[str, Any]]:
    """The JSON lines of ``path``; a line cut short by a kill is dropped and the file rewritten without it
    (so that what is appended next starts on a line of its own)."""
    if not path.is_file():
        return []
    text = path.read_text()
    rows, kept = [], []
    for line in text.splitlines():
        try:
            rows.append(json.loads(line))
            kept.append(line)
        except json.JSONDecodeError:
            print(f"{path}: dropping a cut line ({len(line)} characters)", flush=True)
    if text and (len(kept) != len(text.splitlines()) or not text.endswith("\n")):
        from tognet.io import atomic_write_text

        atomic_write_text(path, "".join(k + "\n" for k in kept))
    return rows


def _log(line: str) -> None:
    print(line, flush=True)


def job_key(task: str, category: str, index: int) -> tuple[str, str, int]:
    return (task, category, int(index))


def plan_jobs(tasks: list[str], scenes: int, out: Path, workers: int, models: dict[str, Path]) -> list[Any]:
    """Every job of the calibration: per task and category ``scenes / 3`` scenes, a test object per job."""
    from tognet.evaluate.config import CATEGORIES, EvalConfig
    from tognet.evaluate.harness import test_objects
    from tognet.evaluate.jobs import plan_eval_jobs
    from tognet.tasks import GRASP_ONLY

    config = EvalConfig(seed=EVAL_SEED)
    per_cat = -(-scenes // len(CATEGORIES))
    n_objects = -(-per_cat // config.scenes_per_job)
    jobs = []
    for cat in CATEGORIES:
        objects = test_objects(cat, n_objects, out, workers, progress=False, log=_log)
        for task in tasks:
            jobs += plan_eval_jobs(task, cat, objects, per_cat, robot_methods(), config,
                                   grasp_model=str(models[GRASP_ONLY]), task_model=str(models[task]),
                                   search_model=str(models[f"{task}_search"]))
    return jobs


def run_jobs(jobs: list[Any], out: Path, workers: int) -> None:
    """Run ``jobs`` in ``workers`` spawned processes, appending each job's records as it ends (a job with
    none, e.g. an object the simulator cannot load, to OUT/empty_jobs.jsonl)."""
    from tognet.evaluate.jobs import run_eval_job
    from tognet.jobs.workers import LocalExecutor

    t0 = time.perf_counter()
    done = 0
    with open(out / RECORDS, "a") as fh, open(out / EMPTY, "a") as empty:

        def on_result(job: Any, output: Any) -> None:
            nonlocal done
            records = output.columns.get("records", [])
            if records:
                fh.write("".join(json.dumps(r) + "\n" for r in records))
                fh.flush()
            else:
                empty.write(json.dumps({"task": job.task, "category": job.category, "job": job.index,
                                        "error": output.error, "stats": output.stats}) + "\n")
                empty.flush()
            done += 1
            if done % 10 == 0 or done == len(jobs) or output.error:
                spent = time.perf_counter() - t0
                eta = spent / done * (len(jobs) - done)
                print(f"{done}/{len(jobs)} jobs, {spent:.0f} s, ~{eta / 60:.1f} min left, load average "
                      f"{os.getloadavg()[0]:.2f}" + (f"; error: {output.error}" if output.error else ""),
                      flush=True)

        executor = LocalExecutor(workers)
        try:
            executor.run(jobs, on_result, _log, run_eval_job)
        finally:
            executor.close()


def fit_entries(records: list[dict[str, Any]], tasks: list[str], level: float) -> dict[str, Any]:
    """Per task and method: the fitted threshold (:func:`tognet.evaluate.confidence.warn_threshold`), the
    score's meaning and the models it uses."""
    from tognet.evaluate.confidence import warn_threshold
    from tognet.planning.methods import NEEDS, get_method

    plans: dict[tuple[str, str], list[tuple[float, bool]]] = defaultdict(list)
    for r in records:
        if r["valid"] and "choice" in r["scores"]:
            plans[(r["task"], r["method"])].append((float(r["scores"]["choice"]), bool(r["task_success"])))
    out: dict[str, Any] = {}
    for task in tasks:
        out[task] = {}
        for method in robot_methods():
            rows = plans.get((task, method))
            if not rows:
                print(f"{task} / {method}: no plans to fit", flush=True)
                continue
            scores, wins = zip(*rows, strict=True)
            out[task][method] = {"score": get_method(method).score, **warn_threshold(scores, wins, level),
                                 "uses": list(NEEDS[method])}
    return out


def about(scenes: dict[str, int], level: float) -> str:
    """The JSON's paragraph on how its thresholds were set."""
    from tognet.evaluate.confidence import MIN_PLANS

    per = ", ".join(f"{t} {n}" for t, n in scenes.items())
    return (
        "Set by benchmarks/calibrate_confidence.py from held-out simulated scenes: "
        f"EvalConfig(seed={EVAL_SEED}) (the README's evaluation and benchmarks/closed_loop_plan.py use seed "
        "0), a third of each task's scenes per test-object category (PG-Primitive, PG-Complex, Realistic), "
        f"scenes per task: {per}; every method a robot can run planned on each scene with the shipped models "
        "(sha256 in 'models') and its plan was executed in the simulator (trial seed 0). Per task and "
        "method, the plans' task success was fitted as a non-decreasing function of the method's own score "
        "(Plan.scores['choice'], see 'score') by isotonic regression (pool adjacent violators; tied "
        "scores and neighbouring blocks of equal rate pooled); warn_below is the lowest score from which "
        f"the fitted success rate is >= {level} over at least {MIN_PLANS} plans: a plan "
        "scoring below it warns of low confidence. null: never warn (the fit is at or above the level from "
        f"the lowest score on); 'always': the fit never reaches {level} (or only on fewer than {MIN_PLANS} "
        "plans), every plan warns. 'scenes' counts "
        "the fitted plans: scenes where the method found no grasp (no plan to warn about) and invalid "
        "trials are left out. 'below'/'above': the plans under and at or over warn_below, their number and "
        "success rate; successes_warned / failures_warned: the share of the successful and of the failed "
        "plans that would warn. The thresholds hold only for the models whose digests are listed.")


def write_json(path: Path, thresholds: dict[str, Any], models: dict[str, Path], planned: dict[str, int],
               level: float) -> None:
    from tognet.io import atomic_write_bytes, sha256_file

    table = {"about": about(planned, level), "made": datetime.now(UTC).date().isoformat(), "level": level,
             "eval_seed": EVAL_SEED, "models": {n: sha256_file(p) for n, p in models.items()},
             "thresholds": thresholds}
    atomic_write_bytes(path, (json.dumps(table, indent=2) + "\n").encode("utf-8"))


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _limit(x: Any) -> str:
    return "never (null)" if x is None else (x if isinstance(x, str) else f"{x:.5g}")


def table(task: str, entries: dict[str, Any], records: list[dict[str, Any]]) -> str:
    """The markdown table of one task's thresholds (with the score's AUC for success, the fit's blocks and
    the scenes with no plan)."""
    from tognet.evaluate.confidence import isotonic_fit, score_auc

    lines = [f"### {task}", "",
             "| method | scenes | success % | warn_below | success % below (n) | success % at/above (n) "
             "| successes warned % | failures warned % | AUC | fit blocks | no plan |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for method, e in entries.items():
        rs = [r for r in records if r["task"] == task and r["method"] == method and r["valid"]]
        fitted = [r for r in rs if "choice" in r["scores"]]
        s = [r["scores"]["choice"] for r in fitted]
        y = [r["task_success"] for r in fitted]
        auc = score_auc(s, y)
        lines.append(f"| {method} | {e['scenes']} | {_pct(e['success'])} | {_limit(e['warn_below'])} | "
                     f"{_pct(e['below']['success'])} ({e['below']['n']}) | {_pct(e['above']['success'])} "
                     f"({e['above']['n']}) | {_pct(e['successes_warned'])} | {_pct(e['failures_warned'])} | "
                     f"{'-' if auc is None else f'{auc:.2f}'} | {len(isotonic_fit(s, y))} | "
                     f"{len(rs) - len(fitted)} |")
    return "\n".join(lines)


def fit_report(records: list[dict[str, Any]], tasks: list[str]) -> str:
    """Each fit's blocks (score range, plans, success rate), to see where the rate rises."""
    from tognet.evaluate.confidence import isotonic_fit

    lines = []
    for task in tasks:
        for method in robot_methods():
            fitted = [r for r in records if r["task"] == task and r["method"] == method and r["valid"]
                      and "choice" in r["scores"]]
            if not fitted:
                continue
            fit = isotonic_fit([r["scores"]["choice"] for r in fitted], [r["task_success"] for r in fitted])
            rows = zip(fit.lower, fit.upper, fit.count, fit.rate, strict=True)
            blocks = ", ".join(f"[{lo:.4f}, {hi:.4f}] {n}: {100 * p:.0f}%" for lo, hi, n, p in rows)
            lines.append(f"- {task} / {method}: {blocks}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default="all", help="comma-separated task names, or all")
    ap.add_argument("--scenes", type=int, default=300, help="scenes per task (a third per category)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (spawned)")
    ap.add_argument("--out", type=Path, default=Path("/tmp/tognet-calibrate"), help="records and objects")
    ap.add_argument("--json", type=Path, default=None, help="where to write the thresholds "
                    "(default tognet/models/confidence.json)")
    ap.add_argument("--level", type=float, default=LEVEL,
                    help="the success rate from which plans do not warn")
    ap.add_argument("--fit-only", action="store_true", help="fit the records in --out, run no jobs")
    args = ap.parse_args()
    from tognet.cli.util import task_list
    from tognet.io import sha256_file
    from tognet.models import MODELS_DIR
    from tognet.tasks import TASK_NAMES

    tasks = task_list(args.tasks)
    json_path = args.json or MODELS_DIR / "confidence.json"
    models = model_paths(list(TASK_NAMES))
    check_settings(args.out, {"eval_seed": EVAL_SEED, "scenes": args.scenes, "methods": list(robot_methods()),
                              "models": {n: sha256_file(p) for n, p in models.items()}})
    print(f"{os.cpu_count()} cpus, load average {os.getloadavg()[0]:.2f}; {args.workers} workers", flush=True)
    t0 = time.perf_counter()
    if not args.fit_only:
        records = read_lines(args.out / RECORDS)
        done = {job_key(r["task"], r["category"], r["job"]) for r in records}
        done |= {job_key(r["task"], r["category"], r["job"]) for r in read_lines(args.out / EMPTY)}
        jobs = [j for j in plan_jobs(tasks, args.scenes, args.out, args.workers, models)
                if job_key(j.task, j.category, j.index) not in done]
        print(f"{len(jobs)} jobs to run ({len(done)} done)", flush=True)
        run_jobs(jobs, args.out, args.workers)
    records = [r for r in read_lines(args.out / RECORDS) if r["task"] in tasks]
    print(f"{len(records)} records, {time.perf_counter() - t0:.0f} s this run, load average "
          f"{os.getloadavg()[0]:.2f}", flush=True)
    thresholds = fit_entries(records, tasks, args.level)
    planned = {t: len({(r["category"], r["job"], r["scene"]) for r in records if r["task"] == t})
               for t in tasks}
    write_json(json_path, thresholds, models, planned, args.level)
    print(f"wrote {json_path}\n")
    for task in tasks:
        print(table(task, thresholds[task], records) + "\n")
    print("Isotonic fits (score range, plans: success rate):\n" + fit_report(records, tasks))


if __name__ == "__main__":
    main()
