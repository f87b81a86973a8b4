"""Command: ``tognet evaluate`` (every method on the same unseen test scenes, results and report)."""

from __future__ import annotations

from pathlib import Path

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
    task_models,
    user_errors,
)
from tognet.planning.method_names import METHOD_NAMES

#: Disk bytes of one method's record on one evaluated scene (a scene takes one per method run, see
#: :func:`scene_bytes`; the job files hold 2 scenes each by default): 1.5 kB measured by
#: benchmarks/space.py (2026-12-06, 13.8 kB a scene with all 9 methods), with a 1.25x margin.
METHOD_SCENE_BYTES = 1.9e3
#: One scene with every method.
SCENE_BYTES = METHOD_SCENE_BYTES * len(METHOD_NAMES)
#: Memory one planned job (one object, a few scenes) takes while the evaluation runs.
JOB_BYTES = 1000.0


def scene_bytes(methods: str) -> float:
    """Disk bytes of one scene evaluated with ``methods`` (--methods: 'all' or a comma-separated list)."""
    names = {m.strip().lower() for m in methods.split(",") if m.strip()}
    return METHOD_SCENE_BYTES * (len(METHOD_NAMES) if methods.strip() == "all" else max(len(names), 1))


def new_objects_bytes(categories: list[str], count: int) -> float:
    """Disk bytes of ``count`` new test objects in each of ``categories`` (objects of that kind)."""
    from tognet.cli.objects import OBJECT_BYTES_BY_KIND
    from tognet.evaluate.config import CATEGORIES

    largest = max(OBJECT_BYTES_BY_KIND.values())  # an unknown category is refused later, by the harness
    return count * sum(OBJECT_BYTES_BY_KIND.get(CATEGORIES.get(c, ""), largest) for c in categories)


def check_run_folder(run: Path, tasks: list[str]) -> None:
    """``--run``: a `tognet pipeline` run folder holding ``<task>/round<k>`` of at least one of ``tasks``."""
    if not run.exists():
        raise FileNotFoundError(f"--run {run}: no such folder (a `tognet pipeline` run folder)")
    if not run.is_dir():
        raise ValueError(f"--run {run}: is a file; give a `tognet pipeline` run folder")
    if not any((run / t / "round1").is_dir() for t in tasks):
        rounds = " or ".join(f"{t}/round1" for t in tasks)
        raise ValueError(f"--run {run}: holds no {rounds} folder, so it is not a `tognet pipeline` run of "
                         "these tasks")


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
    run: Path | None = typer.Option(None, "--run", help="A `tognet pipeline` run folder (with "
                                    "<task>/round<k>/) whose per-round training curves the report shows "
                                    "(default: the task model's run, when it lies in one)."),
    animations: bool = typer.Option(True, "--animations/--no-animations", help="GIFs of typical episodes "
                                    "(needs MuJoCo's renderer: EGL)."),
    workers: int | None = typer.Option(None, "--workers", min=0, help=WORKERS_HELP),
    ray: bool = typer.Option(False, "--ray", help=RAY_HELP),
    ray_address: str | None = typer.Option(None, "--ray-address", help=RAY_ADDRESS_HELP),
    resume: bool = typer.Option(False, "--resume", help="Continue an evaluation in --out (same settings)."),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress bars."),
    robot: str | None = typer.Option(None, "--robot", help=ROBOT_HELP),
) -> None:
    """Evaluate the methods on the same unseen test scenes: results.json (success rates with 95 % Wilson
    intervals, paired differences to TOG-Net), report.html and report.md in --out. Killed, it resumes
    with --resume.

    --out holds evaluation.json (the settings; a resume must use the same), objects/<kind>-test/ (the
    generated test objects), <task>/<category>/ (every job's records), results.json, report.html,
    report.md, figures/ and gifs/. --resume continues the evaluation in --out and is refused when --out
    holds none; without it an --out that already holds one is refused. Models default to the shipped
    tognet/models/<task>.pt, grasping.pt and <task>_search.pt; each is checked to be of its task and head."""
    from tognet.evaluate.config import CATEGORIES, EvalConfig
    from tognet.evaluate.harness import run_evaluation

    tasks = task_list(task)
    out_folder(out)
    if run is not None:
        check_run_folder(run, tasks)
    models = task_models(task_model, tasks)
    cfg = EvalConfig.load(config) if config else EvalConfig()
    cfg = cfg.replace(sim=robot_config(cfg.sim, robot))
    if scenes_per_job is not None:
        cfg = cfg.replace(scenes_per_job=scenes_per_job)
    categories = category or ([] if objects else list(CATEGORIES))
    groups = len(tasks) * (len(categories) + len(objects))
    jobs = -(-episodes // cfg.scenes_per_job)
    per_category = min(jobs, test_objects or jobs)
    new_objects = per_category * len(categories)
    check_disk("--episodes", episodes * groups, scene_bytes(methods), out, "scene",
               label=f"--episodes {episodes} (x {groups} task-category pairs)")
    check_disk("--episodes", new_objects, new_objects_bytes(categories, per_category) / max(new_objects, 1),
               out, "test object", label=f"--episodes {episodes}: {new_objects} new test objects")
    check_memory("--episodes", jobs * groups, JOB_BYTES, "the job list",
                 label=f"--episodes {episodes} (x {groups} task-category pairs)")
    run_evaluation(out, tasks, methods, categories=category, object_dirs=objects, episodes=episodes,
                   test_object_count=test_objects, grasp_model=grasp_model,
                   task_models=models, config=cfg,
                   workers=workers, ray=ray, ray_address=ray_address, resume=resume, progress=progress,
                   run_dir=run, animations=animations, log=typer.echo)
    typer.echo(f"results: {out / 'results.json'}")


def register(app: typer.Typer) -> None:
    """Add ``evaluate`` to the tognet command."""
    app.command("evaluate")(evaluate_cmd)
