"""The simulator: one MuJoCo model per (object, task), reused across scenes and trials.

``reset(seed)`` places the task's props, drops the object at a random pose in the grasping half (x < 0),
lets it settle, disturbs the camera, takes one depth image by ray casting and saves that settled state.
``execute(grasp, action, seed)`` restores the saved state, so one scene serves many trials, and runs:

1. grasp: the gripper appears ``approach_height`` above the (noisy) grasp, descends (a finger or the
   palm pressing into the object on the way down fails the grasp), closes with a force limit, lifts the
   grasp centre to ``lift_height`` (at least ``min_lift``) and holds. S_G: both fingers touch the tool and
   its lowest point is clear of the table. ``info["in_hand"]`` is the tool's (3, 4) pose in the gripper
   frame after the hold (x = jaw axis), for oracles and diagnostics.
2. transport: to ``start_clearance`` above the start pose (task reference + nominal offset + action, yaw
   nominal + a_phi, with noise), then down to it. Touching a prop on the way (a contact: near the props
   every step's contacts are read, through MuJoCo contact sensors; or a prop moved by ``prop_moved``) is
   COLLISION_BEFORE_MOTION; a tool no longer between both fingers is DROPPED.
3. primitive: the task's motion (speed- and force-limited servos, acceleration-limited setpoints), then
   a settling time; the task's rule labels S_T. A can that reaches the ground has done its part and is
   taken out of the scene (its fast impact is not simulated). The targets count as touched when a checked
   step saw the contact or when they moved by ``prop_moved``. A failed task with the tool no longer between
   both fingers after the motion and after the settling time is DROPPED (it slipped out during the
   primitive), else the task's reason.

Any NaN, joint speed above ``max_speed`` or contact deeper than ``max_penetration`` (ground contacts
excepted) makes the trial invalid (UNSTABLE), never a success or a failure. Afterwards the world is back
in the settled scene.
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

from tognet.errors import TognetError
from tognet.geometry import Camera, CameraIntrinsics, Grasp
from tognet.geometry.raster import mesh_depth
from tognet.geometry.transforms import make_pose, rot_x, rot_y, rot_z
from tognet.objects.record import ObjectRecord
from tognet.sim.config import SimConfig
from tognet.sim.world import BASE_RANGE, GROUP_OBJECT_VISUAL, MAX_CANS, PARK, touch_sensor_names, world_xml
from tognet.tasks import TASK_NAMES, FailureReason, Task, TaskOutcome, get_task

SIM_TASKS = (*TASK_NAMES, "grasping")

# Geom categories used to read contacts quickly.
OTHER, TABLE, GROUND, OBJECT, FINGER_L, FINGER_R, GRIPPER, CAN, PEG, SLOT = range(10)
_TOOL_SIDE = np.isin(np.arange(10), (OBJECT, FINGER_L, FINGER_R, GRIPPER))  # the tool or the hand
_HAND = np.isin(np.arange(10), (FINGER_L, FINGER_R, GRIPPER))


def _hull_2d(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Counter-clockwise convex hull of a few 2-D points (monotone chain); ValueError if it is degenerate.
    (scipy's Qhull costs ~1 ms a call here, for 4 or 8 points.)"""
    pts = sorted({(float(x), float(y)) for x, y in points})

    def turn(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    chain: list[tuple[float, float]] = []
    for sweep in (pts, pts[::-1]):  # lower hull, then upper hull
        start = len(chain)
        for q in sweep:
            while len(chain) >= start + 2 and turn(chain[-2], chain[-1], q) <= 0:
                chain.pop()
            chain.append(q)
        chain.pop()  # each half's last point starts the other half
    if len(chain) < 3:
        raise ValueError("degenerate outline")
    return np.asarray(chain)


def _rows_in_hull(
    points: NDArray[np.float64], grow: float, height: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per image row v = 0 .. height - 1, the interval [lo, hi] of u inside the convex hull of the 2-D
    ``points`` grown by ``grow`` px (shrunk if negative); hi < lo on rows it does not reach."""
    hull = _hull_2d(points)
    edge = np.roll(hull, -1, axis=0) - hull
    length = np.hypot(edge[:, 0], edge[:, 1])
    nx, ny = edge[:, 1] / length, -edge[:, 0] / length  # outward unit normals (counter-clockwise hull)
    off = -(nx * hull[:, 0] + ny * hull[:, 1])  # n . p + off <= 0 inside
    nx, ny, off = nx[None, :], ny[None, :], off[None, :]
    rows = np.arange(height, dtype=np.float64)[:, None]
    rhs = grow - off - ny * rows  # nx * u <= rhs
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = rhs / nx
    lo = np.max(np.where(nx < 0, bound, -np.inf), axis=1)
    hi = np.min(np.where(nx > 0, bound, np.inf), axis=1)
    flat_ok = np.all(np.where(nx == 0, rhs >= 0, True), axis=1)
    return lo, np.where(flat_ok, hi, -np.inf)


class SimulationError(TognetError):
    """The world cannot be built or an episode cannot be set up (bad object, bad input)."""


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


@dataclass
class TrialResult:
    """Labels of one trial. An invalid trial (unstable physics) is neither a success nor a failure."""

    grasp_success: bool
    task_success: bool
    valid: bool
    failure: FailureReason
    info: dict[str, Any] = field(default_factory=dict)


class _Unstable(Exception):
    pass


class _Landed(Exception):
    pass


class Simulator:
    """The world with one object and one task's props (see the module docstring)."""

    def __init__(self, config: SimConfig, task: str, obj: ObjectRecord) -> None:
        if task not in SIM_TASKS:
            raise ValueError(f"unknown task '{task}'; known: {', '.join(SIM_TASKS)}")
        self.config = config
        self.task_name = task
        self.task: Task | None = get_task(task, getattr(config, task)) if task in TASK_NAMES else None
        self.obj = obj
        try:
            self.model = mujoco.MjModel.from_xml_string(world_xml(config, obj, task))
        except ValueError as exc:  # MuJoCo's compile errors
            raise SimulationError(f"object {obj.object_id}: MuJoCo could not build the world: {exc}") from exc
        self.data = mujoco.MjData(self.model)
        self._full = (self.model, self.data)
        # Sweeping: the same world without the cans, stepped while the cans are on hold (_hold_cans).
        self._lite: tuple[mujoco.MjModel, mujoco.MjData] | None = None
        if task == "sweeping":
            lite = mujoco.MjModel.from_xml_string(world_xml(config, obj, "grasping"))
            full = self.model
            n = MAX_CANS
            fewer = {"nq": 7 * n, "nv": 6 * n, "nbody": n, "ngeom": n, "nu": 0, "na": 0}
            if all(getattr(lite, f) == getattr(full, f) - k for f, k in fewer.items()):
                self._lite = (lite, mujoco.MjData(lite))
        m = self.model
        self._jid = {
            n: m.joint(n).id for n in ("grip_x", "grip_y", "grip_z", "grip_yaw", "finger_l", "finger_r")
        }
        self._qadr = {n: int(m.jnt_qposadr[j]) for n, j in self._jid.items()}
        self._dadr = {n: int(m.jnt_dofadr[j]) for n, j in self._jid.items()}
        self._obj_qadr = int(m.jnt_qposadr[m.joint("object").id])
        self._hand_qadr = self._qadr["grip_x"]  # grip_y follows it
        self._obj_dadr = int(m.jnt_dofadr[m.joint("object").id])
        self._obj_body = m.body("object").id
        self._cat = np.full(m.ngeom, OTHER, dtype=np.int64)
        self._cat[m.geom("table").id] = TABLE
        self._cat[m.geom("ground").id] = GROUND
        for g in range(m.ngeom):
            name = m.geom(g).name
            if name.startswith("piece_"):
                self._cat[g] = OBJECT
            elif m.geom_bodyid[g] in (m.body("hand").id,):
                self._cat[g] = GRIPPER
        self._cat[m.geom("finger_l").id] = FINGER_L
        self._cat[m.geom("finger_r").id] = FINGER_R
        self._can_geoms = []
        if task == "sweeping":
            self._can_geoms = [m.geom(f"can_{i}").id for i in range(MAX_CANS)]
            for g in self._can_geoms:
                self._cat[g] = CAN
            self._can_qadr = [int(m.jnt_qposadr[m.joint(f"can_{i}").id]) for i in range(MAX_CANS)]
            self._can_dadr = [int(m.jnt_dofadr[m.joint(f"can_{i}").id]) for i in range(MAX_CANS)]
            self._can_body = [m.body(f"can_{i}").id for i in range(MAX_CANS)]
        if task == "hammering":
            self._cat[m.geom("peg").id] = PEG
            self._cat[m.geom("slot").id] = SLOT
            self._peg_qadr = int(m.jnt_qposadr[m.joint("peg").id])
            self._slot_body = m.body("slot").id
        self._vertices = self._object_vertices()  # collision vertices, object frame
        self._com = np.asarray(obj.com, dtype=np.float64)  # the body's origin in the object frame
        self._body_vertices = self._vertices - self._com
        # Where the touch sensors (the tool's and the hand's contacts with the props) sit in sensordata; the
        # world without the cans has none, and a slice past its end is empty: no touch.
        touch = [int(m.sensor_adr[m.sensor(name).id]) for name in touch_sensor_names(task)]
        self._touch = slice(min(touch), max(touch) + 1) if touch else slice(0, 0)
        self._visual_geom = m.geom("object_visual").id
        # The visual mesh as MuJoCo compiled it (geom frame), for the depth camera.
        mid = int(m.geom_dataid[self._visual_geom])
        va, vn = int(m.mesh_vertadr[mid]), int(m.mesh_vertnum[mid])
        fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
        self._visual_local = m.mesh_vert[va : va + vn].astype(np.float64)
        self._visual_faces = m.mesh_face[fa : fa + fn].astype(np.int64)
        # Radius (m) around the object's body origin (its centre of mass) that holds all of its collision
        # geometry.
        self._object_reach = float(np.max(np.linalg.norm(self._body_vertices, axis=1)))
        # Cans on hold while the tool is far from them: {can: its (qpos, qvel, solver warm start) then}.
        self._held_cans: dict[int, tuple[NDArray[np.float64], ...]] = {}
        self._state_spec = mujoco.mjtState.mjSTATE_INTEGRATION
        self._saved: NDArray[np.float64] | None = None
        self._scene: dict[str, Any] = {}
        self._recorder: Any = None
        # Called after every physics step while the tool is near the props (see _near_props), else None.
        self._every_step: Any = None
        self._dt = float(m.opt.timestep)
        self.timers = {"physics": 0.0, "raycast": 0.0}
        self.steps = 0  # physics steps taken since construction (for benchmarks)
        self._image_buffers: dict[tuple[str, int, str], NDArray[Any]] = {}

    # --- public views for other modules (oracles, animations) -----------------------------------------
    @property
    def vertices(self) -> NDArray[np.float64]:
        """(N, 3) collision vertices of the object in its own (mesh) frame; read-only."""
        return self._vertices

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

    # ------------------------------------------------------------------------------------------------
    def _object_vertices(self) -> NDArray[np.float64]:
        pts = []
        for path in self.obj.collision_paths:
            rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
            pts.append(np.asarray(rows, dtype=np.float64))
        return np.concatenate(pts)

    def _step(self, n: int) -> None:
        if self._held_cans and self._near_cans():
            self._release_cans()
        t0 = time.perf_counter()
        if self._every_step is not None and self._near_props():
            watch, m, d = self._every_step, self.model, self.data
            for _ in range(n):  # near the props: look at every step's contacts (a knock is brief)
                mujoco.mj_step(m, d)
                watch()
        else:
            mujoco.mj_step(self.model, self.data, nstep=n)
        self.timers["physics"] += time.perf_counter() - t0
        self.steps += n
        if self._recorder is not None:
            self._recorder(self)

    def _pair_table(self, first: NDArray[np.bool_], second: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """(ngeom, ngeom) table: True for geom pairs with one geom's category in ``first`` and the
        other's in ``second`` (either way round), to test a step's contacts in one lookup."""
        a, b = first[self._cat], second[self._cat]
        return (a[:, None] & b[None, :]) | (b[:, None] & a[None, :])

    def _contacts(self) -> NDArray[np.int64]:
        """(ncon, 2) geom categories of the current contacts, each row sorted."""
        n = self.data.ncon
        if n == 0:
            return np.zeros((0, 2), dtype=np.int64)
        pairs = np.sort(self._cat[self.data.contact.geom[:n]], axis=1)
        return pairs

    def _check_stable(self) -> None:
        d, e = self.data, self.config.episode
        # Fast path (this runs every check_every steps): NaN fails every comparison, inf the finite sum.
        qvel = d.qvel
        if not (qvel.max() <= e.max_speed and -qvel.min() <= e.max_speed and math.isfinite(d.qpos.sum())):
            if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(qvel))):
                raise _Unstable("NaN in the state")
            raise _Unstable(f"speed {float(np.max(np.abs(qvel))):.1f}")
        n = d.ncon
        if n:
            contact = d.contact
            dist = contact.dist[:n]
            if dist.min() < -e.max_penetration:
                # Things falling off the table hit the ground fast; only other contacts count as deep.
                cats = self._cat[contact.geom[:n]]
                deep = (dist < -e.max_penetration) & np.all(cats != GROUND, axis=1)
                if np.any(deep):
                    raise _Unstable(f"penetration {-float(np.min(dist[deep])):.3f} m")

    # --- gripper setpoints --------------------------------------------------------------------------
    def _set_gripper(self, pos: NDArray[np.float64], yaw: float, opening: float) -> None:
        """Teleport the gripper (joints and setpoints) to a pose, at rest."""
        d = self.data
        for i, name in enumerate(("grip_x", "grip_y", "grip_z")):
            d.qpos[self._qadr[name]] = pos[i]
            d.act[i] = pos[i]
            d.ctrl[i] = 0.0
        d.qpos[self._qadr["grip_yaw"]] = yaw
        d.act[3] = yaw
        d.ctrl[3] = 0.0
        half = 0.5 * opening
        for name, ctrl in (("finger_l", 4), ("finger_r", 5)):
            d.qpos[self._qadr[name]] = half
            d.ctrl[ctrl] = half
        for name in ("grip_x", "grip_y", "grip_z", "grip_yaw", "finger_l", "finger_r"):
            d.qvel[self._dadr[name]] = 0.0

    def _move(
        self,
        target: NDArray[np.float64] | None,
        yaw: float | None,
        speed: float,
        yaw_speed: float,
        monitor: Any = None,
    ) -> None:
        """Move the setpoints in a straight line to ``target`` / ``yaw`` at the given rates."""
        dt = self._dt
        cur = self.data.act[:4].copy()
        goal = cur.copy()
        if target is not None:
            goal[:3] = target
        if yaw is not None:
            goal[3] = yaw
        delta = goal - cur
        t_lin = float(np.linalg.norm(delta[:3])) / max(speed, 1e-9)
        t_yaw = abs(float(delta[3])) / max(yaw_speed, 1e-9)
        every = self.config.episode.check_every
        chunk = every * dt
        # Trapezoidal speed profile in chunks: ramps of accel_time at each end (acceleration-limited).
        ramp = max(1, round(self.config.gripper.accel_time / chunk))
        n = max(1, math.ceil(max(t_lin, t_yaw) / chunk - 1e-9)) + ramp
        k = np.arange(n) + 0.5
        profile = np.minimum(1.0, np.minimum(k, n - k) / ramp)
        profile /= profile.sum() * chunk
        for weight in profile:
            self.data.ctrl[:4] = delta * weight
            self._step(every)
            if monitor is not None:
                monitor()  # first: a can that just hit the ground is parked before the stability check
            self._check_stable()
        self.data.ctrl[:4] = 0.0
        self.data.act[:4] = goal  # remove round-off

    def _converge(self, tol: float = 0.002, max_time: float = 0.2, monitor: Any = None) -> None:
        """Let the base catch up with its setpoints (servo lag) until within ``tol`` (m, rad) and slow."""
        q = [self._qadr[n] for n in ("grip_x", "grip_y", "grip_z", "grip_yaw")]
        v = [self._dadr[n] for n in ("grip_x", "grip_y", "grip_z", "grip_yaw")]
        self._wait(
            max_time,
            monitor,
            until=lambda: bool(
                np.max(np.abs(self.data.qpos[q] - self.data.act[:4])) < tol
                and np.max(np.abs(self.data.qvel[v])) < 0.05
            ),
        )

    def _wait(self, duration: float, monitor: Any = None, until: Any = None) -> None:
        every = self.config.episode.check_every
        n = max(1, round(duration / self._dt))
        done = 0
        while done < n:
            k = min(every, n - done)
            self._step(k)
            done += k
            if monitor is not None:
                monitor()
            self._check_stable()
            if until is not None and until():
                return

    # --- scene --------------------------------------------------------------------------------------
    def _camera(self, rng: np.random.Generator) -> Camera:
        c = self.config.camera
        intr = CameraIntrinsics(
            width=c.width,
            height=c.height,
            fx=c.fx * (1 + rng.uniform(-c.focal_noise, c.focal_noise)),
            fy=c.fy * (1 + rng.uniform(-c.focal_noise, c.focal_noise)),
            cx=(c.width - 1) / 2 + rng.uniform(-c.principal_noise, c.principal_noise),
            cy=(c.height - 1) / 2 + rng.uniform(-c.principal_noise, c.principal_noise),
        )
        nominal = Camera.looking_down(intr, c.position, yaw=c.yaw)
        t = np.asarray(c.translation_noise)
        r = c.rotation_noise
        jitter = rot_z(rng.uniform(-r, r)) @ rot_y(rng.uniform(-r, r)) @ rot_x(rng.uniform(-r, r))
        rotation = jitter @ nominal.pose[:3, :3]
        position = nominal.position + rng.uniform(-t, t)
        return Camera(intr, make_pose(rotation, position))

    def _buffer(self, name: str, size: int, dtype: type = np.float64) -> NDArray[Any]:
        """A reusable flat array (fresh multi-MB temporaries cost page faults); valid until reused."""
        key = (name, size, np.dtype(dtype).str)
        buf = self._image_buffers.get(key)
        if buf is None:
            buf = self._image_buffers[key] = np.empty(size, dtype=dtype)
        return buf

    def _static_rays(
        self,
        origin: NDArray[np.float64],
        dx: NDArray[np.float64],
        dy: NDArray[np.float64],
        dz: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Ray parameter (= camera-frame z) to the table slab or the ground plane for rays with world
        directions (dx, dy, dz) from ``origin``; inf if they hit neither."""
        w = self.config.world
        lx, ly, thick = 0.5 * w.table_size[0], 0.5 * w.table_size[1], 0.04
        ox, oy, oz = origin
        out = np.full(dz.shape, np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            if oz > 0:  # the table top, seen from above
                t = -oz / dz
                hit = (t > 0) & (np.abs(ox + t * dx) <= lx) & (np.abs(oy + t * dy) <= ly)
                out[hit] = t[hit]
                rest = np.flatnonzero(~hit)
            else:
                rest = np.arange(out.size)
            dx, dy, dz = dx[rest], dy[rest], dz[rest]
            sub = np.full(rest.size, np.inf)
            for axis_o, axis_d, other_o, other_d, half, other_half in (
                (ox, dx, oy, dy, lx, ly),
                (oy, dy, ox, dx, ly, lx),
            ):
                for sign in (-1.0, 1.0):  # the table's side faces
                    ts = (sign * half - axis_o) / axis_d
                    z = oz + ts * dz
                    side = (
                        (ts > 0) & (np.abs(other_o + ts * other_d) <= other_half) & (z <= 0) & (z >= -thick)
                    )
                    sub = np.where(side & (ts < sub), ts, sub)
            ts = (-w.table_height - oz) / dz
            sub = np.where((ts > 0) & (ts < sub), ts, sub)
            out[rest] = sub
        return out

    def _table_rows(
        self, camera: Camera
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None:
        """Per image row, the columns whose rays surely end on the table top, [top_lo, top_hi] (its
        projected outline shrunk by 1 px), and the interval [slab_lo, slab_hi] outside which they surely
        miss the table slab (its projected outline grown by 1 px) and end on the ground. Pixels between
        the two get the exact test. None when the outlines cannot be used (a corner behind the camera,
        the camera at or below the table top, a degenerate outline)."""
        w, k = self.config.world, camera.intrinsics
        lx, ly, thick = 0.5 * w.table_size[0], 0.5 * w.table_size[1], 0.04
        corners = np.array([[sx * lx, sy * ly, z] for z in (0.0, -thick) for sx in (-1, 1) for sy in (-1, 1)])
        uv, z = camera.project(corners)
        if camera.pose[2, 3] <= 0 or not np.all(z > 1e-6):
            return None
        try:
            top = _rows_in_hull(uv[:4], -1.0, k.height)
            slab = _rows_in_hull(uv, 1.0, k.height)
        except ValueError:
            return None
        return (*top, *slab)

    def _cast_object_rays(
        self,
        origin: NDArray[np.float64],
        dirs: NDArray[np.float64],
        idx: NDArray[np.int64],
        t: NDArray[np.float64],
    ) -> None:
        """Cast the rays of pixels ``idx`` (world directions ``dirs``, (n, 3)) at the object's visual mesh
        with MuJoCo's ray caster; nearer hits overwrite ``t``."""
        n = len(idx)
        if n == 0:
            return
        groups = np.zeros(6, dtype=np.uint8)
        groups[GROUP_OBJECT_VISUAL] = 1  # the table and the ground are already in t
        geomid = np.empty(n, dtype=np.int32)
        dist = np.empty(n, dtype=np.float64)
        mujoco.mj_multiRay(
            self.model,
            self.data,
            origin.astype(np.float64),
            np.ascontiguousarray(dirs).ravel(),
            groups,
            0,
            -1,
            geomid,
            dist,
            None,
            n,
            self.config.camera.max_range,
        )
        hit = (geomid >= 0) & (dist < t[idx])
        t[idx[hit]] = dist[hit]

    def render_depth(self, camera: Camera, rng: np.random.Generator | None = None) -> NDArray[np.float32]:
        """Depth image (camera-frame z, metres, NaN holes) by ray casting (no OpenGL).

        Every pixel's ray ends where MuJoCo's ray caster would end it for a camera above the table:
        on the table slab's top or sides, the ground plane or the object's visual mesh, whichever is
        nearest (the slab's underside is not modelled; the ground is an unbounded plane). The table
        and the ground are intersected analytically: pixels well inside the table top's outline, or
        well outside the slab's, in one vectorised division, the rest with the exact slab test. The
        object's mesh: exact ray-triangle intersection for the pixels its triangles cover
        (:func:`tognet.geometry.raster.mesh_depth`), or MuJoCo's ray caster (``mj_multiRay``) if the
        mesh reaches behind the camera. Task props and the gripper (parked out of view) are not seen.
        """
        t0 = time.perf_counter()
        c = self.config.camera
        k = camera.intrinsics
        n_pix = k.width * k.height
        a = (np.arange(k.width, dtype=np.float64) - k.cx) / k.fx
        b = (np.arange(k.height, dtype=np.float64) - k.cy) / k.fy
        r = camera.pose[:3, :3]
        origin = camera.position
        # World direction of pixel (u, v): R @ (a_u, b_v, 1), its camera-frame z is 1, so the ray
        # parameter of a hit is its depth. Row i of R gives world axis i: ((r_i0 a_u) + (r_i1 b_v)) + r_i2.
        ra = [r[i, 0] * a for i in range(3)]
        rb = [r[i, 1] * b for i in range(3)]
        dz = self._buffer("dz", n_pix).reshape(k.height, k.width)
        np.add(ra[2][None, :], rb[2][:, None], out=dz)
        dz += r[2, 2]
        t = self._buffer("t", n_pix)
        rows = self._table_rows(camera)
        if rows is None:
            todo = np.arange(n_pix)
        else:
            top_lo, top_hi, slab_lo, slab_hi = rows
            cols = np.arange(k.width, dtype=np.float64)[None, :]
            off_slab = self._buffer("off_slab", n_pix, np.bool_).reshape(k.height, k.width)
            np.less(cols, slab_lo[:, None], out=off_slab)
            off_slab |= cols > slab_hi[:, None]
            flat_dz, off = dz.ravel(), off_slab.ravel()
            with np.errstate(divide="ignore"):
                # The table top's plane inside the slab's outline, the ground's plane outside it.
                np.divide(-origin[2], flat_dz, out=t, where=~off)
                np.divide(-self.config.world.table_height - origin[2], flat_dz, out=t, where=off)
            if not np.all(flat_dz < 0):  # rays that do not go down never reach either plane
                t[~(flat_dz < 0)] = np.inf
            exact = self._buffer("exact", n_pix, np.bool_).reshape(k.height, k.width)
            np.less(cols, top_lo[:, None], out=exact)
            exact |= cols > top_hi[:, None]
            exact &= ~off_slab
            todo = np.flatnonzero(exact.ravel())

        def directions(pixels: NDArray[np.int64]) -> NDArray[np.float64]:
            """(n, 3) world ray directions of flat pixel indices (the same sums as the dz image)."""
            v, u = np.divmod(pixels, k.width)
            return np.stack([ra[i][u] + rb[i][v] + r[i, 2] for i in range(3)], axis=1)

        dirs = directions(todo)
        t[todo] = self._static_rays(origin, dirs[:, 0], dirs[:, 1], dirs[:, 2])
        # The object's visual mesh.
        d, gid = self.data, self._visual_geom
        world = self._visual_local @ d.geom_xmat[gid].reshape(3, 3).T + d.geom_xpos[gid]
        intr = (k.fx, k.fy, k.cx, k.cy, k.width, k.height)
        if not mesh_depth(r, origin, intr, world, self._visual_faces, t):
            # A vertex behind the camera: MuJoCo's ray caster on every pixel (slow, never seen in use).
            every = np.arange(n_pix)
            self._cast_object_rays(origin, directions(every), every, t)
        depth = t.astype(np.float32)
        depth[~(depth <= c.max_range)] = np.nan  # also inf (no hit) and NaN
        if rng is not None and c.depth_noise > 0:
            depth += rng.normal(0.0, c.depth_noise, size=depth.shape).astype(np.float32)
        if rng is not None and c.hole_fraction > 0:
            depth[rng.random(depth.shape) < c.hole_fraction] = np.nan
        self.timers["raycast"] += time.perf_counter() - t0
        return depth.reshape(k.height, k.width)

    def _park_can(self, i: int) -> None:
        """Take a can that reached the ground out of the scene (it has done its part): a fast-falling
        can's impact on the ground at 2 ms steps is not worth simulating. A parked can touches nothing
        and floats at rest (gravity compensated), so it costs no contacts (it used to stand on the
        ground, about 4 contacts of every step for nothing)."""
        d, c, h = self.data, self.config.sweeping, self.config.world.table_height
        qa, da = self._can_qadr[i], self._can_dadr[i]
        d.qpos[qa : qa + 7] = (1.5 + 0.3 * i, 1.5, -h + 0.5 * c.can_height, 1, 0, 0, 0)
        d.qvel[da : da + 6] = 0.0
        self._can_active(i, False)

    def _can_active(self, i: int, active: bool) -> None:
        """Switch can ``i``'s contacts and gravity on (in play) or off (parked). These are model fields,
        so every trial sets them again from its scene (see :meth:`_activate_cans`)."""
        m, g = self.model, self._can_geoms[i]
        m.geom_contype[g] = m.geom_conaffinity[g] = 1 if active else 0
        m.body_gravcomp[self._can_body[i]] = 0.0 if active else 1.0

    def _hold_cans(self, n: int) -> None:
        """Put the ``n`` cans in play on hold while the tool is far from them: standing still on the
        table they are a fixed point of the physics, yet they cost a good part of every step (their
        table contacts, and their 6 degrees of freedom each even without contacts). On hold a can keeps
        its state aside and is given it back (:meth:`_release_cans`) before the tool or the hand can
        reach it, so it goes on exactly as it stood. Meanwhile the world is stepped without it: in the
        same world built without the cans (``_lite``; the cans are the model's last bodies, so every
        other index is the same and the other bodies' motion is the same to the last bit), or, while a
        recorder needs the full model, with the cans floating contact-free and gravity-compensated."""
        if not n or self._near_cans(range(n)):
            return
        d = self.data
        for i in range(n):
            qa, da = self._can_qadr[i], self._can_dadr[i]
            ws = d.qacc_warmstart[da : da + 6].copy()
            self._held_cans[i] = (d.qpos[qa : qa + 7].copy(), d.qvel[da : da + 6].copy(), ws)
        if self._lite is not None and self._recorder is None:
            self._switch_model(lite=True)
            return
        for i in range(n):
            da = self._can_dadr[i]
            d.qvel[da : da + 6] = 0.0
            self._can_active(i, False)

    def _release_cans(self) -> None:
        """Every can on hold back in play, in the state it was put on hold in."""
        if self.data is not self._full[1]:
            self._switch_model(lite=False)
        d = self.data
        for i, (qpos, qvel, warmstart) in self._held_cans.items():
            qa, da = self._can_qadr[i], self._can_dadr[i]
            d.qpos[qa : qa + 7] = qpos
            d.qvel[da : da + 6] = qvel
            d.qacc_warmstart[da : da + 6] = warmstart  # the solver starts from where it stood
            self._can_active(i, True)
        self._held_cans = {}

    def _switch_model(self, lite: bool) -> None:
        """Step the world without the cans (``lite``) or with them from now on, carrying the state of
        everything else over (time, positions, velocities, actuators, controls, solver warm start)."""
        assert self._lite is not None
        (fm, fd), (lm, ld) = self._full, self._lite
        src, dst = (fd, ld) if lite else (ld, fd)
        nq, nv, na, nu = lm.nq, lm.nv, lm.na, lm.nu
        dst.time = src.time
        dst.qpos[:nq] = src.qpos[:nq]
        dst.qvel[:nv] = src.qvel[:nv]
        dst.act[:na] = src.act[:na]
        dst.ctrl[:nu] = src.ctrl[:nu]
        dst.qacc_warmstart[:nv] = src.qacc_warmstart[:nv]
        self.model, self.data = (lm, ld) if lite else (fm, fd)
        mujoco.mj_forward(self.model, self.data)

    def _back_to_full_model(self) -> None:
        """After a trial: the full world again (its state is restored from the scene next)."""
        self.model, self.data = self._full
        self._held_cans = {}

    def _near_cans(self, cans: Any = None) -> bool:
        """The object (a sphere around its body holding all its geometry) or the hand within
        ``can_hold_margin`` of a can on hold (or of ``cans``), in x and y."""
        d = self.data
        sw, g = self.config.sweeping, self.config.gripper
        margin = sw.can_hold_margin + sw.can_radius
        hand_reach = 0.5 * g.max_opening + g.pad_size[0] + 0.03 + margin
        obj_reach = self._object_reach + margin
        ox, oy = float(d.xpos[self._obj_body, 0]), float(d.xpos[self._obj_body, 1])
        hx, hy = float(d.qpos[self._hand_qadr]), float(d.qpos[self._hand_qadr + 1])
        if cans is None:
            where = [(float(q[0]), float(q[1])) for q, *_ in self._held_cans.values()]
        else:
            where = [(float(d.qpos[self._can_qadr[i]]), float(d.qpos[self._can_qadr[i] + 1])) for i in cans]
        pts: NDArray[np.float64] | None = None
        for cx, cy in where:
            if math.hypot(hx - cx, hy - cy) < hand_reach:
                return True
            if math.hypot(ox - cx, oy - cy) < obj_reach:
                if pts is None:  # near the bounding sphere: look at the collision vertices themselves
                    rot = d.xmat[self._obj_body].reshape(3, 3)
                    pts = self._body_vertices @ rot[:2].T + d.xpos[self._obj_body, :2]
                if np.min((pts[:, 0] - cx) ** 2 + (pts[:, 1] - cy) ** 2) < margin * margin:
                    return True
        return False

    def _near_props(self) -> bool:
        """Whether the tool or the hand could touch a prop within the next chunk of steps: a can in play
        (cans are on hold, out of the world, until the tool comes near), or the object's bounding sphere
        within reach of a circle around the slot and its peg."""
        if self.task_name == "sweeping":
            return bool(self._scene["layout"].get("cans")) and not self._held_cans
        if self.task_name != "hammering":
            return False
        cx, cy, reach = self._slot_reach
        x, y = self.data.xpos[self._obj_body, :2]
        return math.hypot(float(x) - cx, float(y) - cy) < reach

    def _prop_positions(self) -> NDArray[np.float64]:
        """(k, 3) positions of the task's props now: each can in play (where it stands, on hold or not), or
        the peg's slide (x only); empty for other tasks. A parked can is far from anywhere it stood."""
        d = self.data
        if self.task_name == "sweeping":
            rows = []
            for i in range(len(self._scene["layout"].get("cans", []))):
                held = self._held_cans.get(i)
                qa = self._can_qadr[i]
                rows.append(held[0][:3] if held is not None else d.qpos[qa : qa + 3])
            return np.array(rows, dtype=np.float64).reshape(-1, 3)
        if self.task_name == "hammering":
            return np.array([[float(d.qpos[self._peg_qadr]), 0.0, 0.0]])
        return np.zeros((0, 3))

    def _prop_shift(self, before: NDArray[np.float64]) -> float:
        """How far (m) the props moved at most since ``before`` (:meth:`_prop_positions`); 0 without props."""
        now = self._prop_positions()
        return float(np.max(np.linalg.norm(now - before, axis=1))) if len(now) else 0.0

    def _activate_cans(self, n: int) -> None:
        """The first ``n`` cans in play, the others parked."""
        for i in range(len(self._can_geoms)):
            self._can_active(i, i < n)

    def _place_props(self, layout: dict[str, Any]) -> None:
        m, d = self.model, self.data
        if self.task_name == "sweeping":
            c = self.config.sweeping
            h = self.config.world.table_height
            for i in range(MAX_CANS):
                qa = self._can_qadr[i]
                if i < len(layout["cans"]):
                    x, y, mass = layout["cans"][i]
                    d.qpos[qa : qa + 3] = (x, y, 0.5 * c.can_height)
                else:
                    mass = 0.2
                    d.qpos[qa : qa + 3] = (1.5 + 0.3 * i, 1.5, -h + 0.5 * c.can_height)
                d.qpos[qa + 3 : qa + 7] = (1, 0, 0, 0)
                self._can_active(i, i < len(layout["cans"]))
                body = self._can_body[i]
                r, hh = c.can_radius, c.can_height
                m.body_mass[body] = mass
                ixx = mass * (3 * r * r + hh * hh) / 12
                m.body_inertia[body] = (ixx, ixx, 0.5 * mass * r * r)
        elif self.task_name == "hammering":
            x, y = layout["slot"]
            c = self.config.hammering
            m.body_pos[self._slot_body] = (x, y, c.peg_height)
            # A circle around the slot and its peg (which sticks out toward -x), grown by the object's
            # reach, the hand around the grasp and a chunk's travel (0.1 m): see _near_props.
            depth, width, _ = c.slot_size
            half_peg = 0.5 * c.peg_length
            radius = math.hypot(0.5 * (depth + half_peg), 0.5 * width)
            self._slot_reach = (x + 0.5 * (depth - half_peg), y, self._object_reach + radius + 0.1)
            d.qpos[self._peg_qadr] = 0.0

    def reset(self, seed: int) -> Observation:
        """A new scene from ``seed``: drop and settle the object, take the depth image, place the props."""
        m, d, w = self.model, self.data, self.config.world
        rng = np.random.default_rng([int(seed), 0x5EED])
        layout = self.task.sample_layout(rng) if self.task is not None else {}
        for attempt in range(5):
            mujoco.mj_resetData(m, d)
            self._set_gripper(np.asarray(PARK), 0.0, self.config.gripper.max_opening)
            yaw = rng.uniform(0, 2 * np.pi)
            xy = (rng.uniform(*w.drop_x), rng.uniform(*w.drop_y))
            # The body's origin (the centre of mass) over the drop point, the lowest point drop_height up.
            z = -float(np.min(self._vertices[:, 2])) + w.drop_height  # of the object's own frame
            qa = self._obj_qadr
            d.qpos[qa : qa + 3] = (xy[0], xy[1], z + self._com[2])
            d.qpos[qa + 3 : qa + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
            self._place_props(layout)
            mujoco.mj_forward(m, d)
            try:
                self._settle()
            except _Unstable as exc:
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
        camera = self._camera(rng)
        depth = self.render_depth(camera, rng)
        reference = self.task.reference(layout) if self.task is not None else np.zeros(3)
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

    def save_state(self) -> NDArray[np.float64]:
        """The full integration state (a copy), for :meth:`restore_state`."""
        state = np.empty(mujoco.mj_stateSize(self.model, self._state_spec))
        mujoco.mj_getState(self.model, self.data, state, self._state_spec)
        return state

    def restore_state(self, state: NDArray[np.float64]) -> None:
        """Put the world back in a state from :meth:`save_state`."""
        mujoco.mj_setState(self.model, self.data, state, self._state_spec)
        mujoco.mj_forward(self.model, self.data)

    # --- trial --------------------------------------------------------------------------------------
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

    def execute(self, grasp: Grasp, action: Any = None, seed: int = 0) -> TrialResult:
        """Run one trial from the settled scene (grasp, lift, transport, primitive) and label it.

        The world is put back in the settled scene afterwards, ready for the next trial.
        """
        if self._saved is None:
            raise SimulationError("call reset(seed) before execute()")
        if self.task is not None:
            action = self.task.check_action(np.zeros(4) if action is None else action)
        self._check_reach(grasp, action)
        mujoco.mj_setState(self.model, self.data, self._saved, self._state_spec)
        n_cans = len(self._scene["layout"].get("cans", []))
        self._activate_cans(n_cans)  # cans parked by an earlier trial are back in play
        rng = np.random.default_rng([int(self._scene["seed"]), int(seed), 0xE8EC])
        info: dict[str, Any] = {"seed": int(seed), "scene_seed": self._scene["seed"]}
        try:
            result = self._execute(grasp, action, rng, info)
        except _Unstable as exc:
            info["unstable"] = str(exc)
            result = TrialResult(False, False, False, FailureReason.UNSTABLE, info)
        finally:
            info["sim_time"] = float(self.data.time)
            self._every_step = None
            self._back_to_full_model()
        # Back to the settled scene, so object_pose(), default_grasp() and the next trial see it.
        mujoco.mj_setState(self.model, self.data, self._saved, self._state_spec)
        self._activate_cans(n_cans)
        mujoco.mj_forward(self.model, self.data)
        return result

    def _check_reach(self, grasp: Grasp, action: Any) -> None:
        """ValueError when the grasp (with its approach and lift) or the action's start pose (with its
        clearance) lies outside the travel of the gripper base's joints (``world.BASE_RANGE``)."""
        g = self.config.gripper
        margin = 0.05  # room for the execution noise and the servo's overshoot
        points = [("grasp", np.array([grasp.x, grasp.y, grasp.z]), max(g.approach_height, g.min_lift))]
        if self.task is not None:
            start, _ = self.task.start_pose(self._scene["reference"], action)
            points.append(("the action's start pose", start, g.start_clearance))
        for what, p, above in points:
            for axis, (lo, hi), v, up in zip("xyz", BASE_RANGE, p, (0.0, 0.0, above), strict=True):
                if not (lo + margin <= v and v + up <= hi - margin):
                    raise ValueError(
                        f"{what} is out of the gripper's reach: {axis} = {v:.3f} m, the base travels "
                        f"{lo + margin:g} .. {hi - margin - up:g} m along {axis}"
                    )

    def _execute(
        self, grasp: Grasp, action: Any, rng: np.random.Generator, info: dict[str, Any]
    ) -> TrialResult:
        g, e = self.config.gripper, self.config.episode
        pn, hn, yn = e.grasp_position_noise, e.grasp_height_noise, e.grasp_yaw_noise
        pos = grasp.position + rng.uniform([-pn, -pn, -hn], [pn, pn, hn])
        yaw = float(grasp.phi + rng.uniform(-yn, yn))
        min_z = 0.5 * g.pad_size[2] + 0.003
        if pos[2] < min_z:
            info["grasp_z_clamped"] = float(pos[2])
            pos[2] = min_z
        self._set_gripper(pos + np.array([0, 0, g.approach_height]), yaw, g.max_opening)
        mujoco.mj_forward(self.model, self.data)
        props_at_rest = self._prop_positions()
        self._hold_cans(len(self._scene["layout"].get("cans", [])))
        # Approach, close, lift, hold.
        try:
            self._move(pos, None, g.approach_speed, g.yaw_speed, self._watch_landing)
            self._converge(monitor=self._watch_landing)
        except _Landed:
            info["landed_on_object"] = True
            return TrialResult(False, False, True, FailureReason.GRASP_FAILED, info)
        self.data.ctrl[4] = self.data.ctrl[5] = -0.02
        fingers = [self._dadr["finger_l"], self._dadr["finger_r"]]
        closing = {"steps": 0}

        def closed() -> bool:  # both fingers stopped (on the object or fully closed)
            closing["steps"] += 1
            return closing["steps"] >= 3 and bool(np.max(np.abs(self.data.qvel[fingers])) < 0.03)

        self._wait(g.close_time, until=closed)
        lift_z = max(g.lift_height, pos[2] + g.min_lift)
        self._move(np.array([pos[0], pos[1], lift_z]), None, g.lift_speed, g.yaw_speed)
        self._wait(g.hold_time)
        held = self._held()
        lifted = self._object_clear()
        info["in_hand"] = self._in_hand().tolist()
        info["object_lift"] = float(self.data.xipos[self._obj_body][2] - self._scene["object_com"][2])
        grasp_ok = held and lifted
        if not grasp_ok:
            return TrialResult(False, False, True, FailureReason.GRASP_FAILED, info)
        if self.task is None:
            return TrialResult(True, False, True, FailureReason.NONE, info)
        # Transport to the start pose, high above the props, then down.
        start, start_yaw = self.task.start_pose(self._scene["reference"], action)
        an, ayn = e.action_position_noise, e.action_yaw_noise
        start = start + rng.uniform(-an, an, size=3)
        start_yaw += float(rng.uniform(-ayn, ayn))
        # Turn the wrist the short way round to the start yaw.
        cur_yaw = float(self.data.act[3])
        start_yaw = cur_yaw + (start_yaw - cur_yaw + np.pi) % (2 * np.pi) - np.pi
        if start[2] < min_z:  # the arm does not drive the fingertips into the table
            info["start_z_clamped"] = float(start[2])
            start[2] = min_z
        info["start_pose"] = [*map(float, start), float(start_yaw)]
        high = start[2] + g.start_clearance
        hit_before = [False]

        def watch_props() -> None:
            if not hit_before[0] and self.data.sensordata[self._touch].any():
                hit_before[0] = True

        self._every_step = watch_props  # near the props, every step's contacts are looked at
        self._move(np.array([start[0], start[1], high]), start_yaw, g.linear_speed, g.yaw_speed, watch_props)
        self._move(start, None, g.linear_speed, g.yaw_speed, watch_props)
        self._converge(monitor=watch_props)
        self._every_step = None
        info["in_hand_start"] = self._in_hand().tolist()  # how the tool hangs at the start pose
        info["prop_shift_before_motion"] = self._prop_shift(props_at_rest)
        if hit_before[0] or info["prop_shift_before_motion"] > e.prop_moved:
            return TrialResult(True, False, True, FailureReason.COLLISION_BEFORE_MOTION, info)
        if not self._held():
            return TrialResult(True, False, True, FailureReason.DROPPED, info)
        return self._primitive(info)

    def _in_hand(self) -> NDArray[np.float64]:
        """(3, 4) pose [R | t] of the object's body in the gripper frame (x = jaw axis, z up, origin at the
        grasp centre), as it hangs in the hand now."""
        d = self.data
        gpos = np.array([d.qpos[self._qadr[n]] for n in ("grip_x", "grip_y", "grip_z")])
        back = rot_z(-float(d.qpos[self._qadr["grip_yaw"]]))
        pos, rot = self.object_pose()
        return np.column_stack([back @ rot, back @ (pos - gpos)])

    def _watch_landing(self) -> None:
        """During the approach: a finger or the palm pressing into the object means it landed on it."""
        d = self.data
        n = d.ncon
        if not n:
            return
        cats = np.sort(self._cat[d.contact.geom[:n]], axis=1)
        hit = (cats[:, 0] == OBJECT) & _HAND[cats[:, 1]]
        if np.any(hit & (d.contact.dist[:n] < -self.config.episode.landing_depth)):
            raise _Landed()

    def _held(self) -> bool:
        pairs = self._contacts()
        if not len(pairs):
            return False
        left = np.any((pairs[:, 0] == OBJECT) & (pairs[:, 1] == FINGER_L))
        right = np.any((pairs[:, 0] == OBJECT) & (pairs[:, 1] == FINGER_R))
        return bool(left and right)

    def _object_clear(self) -> bool:
        pairs = self._contacts()
        touching = len(pairs) and np.any((pairs[:, 0] == TABLE) & (pairs[:, 1] == OBJECT))
        pos, rot = self.object_pose()
        lowest = float(np.min(self._vertices @ rot.T[:, 2] + pos[2]))
        return (not touching) and lowest > self.config.episode.lifted_clearance

    def _primitive(self, info: dict[str, Any]) -> TrialResult:
        assert self.task is not None
        self._release_cans()  # the primitive always runs with every can in play
        props_before = self._prop_positions()
        d, g = self.data, self.config.gripper
        touched = [False]
        n_cans = len(self._scene["layout"].get("cans", []))
        on_ground = [False] * n_cans
        targets = (CAN,) if self.task_name == "sweeping" else (PEG,)

        c_sw = self.config.sweeping
        # A can whose centre is below the table top by more than its half-diagonal is wholly beside the
        # table, unsupported: it will reach the ground, so it counts as there (its fall is not simulated).
        fallen_z = -(math.hypot(c_sw.can_radius, 0.5 * c_sw.can_height) + c_sw.fallen_margin)

        touch = self._pair_table(_TOOL_SIDE, np.isin(np.arange(len(_TOOL_SIDE)), targets))
        is_ground = self._cat == GROUND
        qpos = d.qpos

        def watch() -> None:
            for i in range(n_cans):
                if not on_ground[i] and qpos[self._can_qadr[i] + 2] < fallen_z:
                    on_ground[i] = True
                    self._park_can(i)
            n = d.ncon
            if not n:
                return
            geoms = d.contact.geom[:n]
            g0, g1 = geoms[:, 0], geoms[:, 1]
            if not touched[0] and touch[g0, g1].any():
                touched[0] = True
            if n_cans and not all(on_ground):
                ground = is_ground[g0] | is_ground[g1]
                if ground.any():
                    hit = geoms[ground]
                    for i in range(n_cans):
                        if not on_ground[i] and np.any(hit == self._can_geoms[i]):
                            on_ground[i] = True
                            self._park_can(i)

        for motion in self.task.primitive():
            target = d.act[:3] + np.asarray(motion.delta)
            yaw = float(d.act[3] + motion.dyaw)
            self._move(target, yaw, motion.speed or g.linear_speed, motion.yaw_speed or g.yaw_speed, watch)
        held_after = self._held()
        settle = getattr(self.task.config, "settle_time", 0.2)
        if n_cans:
            resting = [0]

            def done() -> bool:  # every can is down, or those left on the table have come to rest
                if all(on_ground):
                    return True
                rest = all(
                    on_ground[i]
                    or (
                        np.linalg.norm(d.qvel[a : a + 3]) < c_sw.rest_speed
                        and np.linalg.norm(d.qvel[a + 3 : a + 6]) < 10 * c_sw.rest_speed
                    )
                    for i, a in enumerate(self._can_dadr[:n_cans])
                )
                resting[0] = resting[0] + 1 if rest else 0
                return resting[0] >= c_sw.rest_checks

            self._wait(settle, watch, until=done)
        else:
            self._wait(settle, watch)
        still = False
        values: dict[str, Any] = {}
        if n_cans:
            values["cans_on_ground"] = list(on_ground)
            speeds = [float(np.linalg.norm(d.qvel[a : a + 3])) for a in self._can_dadr[:n_cans]]
            still = any(s > 0.05 for s in speeds) and not all(on_ground)
        if self.task_name == "hammering":
            c = self.config.hammering
            values["peg_out"] = float(0.5 * c.peg_length - d.qpos[self._peg_qadr])
        # A short blow can fall between two checked steps: a target that moved was touched.
        touched[0] = touched[0] or self._prop_shift(props_before) > self.config.episode.prop_moved
        outcome = TaskOutcome(touched_targets=touched[0], still_moving=still, values=values)
        success, failure = self.task.evaluate(outcome)
        # The finger contacts flicker while the tool strikes or drags: out of the hand means not held at
        # the end of the motion and still not held once everything settled.
        held_settled = self._held()
        if not success and not held_after and not held_settled:
            failure = FailureReason.DROPPED  # the tool slipped out of the fingers during the primitive
        info.update(values)
        info["held_after_primitive"] = held_after
        info["held_after_settling"] = held_settled
        info["touched_targets"] = touched[0]
        return TrialResult(True, success, True, failure, info)
