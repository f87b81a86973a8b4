"""The shipped checkpoints: each is the model its name says, matches its summary, and every task has one."""

from __future__ import annotations

import hashlib
import json

import pytest

from tognet.errors import TognetError
from tognet.model.predict import TOGNetPredictor
from tognet.models import MODELS_DIR, NAMES, default_checkpoint
from tognet.tasks import TASK_NAMES


@pytest.mark.parametrize("name", NAMES)
def test_a_shipped_model_is_the_task_it_is_named_for(name):
    path = default_checkpoint(name)
    summary = json.loads((MODELS_DIR / f"{name}.json").read_text())
    assert summary["name"] == name
    assert summary["checkpoint_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    model = TOGNetPredictor.load(path)
    assert model.task == name.removesuffix("_search")
    assert model.action_conditioned == name.endswith("_search")  # the learned action search's models
    # Its summary's last round is the one the checkpoint came from, with held-out metrics.
    assert summary["rounds"] and summary["rounds"][-1]["model"]


def test_every_registered_task_ships_a_model():
    assert set(TASK_NAMES) | {"grasping"} | {f"{t}_search" for t in TASK_NAMES} == set(NAMES)


def test_an_unknown_name_is_refused_with_the_shipped_list():
    with pytest.raises(TognetError, match="no shipped model for 'juggling'"):
        default_checkpoint("juggling")
