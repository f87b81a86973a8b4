"""Grasp policies: exploration grasps (NMS modes of the candidates) and the model's grasp (CEM)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from tognet.data.format import GRASP_SOURCES
from tognet.grasping import cem, nms
from tognet.policies.config import PolicyConfig
from tognet.policies.view import GraspPick, SceneView

if TYPE_CHECKING:
    from tognet.grasping import CEMResult


class NMSGrasps:
    """Exploration grasps: candidates ranked by a task-agnostic grasp quality, non-maximum suppression,
    at most ``max_modes`` modes; each call draws modes at random without replacement (cycling when more
    grasps than modes are asked for) and holds each either way round (phi or phi + pi) at random.

    The ranking is the grasp-only model's Q_G when one is given (the paper's GQ-CNN ranking), else the
    antipodal score."""

    def __init__(self, config: PolicyConfig, grasp_model: Any = None) -> None:
        self.config = config
        self.grasp_model = grasp_model

    def modes(self, view: SceneView) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The scene's NMS modes (grasps, ranking scores), best first; cached on the view."""
        key = f"nms_modes_{id(self.grasp_model)}"  # one cache entry per ranking
        if key not in view.cache:
            cands = view.candidates
            if self.grasp_model is not None:
                crops, z = view.crops(cands.grasps)
                scores = np.asarray(self.grasp_model.predict(crops, z).q_g, dtype=np.float64)
            else:
                scores = np.asarray(cands.quality, dtype=np.float64)
            keep = nms(cands.grasps, scores, self.config.nms)[: self.config.max_modes]
            view.cache[key] = (cands.grasps[keep], scores[keep])
        return view.cache[key]

    def ranked(self, view: SceneView, rng: np.random.Generator) -> GraspPick:
        """Every mode once, in the order this policy draws them (a random one, each held either way
        round at random): what an arm's reach check falls back on (:mod:`tognet.planning.reach`)."""
        return self(view, max(1, len(self.modes(view)[0])), rng)

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasps, scores = self.modes(view)
        m = len(grasps)
        order = np.concatenate([rng.permutation(m) for _ in range(-(-n // m))])[:n] if m else np.zeros(0, int)
        picked = grasps[order].copy()
        flip = rng.random(n) < 0.5
        picked[flip, 3] = np.mod(picked[flip, 3] + np.pi, 2 * np.pi)
        return GraspPick(picked, np.full(n, GRASP_SOURCES["nms"], np.int8), scores[order].astype(np.float32))


class CEMGrasp:
    """The model's grasp: the cross-entropy method on Q_T = Q_T|G * Q_G (``kind="task"``) or on Q_G
    (``kind="grasp"``, task-agnostic), started from the antipodal candidates. One search per scene (cached),
    the same grasp for every call on that scene."""

    def __init__(self, config: PolicyConfig, model: Any, kind: Literal["task", "grasp"] = "task") -> None:
        self.config = config
        self.model = model
        self.kind = kind

    def result(self, view: SceneView, rng: np.random.Generator) -> CEMResult:
        """The scene's search: its best grasp and every grasp it scored (cached on the view)."""
        key = f"cem_{self.kind}_{id(self.model)}"
        if key not in view.cache:
            field_name = {"task": "q_t", "grasp": "q_g"}[self.kind]

            def score(grasps: NDArray[np.float64]) -> NDArray[np.float64]:
                crops, z = view.crops(grasps)
                return np.asarray(getattr(self.model.predict(crops, z), field_name), dtype=np.float64)

            view.cache[key] = cem(score, view.candidates.grasps, self.config.cem, rng)
        return view.cache[key]

    def best(self, view: SceneView, rng: np.random.Generator) -> tuple[NDArray[np.float64], float]:
        """The scene's CEM grasp and its score (cached on the view)."""
        result = self.result(view, rng)
        return result.best, result.best_score

    def ranked(self, view: SceneView, rng: np.random.Generator) -> GraspPick:
        """Every grasp the search scored, best score first (its best grasp first): what an arm's reach
        check falls back on (:mod:`tognet.planning.reach`)."""
        result = self.result(view, rng)
        order = np.argsort(-result.scores, kind="stable")
        return GraspPick(result.grasps[order].copy(), np.full(len(order), GRASP_SOURCES["cem"], np.int8),
                         result.scores[order].astype(np.float32))

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasp, score = self.best(view, rng)
        return GraspPick(np.repeat(grasp[None], n, axis=0), np.full(n, GRASP_SOURCES["cem"], np.int8),
                         np.full(n, score, np.float32))
