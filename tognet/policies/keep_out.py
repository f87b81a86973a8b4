"""Keep the tool off the task's props at the start pose, from what the depth image shows of it.

A task whose props stand at places its reference point fixes (pulling's can: :meth:`Task.keep_out`)
fails whenever the tool is brought down onto them before the motion. Where the tool will be at the start
pose follows from the image alone, up to how it moves in the hand: the pixels of the object under each
grasp (the connected region of the height map above the table that holds the grasp centre), taken into
the gripper's frame at the grasp and carried with it to the start pose of an action. An action's
*clearance* is the smallest horizontal distance from those points to a prop's side, over the props the
tool's column (from the table under it up to its top, carried the same way) reaches in height; the action
search takes :attr:`ActionSearchConfig.keep_out_penalty` off the score of every action whose clearance is
below :attr:`ActionSearchConfig.keep_out_margin` (the margin: the tool's slip in the hand and the execution
noise). Pure numpy, no simulator state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from tognet.grasping.depth import DepthScene
from tognet.tasks import Task
from tognet.tasks.base import KeepOut

#: Pixels this high above the table (m) or higher are an object's.
ABOVE_TABLE = 0.004
#: Points kept per grasp (the object's pixels thinned evenly to at most this many).
POINTS = 256


@dataclass(frozen=True)
class Footprints:
    """Each candidate grasp's object in that grasp's gripper frame (origin at the grasp centre): ``xy``
    (N, P, 2; x along the jaw axis, y across it, m), each point's column from ``low`` to ``high`` (N, P;
    z, m; from the image: the table under the grasp up to the object's top), and ``seen`` (N,): whether
    the grasp centre lies on an object's pixels at all (False: no points, no penalty)."""

    xy: NDArray[np.float64]
    low: NDArray[np.float64]
    high: NDArray[np.float64]
    seen: NDArray[np.bool_]


def object_points(scene: DepthScene) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    """World points of the pixels above the table (M, 3; z the height map's) and the label of each
    pixel's connected object region (H, W; 0 on the table)."""
    above = np.isfinite(scene.height) & (scene.height > ABOVE_TABLE)
    labels, _ = ndimage.label(above, structure=np.ones((3, 3), bool))
    pts = scene.camera.deproject(scene.filled)[above]
    pts[:, 2] = scene.height[above]
    return pts, labels.astype(np.int32)


def _nearest_label(labels: NDArray[np.int32], within: float = 4.0) -> NDArray[np.int32]:
    """Each pixel's object label, or the nearest object pixel's within ``within`` pixels (a grasp centre
    projected from inside a thin object can land beside its outline), else 0."""
    if not labels.any():
        return labels
    dist, (r, c) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
    return np.where(dist <= within, labels[r, c], 0).astype(np.int32)


def _thin(pts: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """At most ``n`` of ``pts``, evenly spaced in their order; repeated to exactly ``n``."""
    idx = np.linspace(0, len(pts) - 1, n).round().astype(np.intp)
    return pts[idx]


def footprints(scene: DepthScene, grasps: NDArray[np.float64], points: int = POINTS) -> Footprints:
    """The object under each of ``grasps`` (N, 4; world x, y, z, phi) in its gripper frame."""
    grasps = np.asarray(grasps, np.float64).reshape(-1, 4)
    n = len(grasps)
    pts, labels = object_points(scene)
    flat = labels[np.isfinite(scene.height) & (scene.height > ABOVE_TABLE)]
    u, v = scene.camera.project(grasps[:, :3])[0].T
    h, w = labels.shape
    col, row = np.clip(np.rint(u), 0, w - 1).astype(int), np.clip(np.rint(v), 0, h - 1).astype(int)
    under = _nearest_label(labels)[row, col]
    xy, low, high = np.zeros((n, points, 2)), np.zeros((n, points)), np.zeros((n, points))
    seen = under > 0
    for lab in np.unique(under[seen]):
        own = _thin(pts[flat == lab], points)
        for i in np.flatnonzero(under == lab):
            c, s = np.cos(grasps[i, 3]), np.sin(grasps[i, 3])
            d = own[:, :2] - grasps[i, :2]
            xy[i] = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
            low[i], high[i] = -grasps[i, 2], own[:, 2] - grasps[i, 2]
    return Footprints(xy, low, high, seen)


def clearance(fp: Footprints, rows: NDArray[np.intp], actions: NDArray[np.float64], task: Task,
              props: tuple[KeepOut, ...]) -> NDArray[np.float64]:
    """(M, K) clearance (m; negative: overlapping) of actions (M, K, 4) for the grasps ``rows`` (M,) of
    ``fp``: the smallest horizontal distance from the tool's points at the start pose to the side of a
    prop its column reaches in height (+inf where none does, or the grasp's object was not seen)."""
    c = task.config
    off = np.asarray(c.nominal_offset, np.float64)
    yaw = c.nominal_yaw + actions[..., 3]
    cy, sy = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    px, py = fp.xy[rows, None, :, 0], fp.xy[rows, None, :, 1]
    x = off[0] + actions[..., 0, None] + cy * px - sy * py  # (M, K, P), from the reference point
    y = off[1] + actions[..., 1, None] + sy * px + cy * py
    z = off[2] + actions[..., 2, None]
    low, high = z + fp.low[rows, None], z + fp.high[rows, None]
    best = np.full(actions.shape[:2], np.inf)
    for prop in props:
        reach = (low < prop.top) & (high > prop.bottom)
        d = np.where(reach, np.hypot(x - prop.offset[0], y - prop.offset[1]), np.inf).min(axis=2)
        best = np.minimum(best, d - prop.radius)
    return np.where(fp.seen[rows, None], best, np.inf)


class KeepOutPenalty:
    """``penalty(rows, actions) -> (M, K)``: the score taken off each action (``penalty`` where its
    clearance is below ``margin``, else 0) for the candidate grasps ``rows`` of one scene."""

    def __init__(self, fp: Footprints, task: Task, margin: float, penalty: float) -> None:
        self.props = task.keep_out()
        self.task, self.margin, self.penalty, self.fp = task, margin, penalty, fp

    def __call__(self, rows: NDArray[np.intp], actions: NDArray[np.float64]) -> NDArray[np.float64]:
        near = clearance(self.fp, np.asarray(rows, np.intp), np.asarray(actions, np.float64), self.task,
                         self.props) < self.margin
        return near * self.penalty
