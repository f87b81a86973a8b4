"""Scenes in jobs: a scene the simulator cannot set up is counted and skipped, never the job's end."""

from __future__ import annotations

from collections import Counter
from typing import Any


def reset_scene(sim: Any, scene_seed: int, stats: Counter[str]) -> Any:
    """``sim.reset(scene_seed)``, or None for a scene the simulator cannot set up (the object fell off the
    table, an unstable drop), counted in ``stats`` (``bad_scenes`` and the reason) so the job goes on."""
    from tognet.sim import SimulationError

    try:
        return sim.reset(scene_seed)
    except SimulationError as exc:
        stats["bad_scenes"] += 1
        stats[f"bad_scene: {exc}"[:200]] += 1
        return None
