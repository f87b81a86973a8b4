"""``--task`` of the multi-task commands: names from the registry, ``all`` and ``both``."""

from pathlib import Path

import pytest

from tognet.cli.util import task_list, task_models
from tognet.tasks import TASK_NAMES


def test_task_list_reads_names_all_and_both():
    assert task_list("all") == list(TASK_NAMES) and "pulling" in task_list("all")
    assert task_list("both") == ["sweeping", "hammering"]
    assert task_list("pulling") == ["pulling"]
    assert task_list("pulling,hammering") == ["pulling", "hammering"]
    with pytest.raises(ValueError, match="unknown task 'sawing'"):
        task_list("sawing")


def test_task_models_reads_name_path_pairs():
    assert task_models(["pulling=a/b.pt"]) == {"pulling": Path("a/b.pt")}
    with pytest.raises(ValueError, match="NAME=PATH"):
        task_models(["pulling"])


def test_the_plan_and_sim_help_list_every_registered_task():
    """Help texts that list the tasks take them from the registry (`tognet plan --help` once said "sweeping
    or hammering" while pulling shipped)."""
    import re

    from typer.testing import CliRunner

    from tognet.cli import app
    from tognet.tasks import get_task

    for command in ("plan", "sim"):
        text = CliRunner().invoke(app, [command, "--help"], env={"COLUMNS": "400"}).output
        flat = re.sub(r"[\s│]+", " ", text)
        assert all(name in flat for name in TASK_NAMES), (command, flat)
    flat = re.sub(r"[\s│]+", " ", CliRunner().invoke(app, ["plan", "--help"], env={"COLUMNS": "400"}).output)
    for name in TASK_NAMES:
        assert f"{name}: {get_task(name).reference_point}" in flat
