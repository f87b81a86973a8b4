"""The shipped TOG-Net checkpoints: one per task plus the grasp-only (task-agnostic Q_G) model.

    tognet/models/grasping.pt    the grasp-only model (the task-agnostic baselines rank grasps with it)
    tognet/models/sweeping.pt    TOG-Net for sweeping (Q_G, Q_T|G, action mean)
    tognet/models/hammering.pt   TOG-Net for hammering
    tognet/models/pulling.pt     TOG-Net for pulling (the plug-in third task)
    tognet/models/<task>_search.pt  the task's action-conditioned model (the learned action search,
                                 beyond the paper: method TOG-Net+ActionSearch)
    tognet/models/<name>.json    each one's run summary (how it was trained, held-out metrics)

They come from the ``quick`` self-supervision pipeline (``tognet pipeline --task both --preset quick``):
grasping and hammering from the run of 2026-12-02, sweeping from a sweeping-only run of 2026-12-04 after
the preset's sweeping rounds changed (two-can collection, expert exploration, action Sigma from the data),
pulling from a pulling-only run of 2026-12-04 (``tognet pipeline --task pulling --preset quick``).
The ``<task>_search`` models (2026-12-04): hammering's and pulling's from three and five rounds of the
``quick-search`` recipe, run round by round (``tognet collect`` then ``tognet train`` on all rounds so far;
the commands are in benchmarks/RESULTS.md, "The learned action search"), sweeping's from a run of the
``medium`` preset (``tognet pipeline --task sweeping --preset medium``: 600 objects, six rounds). Each
JSON names its run; the README says how to reproduce them.
"""

from __future__ import annotations

from pathlib import Path

from tognet.errors import TognetError
from tognet.tasks import GRASP_ONLY, TASK_NAMES

MODELS_DIR = Path(__file__).resolve().parent
#: The shipped models: the grasp-only model, each task's TOG-Net and its ``<task>_search`` model.
NAMES = (GRASP_ONLY, *TASK_NAMES, *(f"{t}_search" for t in TASK_NAMES))


def default_checkpoint(name: str) -> Path:
    """The shipped checkpoint for ``name`` (a task, or ``grasping``); TognetError if it is not there."""
    if name not in NAMES:
        raise TognetError(f"no shipped model for '{name}'; shipped: {', '.join(NAMES)}")
    path = MODELS_DIR / f"{name}.pt"
    if not path.is_file():
        raise TognetError(f"the shipped {name} model is missing ({path}); train one with `tognet pipeline` "
                          "and pass --checkpoint")
    return path
