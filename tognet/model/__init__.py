"""The TOG-Net model: three-stream network, the paper's loss, training, checkpoints and inference.

Planners use :class:`tognet.model.predict.TOGNetPredictor`; training is :func:`tognet.model.train.train`
(``tognet train`` on the command line), exported here as ``train_model`` because ``tognet.model.train``
is the submodule and would shadow a lazily exported ``train``. Names are imported lazily so that
``tognet --help`` and the configs do not import torch.
"""

from __future__ import annotations

from tognet.lazy_names import lazy_names

_WHERE = {
    "ArchConfig": "tognet.model.config",
    "LossConfig": "tognet.model.config",
    "TrainConfig": "tognet.model.config",
    "CheckpointError": "tognet.model.checkpoint",
    "load_checkpoint": "tognet.model.checkpoint",
    "TOGNet": "tognet.model.network",
    "Prediction": "tognet.model.predict",
    "TOGNetPredictor": "tognet.model.predict",
    "scorer_from_checkpoint": "tognet.model.predict",
    "train_model": "tognet.model.train:train",
}

__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_names(__name__, _WHERE)
