"""The evaluation ``make run`` shows: the shipped models, every method, every task with a shipped model, all
three categories, at a scale that runs in a few minutes on two cores (the README's table is the same run at
300 scenes)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from tognet.evaluate.config import EvalConfig
from tognet.planning.config import BoundConfig, OracleConfig, PlanConfig

#: Demo scale: scenes per (task, category) and test objects per category.
DEMO_EPISODES = 20
DEMO_OBJECTS = 8


def demo_config() -> EvalConfig:
    """The default settings with a cheaper Oracle search (6 grasps both ways round, at most 48 trials)."""
    return EvalConfig(plan=PlanConfig(oracle=OracleConfig(grasps=6, seeds=2, max_trials=48),
                                      bound=BoundConfig(grasps=8, seeds=2, max_trials=96)))


def run_demo(out: str | Path = "runs/demo/evaluation", *, episodes: int = DEMO_EPISODES,
             test_objects: int = DEMO_OBJECTS, workers: int | None = None, progress: bool = True,
             grasp_model: str | Path | None = None, task_models: dict[str, str | Path | None] | None = None,
             run_dir: str | Path | None = None, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Evaluate all methods on every registered task with a shipped (or given) model and the three test
    categories (``episodes`` scenes each, on ``test_objects`` objects per category) with the shipped
    checkpoints unless others are given; writes ``out/report.html``. Run again, it resumes (only
    re-rendering the report when everything is there); an earlier demo evaluation in ``out`` with other
    settings (e.g. new models) is replaced."""
    import shutil

    from tognet.evaluate.harness import SETTINGS, SettingsChanged, run_evaluation
    from tognet.models import NAMES
    from tognet.tasks import TASK_NAMES

    tasks = [task for task in TASK_NAMES if task in NAMES or (task_models or {}).get(task)]

    def run() -> dict[str, Any]:
        return run_evaluation(out, tasks, "all",
                              categories=["pg-primitive", "pg-complex", "realistic"], episodes=episodes,
                              test_object_count=test_objects, grasp_model=grasp_model,
                              task_models=task_models, config=demo_config(), workers=workers,
                              resume=(Path(out) / SETTINGS).is_file(),
                              progress=progress, run_dir=run_dir, log=log)

    try:
        return run()
    except SettingsChanged as exc:
        if not (Path(out) / SETTINGS).is_file():
            raise
        log(f"{exc}: starting the demo evaluation afresh")
        shutil.rmtree(out)
        return run()
