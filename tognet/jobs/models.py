"""Models in workers: each checkpoint loaded once per process, however many jobs use it."""

from __future__ import annotations

from typing import Any

_MODELS: dict[str, Any] = {}


def load_model(path: str) -> Any:
    """A predictor for ``path``, loaded once per worker process."""
    if path not in _MODELS:
        from tognet.model.predict import TOGNetPredictor

        _MODELS[path] = TOGNetPredictor.load(path)
    return _MODELS[path]
