"""The simulator: one MuJoCo model per (object, task), reused across scenes and trials.

``reset(seed)`` places the task's props, drops the object at a random pose in the grasping half (x < 0),
lets it settle, disturbs the camera, takes one depth image by ray casting and saves that settled state.
``execute(grasp, action, seed)`` restores the saved state, so one scene serves many trials, runs the
grasp, the transport and the task's primitive, and labels the trial (:mod:`tognet.sim.trial`).

The simulator names no task: the task's props (:class:`tognet.tasks.props.TaskProps`, from the task
registry) supply their MJCF, layout, what is watched while the primitive runs and the outcome values.
Its parts: :mod:`tognet.sim.world` (the MJCF), :mod:`tognet.sim.physics` (stepping, contacts, states),
:mod:`tognet.sim.gripper` (setpoints, moves, grip checks), :mod:`tognet.sim.trial` (execute and label),
:mod:`tognet.sim.depth` (the ray-cast depth camera).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Camera, Grasp
from tognet.objects.record import ObjectRecord
from tognet.robot.arms import ArmStuck
from tognet.sim.arm import arm_driver
from tognet.sim.config import SimConfig
from tognet.sim.depth import DepthRenderer, sample_camera
from tognet.sim.groups import GROUP_PROPS
from tognet.sim.physics import (
    FINGER_L,
    FINGER_R,
    GRIPPER,
    GROUND,
    OBJECT,
    OTHER,
    PROP,
    TABLE,
    TARGET,
    SimulationError,
    Unstable,
    same_prefix,
)
from tognet.sim.trial import Trial, TrialResult
from tognet.sim.world import PARK, touch_sensor_names, world_xml
from tognet.tasks import SIM_TASKS, TASK_NAMES, Task, check_task_name, get_props, get_task
from tognet.tasks.props import PropsMJCF, TaskProps

__all__ = ["SIM_TASKS", "Observation", "SimulationError", "Simulator", "TrialResult"]


@dataclass
class Observation:
    """What the robot sees before acting: one depth image and the camera that took it."""

    depth: NDArray[np.float32]  # (H, W) camera-frame z in metres, NaN holes
    camera: Camera
    reference: NDArray[np.float64]  # the task's reference point (world); zeros for grasping
    task: str
    object_id: str
    seed: int
    info: dict[str, Any] = field(default_factory=dict)


class Simulator(Trial):
    """The world with one object and one task's props (see the module docstring)."""

    def __init__(self, config: SimConfig, task: str, obj: ObjectRecord) -> None:
        self.config = config
        self.task_name = check_task_name(task, SIM_TASKS)
        self.task: Task | None = get_task(task, config.task_config(task)) if task in TASK_NAMES else None
        self._props: TaskProps = get_props(self.task)
        self.obj = obj
        obj.check_meshes()  # a damaged mesh file is named (MuJoCo would take a truncated one silently)
        props_mjcf = self._props.mjcf(config, GROUP_PROPS)
        try:
            self.model = mujoco.MjModel.from_xml_string(world_xml(config, obj, props_mjcf))
        except ValueError as exc:  # MuJoCo's compile errors
            raise SimulationError(f"object {obj.object_id}: MuJoCo could not build the world: {exc}") from exc
        self.data = mujoco.MjData(self.model)
        self._full = (self.model, self.data)
        # Props that can be put on hold: the same world without them, stepped while they are on hold.
        self._lite: tuple[mujoco.MjModel, mujoco.MjData] | None = None
        if self._props.can_hold:
            lite = mujoco.MjModel.from_xml_string(world_xml(config, obj, PropsMJCF()))
            if same_prefix(lite, self.model):
                self._lite = (lite, mujoco.MjData(lite))
        m = self.model
        joints = ("finger_l", "finger_r")
        if config.robot.name == "floating":
            joints = ("grip_x", "grip_y", "grip_z", "grip_yaw", *joints)
        self._jid = {n: m.joint(n).id for n in joints}
        self._qadr = {n: int(m.jnt_qposadr[j]) for n, j in self._jid.items()}
        self._dadr = {n: int(m.jnt_dofadr[j]) for n, j in self._jid.items()}
        self._fingers_ctrl = (m.actuator("act_finger_l").id, m.actuator("act_finger_r").id)
        self._hand_body = m.body("hand").id
        self._arm = None if config.robot.name == "floating" else arm_driver(config, m)
        self._arm_sp = np.zeros(4)
        self._obj_qadr = int(m.jnt_qposadr[m.joint("object").id])
        self._hand_qadr = self._qadr.get("grip_x", -1)  # grip_y follows it
        self._obj_dadr = int(m.jnt_dofadr[m.joint("object").id])
        self._obj_body = m.body("object").id
        self._cat = np.full(m.ngeom, OTHER, dtype=np.int64)
        self._cat[m.geom("table").id] = TABLE
        self._cat[m.geom("ground").id] = GROUND
        # The hand's geoms (and an arm's links: every body on the hand's root) are the gripper.
        hand_root = m.body_rootid[self._hand_body] if self._arm is not None else None
        for g in range(m.ngeom):
            name = m.geom(g).name
            if name.startswith("piece_"):
                self._cat[g] = OBJECT
            elif m.geom_bodyid[g] in (m.body("hand").id,):
                self._cat[g] = GRIPPER
            elif hand_root is not None and m.body_rootid[m.geom_bodyid[g]] == hand_root:
                self._cat[g] = GRIPPER
        self._cat[m.geom("finger_l").id] = FINGER_L
        self._cat[m.geom("finger_r").id] = FINGER_R
        for name in props_mjcf.other_geoms:
            self._cat[m.geom(name).id] = PROP
        for name in props_mjcf.target_geoms:
            self._cat[m.geom(name).id] = TARGET
        self._vertices, self._vertex_pieces = self._object_vertices()  # collision vertices, object frame
        self._com = np.asarray(obj.com, dtype=np.float64)  # the body's origin in the object frame
        self._body_vertices = self._vertices - self._com
        # Where the touch sensors (the tool's and the hand's contacts with the props) sit in sensordata; the
        # world without the props has none, and a slice past its end is empty: no touch.
        touch = [int(m.sensor_adr[m.sensor(name).id]) for name in touch_sensor_names(props_mjcf)]
        self._touch = slice(min(touch), max(touch) + 1) if touch else slice(0, 0)
        self._depth = DepthRenderer(config, m)
        # Radius (m) around the object's body origin (its centre of mass) that holds all of its collision
        # geometry.
        self._object_reach = float(np.max(np.linalg.norm(self._body_vertices, axis=1)))
        self._state_spec = mujoco.mjtState.mjSTATE_INTEGRATION
        self._saved: NDArray[np.float64] | None = None
        self._arm_park: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._scene: dict[str, Any] = {}
        self._recorder: Any = None
        # Called after every physics step while the tool is near the props (see TaskProps.near), else None.
        self._every_step: Any = None
        self._dt = float(m.opt.timestep)
        self.timers = {"physics": 0.0, "raycast": 0.0}
        self.steps = 0  # physics steps taken since construction (for benchmarks)
        self._props.bind(self)

    @property
    def vertices(self) -> NDArray[np.float64]:
        """(N, 3) collision vertices of the object in its own (mesh) frame; read-only."""
        return self._vertices

    @property
    def vertex_pieces(self) -> tuple[int, ...]:
        """How many of :attr:`vertices` each convex collision piece has, in order: the hull of each piece's
        vertices is that piece (``np.split(v, np.cumsum(sim.vertex_pieces)[:-1])`` splits them)."""
        return self._vertex_pieces

    @property
    def scene(self) -> Mapping[str, Any] | None:
        """The settled scene of the last :meth:`reset` (None before one): ``seed``, ``layout`` (the task's
        prop layout, plain numbers), ``reference`` (the task's reference point, world) and ``object_com``
        (the settled object's centre of mass, world). Read it, do not change it."""
        return MappingProxyType(self._scene) if self._scene else None

    @property
    def recorder(self) -> Callable[[Simulator], None] | None:
        """What is called with the simulator after every chunk of physics steps (an animation's frame
        grabber), or None; set it for a block of code with :meth:`recording`."""
        return self._recorder

    @contextmanager
    def recording(self, recorder: Callable[[Simulator], None]) -> Iterator[Simulator]:
        """Call ``recorder(self)`` after every chunk of physics steps inside the ``with`` block (e.g. a
        :class:`tognet.sim.render.GifRecorder`); detached again on leaving it, also on an error."""
        previous, self._recorder = self._recorder, recorder
        try:
            yield self
        finally:
            self._recorder = previous

    # --- what the task's props use (tognet.tasks.props.PropsHost) -------------------------------------
    @property
    def props(self) -> TaskProps:
        """The task's props in this world (:class:`tognet.tasks.props.TaskProps`; empty for grasping)."""
        return self._props

    @property
    def object_reach(self) -> float:
        """Radius (m) around the object's body origin (its centre of mass) holding all its collision
        geometry."""
        return self._object_reach

    @property
    def object_body(self) -> int:
        """The object's body id."""
        return self._obj_body

    @property
    def body_vertices(self) -> NDArray[np.float64]:
        """(N, 3) collision vertices of the object in its body frame (origin at the centre of mass)."""
        return self._body_vertices

    def hand_xy(self) -> tuple[float, float]:
        """Where the hand is now (the grasp centre's x, y in the world; the floating base's joints)."""
        if self._arm is None:
            q, a = self.data.qpos, self._hand_qadr
            return float(q[a]), float(q[a + 1])
        x, y = self.data.xpos[self._hand_body, :2]
        return float(x), float(y)

    # --- scene --------------------------------------------------------------------------------------
    def _object_vertices(self) -> tuple[NDArray[np.float64], tuple[int, ...]]:
        pts = []
        for path in self.obj.collision_paths:
            rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
            pts.append(np.asarray(rows, dtype=np.float64).reshape(-1, 3))
        return np.concatenate(pts), tuple(len(p) for p in pts)

    def reset(self, seed: int) -> Observation:
        """A new scene from ``seed``: drop and settle the object, take the depth image, place the props."""
        m, d, w = self.model, self.data, self.config.world
        rng = np.random.default_rng([int(seed), 0x5EED])
        layout = self._props.sample_layout(rng)
        for attempt in range(5):
            mujoco.mj_resetData(m, d)
            self._park()
            yaw = rng.uniform(0, 2 * np.pi)
            xy = (rng.uniform(*w.drop_x), rng.uniform(*w.drop_y))
            # The body's origin (the centre of mass) over the drop point, the lowest point drop_height up.
            z = -float(np.min(self._vertices[:, 2])) + w.drop_height  # of the object's own frame
            qa = self._obj_qadr
            d.qpos[qa : qa + 3] = (xy[0], xy[1], z + self._com[2])
            d.qpos[qa + 3 : qa + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
            self._props.place(layout)
            mujoco.mj_forward(m, d)
            try:
                self._settle()
            except Unstable as exc:
                if attempt == 4:
                    raise SimulationError(
                        f"object {self.obj.object_id}: unstable while settling ({exc})"
                    ) from exc
                continue
            pos = d.xipos[self._obj_body]
            if abs(pos[0]) < 0.5 * w.table_size[0] and abs(pos[1]) < 0.5 * w.table_size[1] and pos[2] > -0.01:
                break
        else:
            raise SimulationError(f"object {self.obj.object_id}: fell off the table in 5 drops (seed {seed})")
        d.time = 0.0
        camera = sample_camera(self.config.camera, rng)
        depth = self.render_depth(camera, rng)
        reference = self._props.reference(layout)
        self._saved = np.empty(mujoco.mj_stateSize(m, self._state_spec))
        mujoco.mj_getState(m, d, self._saved, self._state_spec)
        self._scene = {
            "seed": int(seed),
            "layout": layout,
            "reference": reference,
            "object_com": d.xipos[self._obj_body].copy(),
        }
        return Observation(
            depth=depth,
            camera=camera,
            reference=reference,
            task=self.task_name,
            object_id=self.obj.object_id,
            seed=int(seed),
            info={"layout": layout},
        )

    def place_scene(self, layout: dict[str, Any], seed: int) -> None:
        """A scene set rather than drawn: the object's own frame at the world's (its meshes where they
        are, e.g. built from an image in the world frame), the props where ``layout`` says; settled and
        saved, as :meth:`reset` leaves a scene (no depth image is taken). ``seed`` names the scene: the
        trials' execution noise is drawn from it and their own seeds."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        self._park()
        qa = self._obj_qadr
        d.qpos[qa : qa + 3] = self._com
        d.qpos[qa + 3 : qa + 7] = (1.0, 0.0, 0.0, 0.0)
        self._props.place(layout)
        mujoco.mj_forward(m, d)
        try:
            self._settle()
        except Unstable as exc:
            raise SimulationError(f"object {self.obj.object_id}: unstable while settling ({exc})") from exc
        d.time = 0.0
        self._saved = np.empty(mujoco.mj_stateSize(m, self._state_spec))
        mujoco.mj_getState(m, d, self._saved, self._state_spec)
        self._scene = {"seed": int(seed), "layout": layout, "reference": self._props.reference(layout),
                       "object_com": d.xipos[self._obj_body].copy()}

    def _park(self) -> None:
        """The hand out of the way while a scene settles: the floating base above the table, an arm at its
        park pose (``robot.park``)."""
        g = self.config.gripper
        if self._arm is None:
            self._set_gripper(np.asarray(PARK), 0.0, g.max_opening)
            return
        if self._arm_park is None:
            base, yaw = self._arm.base_position, self._arm.base_yaw
            ahead, left, height = self.config.robot.park
            c, s = math.cos(yaw), math.sin(yaw)
            x, y = base[0] + c * ahead - s * left, base[1] + s * ahead + c * left
            pose = np.array([x, y, base[2] + height, yaw])
            try:
                self._arm_park = (pose, self._arm.solve(pose, "the park pose"))
            except ArmStuck as exc:
                raise SimulationError(f"the {self.config.robot.name} arm cannot reach its park pose "
                                      f"{pose[:3].round(3).tolist()} (robot.park): {exc}") from exc
        pose, q = self._arm_park
        self._set_gripper(pose[:3], float(pose[3]), g.max_opening, q)

    def _settle(self) -> None:
        w = self.config.world
        da = self._obj_dadr
        steps = 0
        limit = round(w.settle_time / self._dt)
        while steps < limit:
            self._step(10)
            steps += 10
            self._check_stable()
            if steps >= 60 and np.max(np.abs(self.data.qvel[da : da + 6])) < w.settle_speed:
                break

    def render_depth(self, camera: Camera, rng: np.random.Generator | None = None) -> NDArray[np.float32]:
        """Depth image (camera-frame z, metres, NaN holes) of the world now by ray casting (no OpenGL):
        see :meth:`tognet.sim.depth.DepthRenderer.render`."""
        t0 = time.perf_counter()
        depth = self._depth.render(self.model, self.data, camera, rng)
        self.timers["raycast"] += time.perf_counter() - t0
        return depth

    # --- the settled object -------------------------------------------------------------------------
    def object_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The pose of the object's own frame (its meshes' frame) in the world: position, rotation matrix.
        (The simulated body's origin is the centre of mass, ``obj.com`` in this frame.)"""
        b = self._obj_body
        rot = self.data.xmat[b].reshape(3, 3).copy()
        return self.data.xpos[b] - rot @ self._com, rot

    def default_grasp(self) -> Grasp:
        """A sensible grasp on the settled object: at its centre of mass, jaw across its narrow side."""
        pos, rot = self.object_pose()
        pts = (self._vertices @ rot.T + pos)[:, :2]
        centred = pts - pts.mean(axis=0)
        _, vecs = np.linalg.eigh(centred.T @ centred)
        minor = vecs[:, 0]  # eigenvalues ascending: the narrow direction
        com = self.data.xipos[self._obj_body]
        return Grasp.from_array([com[0], com[1], com[2], np.arctan2(minor[1], minor[0])])
