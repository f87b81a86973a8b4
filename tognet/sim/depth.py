"""The depth camera: one image by ray casting (no OpenGL), and the camera's per-scene disturbance.

The table and the ground are intersected analytically (with per-row outlines of the table's projection,
from the convex-hull helpers here, deciding which pixels need the exact test), the object's visual mesh by
exact ray-triangle intersection (:func:`tognet.geometry.raster.mesh_depth`), or MuJoCo's ray caster when
the mesh reaches behind the camera.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Camera, CameraIntrinsics
from tognet.geometry.raster import mesh_depth
from tognet.geometry.transforms import make_pose, rot_x, rot_y, rot_z
from tognet.sim.config import CameraConfig, SimConfig
from tognet.sim.groups import GROUP_OBJECT_VISUAL


def hull_2d(points: NDArray[np.float64]) -> NDArray[np.float64]:
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


def rows_in_hull(
    points: NDArray[np.float64], grow: float, height: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per image row v = 0 .. height - 1, the interval [lo, hi] of u inside the convex hull of the 2-D
    ``points`` grown by ``grow`` px (shrunk if negative); hi < lo on rows it does not reach."""
    hull = hull_2d(points)
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


def sample_camera(config: CameraConfig, rng: np.random.Generator) -> Camera:
    """The overhead camera of one scene: the nominal one with its pose and intrinsics disturbed (the
    config's noise ranges, uniform)."""
    c = config
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


class DepthRenderer:
    """Renders the depth images of one world (the object's visual mesh as MuJoCo compiled it)."""

    def __init__(self, config: SimConfig, model: mujoco.MjModel) -> None:
        self.config = config
        self.visual_geom = model.geom("object_visual").id
        # The visual mesh as MuJoCo compiled it (geom frame), for the depth camera.
        mid = int(model.geom_dataid[self.visual_geom])
        va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
        fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
        self.visual_local = model.mesh_vert[va : va + vn].astype(np.float64)
        self.visual_faces = model.mesh_face[fa : fa + fn].astype(np.int64)
        self._image_buffers: dict[tuple[str, int, str], NDArray[Any]] = {}

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
            top = rows_in_hull(uv[:4], -1.0, k.height)
            slab = rows_in_hull(uv, 1.0, k.height)
        except ValueError:
            return None
        return (*top, *slab)

    def _cast_object_rays(
        self,
        origin: NDArray[np.float64],
        dirs: NDArray[np.float64],
        idx: NDArray[np.int64],
        t: NDArray[np.float64],
        model: mujoco.MjModel,
        data: mujoco.MjData,
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
            model,
            data,
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

    def render(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        camera: Camera,
        rng: np.random.Generator | None = None,
    ) -> NDArray[np.float32]:
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
        d, gid = data, self.visual_geom
        world = self.visual_local @ d.geom_xmat[gid].reshape(3, 3).T + d.geom_xpos[gid]
        intr = (k.fx, k.fy, k.cx, k.cy, k.width, k.height)
        if not mesh_depth(r, origin, intr, world, self.visual_faces, t):
            # A vertex behind the camera: MuJoCo's ray caster on every pixel (slow, never seen in use).
            every = np.arange(n_pix)
            self._cast_object_rays(origin, directions(every), every, t, model, data)
        depth = t.astype(np.float32)
        depth[~(depth <= c.max_range)] = np.nan  # also inf (no hit) and NaN
        if rng is not None and c.depth_noise > 0:
            depth += rng.normal(0.0, c.depth_noise, size=depth.shape).astype(np.float32)
        if rng is not None and c.hole_fraction > 0:
            depth[rng.random(depth.shape) < c.hole_fraction] = np.nan
        return depth.reshape(k.height, k.width)
