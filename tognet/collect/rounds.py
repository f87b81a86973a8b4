"""One collection round: plan its jobs, skip those already written, run the rest, summarise.

    summary = collect_round(task, 1, objects, RoundConfig(episodes=5000), CollectConfig(), "run/round1/data",
                            executor=LocalExecutor(2))

Killed at any moment and called again with the same arguments, it runs exactly the jobs that are
missing (see :mod:`tognet.collect.store`), so the round ends with the records an uninterrupted run writes.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tognet.collect.config import CollectConfig, RoundConfig
from tognet.collect.jobs import Job, plan_jobs, run_job
from tognet.collect.store import RoundStore
from tognet.data.episodes import read_columns, shard_paths
from tognet.data.format import ACTION_SOURCES, FAILURE_CODES, GRASP_SOURCES
from tognet.errors import TognetError
from tognet.io import atomic_write_text, file_digest
from tognet.jobs.output import JobOutput
from tognet.jobs.workers import Executor, LocalExecutor
from tognet.objects.record import ObjectRecord

SUMMARY = "summary.json"


#: A round whose first this-many jobs all fail stops (the settings are wrong, not the objects).
FAILURES_BEFORE_ABORT = 8

def collect_round(
    task: str,
    round_index: int,
    objects: list[ObjectRecord],
    round_config: RoundConfig,
    config: CollectConfig,
    out: str | Path,
    *,
    grasp_model: str | Path | None = None,
    task_model: str | Path | None = None,
    executor: Executor | None = None,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Collect one round into ``out`` (a dataset folder); returns its summary (also ``out/summary.json``)."""
    out = Path(out)
    config = round_config.collect_config(config)
    grasp_model = str(grasp_model) if grasp_model else None
    task_model = str(task_model) if task_model else None
    jobs = plan_jobs(task, round_index, objects, round_config.episodes, round_config.policy, config,
                     grasp_model, task_model)
    meta = {
        "round": round_index, "policy": round_config.policy, "config_hash": config.fingerprint(),
        "jobs": len(jobs), "objects": len(objects),
        "grasp_model_sha": file_digest(grasp_model), "task_model_sha": file_digest(task_model),
    }
    configs = {"collect": config, "crop": config.crop, "round": round_config}
    store = RoundStore(out, task, meta, configs)
    todo = [j for j in jobs if j.index not in store.done]
    if len(todo) < len(jobs):
        log(f"{task} round {round_index}: {len(jobs) - len(todo)} of {len(jobs)} jobs already written, "
            f"running the other {len(todo)}")
    own = executor is None
    executor = executor or LocalExecutor()
    bar = None
    if progress:
        from tqdm import tqdm

        written = sum(j.planned for j in jobs if j.index in store.done)
        bar = tqdm(total=sum(j.planned for j in jobs), initial=written,
                   desc=f"{task} r{round_index}", unit="ep", mininterval=1.0, dynamic_ncols=True)
    results = _Results(f"{task} round {round_index}", store, bar, min(FAILURES_BEFORE_ABORT, len(todo)), log)
    try:
        executor.run(todo, results, log, fn=run_job)
    except RoundError:
        store.discard_if_unused()  # stopped before its first job: a fresh --out is left as it was
        raise
    finally:
        if bar is not None:
            bar.close()
        store.flush(force=True)
        if own:
            executor.close()
    seconds = time.perf_counter() - results.t0
    summary = summarise_round(out)
    summary.update(task=task, round=round_index, policy=round_config.policy, jobs=len(jobs),
                   jobs_run_now=len(todo), seconds_now=seconds,
                   episodes_per_s_now=results.tally.episodes / seconds if seconds > 0 else None,
                   workers=executor.workers, errors=results.errors)
    atomic_write_text(out / SUMMARY, json.dumps(summary, indent=2) + "\n", fsync=False)
    log(format_round_table(summary))
    return summary


class _Results:
    """What a round does with each job's output: store it, tally it on the progress bar, and report a
    failed job as skipped. Failed jobs are held back until some job of this run succeeds: when the first
    few all fail, the cause is the round's settings (a model that does not load, ...), not bad objects, so
    the round stops and those jobs stay unwritten (a resume after the fix runs them)."""

    def __init__(self, name: str, store: RoundStore, bar: Any, give_up: int,
                 log: Callable[[str], None]) -> None:
        self.name, self.store, self.bar, self.give_up, self.log = name, store, bar, give_up, log
        self.tally = _Tally()
        self.errors: list[str] = []
        self.held: list[tuple[int, dict[str, Any]]] = []
        self.succeeded = False
        self.t0 = time.perf_counter()

    def __call__(self, job: Job, output: JobOutput) -> None:
        info = {k: v for k, v in output.stats.items() if not k.startswith("bad_scene:")}
        if output.error:
            self.errors.append(output.error)
            info["error"] = output.error
            if not self.succeeded:
                self.held.append((job.index, info))
                if len(self.held) >= self.give_up:
                    raise RoundError(f"{self.name}: the first {len(self.held)} jobs all failed, so the round "
                                     f"stopped (nothing written for them): {output.error}")
                return
            self.log(f"skipped job {job.index}: {output.error}")
        elif not self.succeeded:
            self.succeeded = True
            for index, held_info in self.held:
                self.log(f"skipped job {index}: {held_info['error']}")
                self.store.add(index, {}, held_info)
            self.held.clear()
        self.store.add(job.index, output.columns, info)
        self.tally.add(output.columns)
        if self.bar is not None:
            self.bar.update(job.planned)
            self.bar.set_postfix_str(self.tally.postfix(time.perf_counter() - self.t0), refresh=False)


class RoundError(TognetError):
    """A round cannot go on (every job so far failed for the same kind of reason)."""


class _Tally:
    """Running counts for the progress bar (this run's jobs only)."""

    def __init__(self) -> None:
        self.episodes = 0
        self.valid = 0
        self.s_g = 0
        self.s_t = 0

    def add(self, columns: dict[str, np.ndarray]) -> None:
        if not columns:
            return
        ok = columns["valid"].astype(bool)
        self.episodes += int(ok.size)
        self.valid += int(ok.sum())
        self.s_g += int((columns["grasp_success"].astype(bool) & ok).sum())
        self.s_t += int((columns["task_success"].astype(bool) & ok).sum())

    def postfix(self, seconds: float) -> str:
        rate = self.episodes / seconds if seconds > 0 else 0.0
        v = max(self.valid, 1)
        return f"{rate:.1f} ep/s, S_G {self.s_g / v:.1%}, S_T {self.s_t / v:.1%} ({self.s_t})"


def summarise_round(folder: str | Path) -> dict[str, Any]:
    """Counts of a round's dataset folder: episodes, labels, failure reasons, and S_T by grasp and action
    source (greedy versus exploring trials), from the shards' small columns only."""
    names = {v: k for k, v in FAILURE_CODES.items()}
    gsrc = {v: k for k, v in GRASP_SOURCES.items()}
    asrc = {v: k for k, v in ACTION_SOURCES.items()}
    fields = ("valid", "grasp_success", "task_success", "failure", "grasp_source", "action_source",
              "object_id")
    cols: dict[str, list[np.ndarray]] = {f: [] for f in fields}
    for path in shard_paths(folder):
        part, _ = read_columns(path, fields)
        for f in fields:
            cols[f].append(part[f])
    c = {f: np.concatenate(v) if v else np.zeros(0) for f, v in cols.items()}
    ok = c["valid"].astype(bool) if len(c["valid"]) else np.zeros(0, bool)
    s_g = c["grasp_success"].astype(bool) & ok if ok.size else ok
    s_t = c["task_success"].astype(bool) & ok if ok.size else ok
    n = int(ok.sum())
    by_source: dict[str, Any] = {}
    if ok.size:
        for g in np.unique(c["grasp_source"]):
            for a in np.unique(c["action_source"]):
                m = ok & (c["grasp_source"] == g) & (c["action_source"] == a)
                if m.any():
                    by_source[f"{gsrc.get(int(g), g)}+{asrc.get(int(a), a)}"] = {
                        "episodes": int(m.sum()), "task_success": int(s_t[m].sum()),
                        "task_success_rate": float(s_t[m].mean()), "grasp_success_rate": float(s_g[m].mean())}
    failures = Counter(names.get(int(f), str(f)) for f in c["failure"][ok]) if ok.size else Counter()
    return {
        "episodes": int(ok.size), "valid": n,
        "objects": int(len(np.unique(c["object_id"]))) if ok.size else 0,
        "grasp_success": int(s_g.sum()), "task_success": int(s_t.sum()),
        "grasp_success_rate": float(s_g.sum() / n) if n else None,
        "task_success_rate": float(s_t.sum() / n) if n else None,
        "task_given_grasp_rate": float(s_t.sum() / s_g.sum()) if s_g.sum() else None,
        "failures": dict(failures.most_common()), "by_source": by_source,
    }


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.1f} %"


def format_round_table(summary: dict[str, Any]) -> str:
    """A plain-text table of one round's summary."""
    lines = [
        f"{summary['task']} round {summary['round']} ({summary['policy']}): {summary['episodes']} episodes "
        f"({summary['valid']} valid) on {summary['objects']} objects",
        f"  S_G {_pct(summary['grasp_success_rate'])}   S_T {_pct(summary['task_success_rate'])} "
        f"({summary['task_success']} positives)   S_T|S_G {_pct(summary['task_given_grasp_rate'])}",
    ]
    if summary.get("episodes_per_s_now"):
        lines.append(f"  this run: {summary['jobs_run_now']} jobs in {summary['seconds_now']:.0f} s "
                     f"({summary['episodes_per_s_now']:.1f} episodes/s, {summary['workers']} workers)")
    if summary["by_source"]:
        parts = [f"{k} {v['episodes']} ep S_T {_pct(v['task_success_rate'])}"
                 for k, v in summary["by_source"].items()]
        lines.append("  by source (grasp+action): " + ", ".join(parts))
    if summary["failures"]:
        lines.append("  outcomes: " + ", ".join(f"{k} {v}" for k, v in summary["failures"].items()))
    if summary.get("errors"):
        lines.append(f"  {len(summary['errors'])} job(s) skipped (bad objects): {summary['errors'][:3]}")
    return "\n".join(lines)
