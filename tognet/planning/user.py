"""Plan a task-oriented grasp and motion on a user's own depth image, with a trained TOG-Net.

    planner = UserPlanner("hammering", "runs/hammering/round3/model/best.pt")   # default: the shipped model
    plan = planner.plan("depth.png", "intrinsics.json")                          # camera pose optional
    plan.grasp.table, plan.grasp.q_t, plan.grasp.action                          # see UserPlan / PlannedGrasp
    # or in one call (loads the model each time it is not cached):
    plan = tognet.plan("depth.png", "intrinsics.json", task="hammering")

Stages (each timed in ``plan.timing``):

1. **read**: the depth image (16-bit PNG millimetres, .npy/.npz metres or integer millimetres), the
   intrinsics and the optional camera pose (:mod:`tognet.planning.camera`), checked against each other.
2. **table**: the table plane, from the camera pose when given, else fitted to the image (RANSAC + least
   squares), and the table frame every stage works in (z up, origin below the camera, x along the image's
   x: the plan does not depend on where a user's world frame is). Per-pixel heights above the table are
   computed; holes (zeros, NaN: no reading) are filled in height, each from its lowest neighbouring
   surface (:func:`tognet.grasping.depth.fill_holes_by_height`), for the sampler and the crops only.
3. **objects**: what stands on the table, from measured pixels only (a hole never makes or enlarges an
   object; :func:`tognet.planning.camera.segment_objects`), each judged on whether it looks like something
   a gripper picks up (size, height, share measured, not a wall). The plan is made on the largest that
   does near the image's centre (else the nearest to it; the next one when the gripper finds no grasp on
   it), or on the one the caller names (``object``: index or pixel); every other is replaced by the table.
   Nothing to choose is an error that lists what was seen.
4. **candidates**: antipodal candidates (:func:`tognet.grasping.sample_antipodal`, both jaw orientations).
5. **grasp**: the cross-entropy method on Q_T = Q_T|G * Q_G (:class:`tognet.policies.grasp.CEMGrasp`, as the
   TOG-Net planner of the evaluation and the collection's greedy rounds), every evaluated grasp kept.
6. **action**: the policy's mean at the chosen grasp and at the top-K alternatives (distinct grasps, by
   non-maximum suppression of everything the search scored), clipped to the task's action box
   (:class:`tognet.policies.action.PolicyActions`).

Crops are metric and taken from world heights, so any image size, intrinsics and camera height or tilt
gives the network the inputs it was trained on; the network's other input, the gripper depth z, is taken
as a camera looking straight down from ``network_camera_height`` (the simulator's) would see it.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.geometry import Camera, CameraIntrinsics, DepthImageError, validate_depth
from tognet.grasping.antipodal import AntipodalConfig, GraspCandidates, sample_antipodal
from tognet.grasping.crops import CropConfig, extract_crops, resolve_crop
from tognet.grasping.depth import DepthScene, fill_holes_by_height, height_map, load_depth_file
from tognet.grasping.nms import NMSConfig, angle_difference
from tognet.io import atomic_write_bytes
from tognet.planning.camera import (
    NoObjectError,
    PlaneFitConfig,
    SegmentConfig,
    TableObject,
    TablePlane,
    check_image_size,
    choice_reason,
    fit_table_plane,
    load_camera_pose,
    load_intrinsics,
    mask_to_table,
    pick_object,
    plane_from_pose,
    segment_objects,
    table_noise,
)
from tognet.planning.config import ReachConfig
from tognet.planning.reach import ArmReach, Dropped, Option, ReachChoice
from tognet.policies.action import PolicyActions
from tognet.policies.config import PolicyConfig
from tognet.policies.grasp import CEMGrasp
from tognet.policies.view import SceneView
from tognet.tasks import GRASP_ONLY, TASK_NAMES, Task, get_task, reference_points

#: The simulator's nominal camera height above the table (SimConfig().camera.position z), where every
#: training image was taken from (+-3 cm).
SIM_CAMERA_HEIGHT = 0.72


class PlanInputError(TognetError):
    """A user's input to the planner is unusable; the message names it and the problem."""


@dataclass(frozen=True)
class UserPlanConfig(Config):
    """How a user's depth image is planned on."""

    antipodal: AntipodalConfig = doc(
        factory=lambda: AntipodalConfig(axis_direction="both"),
        text="Antipodal candidates, CEM's start (both jaw orientations, as in collection).",
    )
    policy: PolicyConfig = doc(
        factory=PolicyConfig,
        text="Its ``cem`` settings drive the search on Q_T (the paper's 3 iterations of 64); the exploration "
        "fields are unused (a plan's action is the policy's mean, no noise).",
    )
    plane: PlaneFitConfig = doc(factory=PlaneFitConfig, text="The table plane's fit (no camera pose given).")
    segment: SegmentConfig = doc(factory=SegmentConfig, text="What counts as an object on the table.")
    alternatives: NMSConfig = doc(
        factory=lambda: NMSConfig(radius=0.03, symmetric_jaw=False),
        text="Alternatives are at least this far apart from each other and from the chosen grasp (both jaw "
        "orientations count as different grasps: the task cares which way round the tool is held).",
    )
    top: int = doc(3, "Alternatives reported beside the chosen grasp.")
    low_score: float = doc(
        0.3, "Below this best Q_T the plan warns that there is no good grasp for the task on this object."
    )
    network_camera_height: float | None = doc(
        SIM_CAMERA_HEIGHT,
        "The network's gripper-depth input z is the grasp centre's depth from a camera looking straight down "
        "from this height (m) above the table: the training camera's (the simulator's nominal height), so a "
        "camera at 0.5-1.5 m or tilted gives in-distribution z. None: the image camera's own depth of the "
        "grasp centre, as the simulator's planners use (only right for a camera like the simulator's).",
    )
    seed: int = doc(0, "Seed of the sampler and the search: a plan is reproducible from its inputs and this.")
    reach: ReachConfig = doc(
        factory=ReachConfig,
        text="With an arm (``robot``, ``tognet plan --robot``): how many grasps are checked against its "
        "reach (``enabled`` is not read: naming the arm is the switch).",
    )

    def __post_init__(self) -> None:
        if self.top < 0:
            raise ValueError(f"top must be 0 or more, got {self.top}")
        if self.network_camera_height is not None and not self.network_camera_height > 0:
            raise ValueError(f"network_camera_height must be positive, got {self.network_camera_height}")


@dataclass(frozen=True)
class PlannedGrasp:
    """One planned grasp in every frame, its scores and its action.

    ``table``: (x, y, z, phi) in the table frame (m, rad; the gripper points down along -z, phi the jaw
    axis' yaw); ``world``: the same in the world frame (None without a camera pose); ``camera_from_gripper``:
    4 x 4 pose in the camera frame (gripper x = jaw axis, z = the table's up, origin at the grasp centre);
    ``pixel``: (u, v) of the grasp centre. ``action``: (a_x, a_y, a_z, a_phi), the start pose of the task's
    motion relative to its reference point; ``start_offset`` / ``start_yaw``: the start position minus the
    reference point (m) and the absolute start yaw (rad) it means (task frame axes); ``start_position``: the
    absolute start position when a reference point was given (same frame as ``world`` or else ``table``)."""

    table: NDArray[np.float64]
    camera_from_gripper: NDArray[np.float64]
    world: NDArray[np.float64] | None
    pixel: NDArray[np.float64]
    q_g: float
    q_t_given_g: float
    q_t: float
    action: NDArray[np.float64]
    start_offset: NDArray[np.float64]
    start_yaw: float
    start_position: NDArray[np.float64] | None = None

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
            "q_g": r(self.q_g), "q_t_given_g": r(self.q_t_given_g), "q_t": r(self.q_t),
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

    ``timing``: seconds per stage (read, table, objects, candidates, grasp, action) and ``total`` (the model's
    loading is not part of it). ``warnings``: one line each (several objects, low Q_T, ...). ``objects``:
    every region seen standing on the table (:meth:`tognet.planning.camera.TableObject.describe`: those
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
    evaluated: int
    timing: dict[str, float]
    warnings: list[str] = field(default_factory=list)
    checkpoint: str | None = None
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
            "checkpoint": self.checkpoint,
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
            "evaluated": self.evaluated,
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


@dataclass
class _UserView(SceneView):
    """The policies' view of a user's image: the network's z from a virtual overhead camera, and every
    grasp the policies crop recorded (with :class:`_Recording`, their predictions)."""

    network_height: float | None = None
    record: list[NDArray[np.float64]] | None = None

    def crops(self, grasps: NDArray[np.float64]) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """Crops of ``grasps`` (table frame) and the z the network is given."""
        if self.network_height is None:
            crops, z = super().crops(grasps)
        else:
            crops = extract_crops(self.scene, None, grasps, self.crop)
            z = (self.network_height - np.asarray(grasps, dtype=np.float64)[:, 2]).astype(np.float32)
        if self.record is not None:
            self.record.append(np.asarray(grasps, dtype=np.float64))
        return crops, z


class _Recording:
    """A predictor that keeps every prediction it makes (the search's scores, for the alternatives)."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.predictions: list[Any] = []

    def predict(self, crops: NDArray[np.float32], z: NDArray[np.float32]) -> Any:
        pred = self.model.predict(crops, z)
        self.predictions.append(pred)
        return pred


def _load_predictor(task: str, checkpoint: Any, num_threads: int | None) -> tuple[Any, str | None]:
    """The predictor for ``task`` from a path (or the shipped model), checked to be a ``task`` model."""
    if checkpoint is not None and not isinstance(checkpoint, str | Path):
        predictor, where = checkpoint, getattr(checkpoint, "info", {}).get("path")
    else:
        from tognet.model.predict import TOGNetPredictor
        from tognet.models import default_checkpoint

        path = Path(checkpoint) if checkpoint is not None else default_checkpoint(task)
        if path.is_dir():
            raise PlanInputError(f"checkpoint {path} is a folder; give its best.pt")
        if not path.is_file():
            raise FileNotFoundError(f"checkpoint not found: {path}")
        predictor, where = TOGNetPredictor.load(path, num_threads=num_threads), str(path)
    trained = getattr(predictor, "task", None)
    if trained is not None and trained != task:
        kind = "the grasp-only model (Q_G, no task)" if trained == GRASP_ONLY else f"a {trained} model"
        raise PlanInputError(f"checkpoint {where} is {kind}; planning for {task} needs a {task} model")
    return predictor, where


def _distinct(grasps: NDArray[np.float64], scores: NDArray[np.float64], k: int, config: NMSConfig
              ) -> NDArray[np.intp]:
    """Indices of up to ``k`` grasps, best score first, each at least ``config.radius`` from those before
    (NMS's distance, :func:`tognet.grasping.nms`): greedy, k passes, not the N x N distance matrix."""
    order = np.argsort(-scores, kind="stable")
    alive = np.ones(len(grasps), dtype=bool)
    period = np.pi if config.symmetric_jaw else 2 * np.pi
    out: list[int] = []
    while len(out) < k:
        left = order[alive[order]]
        if left.size == 0:
            break
        i = int(left[0])
        out.append(i)
        dp = grasps[:, :3] - grasps[i, :3]
        da = angle_difference(grasps[:, 3], grasps[i, 3], period) * config.angle_scale
        alive &= np.einsum("ij,ij->i", dp, dp) + da * da >= config.radius**2
    return np.asarray(out, dtype=np.intp)


def _grasp_frames(table_grasps: NDArray[np.float64], camera_from_table: NDArray[np.float64]
                  ) -> NDArray[np.float64]:
    """(N, 4, 4) camera_from_gripper of table-frame grasps."""
    n = len(table_grasps)
    c, s = np.cos(table_grasps[:, 3]), np.sin(table_grasps[:, 3])
    gripper = np.zeros((n, 4, 4))
    gripper[:, 0, 0], gripper[:, 1, 0] = c, s
    gripper[:, 0, 1], gripper[:, 1, 1] = -s, c
    gripper[:, 2, 2] = 1.0
    gripper[:, :3, 3] = table_grasps[:, :3]
    gripper[:, 3, 3] = 1.0
    return camera_from_table[None] @ gripper


def _frame_map(table_from_camera: NDArray[np.float64], pose: NDArray[np.float64] | None
               ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """Table-frame grasps (N, 4) -> the frame the reference point and the arm's base are given in: the
    camera pose's world frame, else the table frame itself."""
    if pose is None:
        return lambda grasps: np.asarray(grasps, dtype=np.float64).reshape(-1, 4).copy()
    world_from_table = pose @ np.linalg.inv(table_from_camera)

    def to_world(grasps: NDArray[np.float64]) -> NDArray[np.float64]:
        g = np.asarray(grasps, dtype=np.float64).reshape(-1, 4)
        p = g[:, :3] @ world_from_table[:3, :3].T + world_from_table[:3, 3]
        jaw = np.stack([np.cos(g[:, 3]), np.sin(g[:, 3]), np.zeros(len(g))], axis=1)
        axis = jaw @ world_from_table[:3, :3].T
        return np.column_stack([p, np.mod(np.arctan2(axis[:, 1], axis[:, 0]), 2 * np.pi)])

    return to_world


def _scene_of(target: TableObject, found: list[TableObject], camera: Camera, plane: TablePlane,
              valid: NDArray[np.float32], filled: NDArray[np.float32], height: NDArray[np.float32],
              holes: NDArray[np.bool_], margin: int) -> DepthScene:
    """The scene the sampler and the crops see for ``target``: every other region replaced by the table."""
    if len(found) > 1:
        others = np.zeros_like(target.mask)
        for obj in found:
            if obj is not target:
                others |= obj.mask
        filled = mask_to_table(filled, others, plane, camera.intrinsics, margin)
        valid = np.where(np.isfinite(valid), filled, valid).astype(np.float32)
        height = height_map(filled, camera)
    return DepthScene(camera, valid, filled, height, holes)


@dataclass
class _TableView:
    """The image seen from the table: the plane, the camera in the table frame, and per pixel the measured
    depth, the holes, the measured height above the table (NaN in holes) and the hole-filled depth and
    height."""

    plane: TablePlane
    table_from_camera: NDArray[np.float64]
    camera: Camera
    valid: NDArray[np.float32]
    holes: NDArray[np.bool_]
    measured_height: NDArray[np.float32]
    filled: NDArray[np.float32]
    height: NDArray[np.float32]
    from_pose: bool = False


@dataclass
class _Search:
    """What the grasp search scored (every grasp, its Q_G, Q_T|G and Q_T), the distinct best ones
    (``chosen``, CEM's best first) with their actions, the best Q_T and the grasp stage's seconds."""

    grasps: NDArray[np.float64]
    q_g: NDArray[np.float64]
    q_tg: NDArray[np.float64]
    q_t: NDArray[np.float64]
    chosen: NDArray[np.intp]
    actions: NDArray[np.float64]
    best_score: float
    seconds_grasp: float
    view: Any = None


class UserPlanner:
    """A loaded TOG-Net for one task, planning on users' depth images (see the module docstring).

    ``checkpoint``: a path (default: the shipped model of ``task``) or a loaded predictor. ``num_threads``:
    torch's CPU threads (process-wide), set on loading; 1 by default (see ``TOGNetPredictor.load``).

    ``robot``: plan for an arm beside the table (an arm's name: its preset and default base,
    :func:`tognet.sim.config.with_robot`; a ``RobotConfig``, its base in the frame of the reference point:
    the camera pose's world frame, else the plan's table frame; or a whole ``SimConfig``), carrying the
    simulator's hand: only grasps and motions it
    reaches (:mod:`tognet.planning.reach`; the task's steps are checked when a reference point is given),
    and the joint trajectory of the chosen one (``UserPlan.robot``). RobotExtraMissing without the robot
    extra."""

    def __init__(self, task: str, checkpoint: Any = None, config: UserPlanConfig | None = None,
                 num_threads: int | None = 1, robot: Any = None) -> None:
        if task not in TASK_NAMES:
            raise PlanInputError(f"unknown task '{task}'; known: {', '.join(TASK_NAMES)}")
        self.task_name = task
        self.task: Task = get_task(task)
        self.config = config or UserPlanConfig()
        self.reach: ArmReach | None = None
        if robot is not None:  # before the model: a missing extra is said at once
            from tognet.sim.config import SimConfig, with_robot

            if isinstance(robot, SimConfig):
                sim = robot
            else:
                name = robot if isinstance(robot, str) else robot.name
                sim = with_robot(SimConfig(), name)
                if not isinstance(robot, str):
                    sim = sim.replace(robot=robot)
            if sim.robot.name != "floating":
                self.reach = ArmReach(sim, self.task, self.config.reach)
        self.predictor, self.checkpoint = _load_predictor(task, checkpoint, num_threads)
        try:
            self.crop: CropConfig = resolve_crop([self.predictor])
        except ValueError as exc:
            raise PlanInputError(f"{self.checkpoint}: {exc}") from None

    # --- inputs ------------------------------------------------------------------------------------------
    @staticmethod
    def read_inputs(depth: Any, intrinsics: Any, camera_pose: Any = None
                    ) -> tuple[NDArray[np.float32], CameraIntrinsics, NDArray[np.float64] | None]:
        """The depth image (float32 metres, NaN holes), intrinsics and pose, checked against each other."""
        where = str(depth) if isinstance(depth, str | Path) else "depth image"
        k = load_intrinsics(intrinsics)
        pose = None if camera_pose is None else load_camera_pose(camera_pose)
        raw = load_depth_file(depth) if isinstance(depth, str | Path) else np.asarray(depth)
        if raw.dtype.kind not in "fiu":
            raise DepthImageError(f"{where}: depth image must be numeric, got dtype {raw.dtype}")
        if raw.ndim == 3 and raw.shape[-1] == 1:
            raw = raw[..., 0]
        if raw.ndim != 2:
            raise DepthImageError(f"{where}: depth image must be 2-D (height, width), got shape {raw.shape}")
        if raw.size == 0:
            raise DepthImageError(f"{where}: the depth image is empty (shape {raw.shape})")
        check_image_size(raw.shape, k, where)
        integer = raw.dtype.kind in "iu" and not isinstance(depth, str | Path)
        if integer:  # an integer array handed in directly: millimetres, as the files are read
            raw = raw.astype(np.float32) / 1000.0
        try:
            valid = validate_depth(raw, k, min_depth=0.1, max_depth=5.0)
        except DepthImageError as exc:
            text = str(exc)
            if "millimetres" in text:
                text += " (float images are read as metres)"
            elif "below" in text:
                text += " (16-bit PNGs and integer arrays are read as millimetres: metres as integers?)"
            raise DepthImageError(f"{where}: {text}") from None
        return valid, k, pose

    # --- the plan ----------------------------------------------------------------------------------------
    def plan(self, depth: Any, intrinsics: Any, camera_pose: Any = None, reference: ArrayLike | None = None,
             seed: int | None = None, object: int | tuple[float, float] | None = None) -> UserPlan:
        """Plan on one depth image (see the module docstring). ``depth``: a file path or an array (float
        metres or integer millimetres); ``intrinsics``: a file, dict or CameraIntrinsics; ``camera_pose``:
        None, a file or a 4 x 4 world_from_camera; ``reference``: the task's reference point (world frame
        with a camera pose, else table frame) for the absolute start pose; ``object``: the object to plan
        on, its index in ``UserPlan.objects`` or a pixel (u, v) on it (default: the first of that list that
        looks like something to pick up and on which the gripper finds a grasp: the largest near the image's
        centre, else the nearest to it)."""
        cfg = self.config
        warnings: list[str] = []
        t0 = time.perf_counter()
        valid, k, pose = self.read_inputs(depth, intrinsics, camera_pose)
        t1 = time.perf_counter()
        view = self._table_view(valid, k, pose)
        t2 = time.perf_counter()
        found = self._objects(view)
        target, why = pick_object(found, object)
        fit = [o for o in found if o.qualifies]
        if target.rejected is not None:
            warnings.append(f"object #{target.index} does not look like something to pick up "
                            f"({target.rejected}); planning on it as asked")
        rejected = [o for o in found if not o.qualifies and o is not target]
        if rejected:
            warnings.append("not objects to pick up: " + "; ".join(o.summary() for o in rejected[:3])
                            + (f"; and {len(rejected) - 3} more" if len(rejected) > 3 else ""))
        t3 = time.perf_counter()
        rng = np.random.default_rng(cfg.seed if seed is None else seed)
        # The default choice falls back on the next object that qualifies when the gripper finds no grasp on
        # it (a block too wide to hold beside a smaller tool).
        queue = fit if object is None else [target]
        target, scene, cands, skipped = self._candidates(queue, found, view, rng)
        to_frame = _frame_map(view.table_from_camera, pose)
        dropped = None
        if self.reach is not None:  # candidates beyond the arm's reach are never scored
            keep, dropped = self.reach.keep(to_frame(cands.grasps))
            if not keep.all():
                cands = cands.subset(np.flatnonzero(keep))
        if skipped:
            why = (choice_reason(fit, fit.index(target))
                   + f" (none on {', '.join(f'#{o.index}' for o in skipped)})")
            warnings.append("no antipodal grasp on " + "; ".join(o.summary() for o in skipped)
                            + f": planning on #{target.index}")
        if object is None and len(fit) > 1:
            warnings.append(f"{len(fit)} objects on the table look like something to pick up ("
                            + "; ".join(o.summary() for o in fit[:4]) + f"): planning on #{target.index}, "
                            + why + "; choose another with --object INDEX or --object U,V (object= in "
                            "tognet.plan)")
        if target.touches_border:
            warnings.append(f"object #{target.index} touches the image border: part of it may be out of view")
        t4 = time.perf_counter()
        search = self._search(scene, cands, rng)
        t6 = time.perf_counter()
        arm = None
        if self.reach is not None:
            assert dropped is not None
            search, arm = self._within_reach(search, to_frame, reference, dropped, pose is not None, rng)
            for line in arm.choice.summary(), *self._reach_notes(search, arm, reference):
                if line:
                    warnings.append(line)
        t7 = time.perf_counter()
        if search.best_score < cfg.low_score:
            warnings.append(f"no good grasp for this task on this object: the best Q_T is "
                            f"{search.best_score:.2f} (below {cfg.low_score:g})")
        out = self._planned(search, view, pose, reference)
        timing = dict(read=t1 - t0, table=t2 - t1, objects=t3 - t2, candidates=t4 - t3,
                      grasp=search.seconds_grasp, action=t6 - t4 - search.seconds_grasp)
        if arm is not None:
            timing["reach"] = t7 - t6
        timing["total"] = time.perf_counter() - t0
        return UserPlan(
            task=self.task_name, grasp=out[0], alternatives=out[1:], table_from_camera=view.table_from_camera,
            world_from_camera=pose, plane=view.plane, objects=[o.describe() for o in found],
            object={**target.describe(), "why": why}, candidates=len(cands),
            evaluated=len(search.grasps), timing=timing, warnings=warnings, checkpoint=self.checkpoint,
            seed=cfg.seed if seed is None else seed, intrinsics=k, robot=arm,
        )

    def _table_view(self, valid: NDArray[np.float32], k: CameraIntrinsics,
                    pose: NDArray[np.float64] | None) -> _TableView:
        """The table plane (from the camera pose, else fitted), the camera in the table frame, and the
        image's heights above the table: as measured (NaN in holes) and with the holes filled."""
        plane = plane_from_pose(pose) if pose is not None else fit_table_plane(valid, k, self.config.plane)
        table_from_camera = plane.table_from_camera()
        camera = Camera(k, table_from_camera)
        holes = ~np.isfinite(valid)
        measured_height = height_map(valid, camera)  # NaN where nothing was measured
        filled, height = fill_holes_by_height(valid, holes, camera, height=measured_height)
        if pose is not None:
            self._check_pose(height[::3, ::3][~holes[::3, ::3]], valid, k, plane)
        return _TableView(plane, table_from_camera, camera, valid, holes, measured_height, filled, height,
                          from_pose=pose is not None)

    def _objects(self, view: _TableView) -> list[TableObject]:
        """The objects on the table, from measured pixels only; NoObjectError saying what was seen when
        there is none."""
        seg = self.config.segment
        noise = table_noise(view.measured_height, view.valid)
        found = segment_objects(view.measured_height, view.valid, view.camera.intrinsics,
                                view.table_from_camera, seg, noise)
        if not found:
            plane = view.plane
            raise NoObjectError(
                f"no object on the table: no measured surface rises {1000 * seg.min_height:.0f} mm "
                f"above the table plane over {1e4 * seg.min_area:.0f} cm^2 (the table "
                f"{'from the camera pose' if view.from_pose else 'fitted'} {plane.offset:.3f} m below the "
                f"camera, tilted {plane.tilt:.1f} degrees; range noise {1000 * noise[0]:.1f} mm at "
                f"{noise[1]:.2f} m; {100 * view.holes.mean():.0f} % of the image unmeasured)"
            )
        return found

    def _candidates(
        self, queue: list[TableObject], found: list[TableObject], view: _TableView, rng: np.random.Generator,
    ) -> tuple[TableObject, DepthScene, GraspCandidates, list[TableObject]]:
        """The first object of ``queue`` with antipodal candidates: it, its scene, the candidates and the
        objects passed over; PlanInputError describing them when none has any."""
        cfg = self.config
        skipped: list[TableObject] = []
        for target in queue:
            scene = _scene_of(target, found, view.camera, view.plane, view.valid, view.filled, view.height,
                              view.holes, cfg.segment.mask_margin)
            cands = sample_antipodal(scene, None, cfg.antipodal, rng)
            if len(cands):
                return target, scene, cands, skipped
            skipped.append(target)
        what = "; ".join(f"#{o.index} ({o.area * 1e4:.0f} cm^2, {1000 * o.height:.0f} mm high, at pixel "
                         f"({o.pixel[0]:.0f}, {o.pixel[1]:.0f}))" for o in skipped[:4])
        which = "object " if len(skipped) == 1 else "any object: "
        raise PlanInputError(
            f"no antipodal grasp candidate on {which}{what}: wider than the gripper's "
            f"{1000 * cfg.antipodal.max_width:.0f} mm opening everywhere, or too flat to hold?"
        )

    def _search(self, scene: DepthScene, cands: GraspCandidates, rng: np.random.Generator) -> _Search:
        """CEM on Q_T over the candidates (every grasp it scored recorded), the distinct best grasps and the
        policy's action for each."""
        cfg = self.config
        t0 = time.perf_counter()
        record: list[NDArray[np.float64]] = []
        view = _UserView(scene, cands, self.task, self.crop, network_height=cfg.network_camera_height,
                         record=record)
        recording = _Recording(self.predictor)
        _, best_score = CEMGrasp(cfg.policy, recording, kind="task").best(view, rng)
        view.record = None
        seconds_grasp = time.perf_counter() - t0
        grasps = np.concatenate(record)
        preds = recording.predictions
        q_g = np.concatenate([p.q_g for p in preds]).astype(np.float64)
        q_tg = np.concatenate([p.q_t_given_g for p in preds]).astype(np.float64)
        q_t = np.concatenate([p.q_t for p in preds]).astype(np.float64)
        chosen = _distinct(grasps, q_t, cfg.top + 1, cfg.alternatives)  # [0]: CEM's best, its top score
        actions = PolicyActions(self.predictor)(view, grasps[chosen], rng).actions
        return _Search(grasps, q_g, q_tg, q_t, chosen, actions, float(best_score), seconds_grasp, view)

    def _within_reach(self, search: _Search, to_frame: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      reference: ArrayLike | None, dropped: Dropped, world: bool, rng: np.random.Generator
                      ) -> tuple[_Search, ArmPlan]:
        """The search's distinct best grasps (as :meth:`_search` ranks them) that the arm reaches, each with
        its action, and the arm's side of the plan; OutOfReach when none is."""
        assert self.reach is not None
        cfg = self.config
        order = _distinct(search.grasps, search.q_t, cfg.top + 1 + cfg.reach.tries, cfg.alternatives)
        first = len(search.chosen)  # the same greedy picks: order[:first] is search.chosen
        more: list[NDArray[np.float64]] = []

        def action(j: int) -> tuple[NDArray[np.float64], int]:
            if j < first:
                return search.actions[j], j
            if not more:  # the next ones' actions, in one batch, only once the first are out of reach
                rest = search.grasps[order[first:]]
                more.append(PolicyActions(self.predictor)(search.view, rest, rng).actions)
            return more[0][j - first], j

        ref = None if reference is None else np.asarray(reference, dtype=np.float64).reshape(3)
        grasps = to_frame(search.grasps[order])
        options = (Option(grasps[j], lambda j=j: action(j)) for j in range(len(order)))
        found = self.reach.choose(options, ref, dropped, want=cfg.top + 1)
        picked = np.array([c.extra for c in found], dtype=np.intp)
        reached = replace(search, chosen=order[picked], actions=np.array([c.action for c in found]))
        r = self.reach
        arm = ArmPlan(r.name, "world" if world else "table", r.base_position, r.base_yaw, r.joint_names,
                      found[0])
        return reached, arm

    def _reach_notes(self, search: _Search, arm: ArmPlan, reference: ArrayLike | None) -> list[str]:
        notes = []
        if not arm.choice.with_task:
            notes.append(f"without a reference point (--reference) the {self.task_name} task's motion is not "
                         f"checked against the {arm.arm}'s reach: its trajectory ends at the lift")
        if len(search.chosen) < self.config.top + 1:
            notes.append(f"only {len(search.chosen) - 1} of the {self.config.top} alternatives asked for "
                         f"(--top) found within the {arm.arm}'s reach")
        return notes

    def _planned(self, search: _Search, view: _TableView, pose: NDArray[np.float64] | None,
                 reference: ArrayLike | None) -> list[PlannedGrasp]:
        """The chosen grasps as the plan states them: table, camera and (with a pose) world frames, pixel,
        scores, action and start pose."""
        grasps, chosen, actions = search.grasps, search.chosen, search.actions
        camera_from_table = np.linalg.inv(view.table_from_camera)
        frames = _grasp_frames(grasps[chosen], camera_from_table)
        uv, _ = view.camera.project(grasps[chosen, :3])
        world_from_table = None if pose is None else pose @ camera_from_table
        ref = None if reference is None else np.asarray(reference, dtype=np.float64).reshape(3)
        tc = self.task.config
        out = []
        for j, i in enumerate(chosen):
            world = None
            if world_from_table is not None:
                g = grasps[i]
                p = world_from_table @ np.array([g[0], g[1], g[2], 1.0])
                axis = world_from_table[:3, :3] @ np.array([math.cos(g[3]), math.sin(g[3]), 0.0])
                world = np.array([p[0], p[1], p[2], math.atan2(axis[1], axis[0]) % (2 * math.pi)])
            offset = np.asarray(tc.nominal_offset, dtype=np.float64) + actions[j, :3]
            out.append(PlannedGrasp(
                table=grasps[i].copy(), camera_from_gripper=frames[j], world=world, pixel=uv[j],
                q_g=float(search.q_g[i]), q_t_given_g=float(search.q_tg[i]), q_t=float(search.q_t[i]),
                action=actions[j].copy(), start_offset=offset,
                start_yaw=float(tc.nominal_yaw + actions[j, 3]),
                start_position=None if ref is None else ref + offset,
            ))
        return out

    def _check_pose(self, heights: NDArray[np.float32], valid: NDArray[np.float32], k: CameraIntrinsics,
                    plane: TablePlane) -> None:
        """PlanInputError when the camera pose's table (world z = 0) is not the table the image shows."""
        cfg = self.config.plane
        on = float(np.mean(np.abs(heights) < np.float32(cfg.inlier_distance)))
        if on >= cfg.min_inliers:
            return
        try:
            seen = fit_table_plane(valid, k, cfg)
            found = (f"the image's table is {seen.offset:.3f} m below the camera, tilted {seen.tilt:.1f} "
                     f"degrees; the pose's {plane.offset:.3f} m, {plane.tilt:.1f} degrees")
        except TognetError:
            found = "no table plane found in the image either"
        raise PlanInputError(
            f"the camera pose does not match the image: {100 * on:.0f} % of the pixels lie on its table "
            f"(world z = 0; at least {100 * cfg.min_inliers:.0f} % expected): {found}. Is world z = 0 the "
            "table top, in metres, and the pose world_from_camera?"
        )


_PLANNERS: dict[tuple[str, str, str], UserPlanner] = {}


def plan_image(depth: Any, intrinsics: Any, task: str, camera_pose: Any = None, checkpoint: Any = None,
               *, reference: ArrayLike | None = None, top: int | None = None, seed: int | None = None,
               config: UserPlanConfig | None = None, object: int | tuple[float, float] | None = None
               ) -> UserPlan:
    """Plan a task-oriented grasp and motion on a depth image in one call (``tognet.plan``).

    ``depth``: a .png/.npy/.npz path or an array; ``intrinsics``: a JSON path, dict or CameraIntrinsics;
    ``camera_pose``: None (the table plane is fitted), a JSON path or a 4 x 4 world_from_camera;
    ``checkpoint``: a path or loaded predictor (default: the shipped model of ``task``); ``object``: the
    object to plan on, by index or pixel (see :meth:`UserPlanner.plan`). The model loaded from a path is
    kept for the next call with the same path and settings."""
    cfg = config or UserPlanConfig()
    if top is not None:
        cfg = cfg.replace(top=top)
    if checkpoint is None or isinstance(checkpoint, str | Path):
        key = (task, str(checkpoint), json.dumps(cfg.to_dict(), sort_keys=True))
        planner = _PLANNERS.get(key)
        if planner is None:
            planner = _PLANNERS[key] = UserPlanner(task, checkpoint, cfg)
    else:
        planner = UserPlanner(task, checkpoint, cfg)
    return planner.plan(depth, intrinsics, camera_pose, reference=reference, seed=seed, object=object)
