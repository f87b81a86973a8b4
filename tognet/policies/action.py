"""Action policies: uniform exploration, the baselines' random action, the Gaussian policy, the
simulator's expert actions (collection only) and the grasp-only task's none."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.data.format import ACTION_SOURCES
from tognet.policies.view import ActionPick, SceneView, need_task


class UniformActions:
    """Uniformly random actions over the task's whole action box (round-1 exploration, epsilon_2)."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        task = need_task(view)
        acts = np.stack([task.uniform_action(rng) for _ in range(len(grasps))]) if len(grasps) else \
            np.zeros((0, 4))
        return ActionPick(acts, np.full(len(grasps), ACTION_SOURCES["uniform"], np.int8))


class BaselineRandomActions:
    """The paper's baselines' random action: uniform within +-5 cm and +-pi/20 of the nominal start."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator) -> ActionPick:
        task = need_task(view)
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
        task = need_task(view)
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

        task = need_task(view)
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
