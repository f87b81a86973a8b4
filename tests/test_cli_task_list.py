"""``--task`` of the multi-task commands: names from the registry, ``all`` and ``both``."""

from pathlib import Path

import pytest

from tognet.cliutil import task_list, task_models
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
