"""Tasks by name: each module describes its set-up, motion primitive and success rule (no MuJoCo here)."""

from __future__ import annotations

from typing import Any

from tognet.tasks.base import FailureReason, Motion, Task, TaskOutcome
from tognet.tasks.hammering import Hammering, HammeringConfig
from tognet.tasks.sweeping import Sweeping, SweepingConfig

_REGISTRY: dict[str, type[Task]] = {"sweeping": Sweeping, "hammering": Hammering}
TASK_NAMES: tuple[str, ...] = tuple(_REGISTRY)


def get_task(name: str, config: Any = None) -> Task:
    """The task called ``name`` (``sweeping`` or ``hammering``), with its default or the given config."""
    if name not in _REGISTRY:
        raise ValueError(f"unknown task '{name}'; known tasks: {', '.join(TASK_NAMES)}")
    return _REGISTRY[name](config)


__all__ = [
    "FailureReason",
    "Hammering",
    "HammeringConfig",
    "Motion",
    "Sweeping",
    "SweepingConfig",
    "TASK_NAMES",
    "Task",
    "TaskOutcome",
    "get_task",
]
