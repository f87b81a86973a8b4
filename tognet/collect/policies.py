"""Grasp and action policies for collection, each one small object with one signature.

A :class:`SceneView` holds what every policy may look at for one observation (the prepared depth image,
the antipodal candidates, the task) and caches what several policies share (the NMS modes, model scores).

Grasp policies: ``policy(view, n, rng) -> GraspPick`` (n grasps with their source and score).
Action policies: ``policy(view, grasps, rng) -> ActionPick`` (one action per grasp, with its source).

They are the building blocks of the evaluation's planners too (Antipodal+Random is NMS grasps with
baseline random actions, TOG-Net is CEM grasps with the policy's mean, ...).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.collect.config import PolicyConfig
from tognet.data.episodes import ACTION_SOURCES, GRASP_SOURCES
from tognet.grasping import cem, nms
from tognet.grasping.antipodal import GraspCandidates, grasp_depths
from tognet.grasping.crops import CropConfig, extract_crops
from tognet.grasping.depth import DepthScene
from tognet.tasks import Task


@dataclass
class SceneView:
    """One observation as the policies see it, with a cache shared between them."""

    scene: DepthScene
    candidates: GraspCandidates
    task: Task | None
    crop: CropConfig
    cache: dict[str, Any] = field(default_factory=dict)

    def crops(self, grasps: NDArray[np.float64]) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The network inputs of world grasps: crops (N, S, S) and gripper depths z (N,)."""
        crops = extract_crops(self.scene, None, grasps, self.crop)
        return crops, grasp_depths(self.scene.camera, grasps).astype(np.float32)


@dataclass(frozen=True)
class GraspPick:
    """Grasps chosen by a grasp policy: (n, 4) world grasps, their source code and the score used."""

    grasps: NDArray[np.float64]
    source: NDArray[np.int8]
    score: NDArray[np.float32]


@dataclass(frozen=True)
class ActionPick:
    """Actions chosen by an action policy: (n, 4) and their source code."""

    actions: NDArray[np.float64]
    source: NDArray[np.int8]


def check_predictor_crops(predictor: Any, crop: CropConfig, what: str) -> None:
    """ValueError when a model was trained on crops made with another CropConfig than ``crop``."""
    trained = getattr(predictor, "crop_config", None)
    if trained is not None and trained != crop:
        diff = sorted(k for k, v in crop.to_dict().items() if trained.to_dict().get(k) != v)
        raise ValueError(f"{what}: trained on crops made with another CropConfig (differs in {diff})")


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

    def __init__(self, config: PolicyConfig, model: Any, kind: str = "task") -> None:
        self.config = config
        self.model = model
        self.kind = kind

    def best(self, view: SceneView, rng: np.random.Generator) -> tuple[NDArray[np.float64], float]:
        """The scene's CEM grasp and its score (cached on the view)."""
        key = f"cem_{self.kind}_{id(self.model)}"
        if key not in view.cache:
            field_name = {"task": "q_t", "grasp": "q_g"}[self.kind]

            def score(grasps: NDArray[np.float64]) -> NDArray[np.float64]:
                crops, z = view.crops(grasps)
                return np.asarray(getattr(self.model.predict(crops, z), field_name), dtype=np.float64)

            result = cem(score, view.candidates.grasps, self.config.cem, rng)
            view.cache[key] = (result.best, result.best_score)
        return view.cache[key]

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick:
        grasp, score = self.best(view, rng)
        return GraspPick(np.repeat(grasp[None], n, axis=0), np.full(n, GRASP_SOURCES["cem"], np.int8),
                         np.full(n, score, np.float32))


class UniformActions:
    """Uniformly random actions over the task's whole action box (round-1 exploration, epsilon_2)."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        task = _need_task(view)
        acts = np.stack([task.uniform_action(rng) for _ in range(len(grasps))]) if len(grasps) else \
            np.zeros((0, 4))
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["uniform"], np.int8))


class BaselineRandomActions:
    """The paper's baselines' random action: uniform within +-5 cm and +-pi/20 of the nominal start."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        task = _need_task(view)
        acts = np.stack([task.random_action(rng) for _ in range(len(grasps))]) if len(grasps) else \
            np.zeros((0, 4))
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["baseline_random"], np.int8))


class PolicyActions:
    """The Gaussian policy: the network's action mean f(o, g) plus N(0, noise^2) per dimension, clipped to
    the task's action box (noise zero: the mean, as when planning)."""

    def __init__(self, model: Any, noise: tuple[float, ...] | NDArray[np.float64] = (0.0,) * 4) -> None:
        self.model = model
        self.noise = np.asarray(noise, dtype=np.float64)

    def mean(self, view: SceneView, grasps: NDArray[np.float64]) -> NDArray[np.float64]:
        """The network's action mean for each grasp (N, 4)."""
        if len(grasps) == 0:
            return np.zeros((0, 4))
        crops, z = view.crops(grasps)
        return np.asarray(self.model.predict(crops, z).action_mean, dtype=np.float64)

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        task = _need_task(view)
        acts = self.mean(view, grasps) + rng.standard_normal((len(grasps), 4)) * self.noise
        acts = np.clip(acts, task.action_low, task.action_high)
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["policy"], np.int8))


class ExpertActions:
    """The simulator's hand-computed actions (:func:`tognet.sim.oracle.task_actions`) for each grasp, one
    of its candidates at random: privileged exploration for collection (``PolicyConfig.expert_actions``).
    ``sim`` must hold the view's scene (settled, as after ``sim.reset``)."""

    def __init__(self, sim: Any) -> None:
        self.sim = sim

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        from tognet.geometry import Grasp
        from tognet.sim.oracle import task_actions

        task = _need_task(view)
        acts = np.zeros((len(grasps), 4))
        for i, g in enumerate(grasps):
            candidates = task_actions(self.sim, Grasp.from_array(g))
            pick = candidates[int(rng.integers(len(candidates)))]
            acts[i] = np.clip(pick, task.action_low, task.action_high)
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["expert"], np.int8))


class NoActions:
    """The grasp-only task has no primitive: zero actions."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        return ActionPick(np.zeros((len(grasps), 4)), np.full(len(grasps), ACTION_SOURCES["none"], np.int8))


def _need_task(view: SceneView) -> Task:
    if view.task is None:
        raise ValueError("this action policy needs a task (the grasp-only task has no actions)")
    return view.task


def epsilon_mix(first: GraspPick | ActionPick, second: GraspPick | ActionPick,
                use_second: NDArray[np.bool_]) -> Any:
    """Per trial, the second pick where ``use_second`` else the first (epsilon-greedy mixing)."""
    if isinstance(first, GraspPick) and isinstance(second, GraspPick):
        return GraspPick(np.where(use_second[:, None], second.grasps, first.grasps),
                         np.where(use_second, second.source, first.source).astype(np.int8),
                         np.where(use_second, second.score, first.score).astype(np.float32))
    assert isinstance(first, ActionPick) and isinstance(second, ActionPick)
    return ActionPick(np.where(use_second[:, None], second.actions, first.actions),
                      np.where(use_second, second.source, first.source).astype(np.int8))
