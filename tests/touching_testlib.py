"""Depth images of generated tools settled on a table by MuJoCo: one tool alone, two tools touching side by
side, or one dropped across another (the segmentation tests of two objects touching, issue 35)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Camera, CameraIntrinsics
from tognet.geometry.raster import mesh_depth
from tognet.objects import ObjectRecord

KINECT2 = CameraIntrinsics.kinect2()
REALSENSE = CameraIntrinsics(width=640, height=480, fx=615.0, fy=615.0, cx=320.3, cy=238.9)


@dataclass
class Settled:
    """Tools at rest on the table (z = 0): each tool's visual mesh in the world, and the smallest gap (m)
    between the two tools' collision geoms (0 when touching; None with one tool)."""

    meshes: list[tuple[NDArray[np.float64], NDArray[np.int64]]]
    gap: float | None

    @property
    def centre(self) -> NDArray[np.float64]:
        return np.vstack([v for v, _ in self.meshes])[:, :2].mean(axis=0)


def _spec(records: list[ObjectRecord]) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2.0, 2.0, 0.1])
    for i, rec in enumerate(records):
        child = mujoco.MjSpec.from_file(str(rec.mjcf_path))
        child.meshdir = str(Path(rec.mjcf_path).parent)
        frame = spec.worldbody.add_frame()
        frame.attach_body(child.body("object"), f"t{i}_", "")
    return spec


def _bodies(model: mujoco.MjModel, n: int) -> tuple[list[int], list[list[int]], list[int]]:
    """Per tool: body id, collision geom ids, visual geom id."""
    bodies = [model.body(f"t{i}_object").id for i in range(n)]
    coll = [[g for g in range(model.ngeom) if model.geom_bodyid[g] == b and model.geom_group[g] == 3]
            for b in bodies]
    vis = [model.geom(f"t{i}_visual").id for i in range(n)]
    return bodies, coll, vis


def _gap(model: mujoco.MjModel, data: mujoco.MjData, coll: list[list[int]]) -> float:
    mujoco.mj_forward(model, data)
    return min(mujoco.mj_geomDistance(model, data, a, b, 0.5, None) for a in coll[0] for b in coll[1])


def _place(data: mujoco.MjData, model: mujoco.MjModel, body: int, xy: tuple[float, float], z: float,
           yaw: float) -> None:
    adr = model.jnt_qposadr[model.body_jntadr[body]]
    q = data.qpos[adr + 3:adr + 7].copy()
    turn = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    out = np.empty(4)
    mujoco.mju_mulQuat(out, turn, q)
    data.qpos[adr:adr + 3] = [xy[0], xy[1], z]
    data.qpos[adr + 3:adr + 7] = out


def settle(records: list[ObjectRecord], arrangement: str = "alone", seed: int = 0,
           seconds: float = 1.5) -> Settled:
    """``records`` (one, or two) dropped on the table and settled: ``alone`` (one tool), ``side`` (the
    second slid towards the first from a random direction until their collision geoms are 1 mm apart, then
    both settled) or ``across`` (the second turned 60-120 degrees from the first and dropped onto it)."""
    rng = np.random.default_rng(seed)
    model = _spec(records).compile()
    data = mujoco.MjData(model)
    bodies, coll, vis = _bodies(model, len(records))
    z0 = [float(model.body_pos[b][2]) for b in bodies]
    _place(data, model, bodies[0], (0.0, 0.0), z0[0], rng.uniform(-math.pi, math.pi))
    if len(records) == 2:
        yaw = rng.uniform(-math.pi, math.pi)
        if arrangement == "side":
            d = rng.uniform(-math.pi, math.pi)
            direction = np.array([math.cos(d), math.sin(d)])
            lo, hi = 0.0, 0.6
            for _ in range(30):  # the offset at which the two are 1 mm apart
                mid = 0.5 * (lo + hi)
                _place(data, model, bodies[1], tuple(mid * direction), z0[1], yaw)
                lo, hi = (mid, hi) if _gap(model, data, coll) < 0.001 else (lo, mid)
                _reset_orientation(data, model, bodies[1])
            _place(data, model, bodies[1], tuple(hi * direction), z0[1], yaw)
        elif arrangement == "across":
            top = _top(model, data, vis[0])
            _place(data, model, bodies[1], tuple(rng.uniform(-0.02, 0.02, 2)), top + z0[1] + 0.01,
                   yaw)
        else:
            raise ValueError(f"arrangement must be alone, side or across, got {arrangement!r}")
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    meshes = [_world_mesh(model, data, g) for g in vis]
    return Settled(meshes, _gap(model, data, coll) if len(records) == 2 else None)


def _reset_orientation(data: mujoco.MjData, model: mujoco.MjModel, body: int) -> None:
    adr = model.jnt_qposadr[model.body_jntadr[body]]
    data.qpos[adr + 3:adr + 7] = model.qpos0[adr + 3:adr + 7]


def _top(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> float:
    mujoco.mj_forward(model, data)
    v, _ = _world_mesh(model, data, geom)
    return float(v[:, 2].max() - v[:, 2].min())


def _world_mesh(model: mujoco.MjModel, data: mujoco.MjData, geom: int
                ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    mid = int(model.geom_dataid[geom])
    va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
    fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
    local = model.mesh_vert[va:va + vn].astype(np.float64)
    world = local @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]
    return world, model.mesh_face[fa:fa + fn].astype(np.int64)


def aim(scene: Settled, intrinsics: CameraIntrinsics = KINECT2, distance: float = 0.7, tilt_deg: float = 0.0,
        azimuth: float = 0.0) -> Camera:
    """A camera ``distance`` m from the tools' centre, ``tilt_deg`` from straight down."""
    c = scene.centre
    return Camera.aimed_at(intrinsics, [c[0], c[1], 0.0], distance, math.radians(tilt_deg), azimuth, 0.0)


Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]


def render(meshes: list[Mesh], camera: Camera) -> NDArray[np.float32]:
    """The clean depth image (m, float32) of ``meshes`` on an unbounded table plane z = 0."""
    k = camera.intrinsics
    r, o = camera.pose[:3, :3], camera.position
    a = (np.arange(k.width) - k.cx) / k.fx
    b = (np.arange(k.height) - k.cy) / k.fy
    dz = r[2, 0] * a[None, :] + r[2, 1] * b[:, None] + r[2, 2]
    t = (-o[2] / dz).ravel()
    for v, f in meshes:
        mesh_depth(r, o, (k.fx, k.fy, k.cx, k.cy, k.width, k.height), v, f, t)
    return t.reshape(k.height, k.width).astype(np.float32)


def photograph(scene: Settled, intrinsics: CameraIntrinsics = KINECT2, distance: float = 0.7,
               tilt_deg: float = 0.0, azimuth: float = 0.0) -> tuple[NDArray[np.float32], Camera]:
    """The clean depth image of the tools (see :func:`render`) from :func:`aim`'s camera, and the camera."""
    camera = aim(scene, intrinsics, distance, tilt_deg, azimuth)
    return render(scene.meshes, camera), camera


def owners(scene: Settled, camera: Camera, clean: NDArray[np.float32]) -> NDArray[np.int64]:
    """Per pixel of ``clean`` (the scene's image), the tool it shows (0, 1), -1 for the table."""
    out = np.full(clean.shape, -1)
    for i, mesh in enumerate(scene.meshes):
        alone = render([mesh], camera)
        table = render([], camera)
        out[(alone == clean) & (alone < table - 0.002)] = i
    return out


def outcome(found: list, owner: np.ndarray) -> str:
    """How ``found`` (segmented objects) parts the two tools of ``owner`` (each pixel's tool, -1 none):
    'apart' (already two regions), 'split right' (two halves, each 80 % one tool, different tools),
    'split wrong', 'reported' (one region, the warning) or 'missed'."""
    fit = [o for o in found if o.qualifies]
    halves = [o for o in fit if o.split]
    if halves:
        counts = [[np.count_nonzero(o.mask & (owner == t)) for t in (0, 1)] for o in halves]
        best = [int(np.argmax(c)) for c in counts]
        share = min(max(c) / max(sum(c), 1) for c in counts)
        return "split right" if len(halves) == 2 and best[0] != best[1] and share > 0.8 else "split wrong"
    tools = [max(np.count_nonzero(owner == t), 1) for t in (0, 1)]
    both = [o for o in fit if min(np.count_nonzero(o.mask & (owner == t)) / tools[t] for t in (0, 1)) > 0.2]
    if not both:
        return "apart"
    return "reported" if both[0].touching is not None else "missed"
