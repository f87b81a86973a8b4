"""Plan a task-oriented grasp and motion on a user's own depth image, with any method a robot can run.

    planner = UserPlanner("hammering")                         # the best method with shipped models
    plan = planner.plan("depth.png", "intrinsics.json")        # camera pose optional
    plan.method, plan.grasp.table, plan.grasp.scores, plan.grasp.action   # see UserPlan / PlannedGrasp
    # or in one call (the planner is kept for the next call with the same settings):
    plan = tognet.plan("depth.png", "intrinsics.json", task="hammering", method="TOG-Net")

The image becomes the view the evaluation's planners plan on, and the plan comes from the same planner
(:func:`tognet.planning.methods.make_planner`, :meth:`tognet.planning.planners.PolicyPlanner.plan_view`):
this module builds the view and states the plan, and searches nothing itself. Stages (``plan.timing``):

1. **read**: the depth image (16-bit PNG millimetres, .npy/.npz metres or integer millimetres), the
   intrinsics and the optional camera pose (:mod:`tognet.planning.camera`), checked against each other.
2. **table**: the table plane, from the camera pose when given, else fitted to the image (RANSAC + least
   squares), and the table frame every stage works in (z up, origin below the camera, x along the image's
   x: the plan does not depend on where a user's world frame is). Per-pixel heights above the table are
   computed; holes (zeros, NaN: no reading) are filled in height, each from its lowest neighbouring
   surface (:func:`tognet.grasping.depth.fill_holes_by_height`), for the sampler and the crops only.
3. **objects**: what stands on the table, from measured pixels only (a hole never makes or enlarges an
   object; :func:`tognet.planning.segment.segment_objects`), each judged on whether it looks like something
   a gripper picks up (size, height, share measured, not a wall). The plan is made on the largest that
   does near the image's centre (else the nearest to it; the next one when the gripper finds no grasp on
   it), or on the one the caller names (``object``: index or pixel); every other is replaced by the table.
   Nothing to choose is an error that lists what was seen.
4. **candidates**: antipodal candidates on it (:func:`tognet.grasping.sample_antipodal`, both jaw
   orientations); with an arm, those beyond its reach dropped. With the scene, this is the view
   (:class:`tognet.policies.view.SceneView`) of the evaluation's planners.
5. **the method** (``method``, default the best a robot can run with the models at hand: today
   TOG-Net+ActionSearch): its grasp, its action, its next grasps as alternatives (ranked its way, 3 cm
   apart) and its own scores of each (``grasp.scores``); with an arm, the first it reaches.

Crops are metric and taken from world heights, so any image size, intrinsics and camera height or tilt
gives the network the inputs it was trained on; the network's other input, the gripper depth z, is taken
as a camera looking straight down from ``network_camera_height`` (the simulator's) would see it
(``SceneView.network_height``).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.config import Config, doc
from tognet.errors import TognetError
from tognet.geometry import Camera, CameraIntrinsics, DepthImageError, validate_depth
from tognet.grasping.antipodal import AntipodalConfig, GraspCandidates, sample_antipodal
from tognet.grasping.depth import (
    DepthScene,
    depth_in_metres,
    fill_holes_by_height,
    height_map,
    read_depth_file,
)
from tognet.grasping.nms import NMSConfig
from tognet.planning.camera import check_image_size, load_camera_pose, load_intrinsics
from tognet.planning.confidence import low_confidence
from tognet.planning.config import PlanConfig, ReachConfig
from tognet.planning.limits import (
    InputLimits,
    check_depth_scale,
    check_reference,
    check_reference_reach,
    footprint,
    how_read,
)
from tognet.planning.methods import (
    BEST_FIRST,
    METHOD_TABLE,
    MODEL_WORDS,
    NEEDS,
    Method,
    ModelName,
    default_method,
    make_planner,
    robot_method,
)
from tognet.planning.plan import Plan
from tognet.planning.reach import ArmReach, FramedReach
from tognet.planning.segment import (
    NoObjectError,
    SegmentConfig,
    TableObject,
    choice_reason,
    mask_to_table,
    pick_object,
    segment_objects,
    table_noise,
)
from tognet.planning.table import PlaneFitConfig, TablePlane, fit_table_plane, plane_from_pose
from tognet.planning.user_plan import ArmPlan, PlannedGrasp, UserPlan
from tognet.policies.config import PolicyConfig
from tognet.policies.view import SceneView
from tognet.tasks import GRASP_ONLY, Task, check_task_name, get_task

__all__ = ["ArmPlan", "PlanInputError", "PlannedGrasp", "UserPlan", "UserPlanConfig", "UserPlanner",
           "plan_image"]

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
        text="The methods' settings, as in the evaluation (PlanConfig.policy): CEM (the paper's 3 iterations "
        "of 64), NMS, the action search; the exploration fields are unused (no noise in a plan).",
    )
    plane: PlaneFitConfig = doc(factory=PlaneFitConfig, text="The table plane's fit (no camera pose given).")
    segment: SegmentConfig = doc(factory=SegmentConfig, text="What counts as an object on the table.")
    alternatives: NMSConfig = doc(
        factory=lambda: NMSConfig(radius=0.03, symmetric_jaw=False),
        text="Alternatives are at least this far apart from each other and from the chosen grasp (both jaw "
        "orientations count as different grasps: the task cares which way round the tool is held).",
    )
    top: int = doc(3, "Alternatives reported beside the chosen grasp.")
    low_score: float | None = doc(
        None,
        "A plan whose method's own score is below this warns (low confidence). None: the threshold "
        "calibrated for the method, the task and the shipped models on held-out scenes "
        "(tognet/models/confidence.json); with other models and no value here, no such warning.",
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
    limits: InputLimits = doc(
        factory=InputLimits,
        text="The plausible inputs: the depth image's scale judged from the table's distance, the reference "
        "point's distance from the table the image shows and from the arm (:mod:`tognet.planning.limits`).",
    )

    def __post_init__(self) -> None:
        if self.top < 0:
            raise ValueError(f"top must be 0 or more, got {self.top}")
        if self.network_camera_height is not None and not self.network_camera_height > 0:
            raise ValueError(f"network_camera_height must be positive, got {self.network_camera_height}")


class UserPlanner:
    """A method's planner and models for one task, planning on users' depth images (see the module
    docstring).

    ``method``: a method a robot can run (:data:`tognet.planning.methods.BEST_FIRST`; the Oracle and the
    diagnostic rows need the simulator and are refused); default the best whose models are at hand.
    ``checkpoint``: a path or a loaded predictor of one of the models the method needs (which one is read
    from the checkpoint: the grasp-only model, a task's TOG-Net or its action-search model; one of another
    kind is refused); the method's other models are the shipped ones. Without ``method``, the default is
    the best method that uses the checkpoint's kind of model. ``num_threads``: torch's CPU threads
    (process-wide), set on loading; 1 by default (see ``TOGNetPredictor.load``).

    ``robot``: plan for an arm beside the table (an arm's name: its preset and default base,
    :func:`tognet.sim.config.with_robot`; a ``RobotConfig``, its base in the frame of the reference point:
    the camera pose's world frame, else the plan's table frame; or a whole ``SimConfig``), carrying the
    simulator's hand: only grasps and motions it reaches (:mod:`tognet.planning.reach`; the task's steps
    are checked when a reference point is given), and the joint trajectory of the chosen one
    (``UserPlan.robot``). RobotExtraMissing without the robot extra."""

    def __init__(self, task: str, checkpoint: Any = None, config: UserPlanConfig | None = None,
                 num_threads: int | None = 1, robot: Any = None, method: str | None = None) -> None:
        self.task_name = check_task_name(task, error=PlanInputError)
        self.task: Task = get_task(task)
        self.config = config or UserPlanConfig()
        try:
            self.row: Method | None = robot_method(method) if method is not None else None
        except ValueError as exc:
            raise PlanInputError(str(exc)) from None
        self.arm_reach: ArmReach | None = _arm_reach(robot, self.task, self.config.reach)  # before the models
        given = _load(checkpoint, num_threads) if checkpoint is not None else None
        self.row = self.row or robot_method(_default_for(task, given))
        self.models, self.paths = _models_for(self.row, task, given, num_threads)
        plan_config = PlanConfig(antipodal=self.config.antipodal, policy=self.config.policy,
                                 reach=self.config.reach)
        try:
            self.planner = make_planner(self.row, self.task, config=plan_config, **{
                f"{n}_model": m for n, m in self.models.items()})
        except ValueError as exc:
            raise PlanInputError(str(exc)) from None
        self.method: str = self.row.name
        self.checkpoint: str | None = next(iter(self.paths.values()), None)

    @property
    def predictor(self) -> Any:
        """The method's first model (the task model for TOG-Net, the action-search model for its search)."""
        return next(iter(self.models.values()), None)

    @staticmethod
    def read_inputs(depth: Any, intrinsics: Any, camera_pose: Any = None, limits: InputLimits | None = None
                    ) -> tuple[NDArray[np.float32], CameraIntrinsics, NDArray[np.float64] | None]:
        """The depth image (float32 metres, NaN holes), intrinsics and pose, checked against each other;
        DepthImageError for a depth image whose table is not at a distance a camera sees a table from in
        the unit it is read in (16-bit PNGs and integer arrays: millimetres; float arrays: metres), naming
        the unit it looks like (``limits``, :mod:`tognet.planning.limits`)."""
        valid, k, pose, _ = _read_inputs(depth, intrinsics, camera_pose, limits or InputLimits())
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
        t0 = time.perf_counter()
        valid, k, pose, scale = _read_inputs(depth, intrinsics, camera_pose, self.config.limits)
        try:
            return self._plan_read(valid, k, pose, scale, reference, seed, object, t0)
        except TognetError as exc:  # a plan that fails on an image of doubtful scale says so in its line
            if scale and exc.args and isinstance(exc.args[0], str):
                exc.args = (f"{exc.args[0]}; the depth image's scale may be why: {scale}", *exc.args[1:])
            raise

    def _plan_read(self, valid: NDArray[np.float32], k: CameraIntrinsics, pose: NDArray[np.float64] | None,
                   scale: str | None, reference: ArrayLike | None, seed: int | None,
                   object: int | tuple[float, float] | None, t0: float) -> UserPlan:
        """:meth:`plan` on the image as read (``scale``: the warning on its scale, if any)."""
        cfg = self.config
        seed = cfg.seed if seed is None else seed
        t1 = time.perf_counter()
        view = self._table_view(valid, k, pose)
        ref = None if reference is None else np.asarray(reference, dtype=np.float64).reshape(3)
        if ref is not None:
            self._check_reference(ref, view, pose)
        t2 = time.perf_counter()
        found = self._objects(view)
        target, why = pick_object(found, object)
        fit = [o for o in found if o.qualifies]
        warnings = ([scale] if scale else []) + _object_warnings(found, target)
        t3 = time.perf_counter()
        rng = np.random.default_rng(seed)
        # The default choice falls back on the next object that qualifies when the gripper finds no grasp on
        # it (a block too wide to hold beside a smaller tool).
        queue = fit if object is None else [target]
        target, scene, cands, skipped = self._candidates(queue, found, view, rng)
        if skipped or (object is None and len(fit) > 1):
            why = choice_reason(fit, fit.index(target)) + (
                f" (none on {', '.join(f'#{o.index}' for o in skipped)})" if skipped else "")
        warnings += _choice_warnings(fit, target, skipped, why, object is None)
        t4 = time.perf_counter()
        reach = None if self.arm_reach is None else FramedReach(self.arm_reach, _frame_from_table(view, pose))
        timing = dict(read=t1 - t0, table=t2 - t1, objects=t3 - t2, candidates=t4 - t3)
        plan = self._plan_view(scene, cands, reach, ref, rng, timing)
        out = self._planned(plan, view, pose, reference)
        arm = self._arm(plan, pose is not None)
        if arm is not None:
            warnings += [line for line in (arm.choice.summary(), *self._reach_notes(plan, arm)) if line]
        confidence, line = low_confidence(self.task_name, self.method, self.paths, plan.own["score"],
                                          cfg.low_score)
        warnings += [line] if line else []
        timing.update({key: v for key, v in plan.timing.items() if key != "total"},
                      total=time.perf_counter() - t0)
        return UserPlan(
            task=self.task_name, grasp=out[0], alternatives=out[1:], table_from_camera=view.table_from_camera,
            world_from_camera=pose, plane=view.plane, objects=[o.describe() for o in found],
            object={**target.describe(), "why": why}, candidates=len(cands), timing=timing,
            warnings=warnings, checkpoint=self.checkpoint, seed=seed, intrinsics=k, robot=arm,
            method=self.method, models=dict(self.paths), score=self.row.score if self.row else "",
            confidence=confidence, scored=_scored(plan, cands, self.row),
        )

    def _plan_view(self, scene: DepthScene, cands: GraspCandidates, reach: FramedReach | None,
                   reference: NDArray[np.float64] | None, rng: np.random.Generator, timing: dict[str, float]
                   ) -> Plan:
        """The method's plan on the image's view: its candidates (within the arm's reach), then the
        evaluation's planner (:meth:`tognet.planning.planners.PolicyPlanner.plan_view`)."""
        t0 = time.perf_counter()
        planner = self.planner
        view = SceneView(scene, cands, self.task, planner.crop,
                         network_height=self.config.network_camera_height)
        if reach is not None:  # candidates beyond the arm's reach are never scored
            view.candidates, view.cache["reach_dropped"] = reach.filter(cands)
        timing["candidates"] += time.perf_counter() - t0
        return planner.plan_view(view, rng, reference=reference, alternatives=self.config.top,
                                 spacing=self.config.alternatives, reach=reach)

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

    def _check_reference(self, ref: NDArray[np.float64], view: _TableView, pose: NDArray[np.float64] | None
                         ) -> None:
        """PlanInputError when the reference point is far from the table the image shows, below or high
        above the table top, or (with an arm) puts the task's start pose beyond the arm's reach."""
        limits = self.config.limits
        frame = "world" if pose is not None else "table"
        in_table = (np.linalg.inv(_frame_from_table(view, pose)) @ np.append(ref, 1.0))[:3]
        points = view.camera.deproject(view.valid)[::4, ::4].reshape(-1, 3)
        try:
            check_reference(ref, in_table, footprint(points), frame, limits)
            if self.arm_reach is not None:
                check_reference_reach(ref, frame, self.task, self.arm_reach, limits)
        except ValueError as exc:
            raise PlanInputError(str(exc)) from None

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

    def _arm(self, plan: Plan, world: bool) -> ArmPlan | None:
        """The arm's side of the plan (its first reach choice), None without an arm."""
        r = self.arm_reach
        if r is None:
            return None
        return ArmPlan(r.name, "world" if world else "table", r.base_position, r.base_yaw, r.joint_names,
                       plan.info["reach_choices"][0])

    def _reach_notes(self, plan: Plan, arm: ArmPlan) -> list[str]:
        notes = []
        if not arm.choice.with_task:
            notes.append(f"without a reference point (--reference) the {self.task_name} task's motion is not "
                         f"checked against the {arm.arm}'s reach: its trajectory ends at the lift")
        if len(plan.alternatives) < self.config.top:
            notes.append(f"only {len(plan.alternatives)} of the {self.config.top} alternatives asked for "
                         f"(--top) found within the {arm.arm}'s reach")
        return notes

    def _planned(self, plan: Plan, view: _TableView, pose: NDArray[np.float64] | None,
                 reference: ArrayLike | None) -> list[PlannedGrasp]:
        """The plan's grasp and its alternatives as the plan states them: table, camera and (with a pose)
        world frames, pixel, the method's scores, action and start pose."""
        grasps = np.array([plan.grasp, *(c.grasp for c in plan.alternatives)], dtype=np.float64)
        actions = np.array([plan.action, *(c.action for c in plan.alternatives)], dtype=np.float64)
        owns = [plan.own, *(c.own for c in plan.alternatives)]
        camera_from_table = np.linalg.inv(view.table_from_camera)
        frames = _grasp_frames(grasps, camera_from_table)
        uv, _ = view.camera.project(grasps[:, :3])
        world_from_table = None if pose is None else pose @ camera_from_table
        ref = None if reference is None else np.asarray(reference, dtype=np.float64).reshape(3)
        tc = self.task.config
        out = []
        for j, g in enumerate(grasps):
            world = None
            if world_from_table is not None:
                p = world_from_table @ np.array([g[0], g[1], g[2], 1.0])
                axis = world_from_table[:3, :3] @ np.array([math.cos(g[3]), math.sin(g[3]), 0.0])
                world = np.array([p[0], p[1], p[2], math.atan2(axis[1], axis[0]) % (2 * math.pi)])
            offset = np.asarray(tc.nominal_offset, dtype=np.float64) + actions[j, :3]
            out.append(PlannedGrasp(
                table=g.copy(), camera_from_gripper=frames[j], world=world, pixel=uv[j], scores=dict(owns[j]),
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


def _read_inputs(depth: Any, intrinsics: Any, camera_pose: Any, limits: InputLimits
                 ) -> tuple[NDArray[np.float32], CameraIntrinsics, NDArray[np.float64] | None, str | None]:
    """:meth:`UserPlanner.read_inputs` and the warning on the depth image's scale (None when none)."""
    path = isinstance(depth, str | Path)
    where = str(depth) if path else "depth image"
    k = load_intrinsics(intrinsics)
    pose = None if camera_pose is None else load_camera_pose(camera_pose)
    raw = read_depth_file(depth) if path else np.asarray(depth)
    if raw.dtype.kind not in "fiu":
        raise DepthImageError(f"{where}: depth image must be numeric, got dtype {raw.dtype}")
    if raw.ndim == 3 and raw.shape[-1] == 1:
        raw = raw[..., 0]
    if raw.ndim != 2:
        raise DepthImageError(f"{where}: depth image must be 2-D (height, width), got shape {raw.shape}")
    if raw.size == 0:
        raise DepthImageError(f"{where}: the depth image is empty (shape {raw.shape})")
    check_image_size(raw.shape, k, where)
    read_as, how = how_read(raw, Path(depth).suffix.lower() if path else None)
    try:  # the scale is judged below, from the table's distance
        valid = validate_depth(depth_in_metres(raw), k, min_depth=0.0, max_depth=math.inf)
    except DepthImageError as exc:
        raise DepthImageError(f"{where}: {exc}") from None
    distance = float(np.median(valid[np.isfinite(valid)]))
    warning = check_depth_scale(distance, read_as, how, where, limits)
    return valid, k, pose, warning


_PLANNERS: dict[tuple[str, str, str, str], UserPlanner] = {}


def plan_image(depth: Any, intrinsics: Any, task: str, camera_pose: Any = None, checkpoint: Any = None,
               *, reference: ArrayLike | None = None, top: int | None = None, seed: int | None = None,
               config: UserPlanConfig | None = None, object: int | tuple[float, float] | None = None,
               method: str | None = None) -> UserPlan:
    """Plan a task-oriented grasp and motion on a depth image in one call (``tognet.plan``).

    ``depth``: a .png/.npy/.npz path or an array; ``intrinsics``: a JSON path, dict or CameraIntrinsics;
    ``camera_pose``: None (the table plane is fitted), a JSON path or a 4 x 4 world_from_camera;
    ``method``: a method a robot can run (default: the best with the models at hand, see
    :class:`UserPlanner`); ``checkpoint``: a path or loaded predictor of one of its models (default: the
    shipped ones); ``object``: the object to plan on, by index or pixel (see :meth:`UserPlanner.plan`). The
    planner made for a path is kept for the next call with the same method, path and settings."""
    cfg = config or UserPlanConfig()
    if top is not None:
        cfg = cfg.replace(top=top)
    if checkpoint is None or isinstance(checkpoint, str | Path):
        key = (task, str(method), str(checkpoint), json.dumps(cfg.to_dict(), sort_keys=True))
        planner = _PLANNERS.get(key)
        if planner is None:
            planner = _PLANNERS[key] = UserPlanner(task, checkpoint, cfg, method=method)
    else:
        planner = UserPlanner(task, checkpoint, cfg, method=method)
    return planner.plan(depth, intrinsics, camera_pose, reference=reference, seed=seed, object=object)


def parse_object(text: str | None) -> int | tuple[float, float] | None:
    """The object to plan on, from text (``tognet plan --object``, the service's ``object``): an index ('2')
    or a pixel ('320,240'); ValueError naming the option otherwise."""
    if text is None:
        return None
    parts = [p.strip() for p in text.replace(" ", ",").split(",") if p.strip()]
    try:
        if len(parts) == 1 and parts[0].lstrip("#").isdigit():
            return int(parts[0].lstrip("#"))
        if len(parts) == 2:
            u, v = float(parts[0]), float(parts[1])
            if math.isfinite(u) and math.isfinite(v):
                return (u, v)
    except ValueError:
        pass
    raise ValueError(f"--object takes an object's index (0, 1, ...) or a pixel U,V on it, got '{text}'")


# --- the models -----------------------------------------------------------------------------------------
#: The shipped model of each kind of model for a task (tognet/models/<name>.pt).
def _shipped_name(kind: str, task: str) -> str:
    return {"grasp": GRASP_ONLY, "task": task, "search": f"{task}_search"}[kind]


def _shipped(kind: str, task: str) -> bool:
    from tognet.models import MODELS_DIR

    return (MODELS_DIR / f"{_shipped_name(kind, task)}.pt").is_file()


def _load(checkpoint: Any, num_threads: int | None) -> tuple[Any, str | None]:
    """A checkpoint (path or loaded predictor) and where it is."""
    if not isinstance(checkpoint, str | Path):
        return checkpoint, getattr(checkpoint, "info", {}).get("path")
    from tognet.model.predict import TOGNetPredictor

    path = Path(checkpoint)
    if path.is_dir():
        raise PlanInputError(f"checkpoint {path} is a folder; give its best.pt")
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    return TOGNetPredictor.load(path, num_threads=num_threads), str(path)


def _kind(predictor: Any) -> ModelName:
    """What a loaded model is: the grasp-only model, an action-search model or a task's TOG-Net."""
    if getattr(predictor, "task", None) == GRASP_ONLY:
        return "grasp"
    return "search" if getattr(predictor, "action_conditioned", False) else "task"


def _default_for(task: str, given: tuple[Any, str | None] | None) -> str:
    """The default method: the best a robot can run whose models ship for ``task``; with a checkpoint, the
    best of TOG-Net's rows that uses its kind of model (a grasp-only model is refused: the methods that
    use it are baselines, to be named)."""
    if given is None:
        return default_method(lambda needs: all(_shipped(n, task) for n in needs))
    kind = _kind(given[0])
    ours = [m.name for m in METHOD_TABLE if m.kind == "ours" and kind in m.needs]
    if not ours:
        users = [name for name in BEST_FIRST if kind in NEEDS[name]]
        raise PlanInputError(f"checkpoint {given[1]} is {MODEL_WORDS[kind]}, which no TOG-Net method uses; "
                             f"name one that does: --method {' or '.join(users)}")
    return default_method(lambda needs: kind in needs and all(n == kind or _shipped(n, task) for n in needs))


def _models_for(row: Method, task: str, given: tuple[Any, str | None] | None, num_threads: int | None
                ) -> tuple[dict[str, Any], dict[str, str]]:
    """The method's models (by kind) and their paths: the checkpoint given for its kind, the shipped
    models for the others; PlanInputError for a checkpoint of another kind or task."""
    models: dict[str, Any] = {}
    paths: dict[str, str] = {}
    if given is not None:
        predictor, where = given
        kind = _kind(predictor)
        if kind not in row.needs:
            needs = " and ".join(MODEL_WORDS[n] for n in row.needs) or "no model"
            raise PlanInputError(f"checkpoint {where} is {MODEL_WORDS[kind]}; {row.name} needs {needs}")
        trained = getattr(predictor, "task", None)
        if kind != "grasp" and trained is not None and trained != task:
            raise PlanInputError(f"checkpoint {where} is a {trained} model; planning for {task} needs a "
                                 f"{task} model")
        models[kind], paths[kind] = predictor, str(where)
    from tognet.models import default_checkpoint

    for need in row.needs:
        if need not in models:
            path = default_checkpoint(_shipped_name(need, task))
            models[need], paths[need] = _load(path, num_threads)[0], str(path)
    return {n: models[n] for n in row.needs}, {n: paths[n] for n in row.needs}


def _arm_reach(robot: Any, task: Task, config: ReachConfig) -> ArmReach | None:
    """The arm's reach filter (see :class:`UserPlanner`), None without an arm or for the floating hand."""
    if robot is None:
        return None
    from tognet.sim.config import SimConfig, with_robot

    if isinstance(robot, SimConfig):
        sim = robot
    else:
        name = robot if isinstance(robot, str) else robot.name
        sim = with_robot(SimConfig(), name)
        if not isinstance(robot, str):
            sim = sim.replace(robot=robot)
    return None if sim.robot.name == "floating" else ArmReach(sim, task, config)


# --- what is said about the objects -----------------------------------------------------------------------
def _object_warnings(found: list[TableObject], target: TableObject) -> list[str]:
    """Warnings on the object asked for and the regions that are not objects to pick up."""
    warnings = []
    if target.rejected is not None:
        warnings.append(f"object #{target.index} does not look like something to pick up "
                        f"({target.rejected}); planning on it as asked")
    if target.touching is not None:
        pick = "" if target.split else "; pick one with --object U,V (object= in tognet.plan)"
        warnings.append(f"object #{target.index} {target.touching}{pick}")
    rejected = [o for o in found if not o.qualifies and o is not target]
    if rejected:
        warnings.append("not objects to pick up: " + "; ".join(o.summary() for o in rejected[:3])
                        + (f"; and {len(rejected) - 3} more" if len(rejected) > 3 else ""))
    return warnings


def _choice_warnings(fit: list[TableObject], target: TableObject, skipped: list[TableObject], why: str,
                     default: bool) -> list[str]:
    """Warnings on the object planned on: the ones passed over, the others that qualify, the border."""
    warnings = []
    if skipped:
        warnings.append("no antipodal grasp on " + "; ".join(o.summary() for o in skipped)
                        + f": planning on #{target.index}")
    if default and len(fit) > 1:
        warnings.append(f"{len(fit)} objects on the table look like something to pick up ("
                        + "; ".join(o.summary() for o in fit[:4]) + f"): planning on #{target.index}, "
                        + why + "; choose another with --object INDEX or --object U,V (object= in "
                        "tognet.plan)")
    if target.touches_border:
        warnings.append(f"object #{target.index} touches the image border: part of it may be out of view")
    return warnings


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


def _scored(plan: Plan, cands: GraspCandidates, row: Method | None
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], str]:
    """What the method ranked and by what score, else the candidates by antipodal quality."""
    ranked = plan.info.get("ranked")
    if ranked is not None and len(ranked.grasps):
        return (np.asarray(ranked.grasps, np.float64), np.asarray(ranked.score, np.float64),
                row.score if row is not None else "score")
    return np.asarray(cands.grasps, np.float64), np.asarray(cands.quality, np.float64), "antipodal quality"


def _frame_from_table(view: _TableView, pose: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """The transform from the plan's table frame to the frame of the reference point and the arm's base:
    the camera pose's world frame, else the table frame itself."""
    if pose is None:
        return np.eye(4)
    return np.asarray(pose @ np.linalg.inv(view.table_from_camera), dtype=np.float64)


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
