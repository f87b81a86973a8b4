"""The self-supervision loop end to end: objects, the grasp-only round, then per task the rounds of
collection, each followed by training on all data so far (warm-started from the last model).

    OUT/
      preset.json                      the PipelineConfig of the run (a resume must use the same)
      objects/primitive-train/ ...     the generated training objects
      grasping/round0/data, model/     the grasp-only round and the task-agnostic Q_G model
      <task>/round<k>/data, model/     each round's episodes and the model trained after it
      summary.json, summary.md         per task and round: episodes, S_G, S_T, positives, held-out metrics

Every stage leaves a marker when it is complete (a round's ``summary.json``, a model's ``done.json``); a
run started again with ``resume=True`` skips what is complete and resumes what is not (collection at the
first missing job, training from its ``last.pt``).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from tognet.collect.config import MODEL_POLICIES, PipelineConfig, RoundConfig
from tognet.collect.rounds import SUMMARY, collect_round
from tognet.errors import TognetError
from tognet.io import atomic_copy, atomic_write_text
from tognet.jobs.workers import Executor, make_executor
from tognet.objects.record import ObjectRecord
from tognet.tasks import GRASP_ONLY

DONE = "done.json"


class PipelineError(TognetError):
    """The pipeline cannot start or continue (a run folder of another preset, nothing to resume...)."""


def _check_out(out: Path, preset: PipelineConfig, resume: bool) -> None:
    saved = out / "preset.json"
    if out.exists() and not out.is_dir():
        raise PipelineError(f"{out}: exists and is not a folder; pass another --out")
    if saved.is_file():
        if not resume:
            raise PipelineError(f"{out}: already holds a pipeline run; pass --resume to continue it or "
                                "another --out")
        old = PipelineConfig.load(saved)
        if old != preset:
            a, b = old.to_dict(), preset.to_dict()
            diff = sorted(k for k in a if a[k] != b.get(k))
            raise PipelineError(f"{saved}: the run was started with another preset (differs in {diff}); "
                                "resume with the same preset or use another --out")
    elif resume:  # as `train --resume` and `evaluate --resume`: nothing there, nothing to resume
        what = "is not a pipeline run (no preset.json)" if out.is_dir() and any(out.iterdir()) else \
            "holds no pipeline run"
        raise PipelineError(f"--out {out} {what}, so there is nothing to resume; drop --resume to start "
                            "a run")
    out.mkdir(parents=True, exist_ok=True)
    preset.save(saved)


def make_objects(preset: PipelineConfig, out: Path, workers: int, log: Callable[[str], None],
                 progress: bool) -> list[ObjectRecord]:
    """The run's training objects (generated once; a resumed run loads them)."""
    from tognet.objects.generate import generate_set
    from tognet.objects.record import load_catalog

    records: list[ObjectRecord] = []
    for kind, count in preset.objects.items():
        if count <= 0:
            continue
        folder = out / "objects" / f"{kind}-train"
        have = load_catalog(folder) if (folder / "catalog.json").is_file() else []
        if len(have) < count:
            log(f"generating {count - len(have)} {kind} training objects into {folder}")
            generate_set(kind, "train", count - len(have), folder, start=len(have), progress=progress,
                         workers=max(1, preset.object_workers or workers), config=preset.generator)
            have = load_catalog(folder)
        records.extend(sorted(have, key=lambda r: r.object_id)[:count])
    if not records:
        raise PipelineError("the preset asks for no objects")
    return records


def train_round(data_dirs: Sequence[Path], task: str, out: Path, preset: PipelineConfig, epochs: int,
                init_from: Path | None, log: Callable[[str], None], progress: bool) -> dict[str, Any]:
    """Train (or resume training) one round's model; returns its done-marker content."""
    from tognet.model.train import train

    marker = out / DONE
    if marker.is_file():
        return json.loads(marker.read_text())
    config = preset.train_for(task).replace(epochs=epochs)
    resume = (out / "last.pt").is_file()
    t0 = time.perf_counter()
    result = train(list(data_dirs), task, out, config, resume=resume, progress=progress, log=log,
                   init_from=init_from)
    best_val = result.best.get("val") or {}
    done = {"best": str(result.best_path), "epochs_run": result.epochs_run,
            "best_epoch": result.best.get("epoch"), "seconds": time.perf_counter() - t0,
            "init_from": str(init_from) if init_from else None,
            "val": {k: best_val.get(k) for k in ("count", "loss", "grasp", "task", "action", "metrics")}}
    atomic_write_text(marker, json.dumps(done, indent=2, default=str) + "\n")
    return done


def run_pipeline(
    preset: PipelineConfig,
    tasks: Sequence[str],
    out: str | Path,
    *,
    workers: int | None = None,
    ray: bool = False,
    ray_address: str | None = None,
    resume: bool = False,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Run (or resume) the whole loop for ``tasks``; returns the summary (also OUT/summary.json)."""
    from tognet.tasks import TASK_NAMES, check_task_name

    for task in tasks:
        check_task_name(task, error=PipelineError)
    if not tasks:
        raise PipelineError(f"no task given; known: {', '.join(TASK_NAMES)}")
    if not all(preset.rounds_for(t) for t in tasks):
        raise PipelineError("the preset has no rounds")
    out = Path(out)
    _check_out(out, preset, resume)
    executor: Executor = make_executor(workers, ray, ray_address)
    summary: dict[str, Any] = {"preset": preset.name, "tasks": {}, GRASP_ONLY: None}
    try:
        objects = make_objects(preset, out, executor.workers, log, progress)
        # The grasp-only round and the task-agnostic model.
        g_dir = out / GRASP_ONLY
        g_round = _collect(GRASP_ONLY, 0, objects, preset.grasp_round, preset, g_dir / "round0" / "data",
                           None, None, executor, log, progress)
        g_model = train_round([g_dir / "round0" / "data"], GRASP_ONLY, g_dir / "model", preset,
                              preset.grasp_round.epochs, None, log, progress)
        summary[GRASP_ONLY] = {"round": g_round, "model": g_model}
        grasp_model = Path(g_model["best"])
        for task in tasks:
            rows = []
            last: Path | None = None
            data: list[Path] = []
            for k, rc in enumerate(preset.rounds_for(task), start=1):
                rdir = out / task / f"round{k}"
                policy_model = last if rc.policy in MODEL_POLICIES else None
                if rc.policy in MODEL_POLICIES and policy_model is None:
                    raise PipelineError(f"round {k} is {rc.policy} but no model was trained before it")
                r = _collect(task, k, objects, rc, preset, rdir / "data", grasp_model, policy_model, executor,
                             log, progress)
                data.append(rdir / "data")
                m = train_round(data, task, rdir / "model", preset, rc.epochs, last, log, progress)
                last = Path(m["best"])
                rows.append({"round": k, "collection": r, "model": m})
                summary["tasks"][task] = rows
                _write_summary(out, summary)
            log(format_pipeline_table(task, rows))
    finally:
        executor.close()
    _write_summary(out, summary)
    return summary


def _collect(task: str, k: int, objects: list[ObjectRecord], rc: RoundConfig, preset: PipelineConfig,
             folder: Path, grasp_model: Path | None, task_model: Path | None, executor: Executor,
             log: Callable[[str], None], progress: bool) -> dict[str, Any]:
    done = folder / SUMMARY
    if done.is_file():
        return json.loads(done.read_text())
    return collect_round(task, k, objects, rc, preset.collect, folder, grasp_model=grasp_model,
                         task_model=task_model, executor=executor, progress=progress, log=log)


def _metric(model: dict[str, Any], head: str, key: str = "auc") -> Any:
    metrics = (model.get("val") or {}).get("metrics") or {}
    return (metrics.get(head) or {}).get(key)


def _fmt(x: Any, pct: bool = False) -> str:
    if x is None:
        return "n/a"
    return f"{100 * x:.1f} %" if pct else f"{x:.3f}"


def format_pipeline_table(task: str, rows: list[dict[str, Any]]) -> str:
    """Markdown table: per round, the collection's labels and the trained model's held-out metrics."""
    head = ("| round | policy | episodes | S_G | S_T | positives | Q_G AUC | Q_T\\|G AUC | Q_T AUC | "
            "action MAE (x, y, z m; phi rad) |")
    lines = [f"### {task}", "", head, "| --- " * 10 + "|"]
    for row in rows:
        c, m = row["collection"], row["model"]
        mae = _metric(m, "action", "mae")
        lines.append(
            f"| {row['round']} | {c['policy']} | {c['valid']} | {_fmt(c['grasp_success_rate'], True)} | "
            f"{_fmt(c['task_success_rate'], True)} | {c['task_success']} | {_fmt(_metric(m, 'grasp'))} | "
            f"{_fmt(_metric(m, 'task_given_grasp'))} | {_fmt(_metric(m, 'task'))} | "
            f"{', '.join(f'{v:.3f}' for v in mae) if isinstance(mae, list) else 'n/a'} |")
    return "\n".join(lines)


def _write_summary(out: Path, summary: dict[str, Any]) -> None:
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, default=str) + "\n")
    parts = [f"# tognet pipeline, preset {summary['preset']}", ""]
    g = summary.get(GRASP_ONLY)
    if g:
        r, m = g["round"], g["model"]
        parts += ["### grasp-only round (task-agnostic Q_G model)", "",
                  f"{r['valid']} episodes, S_G {_fmt(r['grasp_success_rate'], True)}; held-out Q_G AUC "
                  f"{_fmt(_metric(m, 'grasp'))}", ""]
    for task, rows in summary["tasks"].items():
        parts += [format_pipeline_table(task, rows), ""]
    atomic_write_text(out / "summary.md", "\n".join(parts))


def export_models(run: str | Path, out: str | Path, command: str | None = None) -> list[Path]:
    """Copy a finished run's final models to ``out`` as ``grasping.pt`` and ``<task>.pt`` (the last
    round's best), each with ``<name>.json``: the preset, every round's collection summary, the trained
    model's held-out metrics and its per-epoch training history (for curves), and the command."""
    run, out = Path(run), Path(out)
    if not run.is_dir():
        raise PipelineError(f"{run}: {'is a file, not a' if run.exists() else 'no such'} pipeline run folder")
    summary_path = run / "summary.json"
    if not summary_path.is_file():
        raise PipelineError(f"{run}: no summary.json, so not a finished pipeline run")

    def read(path: Path) -> Any:
        if not path.is_file():
            raise PipelineError(f"{path}: missing, so {run} is not a finished pipeline run")
        try:
            return json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise PipelineError(f"{path}: not valid JSON ({exc})") from None

    summary = read(summary_path)
    preset = read(run / "preset.json")
    written = []

    def history(model_dir: Path) -> list[dict[str, Any]]:
        metrics = read(model_dir / "metrics.json")
        keep = ("epoch", "train", "val", "seconds")
        rows = []
        for h in metrics.get("history", []):
            row = {k: h.get(k) for k in keep}
            row["train"] = {k: v for k, v in (row["train"] or {}).items() if k != "metrics"}
            rows.append(row)
        return rows

    entries: dict[str, tuple[Path, dict[str, Any]]] = {}
    g = summary.get(GRASP_ONLY)
    if g:
        mdir = run / GRASP_ONLY / "model"
        row0 = {"round": 0, "collection": g["round"], "model": g["model"], "history": history(mdir)}
        entries[GRASP_ONLY] = (mdir / "best.pt", {"rounds": [row0]})
    for task, rows in summary.get("tasks", {}).items():
        final = run / task / f"round{rows[-1]['round']}" / "model" / "best.pt"
        rounds = [{**row, "history": history(run / task / f"round{row['round']}" / "model")} for row in rows]
        entries[task] = (final, {"rounds": rounds})
    if not entries:
        raise PipelineError(f"{summary_path}: lists no models, so there is nothing to export")
    for name, (src, _info) in entries.items():  # everything checked before anything is written
        if not src.is_file():
            raise PipelineError(f"{src}: missing; the run did not finish {name}")
    out.mkdir(parents=True, exist_ok=True)
    for name, (src, info) in entries.items():
        dst = out / f"{name}.pt"
        atomic_copy(src, dst)
        doc = {"name": name, "preset": preset, "command": command, "source_run": str(run),
               "checkpoint_sha256": hashlib.sha256(dst.read_bytes()).hexdigest(), **info}
        atomic_write_text(out / f"{name}.json", json.dumps(doc, indent=2, default=str) + "\n")
        written.append(dst)
    return written

