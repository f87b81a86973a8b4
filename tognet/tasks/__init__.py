"""Tasks by name: each module describes its set-up, motion primitive and success rule (no MuJoCo here),
and a sibling ``<task>_props`` module hands the simulator its props (:class:`tognet.tasks.props.TaskProps`).

Adding a task: its two modules, and one line in ``_REGISTRY`` below.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from tognet.tasks.base import FailureReason, Motion, SceneSubset, Task, TaskOutcome
from tognet.tasks.hammering import Hammering, HammeringConfig
from tognet.tasks.hammering_props import HammeringProps
from tognet.tasks.props import TaskProps
from tognet.tasks.pulling import Pulling, PullingConfig
from tognet.tasks.pulling_props import PullingProps
from tognet.tasks.sweeping import Sweeping, SweepingConfig
from tognet.tasks.sweeping_props import SweepingProps


@dataclass(frozen=True)
class TaskEntry:
    """A registered task: its class (which names its config class, a section of ``SimConfig`` named after
    the task) and its props in the simulator."""

    task: type[Task]
    props: type[TaskProps]


_REGISTRY: dict[str, TaskEntry] = {
    "sweeping": TaskEntry(Sweeping, SweepingProps),
    "hammering": TaskEntry(Hammering, HammeringProps),
    "pulling": TaskEntry(Pulling, PullingProps),
}
TASK_NAMES: tuple[str, ...] = tuple(_REGISTRY)
#: The task a command runs when none is named.
DEFAULT_TASK = "hammering"
#: The paper's two tasks (what ``--task both`` means).
PAPER_TASKS: tuple[str, ...] = ("sweeping", "hammering")
#: The grasp-only pseudo-task: lift the tool, no props and no motion (the task-agnostic model's data, the
#: Gymnasium env ``tognet/Grasping-v0``). It is no :class:`Task`; :data:`SIM_TASKS` is every name the
#: simulator takes.
GRASP_ONLY = "grasping"
SIM_TASKS: tuple[str, ...] = (*TASK_NAMES, GRASP_ONLY)


def reference_points() -> str:
    """What each registered task's reference point is ('sweeping: the cans' mean ...; hammering: ...'), for
    help texts and plan files."""
    return "; ".join(f"{name}: {entry.task.reference_point}" for name, entry in _REGISTRY.items())


def check_task_name(name: str, known: Iterable[str] | None = None, what: str = "task", *,
                    error: Callable[[str], Exception] = ValueError) -> str:
    """``name`` if it is one of ``known`` (default :data:`TASK_NAMES`; a caller taking more, such as
    :data:`SIM_TASKS`, passes its own); otherwise ``error`` (ValueError, or the caller's own class) with
    the one message of an unknown task, ``unknown <what> 'name'; known: a, b`` (``what``: how the caller's
    user named it, e.g. ``--task``)."""
    choices = TASK_NAMES if known is None else tuple(known)
    if name not in choices:
        raise error(f"unknown {what} '{name}'; known: {', '.join(choices)}")
    return name


def _entry(name: str) -> TaskEntry:
    return _REGISTRY[check_task_name(name)]


def get_task(name: str, config: Any = None) -> Task:
    """The task called ``name`` (one of ``TASK_NAMES``), with its default or the given config."""
    return _entry(name).task(config)


def task_config_class(name: str) -> type:
    """The config class of the task called ``name``."""
    return _entry(name).task.config_class


def get_props(task: Task | None) -> TaskProps:
    """The simulator props of ``task`` (a :class:`Task` from :func:`get_task`); None: no props (grasping)."""
    if task is None:
        return TaskProps()
    return _entry(task.name).props(task)


__all__ = [
    "DEFAULT_TASK",
    "FailureReason",
    "GRASP_ONLY",
    "Hammering",
    "HammeringConfig",
    "Motion",
    "PAPER_TASKS",
    "Pulling",
    "PullingConfig",
    "Sweeping",
    "SweepingConfig",
    "SIM_TASKS",
    "SceneSubset",
    "TASK_NAMES",
    "Task",
    "TaskEntry",
    "TaskOutcome",
    "TaskProps",
    "check_task_name",
    "get_props",
    "get_task",
    "reference_points",
    "task_config_class",
]
