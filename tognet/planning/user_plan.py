"""What a plan on a user's depth image says (:mod:`tognet.planning.user`): the grasp in every frame with the
method's own scores and its action, the alternatives, the arm's trajectory, and the JSON of ``tognet plan
--out``."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Camera, CameraIntrinsics
from tognet.io import atomic_write_bytes
from tognet.planning.reach import ReachChoice
from tognet.planning.table import TablePlane
from tognet.tasks import reference_points


@dataclass(frozen=True)
class PlannedGrasp:
    """One planned grasp in every frame, its scores and its action.

    ``table``: (x, y, z, phi) in the table frame (m, rad; the gripper points down along -z, phi the jaw
    axis' yaw); ``world``: the same in the world frame (None without a camera pose); ``camera_from_gripper``:
    4 x 4 pose in the camera frame (gripper x = jaw axis, z = the table's up, origin at the grasp centre);
    ``pixel``: (u, v) of the grasp centre. ``scores``: the method's own (:attr:`tognet.planning.Plan.own`:
    ``score``, what it ranked by, and its parts, e.g. ``q_g``, ``q_t_given_g`` or ``q_t_given_ga``, ``q_t``).
    ``action``: (a_x, a_y, a_z, a_phi), the start pose of the task's
    motion relative to its reference point; ``start_offset`` / ``start_yaw``: the start position minus the
    reference point (m) and the absolute start yaw (rad) it means (task frame axes); ``start_position``: the
    absolute start position when a reference point was given (same frame as ``world`` or else ``table``)."""

    table: NDArray[np.float64]
    camera_from_gripper: NDArray[np.float64]
    world: NDArray[np.float64] | None
    pixel: NDArray[np.float64]
    scores: dict[str, float]
    action: NDArray[np.float64]
    start_offset: NDArray[np.float64]
    start_yaw: float
    start_position: NDArray[np.float64] | None = None

    @property
    def score(self) -> float:
        """The method's own score of this grasp and action (what it ranked by)."""
        return self.scores["score"]

    @property
    def q_g(self) -> float | None:
        """Q_G of the grasp (None for a method without a model)."""
        return self.scores.get("q_g")

    @property
    def q_t(self) -> float | None:
        """Q_T of the grasp and its action (Q_G x Q_T|G, or x Q_T|G,a for the action search; None for a
        method without a task model)."""
        return self.scores.get("q_t")

    @property
    def q_t_given_g(self) -> float | None:
        """Q_T|G (TOG-Net's task model), else Q_T|G,a of the chosen action (the action search), else None."""
        return self.scores.get("q_t_given_g", self.scores.get("q_t_given_ga"))

    def describe_scores(self) -> str:
        """The scores in one line, e.g. ``score 0.412: Q_T 0.412 = Q_T|G,a 0.52 x Q_G 0.79``."""
        s = self.scores
        text = f"score {s['score']:.3f}"
        if "q_t" in s:
            cond = "Q_T|G,a" if "q_t_given_ga" in s else "Q_T|G"
            text += f" (Q_T {s['q_t']:.3f} = {cond} {self.q_t_given_g:.3f} x Q_G {s['q_g']:.3f})"
        elif "q_g" in s:
            text += f" (Q_G {s['q_g']:.3f})"
        return text

    @property
    def camera_position(self) -> NDArray[np.float64]:
        """Grasp centre in the camera frame (m)."""
        return self.camera_from_gripper[:3, 3].copy()

    @property
    def camera_jaw_axis(self) -> NDArray[np.float64]:
        """Unit jaw axis (from phi's negative to positive finger) in the camera frame."""
        return self.camera_from_gripper[:3, 0].copy()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description."""
        r = _rounded
        names = ("x", "y", "z", "phi")
        return {
            "table": dict(zip(names, r(self.table), strict=True)),
            "world": None if self.world is None else dict(zip(names, r(self.world), strict=True)),
            "camera": {"position": r(self.camera_position), "jaw_axis": r(self.camera_jaw_axis),
                       "approach": r(-self.camera_from_gripper[:3, 2]),
                       "camera_from_gripper": r(self.camera_from_gripper)},
            "pixel": r(self.pixel, 1),
            **{k: r(v) for k, v in self.scores.items()},
            "action": r(self.action),
            "start_pose": {"offset_from_reference": r(self.start_offset), "yaw": r(self.start_yaw),
                           "position": None if self.start_position is None else r(self.start_position)},
        }


@dataclass(frozen=True)
class ArmPlan:
    """The arm's side of a plan (``robot=``, ``tognet plan --robot``): the arm, its base (in ``frame``: the
    camera pose's world frame, else the plan's table frame; the frame of the reference point too), and the
    chosen grasp's trial as joint waypoints (:meth:`tognet.planning.reach.ReachChoice.waypoints`: per step,
    the hand's pose in ``frame``, the joint angles and the earliest time at the joints' speed limits)."""

    arm: str
    frame: str
    base_position: tuple[float, float, float]
    base_yaw: float
    joint_names: list[str]
    choice: ReachChoice

    @property
    def waypoints(self) -> list[dict[str, Any]]:
        return self.choice.waypoints()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (the plan's ``robot`` section)."""
        c = self.choice
        names = ("x", "y", "z", "phi")
        steps = [{"step": w["step"], "pose": dict(zip(names, _rounded(np.array(w["pose"]), 5), strict=True)),
                  "q": _rounded(np.array(w["q"]), 5), "time_s": _rounded(w["time"])} for w in c.waypoints()]
        return {
            "arm": self.arm,
            "frame": self.frame,
            "base": {"position": _rounded(np.array(self.base_position)), "yaw": _rounded(self.base_yaw)},
            "joint_names": list(self.joint_names),
            "trajectory": steps,
            "duration_s": _rounded(c.reach.path.min_duration),
            "times": "the earliest time each step can be reached, from the first, with every joint at most "
                     "at its speed limit (joint-space moves between the waypoints)",
            "with_task": c.with_task,
            "wrist_turn": _rounded(c.reach.turn),
            "candidates": c.dropped.candidates,
            "beyond_reach": c.dropped.count,
            "checked": c.checked,
            "passed_over": [{"grasp": _rounded(p.grasp), "step": p.what, "reason": p.reason}
                            for p in c.passed],
        }


@dataclass(frozen=True)
class UserPlan:
    """A plan on a user's depth image: the chosen grasp and action, alternatives, frames and diagnostics.

    ``method``: the method that planned (a row of :mod:`tognet.planning.methods`), ``models``: the checkpoint
    of each model it used (by what it is: grasp, task, search; ``checkpoint``: the first), ``score``: what
    its score is, ``confidence``: the low-confidence threshold the plan was held against and where it comes
    from. ``scored``: the grasps the method ranked (table frame, (N, 4)) with its scores and what those are
    (the antipodal candidates with their antipodal quality where it ranked nothing more); not in the JSON.
    ``timing``: seconds per stage (read, table, objects, candidates, then the method's: grasp, action,
    alternatives, rate, with an arm reach) and ``total`` (the models' loading is not part of it).
    ``warnings``: one line each (several objects, low confidence, ...). ``objects``:
    every region seen standing on the table (:meth:`tognet.planning.segment.TableObject.describe`: those
    that look like something to pick up first, each with its index and, if not, why); ``object``: the one
    planned on, with ``why`` it was chosen."""

    task: str
    grasp: PlannedGrasp
    alternatives: list[PlannedGrasp]
    table_from_camera: NDArray[np.float64]
    world_from_camera: NDArray[np.float64] | None
    plane: TablePlane
    objects: list[dict[str, Any]]
    object: dict[str, Any]
    candidates: int
    timing: dict[str, float]
    warnings: list[str] = field(default_factory=list)
    checkpoint: str | None = None
    method: str = "TOG-Net"
    models: dict[str, str] = field(default_factory=dict)
    score: str = ""
    confidence: dict[str, Any] = field(default_factory=dict)
    scored: tuple[NDArray[np.float64], NDArray[np.float64], str] | None = None
    seed: int = 0
    intrinsics: CameraIntrinsics | None = None
    robot: ArmPlan | None = None

    @property
    def action(self) -> NDArray[np.float64]:
        """The chosen grasp's action (a_x, a_y, a_z, a_phi)."""
        return self.grasp.action

    @property
    def camera(self) -> Camera | None:
        """The camera in the table frame (what the plan was computed with)."""
        return None if self.intrinsics is None else Camera(self.intrinsics, self.table_from_camera)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description of everything (``tognet plan --out``)."""
        return {
            "task": self.task,
            "method": self.method,
            "models": dict(self.models),
            "checkpoint": self.checkpoint,
            "score": self.score,
            "confidence": self.confidence,
            "seed": self.seed,
            "grasp": self.grasp.to_dict(),
            "alternatives": [g.to_dict() for g in self.alternatives],
            "warnings": list(self.warnings),
            "frames": {
                "table": "z up along the table's normal, origin on the table top below the camera's centre, "
                         "x along the image's x axis laid onto the table",
                "camera": "OpenCV: x right, y down, z forward (viewing direction)",
                "world": "the camera pose's world frame (z = 0: the table top)" if self.world_from_camera
                is not None else None,
                "table_from_camera": _rounded(self.table_from_camera, 6),
                "world_from_camera": None if self.world_from_camera is None
                else _rounded(self.world_from_camera, 6),
                "action": "start pose of the task's motion relative to its reference point ("
                          f"{reference_points()}), task frame axes",
            },
            "table_plane": {"source": "fitted" if self.plane.fitted else "camera pose",
                            "camera_height_m": _rounded(self.plane.offset),
                            "tilt_deg": _rounded(self.plane.tilt, 2),
                            "inlier_fraction": _rounded(self.plane.inliers, 3),
                            "rms_m": _rounded(self.plane.rms, 5)},
            "object": self.object,
            "objects": self.objects,
            "candidates": self.candidates,
            "timing_ms": {k: round(1000 * v, 2) for k, v in self.timing.items()},
            **({"robot": self.robot.to_dict()} if self.robot is not None else {}),
        }

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` as JSON (atomically: a reader never sees half a file)."""
        return atomic_write_bytes(path, (json.dumps(self.to_dict(), indent=2) + "\n").encode(), fsync=False)


def _rounded(value: Any, digits: int = 4) -> Any:
    if isinstance(value, np.ndarray):
        return np.round(value.astype(np.float64), digits).tolist()
    return round(float(value), digits)
