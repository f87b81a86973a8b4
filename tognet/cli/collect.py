"""Commands: ``tognet collect`` (one round) and ``tognet pipeline`` (the whole self-supervision loop)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from tognet.cli.util import (
    RAY_ADDRESS_HELP,
    RAY_HELP,
    ROBOT_HELP,
    TASKS_HELP,
    WORKERS_HELP,
    check_disk,
    check_memory,
    out_folder,
    robot_config,
    task_list,
    user_errors,
)

#: Disk bytes of one collected trial's records (a shard's compressed columns) and of one shard's own
#: headers and part-filled last block: a job writes one shard, so a trial takes :func:`trial_bytes`
#: (EPISODE_BYTES + SHARD_BYTES / trials per job). Fitted to what benchmarks/space.py measured
#: (2026-12-06: 512 B per trial at the default 32 trials per job, 2,219 B at 4 per job: 268 B per trial
#: and 7.8 kB per shard), with a 1.25x margin.
EPISODE_BYTES = 340.0
SHARD_BYTES = 9.8e3
#: Memory one planned job takes while a round runs (its record, the to-do list, the store's entry).
JOB_BYTES = 1000.0


def trial_bytes(per_job: int) -> float:
    """Disk bytes of one trial collected ``per_job`` trials to a job (to a shard)."""
    return EPISODE_BYTES + SHARD_BYTES / per_job


def check_pipeline_size(cfg: Any, preset: str, tasks: list[str], out: Path) -> None:
    """Refuse a preset whose objects and rounds cannot fit on the disk of ``out`` or in memory, before
    anything is generated: the reason names the preset's numbers."""
    from tognet.cli.objects import OBJECT_BYTES, OBJECT_BYTES_BY_KIND, RECORD_BYTES

    objects = sum(cfg.objects.values())
    label = f"--preset {preset}: {objects} objects"
    need = sum(n * OBJECT_BYTES_BY_KIND.get(kind, OBJECT_BYTES) for kind, n in cfg.objects.items())
    check_disk("--preset", objects, need / objects, out, "object", label=label)
    check_memory("--preset", objects, RECORD_BYTES, "the objects' records", label=label)
    rounds = [cfg.grasp_round, *(rc for t in tasks for rc in cfg.rounds_for(t))]
    per_job = cfg.collect.scenes_per_job * cfg.collect.trials_per_scene
    trials = sum(rc.episodes for rc in rounds)
    check_disk("--preset", trials, trial_bytes(per_job), out, "trial",
               label=f"--preset {preset}: {trials} trials in its rounds for {', '.join(tasks)}")
    largest = max(rc.episodes for rc in rounds)
    check_memory("--preset", -(-largest // per_job), JOB_BYTES, "its job list",
                 label=f"--preset {preset}: a round of {largest} trials")


def check_round_size(option: str, episodes: int, per_job: int, out: Path) -> None:
    """Refuse a round that cannot fit on the disk of ``out`` or in memory, before anything is written."""
    check_disk(option, episodes, trial_bytes(per_job), out, "trial")
    check_memory(option, -(-episodes // per_job), JOB_BYTES, "the round's job list")


@user_errors
def collect_cmd(
    task: str = typer.Option(..., "--task", help="A registered task or grasping (grasp only)."),
    objects: list[Path] = typer.Option(..., "--objects", help="Object set folder (repeat for several)."),
    out: Path = typer.Option(..., "--out", help="Dataset folder to write (resumes what is already there)."),
    episodes: int = typer.Option(1000, "--episodes", min=1, help="Trials to run (rounded up to whole jobs)."),
    policy: str = typer.Option("nms_uniform", "--policy",
                               help="nms_uniform (round 1), epsilon_greedy or search_candidates (an "
                               "action-search model's best candidates per scene; both need --task-model)."),
    round_index: int = typer.Option(1, "--round", min=0, help="Round number (part of every seed)."),
    grasp_model: Path | None = typer.Option(None, "--grasp-model",
                                            help="The grasp-only checkpoint (task 'grasping', e.g. "
                                            "tognet/models/grasping.pt) ranking the NMS grasps by Q_G."),
    task_model: Path | None = typer.Option(None, "--task-model",
                                           help="Last round's checkpoint of the same --task (CEM grasps, "
                                           "policy actions; an action-search model runs the learned "
                                           "search)."),
    config: Path | None = typer.Option(None, "--config", help="CollectConfig JSON file (else defaults)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show the progress bar."),
    robot: str | None = typer.Option(None, "--robot", help=ROBOT_HELP),
) -> None:
    """Collect one round of self-supervised trials into a dataset folder (killed, it resumes when run
    again with the same arguments).

    --out holds shard-<job>.npz files (one job: one object, a few scenes), manifest.json (counts, labels,
    hashes), configs/ (the settings) and summary.json (the round's figures). Run again on the same --out with
    the same arguments it resumes; other arguments are refused."""
    from tognet.collect.config import MODEL_POLICIES, ROUND_POLICIES, CollectConfig, RoundConfig
    from tognet.collect.rounds import collect_round
    from tognet.jobs.workers import make_executor
    from tognet.objects.record import load_catalog
    from tognet.tasks import GRASP_ONLY, SIM_TASKS, check_task_name

    check_task_name(task, SIM_TASKS)
    if policy not in ROUND_POLICIES:
        raise ValueError(f"unknown policy '{policy}'; use {', '.join(ROUND_POLICIES)}")
    if policy in MODEL_POLICIES and task_model is None:
        raise ValueError(f"--policy {policy} needs --task-model (the last round's best.pt)")
    out_folder(out)
    cfg = CollectConfig.load(config) if config else CollectConfig()
    cfg = cfg.replace(sim=robot_config(cfg.sim, robot))
    check_round_size("--episodes", episodes, cfg.scenes_per_job * cfg.trials_per_scene, out)
    records = [r for folder in objects for r in load_catalog(folder)]
    from tognet.model.checkpoint import check_model_role

    if grasp_model is not None:
        check_model_role(grasp_model, GRASP_ONLY, "--grasp-model",
                         context=" (e.g. tognet/models/grasping.pt)")
    if task_model is not None:
        check_model_role(task_model, task, "--task-model", context=f" for --task {task}",
                         action_search=True if policy == "search_candidates" else None)
    executor = make_executor(workers, ray, ray_address)
    try:
        collect_round(task, round_index, records, RoundConfig(episodes=episodes, policy=policy), cfg, out,
                      grasp_model=grasp_model, task_model=task_model, executor=executor, progress=progress,
                      log=typer.echo)
    finally:
        executor.close()


@user_errors
def pipeline_cmd(
    task: str = typer.Option(..., "--task", help=TASKS_HELP),
    preset: str = typer.Option("quick", "--preset", help="ci, quick, quick-search (the learned action "
                               "search's models), medium (quick-search with twice the objects and six "
                               "rounds; one task in under 3 h on 2 cores), medium-wide (medium on the "
                               "wide generator's objects), paper, or a PipelineConfig JSON file."),
    out: Path = typer.Option(..., "--out", help="Run folder (objects, data, models, summary)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    resume: bool = typer.Option(False, "--resume", help="Continue a run in --out from where it stopped."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress bars."),
) -> None:
    """The self-supervision loop: objects, a grasp-only round and its Q_G model, then per task the rounds
    of collection (round 1 explores, later rounds epsilon-greedy with the last model), each followed by
    training on all data so far. Writes summary.md / summary.json into --out.

    --out holds preset.json (the PipelineConfig), objects/<kind>-train/ (the training objects),
    grasping/round0/data/ and grasping/model/ (the grasp-only round and its Q_G model), and per task
    <task>/round<k>/data/ (shards, manifest.json, summary.json: the round's figures) and
    <task>/round<k>/model/ (best.pt, last.pt, metrics.json, curves.png), then summary.json and summary.md.
    --resume continues a run in --out from where it stopped (the same preset); it is refused when --out
    holds no run, and a run is never restarted over an existing one without it."""
    from tognet.collect.config import load_preset
    from tognet.collect.pipeline import run_pipeline

    tasks = task_list(task)
    out_folder(out)
    cfg = load_preset(preset)
    check_pipeline_size(cfg, preset, tasks, out)
    run_pipeline(cfg, tasks, out, workers=workers, ray=ray, ray_address=ray_address, resume=resume,
                 progress=progress, log=typer.echo)
    typer.echo(f"summary: {out / 'summary.md'}")


@user_errors
def export_cmd(
    run: Path = typer.Argument(..., help="A finished `tognet pipeline` run folder."),
    out: Path = typer.Option(..., "--out", help="Folder for grasping.pt, <task>.pt and their .json."),
    command: str | None = typer.Option(None, "--command", help="The command that made the run (recorded)."),
) -> None:
    """Copy a finished run's final models (the grasp-only model and each task's last round) with their
    summaries: how they were trained, per-round collection figures, held-out metrics, training curves.

    Writes grasping.pt and <task>.pt (the last round's best.pt) into --out, each with <name>.json (the
    preset, every round's collection summary and held-out metrics, the training history, the command):
    the layout of tognet/models/. Nothing is written unless every model of the run is there."""
    from tognet.collect.pipeline import export_models

    out_folder(out)
    for path in export_models(run, out, command):
        typer.echo(f"wrote {path} and {path.with_suffix('.json').name}")


def register(app: typer.Typer) -> None:
    """Add ``collect``, ``pipeline`` and ``export-models`` to the ``tognet`` command."""
    app.command("collect")(collect_cmd)
    app.command("pipeline")(pipeline_cmd)
    app.command("export-models")(export_cmd)
