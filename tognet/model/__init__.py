"""The TOG-Net model: three-stream network, the paper's loss, training, checkpoints and inference.

Planners use :class:`tognet.model.predict.TOGNetPredictor`; training is :func:`tognet.model.train.train`
(``tognet train`` on the command line), exported here as ``train_model`` because ``tognet.model.train``
is the submodule and would shadow a lazily exported ``train``. Names are imported lazily so that
``tognet --help`` and the configs do not import torch.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ArchConfig": "tognet.model.config",
    "LossConfig": "tognet.model.config",
    "TrainConfig": "tognet.model.config",
    "CheckpointError": "tognet.model.checkpoint",
    "load_checkpoint": "tognet.model.checkpoint",
    "TOGNet": "tognet.model.network",
    "Prediction": "tognet.model.predict",
    "TOGNetPredictor": "tognet.model.predict",
    "scorer_from_checkpoint": "tognet.model.predict",
    "train_model": "tognet.model.train",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        source = "train" if name == "train_model" else name
        return getattr(importlib.import_module(_EXPORTS[name]), source)
    raise AttributeError(f"module 'tognet.model' has no attribute {name!r}")
