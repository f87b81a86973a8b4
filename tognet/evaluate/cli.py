"""Command: ``tognet evaluate`` (every method on the same unseen test scenes, results and report)."""

from __future__ import annotations

from pathlib import Path

import typer

from tognet.cliutil import (
    RAY_ADDRESS_HELP,
    RAY_HELP,
    TASKS_HELP,
    WORKERS_HELP,
    task_list,
    task_models,
    user_errors,
)
from tognet.planning.method_names import METHOD_NAMES


@user_errors
def evaluate_cmd(
    task: str = typer.Option(..., "--task", help=TASKS_HELP),
    methods: str = typer.Option("all", "--methods", help="'all' or a comma-separated list of: "
                                f"{', '.join(METHOD_NAMES)}. The last two are diagnostics (the simulator's "
                                "ground truth for one half of the plan), never baselines."),
    category: list[str] = typer.Option([], "--category", help="pg-primitive, pg-complex or realistic (repeat "
                                       "for several; default: all three unless --objects is given)."),
    objects: list[Path] = typer.Option([], "--objects", help="An object set folder of your own: a category "
                                       "named after it (repeat for several; no training objects)."),
    episodes: int = typer.Option(100, "--episodes", min=1, help="Scenes per task and category; every method "
                                 "runs on each."),
    out: Path = typer.Option(..., "--out", help="Folder for the results, report and test objects."),
    grasp_model: Path | None = typer.Option(None, "--grasp-model", help="Grasp-only (Q_G) checkpoint "
                                            "(default: the shipped tognet/models/grasping.pt)."),
    task_model: list[str] = typer.Option([], "--task-model", metavar="NAME=PATH", help="A task's TOG-Net "
                                         "checkpoint (NAME: the task), or its action-conditioned model for "
                                         "TOG-Net+ActionSearch (NAME: <task>_search); repeat for several "
                                         "(default: the shipped ones, tognet/models/NAME.pt)."),
    test_objects: int | None = typer.Option(None, "--test-objects", min=1, help="Test objects per category "
                                            "at most (default: a new one per job)."),
    scenes_per_job: int | None = typer.Option(None, "--scenes-per-job", min=1, help="Scenes per job (one "
                                              "object) (default: the config's, 2)."),
    config: Path | None = typer.Option(None, "--config", help="EvalConfig JSON file (else defaults)."),
    run: Path | None = typer.Option(None, "--run", help="A `tognet pipeline` run folder whose per-round "
                                    "training curves the report shows (default: the task model's run)."),
    animations: bool = typer.Option(True, "--animations/--no-animations", help="GIFs of typical episodes "
                                    "(needs MuJoCo's renderer: EGL)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    resume: bool = typer.Option(False, "--resume", help="Continue an evaluation in --out (same settings)."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress bars."),
) -> None:
    """Evaluate the methods on the same unseen test scenes: results.json (success rates with 95 % Wilson
    intervals, paired differences to TOG-Net), report.html and report.md in --out. Killed, it resumes
    with --resume."""
    from tognet.evaluate.config import EvalConfig
    from tognet.evaluate.harness import run_evaluation

    tasks = task_list(task)
    models = task_models(task_model)
    cfg = EvalConfig.load(config) if config else EvalConfig()
    if scenes_per_job is not None:
        cfg = cfg.replace(scenes_per_job=scenes_per_job)
    run_evaluation(out, tasks, methods, categories=category, object_dirs=objects, episodes=episodes,
                   test_object_count=test_objects, grasp_model=grasp_model,
                   task_models=models, config=cfg,
                   workers=workers, ray=ray, ray_address=ray_address, resume=resume, progress=progress,
                   run_dir=run, animations=animations, log=typer.echo)
    typer.echo(f"results: {out / 'results.json'}")


def register(app: typer.Typer) -> None:
    """Add ``evaluate`` to the tognet command."""
    app.command("evaluate")(evaluate_cmd)
