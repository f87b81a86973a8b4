"""Hand-computed ("oracle") actions for any grasp on any object, from the settled scene's geometry.

Used to measure whether a task is feasible at all on an object (some (grasp, action) succeeds), by the
scripted diagnostics, by the evaluation's Oracle and, when a collection round asks for it
(``PolicyConfig.expert_actions``), as privileged exploration while collecting training data; never by a
planner a robot could run (they read the simulator's ground truth).

The tool is assumed to stay in the hand as it was grasped: its vertices are taken from the settled pose
into the gripper frame (x = jaw axis at yaw phi, z up, origin at the grasp centre). The start yaw of both
tasks is absolute, so the grasp's phi versus phi + pi decides which side of the hand the tool is on.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.sim.simulator import Simulator


def _rot(a: float) -> NDArray[np.float64]:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def tool_in_gripper(sim: Simulator, grasp: Grasp, in_hand: object = None) -> NDArray[np.float64]:
    """(N, 3) collision vertices of the object in the gripper frame of ``grasp``: from ``in_hand`` (the
    (3, 4) pose a trial's ``info["in_hand"]`` reports after the lift) if given, else the settled pose."""
    if in_hand is not None:
        pose = np.asarray(in_hand, dtype=np.float64)
        return sim.vertices @ pose[:, :3].T + pose[:, 3]
    pos, rot = sim.object_pose()
    world = sim.vertices @ rot.T + pos
    d = world - grasp.position
    r = _rot(-grasp.phi)
    xy = d[:, :2] @ r.T
    return np.column_stack([xy, d[:, 2]])


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def hammer_actions(
    sim: Simulator,
    grasp: Grasp,
    n_points: int = 3,
    impact_angles: tuple[float, ...] = (-0.1, 0.15),
    in_hand: object = None,
) -> list[NDArray[np.float64]]:
    """Candidate hammering actions for ``grasp``: the tool's farthest points from the grasp axis strike
    the peg's free end (moving along +x at impact, ``impact_angle`` before that), 45 degrees into the swing
    (or wherever the action box's yaw limits put it), at the peg's height. Clipped to the action box."""
    task = sim.task
    assert task is not None and sim.task_name == "hammering"
    c = sim.config.hammering
    pts = tool_in_gripper(sim, grasp, in_hand)
    radius = np.hypot(pts[:, 0], pts[:, 1])
    ref = np.asarray(sim.scene["reference"])
    target = np.array([ref[0] - 0.5 * c.peg_length, ref[1]])
    bottom = float(pts[:, 2].min())
    lo, hi = task.action_low, task.action_high
    out: list[NDArray[np.float64]] = []
    # Striking candidates: the farthest vertex in each of a few angular sectors around the grasp axis.
    ang = np.arctan2(pts[:, 1], pts[:, 0])
    sectors = np.floor((ang + np.pi) / (np.pi / 4)).astype(int)
    best = []
    for s in np.unique(sectors):
        idx = np.flatnonzero(sectors == s)
        best.append(idx[np.argmax(radius[idx])])
    best = sorted(best, key=lambda i: -radius[i])[:n_points]
    for i in best:
        p = pts[i]
        alpha = float(np.arctan2(p[1], p[0]))
        # Vertices near the striking point (within 2 cm in xy) give the height of the striking region.
        near = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1]) < 0.02
        mid = 0.5 * float(pts[near, 2].min() + pts[near, 2].max())
        grip_z = max(ref[2] - mid, ref[2] - 0.5 * c.peg_size + 0.004 - float(pts[near, 2].min()))
        grip_z = max(grip_z, 0.004 - bottom)
        for impact in impact_angles:
            yaw_imp = -np.pi / 2 - alpha + impact
            yaw_start = yaw_imp - np.pi / 4
            a_phi = _wrap(yaw_start - c.nominal_yaw)
            a_phi = float(np.clip(a_phi, lo[3], hi[3]))
            # If the yaw was clipped, the impact comes earlier or later in the swing: keep the geometry.
            grip_xy = target - _rot(yaw_imp) @ p[:2]
            a = np.array([*(np.array([*grip_xy, grip_z]) - ref - np.asarray(c.nominal_offset)), a_phi])
            out.append(np.clip(a, lo, hi))
    return out


def sweep_actions(
    sim: Simulator,
    grasp: Grasp,
    yaws: tuple[float, ...] = (-np.pi / 4, -np.pi / 8, 0.0, np.pi / 8, np.pi / 4),
    in_hand: object = None,
) -> list[NDArray[np.float64]]:
    """Candidate sweeping actions for ``grasp``: at each start yaw, the tool's footprint centred on the
    cans in x, its leading edge 3 cm behind the nearest can, its lowest point 8 mm above the table."""
    task = sim.task
    assert task is not None and sim.task_name == "sweeping"
    c = sim.config.sweeping
    pts = tool_in_gripper(sim, grasp, in_hand)
    ref = np.asarray(sim.scene["reference"])
    cans = sim.scene["layout"]["cans"]
    can_y_min = min(y for _, y, _ in cans)
    out = []
    for a_phi in yaws:
        yaw = c.nominal_yaw + a_phi
        xy = pts[:, :2] @ _rot(yaw).T
        centre_x = 0.5 * (xy[:, 0].min() + xy[:, 0].max())
        front = xy[:, 1].max()
        grip = np.array([ref[0] - centre_x, can_y_min - c.can_radius - 0.03 - front, 0.008 - pts[:, 2].min()])
        a = np.array([*(grip - ref - np.asarray(c.nominal_offset)), a_phi])
        out.append(np.clip(a, task.action_low, task.action_high))
    return out


def task_actions(sim: Simulator, grasp: Grasp, in_hand: object = None) -> list[NDArray[np.float64]]:
    """The candidate actions of the simulator's task for ``grasp`` (:func:`hammer_actions` or
    :func:`sweep_actions`); ``in_hand`` as there (default: the tool as it lies, taken into the hand)."""
    if sim.task_name == "hammering":
        return hammer_actions(sim, grasp, in_hand=in_hand)
    if sim.task_name == "sweeping":
        return sweep_actions(sim, grasp, in_hand=in_hand)
    raise ValueError(f"no hand-computed actions for task {sim.task_name!r}")
