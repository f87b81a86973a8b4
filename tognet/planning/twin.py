"""The image's twin: try the action search's best plans in a world built from the depth image alone.

The learned action search proposes good (grasp, action) pairs but ranks them poorly within a scene: the
pair it picks is often not the best of its own few best (benchmarks/RESULTS.md, "How the action search
chooses its grasp"). A robot can check them before it moves: from the one depth image it builds a solid of
what it sees of the tool (:mod:`tognet.objects.columns`: columns from the table up to the seen surface),
sets it in a simulated world with the task's props where it is told they are (the reference point,
:meth:`tognet.tasks.Task.told_layout`), tries each of the search's ``twin.pairs`` best pairs there on
``twin.seeds`` execution-noise seeds, and takes the pair that succeeds most often (the search's own score
breaks ties). Nothing of the simulator's scene is read: the density and friction are nominal, the hidden
underside is filled, the props' hidden masses are the middle of their range. Where the task's layout does
not follow from its reference point (sweeping's cans), or no solid can be made, the search's own choice
stands (``view.cache["twin"]`` says why).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.data.format import GRASP_SOURCES
from tognet.geometry import Grasp
from tognet.planning.config import TwinConfig
from tognet.policies.action_search import ActionSearchGrasps, SearchResult
from tognet.policies.config import ActionSearchConfig
from tognet.policies.view import GraspPick, SceneView

#: The twin's trials use execution-noise seeds from here (the evaluation's own trial uses 0, the Oracle's
#: search 1000 + k).
TWIN_SEED = 5000


def object_pixels(view: SceneView, config: TwinConfig) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The world points the image sees of the object (raised above the table, short of the props) and
    each pixel's half-size on the table (m)."""
    scene = view.scene
    pts = scene.camera.deproject(scene.filled)
    mask = (scene.height > config.min_height) & (pts[..., 0] < config.max_x) & ~scene.holes
    half = 0.5 * scene.filled[mask].astype(np.float64) / float(scene.camera.intrinsics.fx)
    return pts[mask], half


def build_twin(view: SceneView, reference: NDArray[np.float64], sim_config: Any, config: TwinConfig,
               folder: str) -> Any:
    """The twin's simulator, its scene set (ValueError / MeshError / SimulationError when it cannot be)."""
    from tognet.objects.columns import column_object
    from tognet.sim import Simulator

    task = view.task
    if task is None:
        raise ValueError("the twin needs a task")
    layout = task.told_layout(np.asarray(reference, dtype=np.float64))
    if layout is None:
        raise ValueError(f"{task.name}: the props' layout does not follow from the reference point")
    points, half = object_pixels(view, config)
    record = column_object(folder, "twin", points, half, cell=config.cell, density=config.density,
                           friction=config.friction)
    sim = Simulator(sim_config, task.name, record)
    sim.place_scene(layout, seed=0)
    return sim


def twin_wins(sim: Any, grasps: NDArray[np.float64], actions: NDArray[np.float64], seeds: int
              ) -> NDArray[np.int64]:
    """Successes of each (grasp, action) pair in the twin over ``seeds`` trials (a pair the hand cannot
    reach: none)."""
    wins = np.zeros(len(grasps), dtype=np.int64)
    for i, (g, a) in enumerate(zip(grasps, actions, strict=True)):
        for k in range(seeds):
            try:
                r = sim.execute(Grasp.from_array(g), a, TWIN_SEED + k)
            except ValueError:
                break
            wins[i] += int(r.task_success)
    return wins


class TwinGrasps(ActionSearchGrasps):
    """Grasp policy: the action search's ``twin.pairs`` best pairs, tried in the image's twin; the one that
    wins most there (ties: the search's order). Its action is the search's own for that grasp, so the
    search's action policy (:class:`tognet.policies.action_search.ActionSearchActions`) finds it."""

    def __init__(self, model: Any, config: ActionSearchConfig, twin: TwinConfig, sim_config: Any) -> None:
        super().__init__(model, replace(config, refine_grasps=max(config.refine_grasps, twin.pairs)))
        self.twin = twin
        self.sim_config = sim_config

    def checked(self, view: SceneView, rng: np.random.Generator) -> tuple[NDArray[np.float64], SearchResult,
                                                                           int]:
        """The search's candidates and result, and the row of ``result.index`` the twin chose (cached)."""
        grasps, res = self.result(view, rng)
        if "twin_choice" not in view.cache:
            view.cache["twin_choice"] = self._choose(view, grasps, res)
        return grasps, res, int(view.cache["twin_choice"])

    def _choose(self, view: SceneView, grasps: NDArray[np.float64], res: SearchResult) -> int:
        n = min(self.twin.pairs, len(res.index))
        reference = view.cache.get("reference")
        t0 = time.perf_counter()
        info: dict[str, Any] = {}
        view.cache["twin"] = info
        if reference is None:
            info["skipped"] = "no reference point"
            return 0
        try:
            with tempfile.TemporaryDirectory(prefix="tognet-twin-") as folder:
                sim = build_twin(view, reference, self.sim_config, self.twin, folder)
                wins = twin_wins(sim, grasps[res.index[:n]], res.actions[:n], self.twin.seeds)
        except Exception as exc:  # no solid, no layout, an unstable twin: the search's own choice
            info["skipped"] = f"{type(exc).__name__}: {exc}"
            return 0
        info.update(wins=wins.tolist(), seconds=time.perf_counter() - t0)
        return int(np.argmax(wins))  # first of the most wins: the search's order breaks ties

    def ranked(self, view: SceneView, rng: np.random.Generator) -> GraspPick:
        """The pairs tried in the twin by their wins there (most first, the search's order breaking ties),
        then the search's other refined grasps and every other candidate by its rating."""
        self.checked(view, rng)
        pick = super().ranked(view, rng)
        wins = view.cache["twin"].get("wins")
        if wins is None:
            return pick
        head = np.argsort(-np.asarray(wins), kind="stable")
        order = np.concatenate([head, np.arange(len(wins), len(pick.grasps))])
        return GraspPick(pick.grasps[order], pick.source[order], pick.score[order])

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasps, res, row = self.checked(view, rng)
        best = grasps[res.index[row]]
        return GraspPick(np.repeat(best[None], n, axis=0), np.full(n, GRASP_SOURCES["search"], np.int8),
                         np.full(n, res.q_t[row], np.float32))
