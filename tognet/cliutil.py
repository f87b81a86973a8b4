"""Helpers shared by the subcommands: turn expected errors into one clear line and exit status 2."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import typer

from tognet.config import ConfigError
from tognet.errors import TognetError

F = TypeVar("F", bound=Callable[..., Any])

#: Exceptions whose message is written for the user; anything else is a bug and keeps its traceback.
USER_ERRORS: tuple[type[BaseException], ...] = (TognetError, ConfigError, FileNotFoundError, ValueError)


#: ``--workers``, ``--ray`` and ``--ray-address`` of the commands that run jobs (collection, evaluation).
WORKERS_HELP = "Local worker processes (default: the number of cores)."
RAY_HELP = "Run the jobs on a local Ray instance (pip install 'tognet\\[ray]')."
RAY_ADDRESS_HELP = "Run the jobs on this Ray cluster ('auto', or 'ray://HOST:10001')."

#: ``--task`` of the commands that run several tasks: a task's name, ``all`` (every registered task) or
#: ``both`` (the paper's two, sweeping and hammering, as before a third task was registered).
TASKS_HELP = (
    "A task's name (or several, comma-separated), 'all' (every registered task), or 'both' (the paper's two)."
)


def task_list(spec: str) -> list[str]:
    """The tasks ``--task`` names (see :data:`TASKS_HELP`); an unknown name raises ValueError."""
    from tognet.tasks import PAPER_TASKS, TASK_NAMES

    if spec == "all":
        return list(TASK_NAMES)
    names = list(PAPER_TASKS) if spec == "both" else [n.strip() for n in spec.split(",") if n.strip()]
    for name in names:
        if name not in TASK_NAMES:
            raise ValueError(f"unknown task '{name}'; known tasks: {', '.join(TASK_NAMES)} (or all, both)")
    return names


def task_models(pairs: list[str]) -> dict[str, Path]:
    """``--task-model NAME=PATH`` options as {name: checkpoint}: NAME a task (its TOG-Net) or
    ``<task>_search`` (its action-conditioned model, for TOG-Net+ActionSearch)."""
    out: dict[str, Path] = {}
    for pair in pairs:
        name, sep, path = pair.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--task-model takes NAME=PATH, got '{pair}'")
        suffix = "_search" if name.endswith("_search") else ""
        out[task_list(name.removesuffix(suffix))[0] + suffix] = Path(path)
    return out


def user_errors(func: F) -> F:
    """Decorator for a command: print ``error: <message>`` and exit 2 on a user-facing error."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except USER_ERRORS as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=2) from None

    return wrapper  # type: ignore[return-value]


def _file_above(path: Path) -> Path | None:
    return next((p for p in path.parents if p.exists() and not p.is_dir()), None)


def out_folder(path: Path, option: str = "--out") -> Path:
    """``path`` checked as a folder to write into: a file there (or above it) is a one-line user error."""
    if path.exists() and not path.is_dir():
        raise TognetError(f"{option} {path}: exists and is not a folder; pass a folder")
    above = _file_above(path)
    if above is not None:
        raise TognetError(f"{option} {path}: {above} is a file, not a folder")
    return path


def out_file(path: Path, option: str = "--out") -> Path:
    """``path`` checked as a file to write: a folder there, or a file above it, is a one-line user error."""
    if path.is_dir():
        raise TognetError(f"{option} {path}: is a folder; pass a file name (e.g. {path / 'metrics.json'})")
    above = _file_above(path)
    if above is not None:
        raise TognetError(f"{option} {path}: {above} is a file, not a folder")
    return path
