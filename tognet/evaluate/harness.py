"""The evaluation harness: every method on the same unseen test scenes, in parallel and resumable.

    results = run_evaluation("runs/eval", ["hammering"], "all", categories=["pg-primitive"], episodes=300)

    OUT/
      evaluation.json          the settings (tasks, methods, categories, episodes, config, models + sha256)
      objects/<kind>-test/     the generated test objects (split "test": never used in training)
      <task>/<category>/       the job files (tognet.evaluate.store)
      results.json             per task, category (and sweeping's can counts), method: success rate with
                               its 95 % Wilson interval, grasp success, failure reasons; paired differences
                               to TOG-Net (and to the learned action search) with their intervals; the
                               fraction of the Oracle's rate; where the gap to the Oracle is (the
                               diagnostic rows); how the task model rates each method's grasps; each
                               method's kind; timings
      report.html, report.md   tognet.evaluate.report

Killed at any moment and run again with ``resume=True`` and the same settings, it runs exactly the jobs
that are missing. Jobs run on :mod:`tognet.jobs`' executors (local processes or Ray).
"""

from __future__ import annotations

import json
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tognet.errors import TognetError
from tognet.evaluate.config import CATEGORIES, EvalConfig
from tognet.evaluate.jobs import EvalJob, plan_eval_jobs, run_eval_job
from tognet.evaluate.kinds import (
    ACTION_SEARCH,
    BOUND,
    GAP_ROWS,
    ORACLE,
    ORACLE_GRASP,
    ORACLE_MOTION,
    REFERENCE,
    SIM_NOTE,
    compared,
    kinds_of,
    label,
)
from tognet.evaluate.stats import paired_difference, wilson
from tognet.evaluate.store import EvalStore, EvalStoreError, read_json_object
from tognet.evaluate.subsets import main_subset, subsets_of
from tognet.io import atomic_write_text, file_digest
from tognet.jobs.output import JobOutput
from tognet.jobs.workers import Executor, default_workers, make_executor
from tognet.objects.record import ObjectRecord
from tognet.planning.methods import METHODS, NEEDS, check_methods
from tognet.tasks import GRASP_ONLY

SETTINGS = "evaluation.json"
RESULTS = "results.json"


class EvalError(TognetError):
    """An evaluation cannot start or continue (an existing folder, missing models, bad objects...)."""


class SettingsChanged(EvalError):
    """``--resume`` on a folder whose evaluation was started with other settings (models, config...)."""


def search_name(task: str) -> str:
    """The models-dict name of a task's action-conditioned model (the learned action search's)."""
    return f"{task}_search"


def resolve_models(tasks: Sequence[str], methods: Sequence[str], grasp_model: str | Path | None = None,
                   task_models: dict[str, str | Path | None] | None = None) -> dict[str, Path]:
    """The checkpoint paths the methods need: ``grasping``, each task's and, for the learned action search,
    each task's ``<task>_search`` (the shipped ones unless given). A task model that is not needed but is
    given (or shipped) is kept too, for the qualitative figure."""
    from tognet.models import default_checkpoint

    task_models = task_models or {}
    needs = {n for m in methods for n in NEEDS[m]}
    wanted: dict[str, str | Path | None] = {GRASP_ONLY: grasp_model, **{t: task_models.get(t) for t in tasks}}
    wanted.update({search_name(t): task_models.get(search_name(t)) for t in tasks})
    for other, path in task_models.items():
        wanted.setdefault(other, path)
    searched = {search_name(t) for t in tasks}
    out: dict[str, Path] = {}
    for name, path in wanted.items():
        if name == GRASP_ONLY:
            required = "grasp" in needs
        elif name in searched:
            required = "search" in needs
        else:
            required = name in tasks and "task" in needs
        if path is None:
            if not required:
                continue
            path = default_checkpoint(name)
        path = Path(path)
        if not path.is_file():
            raise EvalError(f"checkpoint not found: {path}")
        out[name] = path
    return out


def check_models(models: dict[str, Path]) -> None:
    """Each checkpoint is of the task it is given for (the grasp-only one of ``grasping``; a
    ``<task>_search`` one of the task, with a task stream that sees the action)."""
    from tognet.jobs.models import load_model

    for name, path in models.items():
        model = load_model(str(path))
        task = name.removesuffix("_search")
        if model.task is not None and model.task != task:
            raise EvalError(f"{path}: a {model.task} model, given as the {name} model")
        if name != task and not model.action_conditioned:
            raise EvalError(f"{path}: given as the {name} model, but its task stream does not see the action "
                            "(train it with ArchConfig.task_head='action')")
        if name == task and task != GRASP_ONLY and model.action_conditioned:
            raise EvalError(f"{path}: an action-search model (task_head='action'), given as the {task} "
                            f"TOG-Net model; pass it as --task-model {task}_search={path} "
                            "(TOG-Net+ActionSearch)")


def test_objects(category: str, count: int, out: Path, workers: int = 1, progress: bool = True,
                 log: Callable[[str], None] = print) -> list[ObjectRecord]:
    """The first ``count`` test objects of a category (all 44 realistic ones at most), generated into
    ``out/objects/<kind>-test`` once and loaded afterwards."""
    from tognet.objects.generate import generate_set, realistic_count
    from tognet.objects.record import load_catalog

    kind = CATEGORIES[category]
    if kind == "realistic":
        count = min(count, realistic_count())
    folder = out / "objects" / f"{kind}-test"
    have = load_catalog(folder) if (folder / "catalog.json").is_file() else []
    if len(have) < count:
        log(f"generating {count - len(have)} {category} test objects into {folder}")
        generate_set(kind, "test", count - len(have), folder, start=len(have), progress=progress,
                     workers=max(1, workers))
        have = load_catalog(folder)
    return sorted(have, key=lambda r: r.object_id)[:count]


def user_objects(folder: Path) -> tuple[str, list[ObjectRecord]]:
    """(category name, records) of an object set folder; training objects are refused."""
    from tognet.objects.record import load_catalog

    records = load_catalog(folder)
    train = [r.object_id for r in records if r.split == "train"]
    if train:
        raise EvalError(f"{folder}: holds training objects ({train[0]}, ...); evaluate on unseen test "
                        "objects")
    return folder.resolve().name, records


def _by_content(settings: Any) -> Any:
    """Settings as a resume compares them: a file named with its digest is the digest (the same model at
    another path is the same model; another model at the same path is not)."""
    if isinstance(settings, dict):
        return {k: _by_content(v) for k, v in settings.items() if not (k == "path" and "sha256" in settings)}
    return [_by_content(v) for v in settings] if isinstance(settings, list) else settings


def _check_out(out: Path, settings: dict[str, Any], resume: bool) -> None:
    if out.exists() and not out.is_dir():
        raise EvalError(f"{out}: exists and is not a folder; pass another --out")
    saved = out / SETTINGS
    if saved.is_file():
        if not resume:
            raise EvalError(f"{out}: already holds an evaluation; pass --resume to continue it or another "
                            "--out")
        try:
            old = _by_content(read_json_object(saved, "the settings the evaluation was started with"))
        except EvalStoreError as exc:
            raise EvalError(f"{exc}, so it cannot be resumed; restore the file, or start again in another "
                            "--out") from None
        new = _by_content(json.loads(json.dumps(settings)))
        if old != new:
            diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
            raise SettingsChanged(f"{saved}: the evaluation was started with other settings (differs in "
                            f"{', '.join(diff)}); resume with the same ones or use another --out")
    elif resume:  # as `train --resume` and `pipeline --resume`: nothing there, nothing to resume
        what = f"is not an evaluation (no {SETTINGS})" if out.is_dir() and any(out.iterdir()) else \
            "holds no evaluation"
        raise EvalError(f"--out {out} {what}, so there is nothing to resume; drop --resume to start one")
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(saved, json.dumps(settings, indent=2) + "\n")


def run_evaluation(
    out: str | Path,
    tasks: Sequence[str],
    methods: Sequence[str] | str = "all",
    *,
    categories: Sequence[str] = (),
    object_dirs: Sequence[str | Path] = (),
    episodes: int = 100,
    test_object_count: int | None = None,
    grasp_model: str | Path | None = None,
    task_models: dict[str, str | Path | None] | None = None,
    config: EvalConfig | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
    ray: bool = False,
    ray_address: str | None = None,
    resume: bool = False,
    progress: bool = True,
    report: bool = True,
    run_dir: str | Path | None = None,
    animations: bool = True,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Evaluate ``methods`` on ``tasks`` with ``episodes`` scenes per (task, category); every method runs
    on every scene. ``categories``: of :data:`CATEGORIES` (default: all three unless ``object_dirs`` are
    given), each with a new test object per job unless ``test_object_count`` caps their number (the
    realistic set has 44); ``object_dirs``: object set folders evaluated as categories of their own.
    Writes and returns ``results.json``'s content; with ``report``, also the report (``run_dir``: a
    pipeline run whose training curves to show; by default the task model's run when it lies in one)."""
    out = Path(out)
    tasks, methods, categories = _checked_request(tasks, methods, categories, object_dirs, episodes)
    config = config or EvalConfig()
    models = resolve_models(tasks, methods, grasp_model, task_models)
    check_models(models)
    users = [user_objects(Path(d)) for d in object_dirs]
    names = categories + [name for name, _ in users]
    if len(set(names)) != len(names):
        raise EvalError(f"two object sets are called the same: {names}")
    settings = _settings(tasks, methods, names, episodes, test_object_count, object_dirs, config, models)
    _check_out(out, settings, resume)
    own = executor is None
    executor = executor or make_executor(workers, ray, ray_address)
    t_start = time.perf_counter()
    try:
        objects = _eval_objects(out, categories, users, episodes, test_object_count, config, executor,
                                progress, log)
        stores, jobs = _stores_and_jobs(out, tasks, objects, episodes, methods, config, models, settings)
        total = len(tasks) * len(objects) * episodes * len(methods)
        remaining = sum(j.planned for j in jobs)
        if remaining < total:
            log(f"{(total - remaining) // len(methods)} scenes already evaluated; running the other "
                f"{remaining // len(methods)}")
        t0 = time.perf_counter()
        done_now = _run_jobs(executor, jobs, stores, total, remaining, progress, log)
        seconds_now = time.perf_counter() - t0
        records = [r for s in stores.values() for r in s.records()]
        results = summarise(records, tasks, methods, names)
        results["settings"] = settings
        results["run"] = _run_info(stores, executor, done_now, seconds_now, t_start)
        atomic_write_text(out / RESULTS, json.dumps(results, indent=2, default=_json_default) + "\n",
                          fsync=False)
        log(format_results(results))
        if report:
            _report(out, results, records, models, run_dir, animations, config, objects, executor, log)
    finally:
        if own:
            executor.close()
    return results


def _settings(tasks: list[str], methods: Sequence[str], names: list[str], episodes: int,
              test_object_count: int | None, object_dirs: Sequence[str | Path], config: EvalConfig,
              models: dict[str, Path]) -> dict[str, Any]:
    """The evaluation's settings as ``evaluation.json`` holds them (models with their sha256)."""
    return {
        "tasks": tasks, "methods": list(methods), "categories": names, "episodes": episodes,
        "test_object_count": test_object_count,
        "object_dirs": [str(Path(d).resolve()) for d in object_dirs], "config": config.to_dict(),
        "config_hash": config.fingerprint(),
        "models": {k: {"path": str(v.resolve()), "sha256": file_digest(v)} for k, v in models.items()},
    }


def _eval_objects(out: Path, categories: list[str], users: list[tuple[str, list[ObjectRecord]]],
                  episodes: int, test_object_count: int | None, config: EvalConfig, executor: Executor,
                  progress: bool, log: Callable[[str], None]) -> dict[str, list[ObjectRecord]]:
    """The test objects per category (generated here, one per job unless capped), then the user sets."""
    n_objects = -(-episodes // config.scenes_per_job)  # one object per job ...
    if test_object_count is not None:
        n_objects = min(n_objects, test_object_count)  # ... or fewer, visited in turn
    local = min(executor.workers, default_workers())  # objects are generated on this machine
    objects = {c: test_objects(c, n_objects, out, max(1, local), progress, log) for c in categories}
    objects.update(dict(users))
    return objects


def _run_info(stores: dict[tuple[str, str], EvalStore], executor: Executor, done_now: int, seconds_now: float,
              t_start: float) -> dict[str, Any]:
    """results.json's ``run``: this run's episodes and rate, the workers, total seconds, the jobs' errors."""
    job_errors = [i["error"] for s in stores.values() for i in s.info().values() if i.get("error")]
    return {"episodes_run_now": done_now, "seconds_now": seconds_now,
            "episodes_per_s_now": done_now / seconds_now if seconds_now > 0 else None,
            "workers": executor.workers, "evaluation_seconds": time.perf_counter() - t_start,
            "job_errors": job_errors}


def _report(out: Path, results: dict[str, Any], records: list[dict[str, Any]], models: dict[str, Path],
            run_dir: str | Path | None, animations: bool, config: EvalConfig,
            objects: dict[str, list[ObjectRecord]], executor: Executor, log: Callable[[str], None]) -> None:
    """Write the report and log its path, size and the seconds it took."""
    from tognet.evaluate.report import write_report

    t_report = time.perf_counter()
    paths = write_report(out, results, records, models=models, run_dir=run_dir, animations=animations,
                         config=config, objects=objects, executor=executor, log=log)
    log(f"report: {paths[0]} ({paths[0].stat().st_size / 1e6:.1f} MB, "
        f"{time.perf_counter() - t_report:.0f} s)")


def _checked_request(
    tasks: Sequence[str], methods: Sequence[str] | str, categories: Sequence[str],
    object_dirs: Sequence[str | Path], episodes: int,
) -> tuple[list[str], list[str], list[str]]:
    """The tasks, methods and categories asked for, without repeats; EvalError names what is unknown."""
    from tognet.tasks import TASK_NAMES, check_task_name

    tasks = [check_task_name(t, error=EvalError) for t in dict.fromkeys(tasks)]
    if not tasks:
        raise EvalError(f"no task given; known: {', '.join(TASK_NAMES)}")
    checked = list(check_methods(methods))
    if episodes < 1:
        raise EvalError("episodes must be >= 1")
    categories = list(dict.fromkeys(categories or ([] if object_dirs else list(CATEGORIES))))
    unknown = [c for c in categories if c not in CATEGORIES]
    if unknown:
        raise EvalError(f"unknown category {unknown}; known: {', '.join(CATEGORIES)} (or --objects DIR)")
    return tasks, checked, categories


def _stores_and_jobs(out: Path, tasks: Sequence[str], objects: dict[str, list[ObjectRecord]], episodes: int,
                     methods: Sequence[str], config: EvalConfig, models: dict[str, Path],
                     settings: dict[str, Any]) -> tuple[dict[tuple[str, str], EvalStore], list[EvalJob]]:
    """One store per (task, category) in ``out`` and the jobs none of them holds yet (a resumed run
    skips the finished ones)."""
    stores: dict[tuple[str, str], EvalStore] = {}
    jobs: list[EvalJob] = []
    for task in tasks:
        for cat, recs in objects.items():
            grasp = str(models[GRASP_ONLY]) if GRASP_ONLY in models else None
            tmodel = str(models[task]) if task in models else None
            smodel = str(models[search_name(task)]) if search_name(task) in models else None
            planned = plan_eval_jobs(task, cat, recs, episodes, methods, config, grasp, tmodel, smodel)
            meta = {"task": task, "category": cat, "methods": list(methods), "episodes": episodes,
                    "config_hash": config.fingerprint(), "jobs": len(planned),
                    "objects": sorted({j.obj.object_id for j in planned}),
                    "models": {k: settings["models"][k]["sha256"]
                               for k in (GRASP_ONLY, task, search_name(task)) if k in settings["models"]}}
            store = stores[(task, cat)] = EvalStore(out / task / cat, meta)
            jobs += [j for j in planned if j.index not in store.done]
    return stores, jobs


def _run_jobs(executor: Executor, jobs: list[EvalJob], stores: dict[tuple[str, str], EvalStore], total: int,
              remaining: int, progress: bool, log: Callable[[str], None]) -> int:
    """Run the jobs, each result stored as it comes, with a progress bar showing TOG-Net's, the learned
    action search's and the Oracle's running rates; the episodes run now."""
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=total, initial=total - remaining, desc="evaluate", unit="ep", mininterval=1.0,
                   dynamic_ncols=True)
    done_now = 0
    tally: Counter[str] = Counter()

    def on_result(job: EvalJob, output: JobOutput) -> None:
        nonlocal done_now
        info = {k: v for k, v in output.stats.items() if not k.startswith("bad_scene:")}
        if output.error:
            info["error"] = output.error
            log(f"skipped job {job.task}/{job.category}/{job.index}: {output.error}")
        records = list(output.columns.get("records", []))  # type: ignore[arg-type]
        stores[(job.task, job.category)].add(job.index, records, info)
        done_now += job.planned
        for r in records:
            if r["valid"]:
                tally[r["method"]] += 1
                tally[r["method"] + " ok"] += int(r["task_success"])
        if bar is not None:
            bar.update(job.planned)
            shown = [m for m in (REFERENCE, ACTION_SEARCH, ORACLE) if tally[m]]
            bar.set_postfix_str(", ".join(f"{m} {tally[m + ' ok'] / tally[m]:.0%}" for m in shown),
                                refresh=False)

    try:
        executor.run(jobs, on_result, log, fn=run_eval_job)
    finally:
        if bar is not None:
            bar.close()
    return done_now


def _json_default(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


# --- statistics of the records ------------------------------------------------------------------------
def rate_stats(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Episodes, valid trials, task and grasp successes with rates and 95 % Wilson intervals, failure
    reasons (valid failed trials), mean planning and execution seconds, and for a search in the simulator
    (the Oracle, Oracle+) its mean trials per scene."""
    valid = [r for r in records if r["valid"]]
    n = len(valid)
    k = sum(bool(r["task_success"]) for r in valid)
    g = sum(bool(r["grasp_success"]) for r in valid)
    failures = Counter(r["failure"] for r in valid if not r["task_success"])
    plan = [r["timing"]["total"] for r in records if r.get("timing")]
    execute = [r["execute_seconds"] for r in records if r.get("execute_seconds") is not None]
    searched = [r["search_trials"] for r in records if r.get("search_trials") is not None]
    return {
        "episodes": len(records), "valid": n, "invalid": len(records) - n,
        "successes": k, "rate": k / n if n else None, "ci": list(wilson(k, n)) if n else None,
        "grasp_successes": g, "grasp_rate": g / n if n else None,
        "grasp_ci": list(wilson(g, n)) if n else None,
        "failures": dict(failures.most_common()),
        "plan_seconds": float(np.mean(plan)) if plan else None,
        "execute_seconds": float(np.mean(execute)) if execute else None,
        "search_trials": float(np.mean(searched)) if searched else None,
    }


def _outcomes(records: Iterable[dict[str, Any]]) -> dict[tuple[str, int], bool]:
    return {(r["object_id"], int(r["scene_seed"])): bool(r["task_success"]) for r in records if r["valid"]}


def paired(first: Sequence[dict[str, Any]], second: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The first method's rate minus the second's over the scenes where both trials are valid
    (:func:`paired_difference`: the difference, its 95 % interval and the 2x2 table)."""
    a, b = _outcomes(first), _outcomes(second)
    keys = sorted(set(a) & set(b))
    return paired_difference([a[k] for k in keys], [b[k] for k in keys])


def beyond_bound(per_method: dict[str, list[dict[str, Any]]], bound: str) -> dict[str, dict[str, int]]:
    """Per method, the scenes it solves that the ``bound`` row does not (``scenes``) out of the scenes
    where both trials are valid (``pairs``): a bound worth its name has 0 for every method. Empty without
    the bound's row."""
    if bound not in per_method:
        return {}
    out = {}
    for m, recs in per_method.items():
        if m != bound:
            pair = paired(recs, per_method[bound])
            out[m] = {"scenes": pair["first_only"], "pairs": pair["pairs"]}
    return out


def scene_bound(per_method: dict[str, list[dict[str, Any]]], bound: str) -> dict[str, Any]:
    """The bound no row can beat: a scene counts as solved where any row's trial of it succeeded (the
    ``bound`` row's, every method's, the diagnostics'), over the scenes where at least one row's trial is
    valid. A plan that works was tried there in the simulator, so no row solves a scene it does not (issue
    34); it rises with every row evaluated beside it. ``successes``, ``valid``, ``rate``, ``ci`` (Wilson);
    ``added``: the scenes it solves that the ``bound`` row alone does not; ``fraction``: each row's share
    of it, paired: the scenes the row solves over those the bound solves among the row's valid trials
    (the ratio of the rates when every trial is valid; never above 1)."""
    outcomes = {m: _outcomes(recs) for m, recs in per_method.items()}
    solved: dict[tuple[str, int], bool] = {}
    for rows in outcomes.values():
        for key, ok in rows.items():
            solved[key] = solved.get(key, False) or ok
    alone = outcomes.get(bound, {})
    n, k = len(solved), sum(solved.values())
    fraction = {}
    for m, rows in outcomes.items():
        top = sum(solved[key] for key in rows)
        fraction[m] = sum(rows.values()) / top if top else None
    return {"successes": k, "valid": n, "rate": k / n if n else None, "ci": list(wilson(k, n)) if n else None,
            "added": sum(ok and not alone.get(key, False) for key, ok in solved.items()),
            "fraction": fraction}


def _q_t(record: dict[str, Any]) -> float | None:
    q = (record.get("scores") or {}).get("q_t")
    return None if q is None else float(q)


def _rating(values: Sequence[float]) -> dict[str, Any]:
    return {"mean_q_t": float(np.mean(values)) if values else None,
            "median_q_t": float(np.median(values)) if values else None, "n": len(values)}


def model_rating(per_method: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """How the task's TOG-Net model rates each method's chosen grasps: mean and median of the records'
    ``scores.q_t`` (Q_T at the grasp) and their number; methods whose records carry none are left out."""
    out = {}
    for m, recs in per_method.items():
        values = [q for r in recs if (q := _q_t(r)) is not None]
        if values:
            out[m] = _rating(values)
    return out


def _oracle_grasp_ratings(per_method: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """The task model's rating of the Oracle's grasps, all of them and those that worked: from the Oracle's
    own records when they carry ``q_t``, else from "Oracle grasp + TOG-Net motion" (whose grasp is the
    Oracle's on the same scene; a record whose grasp differs from the Oracle's is left out)."""
    oracle = {(r["object_id"], int(r["scene_seed"])): r for r in per_method.get(ORACLE, [])}
    for source in (ORACLE, ORACLE_GRASP):
        recs = [r for r in per_method.get(source, []) if _q_t(r) is not None]
        if source != ORACLE:
            recs = [r for r in recs if (o := oracle.get((r["object_id"], int(r["scene_seed"])))) is None
                    or (o.get("grasp") is not None and r.get("grasp") is not None
                        and np.allclose(o["grasp"], r["grasp"]))]
        if not recs:
            continue
        worked = [r for r in recs if (o := oracle.get((r["object_id"], int(r["scene_seed"])))) is not None
                  and o["valid"] and o["task_success"]]
        return {"source": source, "all": _rating([q for r in recs if (q := _q_t(r)) is not None]),
                "worked": _rating([q for r in worked if (q := _q_t(r)) is not None])}
    return {}


def gap_decomposition(per_method: dict[str, list[dict[str, Any]]], stats: dict[str, dict[str, Any]]
                      ) -> dict[str, Any] | None:
    """Where the gap between TOG-Net and the Oracle is, from the diagnostic rows (None unless TOG-Net, the
    Oracle and at least one diagnostic were evaluated).

    ``rates``: the four rows' rates with their Wilson intervals; ``gap``: the Oracle's rate minus
    TOG-Net's; ``perfect_motion``: (TOG-Net grasp + Oracle motion) - TOG-Net, what a perfect motion gains
    from TOG-Net's grasps (the grasp fixed); ``perfect_grasp``: (Oracle grasp + TOG-Net motion) - TOG-Net,
    what a perfect grasp gains with TOG-Net's motion (the motion fixed); each with ``share_of_gap`` (the
    gain over the gap, when the gap is positive) and ``paired`` (the paired difference over the scenes
    where both trials are valid, with its 95 % interval); ``needs_both``: the part of the gap neither half
    closes alone (negative when the halves close overlapping parts); ``model_rating``: how the task model
    rates TOG-Net's grasps and the Oracle's (all, and those that worked)."""
    if not {REFERENCE, ORACLE} <= set(per_method) or not {ORACLE_MOTION, ORACLE_GRASP} & set(per_method):
        return None
    rates = {m: {k: stats[m][k] for k in ("rate", "ci", "valid")} for m in GAP_ROWS if m in per_method}
    ref, top = stats[REFERENCE]["rate"], stats[ORACLE]["rate"]
    gap = None if ref is None or top is None else top - ref
    out: dict[str, Any] = {"rates": rates, "gap": gap,
                           "gap_paired": paired(per_method[ORACLE], per_method[REFERENCE])}
    for key, m in (("perfect_motion", ORACLE_MOTION), ("perfect_grasp", ORACLE_GRASP)):
        if m not in per_method:
            continue
        rate = stats[m]["rate"]
        gain = None if ref is None or rate is None else rate - ref
        out[key] = {"method": m, "gain": gain,
                    "share_of_gap": gain / gap if gain is not None and gap is not None and gap > 0 else None,
                    "paired": paired(per_method[m], per_method[REFERENCE])}
    gains = [out[k]["gain"] for k in ("perfect_motion", "perfect_grasp") if k in out]
    out["needs_both"] = gap - sum(gains) if len(gains) == 2 and gap is not None and None not in gains \
        else None
    own = [q for r in per_method[REFERENCE] if (q := _q_t(r)) is not None]
    out["model_rating"] = {"tognet": _rating(own), "oracle_grasps": _oracle_grasp_ratings(per_method)}
    return out


def summarise(records: Sequence[dict[str, Any]], tasks: Sequence[str], methods: Sequence[str],
              categories: Sequence[str]) -> dict[str, Any]:
    """results.json's numbers from the records: ``kinds`` (each method's kind: baseline, ours, oracle or
    diagnostic) and per task, category (and ``all`` when there are several), subset (the task's
    :attr:`~tognet.tasks.Task.subsets`; sweeping: mix, one-can, two-can) and method: :func:`rate_stats`;
    ``tognet_minus_method``: the paired difference of TOG-Net's rate and each other method's (diagnostics
    included) over the scenes where both trials are valid, with its 95 % interval (Newcombe);
    ``action_search_minus_method``: the same for the learned action search against every other method that
    is not a diagnostic (empty when it was not evaluated); ``oracle_fraction``: the method's rate over the
    Oracle's; ``beyond_oracle``: :func:`beyond_bound` against the Oracle; with Oracle+ evaluated,
    ``bound_fraction`` and ``beyond_bound``, the same against it (the stronger bound); with either,
    ``scene_bound``: :func:`scene_bound` (the bound for every share, over Oracle+'s row); ``gap``:
    :func:`gap_decomposition` (absent without the rows it needs); ``model_rating``: :func:`model_rating`."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        groups[(r["task"], r["category"], r["method"])].append(r)
    cats = list(categories) + (["all"] if len(categories) > 1 else [])
    main = compared(methods)
    out: dict[str, Any] = {"methods": list(methods), "kinds": kinds_of(methods), "categories": cats,
                           "reference": REFERENCE, "tasks": {}}
    for task in tasks:
        tcats: dict[str, Any] = {}
        for cat in cats:
            members = list(categories) if cat == "all" else [cat]
            subsets: dict[str, Any] = {}
            for subset in subsets_of(task):
                sub = subset.name
                per_method = {m: [r for c in members for r in groups[(task, c, m)] if subset.holds(r)]
                              for m in methods}
                stats = {m: rate_stats(v) for m, v in per_method.items()}
                diffs = {m: paired(per_method[REFERENCE], per_method[m]) for m in methods
                         if REFERENCE in methods and m != REFERENCE}
                search = {m: paired(per_method[ACTION_SEARCH], per_method[m]) for m in main
                          if ACTION_SEARCH in methods and m != ACTION_SEARCH}
                subsets[sub] = {"methods": stats, "tognet_minus_method": diffs,
                                "action_search_minus_method": search,
                                "oracle_fraction": _fractions(stats, ORACLE),
                                "beyond_oracle": beyond_bound(per_method, ORACLE),
                                "model_rating": model_rating(per_method)}
                if BOUND in methods:
                    subsets[sub].update(bound_fraction=_fractions(stats, BOUND),
                                        beyond_bound=beyond_bound(per_method, BOUND))
                if {BOUND, ORACLE} & set(methods):
                    subsets[sub]["scene_bound"] = scene_bound(per_method, BOUND if BOUND in methods
                                                              else ORACLE)
                gap = gap_decomposition(per_method, stats)
                if gap is not None:
                    subsets[sub]["gap"] = gap
            tcats[cat] = subsets
        timing = {m: _timing([r for c in categories for r in groups[(task, c, m)]]) for m in methods}
        out["tasks"][task] = {"categories": tcats, "timing": timing}
    return out


def _fractions(stats: dict[str, dict[str, Any]], bound: str) -> dict[str, float | None]:
    """Each method's rate over the ``bound`` row's (None without it or where a rate is missing)."""
    top = stats.get(bound, {}).get("rate")
    return {m: (s["rate"] / top if top and s["rate"] is not None else None) for m, s in stats.items()}


def _timing(records: Sequence[dict[str, Any]]) -> dict[str, float]:
    stages: dict[str, list[float]] = defaultdict(list)
    for r in records:
        for k, v in (r.get("timing") or {}).items():
            stages[k].append(v)
        if r.get("execute_seconds") is not None:
            stages["execute"].append(r["execute_seconds"])
        if r.get("search_trials") is not None:
            stages["search_trials"].append(r["search_trials"])
    return {k: float(np.mean(v)) for k, v in stages.items()}


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.1f}"


def format_results(results: dict[str, Any]) -> str:
    """A plain-text summary: per task and category, each method's task success (95 % interval)."""
    lines = []
    for task, tres in results["tasks"].items():
        sub = main_subset(task)
        lines.append(f"{task} ({sub}): task success % [95 % interval] (valid trials)")
        cats = list(tres["categories"])
        rows = [["method", *cats]]
        for m in results["methods"]:
            row = [label(m, results.get("kinds"))]
            for c in cats:
                s = tres["categories"][c][sub]["methods"][m]
                ci = s["ci"] or [None, None]
                row.append(f"{_pct(s['rate'])} [{_pct(ci[0])}, {_pct(ci[1])}] ({s['valid']})")
            rows.append(row)
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        for row in rows:
            cells = [row[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(row[1:], widths[1:], strict=True)]
            lines.append("  " + "  ".join(cells))
    if any(label(m, results.get("kinds")) != m for m in results["methods"]):
        lines.append(SIM_NOTE)
    return "\n".join(lines)


__all__ = ["METHODS", "REFERENCE", "EvalError", "format_results", "gap_decomposition", "model_rating",
           "paired", "rate_stats", "run_evaluation", "summarise"]
