"""When a plan is not to be trusted: the low-confidence threshold of each method and task.

A method's own score of its plan (``Plan.own["score"]``: Q_T for TOG-Net, Q_G x Q_T|G,a for the action
search, ...) means a different thing for every method, task and model, so a fixed threshold warns on good
plans of one and passes bad plans of another. The thresholds in ``tognet/models/confidence.json`` were
set from held-out scenes for the shipped models (``benchmarks/calibrate_confidence.py``: the evaluation's
planners on scenes of another root seed than the README's evaluation, the plans' success fitted as a
non-decreasing function of the score): a plan warns when its score is below the lowest score from which
the fitted success rate reaches one half. So a plan whose kind succeeds more often than not does not warn.
The thresholds hold only for the models they were set with: each model's sha256 is checked, and with
other models there is no calibrated warning (a ``low_score`` of one's own still works).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from tognet.io import sha256_file
from tognet.models import MODELS_DIR
from tognet.tasks import GRASP_ONLY

#: The calibrated thresholds of the shipped models.
CONFIDENCE_FILE = MODELS_DIR / "confidence.json"


@lru_cache(maxsize=4)
def _table(path: str, mtime: float) -> dict[str, Any]:
    try:
        return dict(json.loads(Path(path).read_text()))
    except (OSError, ValueError):
        return {}


def calibration(path: Path | None = None) -> dict[str, Any]:
    """The calibration file's contents (default :data:`CONFIDENCE_FILE`; {} when it is missing or
    unreadable)."""
    path = CONFIDENCE_FILE if path is None else path
    try:
        return _table(str(path), path.stat().st_mtime)
    except OSError:
        return {}


@lru_cache(maxsize=32)
def _digest(path: str, size: int, mtime: float) -> str:
    return sha256_file(path)


def file_digest(path: str | Path) -> str | None:
    """The sha256 of a file (cached while its size and time are unchanged); None when it cannot be read."""
    try:
        st = Path(path).stat()
        return _digest(str(path), st.st_size, st.st_mtime)
    except OSError:
        return None


def _model_name(kind: str, task: str) -> str:
    return {"grasp": GRASP_ONLY, "task": task, "search": f"{task}_search"}[kind]


def threshold(task: str, method: str, paths: dict[str, str], path: Path | None = None
              ) -> dict[str, Any] | None:
    """The calibrated entry of ``method`` on ``task`` (``warn_below``: a score, None for never, "always"),
    or None when there is none or the models at ``paths`` (by kind: grasp, task, search) are not the ones
    it was set with."""
    table = calibration(path)
    entry = table.get("thresholds", {}).get(task, {}).get(method)
    if entry is None:
        return None
    digests = table.get("models", {})
    for kind in entry.get("uses", []):
        want = digests.get(_model_name(kind, task))
        if kind not in paths or want is None or file_digest(paths[kind]) != want:
            return None
    return dict(entry)


def low_confidence(task: str, method: str, paths: dict[str, str], score: float, own: float | None = None
                   ) -> tuple[dict[str, Any], str | None]:
    """(what the plan was held against, the warning line or None) for a plan of ``method`` on ``task``
    scoring ``score``: a threshold of one's own (``own``) first, else the calibrated one."""
    if own is not None:
        held = {"source": "UserPlanConfig.low_score", "warn_below": own}
        if score < own:
            return held, f"low confidence: the plan's score {score:.3f} is below the low_score {own:g} set"
        return held, None
    entry = threshold(task, method, paths)
    if entry is None:
        return {"source": None, "warn_below": None,
                "note": "no threshold calibrated for this method, task and these models: no warning"}, None
    held = {"source": f"tognet/models/{CONFIDENCE_FILE.name}", **{k: entry.get(k) for k in
                                                    ("warn_below", "scenes", "success", "below", "above")}}
    limit = entry.get("warn_below")
    below, above = entry.get("below") or {}, entry.get("above") or {}
    if limit == "always":
        return held, (f"low confidence: {method}'s {task} plans succeeded in "
                      f"{100 * float(entry.get('success', 0.0)):.0f} % of {entry.get('scenes')} held-out "
                      "scenes, never more often than not at any score")
    if limit is None or score >= float(limit):
        return held, None
    return held, (f"low confidence: the plan's score {score:.3f} is below {float(limit):.3f}, under which "
                  f"{method}'s {task} plans succeeded in {100 * float(below.get('success', 0.0)):.0f} % of "
                  f"held-out scenes ({100 * float(above.get('success', 0.0)):.0f} % at or above it)")
