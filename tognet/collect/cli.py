"""Commands: ``tognet collect`` (one round) and ``tognet pipeline`` (the whole self-supervision loop)."""

from __future__ import annotations

from pathlib import Path

import typer

from tognet.cliutil import (
    RAY_ADDRESS_HELP,
    RAY_HELP,
    TASKS_HELP,
    WORKERS_HELP,
    out_folder,
    task_list,
    user_errors,
)


@user_errors
def collect_cmd(
    task: str = typer.Option(..., "--task", help="A registered task or grasping (grasp only)."),
    objects: list[Path] = typer.Option(..., "--objects", help="Object set folder (repeat for several)."),
    out: Path = typer.Option(..., "--out", help="Dataset folder to write (resumes what is already there)."),
    episodes: int = typer.Option(1000, "--episodes", min=1, help="Trials to run (rounded up to whole jobs)."),
    policy: str = typer.Option("nms_uniform", "--policy",
                               help="nms_uniform (round 1) or epsilon_greedy (needs --task-model)."),
    round_index: int = typer.Option(1, "--round", min=0, help="Round number (part of every seed)."),
    grasp_model: Path | None = typer.Option(None, "--grasp-model",
                                            help="Grasp-only checkpoint ranking the NMS grasps by Q_G."),
    task_model: Path | None = typer.Option(None, "--task-model",
                                           help="Last round's checkpoint (CEM grasps, policy actions)."),
    config: Path | None = typer.Option(None, "--config", help="CollectConfig JSON file (else defaults)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show the progress bar."),
) -> None:
    """Collect one round of self-supervised trials into a dataset folder (killed, it resumes when run
    again with the same arguments)."""
    from tognet.collect.config import CollectConfig, RoundConfig
    from tognet.collect.rounds import collect_round
    from tognet.jobs.workers import make_executor
    from tognet.objects.record import load_catalog
    from tognet.tasks import SIM_TASKS

    if task not in SIM_TASKS:
        raise ValueError(f"unknown task '{task}'; known: {', '.join(SIM_TASKS)}")
    if policy not in ("nms_uniform", "epsilon_greedy"):
        raise ValueError(f"unknown policy '{policy}'; use nms_uniform or epsilon_greedy")
    if policy == "epsilon_greedy" and task_model is None:
        raise ValueError("--policy epsilon_greedy needs --task-model (the last round's best.pt)")
    for path in (grasp_model, task_model):
        if path is not None and not path.is_file():
            raise FileNotFoundError(f"checkpoint not found: {path}")
    out_folder(out)
    records = [r for folder in objects for r in load_catalog(folder)]
    cfg = CollectConfig.load(config) if config else CollectConfig()
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
                               "rounds; one task in under 3 h on 2 cores), paper, or a PipelineConfig JSON "
                               "file."),
    out: Path = typer.Option(..., "--out", help="Run folder (objects, data, models, summary)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    resume: bool = typer.Option(False, "--resume", help="Continue a run in --out from where it stopped."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress bars."),
) -> None:
    """The self-supervision loop: objects, a grasp-only round and its Q_G model, then per task the rounds
    of collection (round 1 explores, later rounds epsilon-greedy with the last model), each followed by
    training on all data so far. Writes summary.md / summary.json into --out."""
    from tognet.collect.config import load_preset
    from tognet.collect.pipeline import run_pipeline

    tasks = task_list(task)
    cfg = load_preset(preset)
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
    summaries: how they were trained, per-round collection figures, held-out metrics, training curves."""
    from tognet.collect.pipeline import export_models

    for path in export_models(run, out, command):
        typer.echo(f"wrote {path} and {path.with_suffix('.json').name}")


def register(app: typer.Typer) -> None:
    """Add ``collect``, ``pipeline`` and ``export-models`` to the ``tognet`` command."""
    app.command("collect")(collect_cmd)
    app.command("pipeline")(pipeline_cmd)
    app.command("export-models")(export_cmd)
