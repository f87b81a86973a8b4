"""What a policy sees and returns: the :class:`SceneView` of one observation, the picks, the two shapes.

A :class:`SceneView` holds what every policy may look at for one observation (the prepared depth image,
the antipodal candidates, the task) and caches what several policies share (the NMS modes, model scores).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from tognet.grasping.antipodal import GraspCandidates, grasp_depths
from tognet.grasping.crops import CropConfig, extract_crops, resolve_crop
from tognet.grasping.depth import DepthScene
from tognet.tasks import Task


@dataclass
class SceneView:
    """One observation as the policies see it, with a cache shared between them.

    ``network_height``: None (the simulator's observations): the network's gripper depth z is the grasp
    centre's depth from the image's own camera. A height (m) above the table (a user's camera, anywhere and
    tilted any way): z is the grasp centre's depth from a camera looking straight down from there, the
    training camera's, so that the network gets the z it was trained on."""

    scene: DepthScene
    candidates: GraspCandidates
    task: Task | None
    crop: CropConfig
    cache: dict[str, Any] = field(default_factory=dict)
    network_height: float | None = None

    def crops(self, grasps: NDArray[np.float64]) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The network inputs of grasps (the scene's frame): crops (N, S, S) and gripper depths z (N,)."""
        crops = extract_crops(self.scene, None, grasps, self.crop)
        if self.network_height is None:
            return crops, grasp_depths(self.scene.camera, grasps).astype(np.float32)
        z = self.network_height - np.asarray(grasps, dtype=np.float64).reshape(-1, 4)[:, 2]
        return crops, z.astype(np.float32)


@dataclass(frozen=True)
class GraspPick:
    """Grasps chosen by a grasp policy: (n, 4) world grasps, their source code and the score used (the
    policy's own: what it ranks grasps by)."""

    grasps: NDArray[np.float64]
    source: NDArray[np.int8]
    score: NDArray[np.float32]


@dataclass(frozen=True)
class ActionPick:
    """Actions chosen by an action policy: (n, 4) and their source code."""

    actions: NDArray[np.float64]
    source: NDArray[np.int8]


class GraspPolicy(Protocol):
    """``policy(view, n, rng) -> GraspPick``: ``n`` grasps for the view's observation."""

    def __call__(self, view: SceneView, n: int, rng: np.random.Generator) -> GraspPick: ...


class ActionPolicy(Protocol):
    """``policy(view, grasps, rng) -> ActionPick``: one action for each of ``grasps`` (n, 4)."""

    def __call__(self, view: SceneView, grasps: NDArray[np.float64], rng: np.random.Generator
                 ) -> ActionPick: ...


def need_task(view: SceneView) -> Task:
    """The view's task (ValueError for the grasp-only task, which has no actions)."""
    if view.task is None:
        raise ValueError("this action policy needs a task (the grasp-only task has no actions)")
    return view.task


def check_predictor_crops(predictor: Any, crop: CropConfig, what: str) -> None:
    """ValueError, prefixed with ``what``, when a model was trained on crops made with another CropConfig
    than ``crop`` (:func:`tognet.grasping.crops.resolve_crop`)."""
    try:
        resolve_crop([predictor], crop)
    except ValueError as exc:
        raise ValueError(f"{what}: {exc}") from None
