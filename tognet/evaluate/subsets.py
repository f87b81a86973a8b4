"""The subsets of scenes each task is reported by, as the task declares them
(:attr:`tognet.tasks.Task.subsets`).

A task's first subset is its headline (sweeping: the paper's mix of one and two cans); a task with several
is also broken down by them in the report (sweeping: by number of cans). Nothing here names a task.
"""

from __future__ import annotations

from typing import Any

from tognet.tasks import SceneSubset, get_task


def subsets_of(task: str) -> tuple[SceneSubset, ...]:
    """The task's subsets of scenes, the headline first."""
    return get_task(task).subsets


def main_subset(task: str) -> str:
    """The subset reported as the task's headline."""
    return subsets_of(task)[0].name


def headline(task: str) -> str:
    """The task's name as a title, with its headline subset when it has several ("sweeping (the paper's
    mix: one or two cans)")."""
    subsets = subsets_of(task)
    return task if len(subsets) == 1 else f"{task} ({subsets[0].label})"


def broken_down(results: dict[str, Any]) -> list[str]:
    """The tasks of ``results`` that have more than one subset (the report breaks them down)."""
    return [t for t in results["tasks"] if len(subsets_of(t)) > 1]


def breakdown_title(task: str) -> str:
    """"sweeping by number of cans"."""
    return f"{task} by {get_task(task).subsets_by}"


def breakdown_note(task: str) -> str:
    """What the task says under its breakdown."""
    return get_task(task).subsets_note


__all__ = ["breakdown_note", "breakdown_title", "broken_down", "headline", "main_subset", "subsets_of"]
