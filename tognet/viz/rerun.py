"""Rerun recordings (``.rrd``, the optional extra ``rerun``) of a plan and of a simulated episode, to look at
in Rerun's 3-D viewer (``rerun FILE.rrd``).

A plan (``tognet plan --rerun``), under ``world`` (the camera pose's world frame; the plan's table frame
when no pose was given), the table frame as ``world/table``:

* ``world/table/depth``: the depth image as a point cloud, coloured by height above the table;
* ``world/table/objects``: the objects seen on the table (their centres, labelled, the one planned on first);
* ``world/table/candidates``: the grasps the method ranked, coloured by its score (red low, green high);
* ``world/table/grasp``, ``world/table/alternatives``: the chosen grasp as a gripper (two fingers and the
  palm), and the alternatives;
* ``world/motion``: with a reference point, the task's motion from the start pose (where the tool's start
  pose is, then the primitive's path);
* ``world/arm`` (with ``--robot``): the hand's pose at each waypoint and ``world/arm/joints/<name>`` the
  joint angles, on the timeline ``time`` (seconds at the joints' speed limits).

An episode (``tognet sim --rerun``): each body's shapes once, its pose over the timeline ``sim_time``, and
the outcome (labels, failure) as a text at the end.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError

EXTRA_HINT = "pip install 'tognet[rerun]'"
#: The gripper drawn: finger length (m) and the palm above it.
FINGER = 0.05


def require_rerun() -> Any:
    """The rerun module; TognetError with the install hint without the extra."""
    try:
        import rerun
    except ImportError:
        raise TognetError(f"--rerun needs the rerun extra (rerun-sdk): {EXTRA_HINT}") from None
    return rerun


def _recording(name: str, path: str | Path) -> Any:
    rr = require_rerun()
    rec = rr.RecordingStream(f"tognet {name}")
    rec.save(str(path))  # the caller's path: tognet.io.atomic_path's
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    return rec


def _score_colours(scores: NDArray[np.float64]) -> NDArray[np.uint8]:
    s = np.asarray(scores, dtype=np.float64)
    span = float(s.max() - s.min()) if len(s) else 0.0
    t = (s - s.min()) / span if span > 0 else np.ones(len(s))
    return np.stack([255 * (1 - t), 255 * t, 60 * np.ones(len(s))], axis=1).astype(np.uint8)


def gripper_strips(grasp: NDArray[np.float64], width: float) -> list[NDArray[np.float64]]:
    """Line strips of a top-down gripper at ``grasp`` (x, y, z, phi): the two fingers and the palm."""
    x, y, z, phi = (float(v) for v in grasp)
    jaw = np.array([math.cos(phi), math.sin(phi), 0.0])
    centre = np.array([x, y, z])
    tips = [centre + s * 0.5 * width * jaw for s in (-1.0, 1.0)]
    tops = [t + np.array([0.0, 0.0, FINGER]) for t in tips]
    return [np.array([tips[0], tops[0], tops[1], tips[1]]),
            np.array([centre + [0, 0, FINGER], centre + [0, 0, FINGER + 0.04]])]


def _depth_points(plan: Any, image: NDArray[np.float32], stride: int = 2
                  ) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """The measured pixels (every ``stride``-th) as points in the table frame, coloured by height."""
    cam = plan.camera
    k = cam.intrinsics
    v, u = np.mgrid[0:k.height:stride, 0:k.width:stride]
    d = image[::stride, ::stride]
    ok = np.isfinite(d) & (d > 0)
    z = d[ok].astype(np.float64)
    pc = np.stack([(u[ok] - k.cx) * z / k.fx, (v[ok] - k.cy) * z / k.fy, z], axis=1)
    pose = plan.table_from_camera
    pts = pc @ pose[:3, :3].T + pose[:3, 3]
    h = np.clip(pts[:, 2] / 0.15, 0.0, 1.0)
    colours = np.stack([80 + 175 * h, 80 + 100 * h, 200 - 150 * h], axis=1).astype(np.uint8)
    return pts, colours


def log_plan(path: str | Path, plan: Any, image: NDArray[np.float32], width: float, task: Any,
             reference: Any = None) -> Path:
    """Write a plan's recording (see the module docstring); ``image``: the depth image planned on
    (metres, NaN holes), ``width``: the gripper's opening (m), ``task``: the task (its primitive)."""
    rr = require_rerun()
    rec = _recording("plan", path)
    world_from_table = (np.eye(4) if plan.world_from_camera is None
                        else plan.world_from_camera @ np.linalg.inv(plan.table_from_camera))
    frame = rr.Transform3D(translation=world_from_table[:3, 3], mat3x3=world_from_table[:3, :3])
    rec.log("world/table", frame, static=True)
    pts, colours = _depth_points(plan, image)
    rec.log("world/table/depth", rr.Points3D(pts, colors=colours, radii=0.0015), static=True)
    objects = [plan.object, *(o for o in plan.objects if o["index"] != plan.object["index"])]
    rec.log("world/table/objects", rr.Points3D(
        [[*o["centre_table_m"][:2], o["height_m"]] for o in objects], radii=0.008,
        labels=[f"#{o['index']} {'planned on' if i == 0 else ''}".strip() for i, o in enumerate(objects)]),
        static=True)
    if plan.scored is not None:
        grasps, scores, what = plan.scored
        dots = rr.Points3D(grasps[:, :3], colors=_score_colours(scores), radii=0.003)
        rec.log("world/table/candidates", dots, static=True)
        rec.log("world/table/candidates/score", rr.TextDocument(f"coloured by {what}: red low, green high"),
                static=True)
    rec.log("world/table/grasp", rr.LineStrips3D(gripper_strips(plan.grasp.table, width), colors=[0, 220, 90],
                                                 radii=0.003, labels=[f"{plan.method}", ""]), static=True)
    alt = [s for g in plan.alternatives for s in gripper_strips(g.table, width)]
    if alt:
        rec.log("world/table/alternatives", rr.LineStrips3D(alt, colors=[120, 160, 230], radii=0.0015),
                static=True)
    _log_motion(rec, rr, plan, task, reference)
    _log_arm(rec, rr, plan)
    rec.flush()
    return Path(path)


def _log_motion(rec: Any, rr: Any, plan: Any, task: Any, reference: Any) -> None:
    """The task's motion from the start pose (needs the reference point)."""
    g = plan.grasp
    if reference is None or g.start_position is None:
        rec.log("world/motion", rr.TextDocument(
            f"action {np.round(g.action, 4).tolist()} (start pose relative to the task's reference point: "
            "give --reference to see the motion)"), static=True)
        return
    path = [np.asarray(g.start_position, dtype=np.float64)]
    for motion in task.primitive():
        path.append(path[-1] + np.asarray(motion.delta, dtype=np.float64))
    rec.log("world/motion", rr.LineStrips3D([np.array(path)], colors=[250, 170, 40], radii=0.003,
                                            labels=["the task's motion"]), static=True)
    rec.log("world/motion/reference", rr.Points3D([np.asarray(reference, dtype=np.float64)], radii=0.01,
                                                  labels=["reference"]), static=True)


def _log_arm(rec: Any, rr: Any, plan: Any) -> None:
    """The arm's waypoints over time: the hand's pose and each joint's angle."""
    if plan.robot is None:
        return
    names = plan.robot.joint_names
    for w in plan.robot.waypoints:
        rec.set_time("time", duration=float(w["time"]))
        x, y, z, _ = w["pose"]
        rec.log("world/arm/hand", rr.Points3D([[x, y, z]], radii=0.01, labels=[w["step"]]))
        for name, q in zip(names, w["q"], strict=True):
            rec.log(f"world/arm/joints/{name}", rr.Scalars(float(q)))


# --- an episode ------------------------------------------------------------------------------------------
def _shape_archetype(rr: Any, shape: Any) -> Any:
    colour = (np.clip(shape.rgba, 0, 1) * 255).astype(np.uint8)
    if shape.kind == "mesh" and shape.vertices is not None:
        return rr.Mesh3D(vertex_positions=shape.vertices, triangle_indices=shape.faces, albedo_factor=colour)
    if shape.kind == "box":
        return rr.Boxes3D(half_sizes=[shape.size[:3]], colors=[colour])
    if shape.kind in ("cylinder", "capsule"):
        return rr.Cylinders3D(lengths=[2 * shape.size[1]], radii=[shape.size[0]], colors=[colour])
    return rr.Ellipsoids3D(half_sizes=[shape.size[:3] if shape.kind == "ellipsoid" else [shape.size[0]] * 3],
                           colors=[colour])


def log_episode(path: str | Path, trace: Any, result: Any, grasp: Any, action: Any) -> Path:
    """Write an episode's recording from a :class:`tognet.sim.trace.PoseTrace` and the trial's result."""
    rr = require_rerun()
    rec = _recording("episode", path)
    for i, shape in enumerate(trace.shapes):
        entity = f"world/bodies/{shape.body}/geom_{i}"
        w, x, y, z = shape.quat
        rec.log(entity, rr.Transform3D(translation=shape.pos, quaternion=rr.Quaternion(xyzw=[x, y, z, w])),
                static=True)
        rec.log(entity, _shape_archetype(rr, shape), static=True)
    for t, pos, quat in zip(trace.times, trace.positions, trace.quats, strict=True):
        rec.set_time("sim_time", duration=t)
        for name, p, (w, x, y, z) in zip(trace.bodies, pos, quat, strict=True):
            if name == "world":  # the table and the scenery do not move
                continue
            rec.log(f"world/bodies/{name}", rr.Transform3D(translation=p, quaternion=rr.Quaternion(
                xyzw=[x, y, z, w])))
    end = trace.times[-1] if trace.times else 0.0
    rec.set_time("sim_time", duration=end)
    rec.log("outcome", rr.TextDocument(
        f"grasp {np.round(np.asarray(grasp, dtype=np.float64), 4).tolist()}, action "
        f"{np.round(np.asarray(action, dtype=np.float64), 4).tolist()}: grasp_success={result.grasp_success} "
        f"task_success={result.task_success} valid={result.valid} failure={result.failure.value}"))
    rec.log("outcome/task_success", rr.Scalars(float(result.task_success)))
    rec.flush()
    return Path(path)
