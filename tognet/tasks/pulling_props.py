"""Pulling's props in the simulator: one can, a free body standing on the table.

The can is the target. Outcome values: ``can_xy`` (where it ended), ``can_tilt`` (rad), ``can_on_table``
and ``can_in_target`` (the task's success rule: in the target region, upright and on the table).

Also the task's privileged knowledge: the oracle's hand-computed actions for a grasp and the scripted
checks on the hand-made L tool (:mod:`tognet.objects.handmade`), its short bar the hook.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import MultiPoint
from shapely.ops import unary_union

from tognet.geometry import Grasp
from tognet.objects.handmade import L_LONG, L_SHORT, L_WIDTH
from tognet.tasks.props import PropsHost, PropsMJCF, TaskProps, in_gripper, rot2, tool_in_gripper
from tognet.tasks.pulling import PullingConfig

#: Gap (m) the hand-computed actions leave between the hook and the can, and between the tool and the
#: table.
HOOK_GAP = 0.04
TABLE_GAP = 0.008


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def _pull_positions(
    outlines: list[NDArray[np.float64]], cans: NDArray[np.float64], radius: float
) -> list[tuple[float, float, NDArray[np.float64]]]:
    """(score, contact offset, can centre) for each can centre of ``cans`` (relative to the gripper,
    world-aligned) from which pulling the tool, whose pieces' outlines (xy points, same frame) are given,
    along -x catches the can (see :meth:`PullingProps.oracle_actions`); score = the fraction of the can's
    width the pulling face covers."""
    foot = unary_union([MultiPoint(p).convex_hull for p in outlines])
    # The footprint's outline every 5 mm: the first point of it the moving can meets is where it pulls.
    edge = shapely.get_coordinates(shapely.segmentize(foot.boundary, 0.005))
    if len(edge) == 0:
        return []
    # Only can centres in the footprint's shadow (within a radius of it in y, short of its far end in x).
    lo, hi = edge.min(axis=0), edge.max(axis=0)
    cans = cans[(cans[:, 1] > lo[1] - radius) & (cans[:, 1] < hi[1] + radius) & (cans[:, 0] < hi[0])]
    cans = cans[~shapely.contains_xy(foot, cans[:, 0], cans[:, 1])]
    dx = edge[None, :, 0] - cans[:, 0:1]  # (cans, edge points)
    dy = edge[None, :, 1] - cans[:, 1:2]
    clear = np.sqrt((dx**2 + dy**2).min(axis=1)) - radius if len(cans) else np.zeros(0)
    ok = clear >= HOOK_GAP / 4
    cans, dx, dy = cans[ok], dx[ok], dy[ok]
    ahead = (np.abs(dy) < radius) & (dx > 0)
    travel = np.where(ahead, dx - np.sqrt(np.clip(radius**2 - dy**2, 0.0, None)), np.inf)
    k = np.argmin(travel, axis=1) if len(cans) else np.zeros(0, dtype=int)
    rows = np.arange(len(cans))
    first, off = travel[rows, k], np.abs(dy[rows, k])
    keep = np.isfinite(first) & (first <= 1.5 * HOOK_GAP) & (off <= 0.5 * radius)
    if not keep.any():
        return []
    # How much of the can's width (9 lines across it) meets the face within 1.5 cm more travel.
    near = travel[keep] < first[keep, None] + 0.015
    lanes = np.linspace(-0.8, 0.8, 9) * radius
    hit = np.abs(dy[keep][:, None, :] - lanes[None, :, None]) < 0.006
    covered = (hit & near[:, None, :]).any(axis=2).mean(axis=1)
    return [(float(sc), float(o), cn) for sc, o, cn in zip(covered, off[keep], cans[keep], strict=True)]


class PullingProps(TaskProps):
    """The can (see the module docstring)."""

    check_object = "l_tool"
    demo_grasp = "far_end"
    check_texts = {
        "far_end": "L tool held at the end of its long bar (hook far)",
        "near_hook": "L tool held on its long bar near the hook",
    }
    outcome_keys = ("can_in_target", "can_xy", "can_tilt")
    config: PullingConfig

    # --- world ----------------------------------------------------------------------------------------
    def mjcf(self, sim_config: Any, group: int) -> PropsMJCF:
        """A free cylinder ``pull_can`` (placed by each scene)."""
        c = self.config
        bodies = [
            f'<body name="pull_can" pos="0.4 0 {0.5 * c.can_height:g}">',
            '  <freejoint name="pull_can"/>',
            f'  <geom name="pull_can" type="cylinder" size="{c.can_radius:g} {0.5 * c.can_height:g}" '
            f'mass="0.2" friction="{c.can_friction:g} 0.005 0.0001" group="{group}" rgba="0.2 0.6 0.3 1"/>',
            "</body>",
        ]
        return PropsMJCF(bodies=bodies, touch_bodies=["pull_can"], target_geoms=["pull_can"])

    def bind(self, host: PropsHost) -> None:
        """The can's joint and body; the reach of the object around it."""
        super().bind(host)
        m = host.model
        joint = m.joint("pull_can").id
        self._qadr = int(m.jnt_qposadr[joint])
        self._dadr = int(m.jnt_dofadr[joint])
        self._body = m.body("pull_can").id
        g = host.config.gripper
        # The object's bounding sphere or the hand within a chunk's travel (0.1 m) of the can.
        self._reach = host.object_reach + self.config.can_radius + 0.1
        self._hand_reach = 0.5 * g.max_opening + g.pad_size[0] + 0.03 + self.config.can_radius + 0.1
        self._obj_body = host.object_body

    # --- scene ----------------------------------------------------------------------------------------
    def place(self, layout: dict[str, Any]) -> None:
        """The can standing at the layout's (x, y), with its mass."""
        super().place(layout)
        assert self.host is not None
        m, d, c = self.host.model, self.host.data, self.config
        x, y, mass = layout["can"]
        d.qpos[self._qadr : self._qadr + 7] = (x, y, 0.5 * c.can_height, 1, 0, 0, 0)
        d.qvel[self._dadr : self._dadr + 6] = 0.0
        r, h = c.can_radius, c.can_height
        m.body_mass[self._body] = mass
        ixx = mass * (3 * r * r + h * h) / 12
        m.body_inertia[self._body] = (ixx, ixx, 0.5 * mass * r * r)

    # --- while a trial runs ---------------------------------------------------------------------------
    def positions(self) -> NDArray[np.float64]:
        """The can's centre."""
        assert self.host is not None
        return self.host.data.qpos[self._qadr : self._qadr + 3].reshape(1, 3).copy()

    def near(self) -> bool:
        """The object's bounding sphere or the hand within reach of the can."""
        assert self.host is not None
        d = self.host.data
        cx, cy = float(d.qpos[self._qadr]), float(d.qpos[self._qadr + 1])
        ox, oy = d.xpos[self._obj_body, :2]
        hx, hy = self.host.hand_xy()
        return (
            math.hypot(float(ox) - cx, float(oy) - cy) < self._reach
            or math.hypot(hx - cx, hy - cy) < self._hand_reach
        )

    def _resting(self) -> bool:
        assert self.host is not None
        v = self.host.data.qvel[self._dadr : self._dadr + 6]
        rest = self.config.rest_speed
        return bool(np.linalg.norm(v[:3]) < rest and np.linalg.norm(v[3:]) < 10 * rest)

    def settled(self) -> Callable[[], bool] | None:
        """The can at rest three checks in a row."""
        resting = [0]

        def done() -> bool:
            resting[0] = resting[0] + 1 if self._resting() else 0
            return resting[0] >= 3

        return done

    def outcome(self) -> tuple[dict[str, Any], bool]:
        """Where the can ended, its tilt, whether it is on the table and in the target region; still
        moving: faster than 5 cm/s."""
        assert self.host is not None
        d, c = self.host.data, self.config
        qa = self._qadr
        x, y, z = (float(v) for v in d.qpos[qa : qa + 3])
        # The tilt of the can's axis: the rotation's angle about a horizontal axis (for an upright can
        # the quaternion is (cos(a/2), 0, 0, sin(a/2)) and the tilt is 0).
        qx, qy = float(d.qpos[qa + 4]), float(d.qpos[qa + 5])
        tilt = float(2.0 * math.asin(min(1.0, math.hypot(qx, qy))))
        on_table = z > 0.0 and abs(x) < 0.5 * self.host.config.world.table_size[0]
        y0 = float(self.layout["can"][1])
        in_target = (
            on_table
            and tilt < c.max_tilt
            and c.target_x[0] <= x <= c.target_x[1]
            and abs(y - y0) <= c.target_y
        )
        speed = float(np.linalg.norm(d.qvel[self._dadr : self._dadr + 3]))
        values = {
            "can_in_target": bool(in_target),
            "can_xy": [x, y],
            "can_tilt": tilt,
            "can_on_table": on_table,
            "can_start_x": float(self.layout["can"][0]),
        }
        return values, speed > 0.05

    # --- privileged knowledge -------------------------------------------------------------------------
    def oracle_actions(self, pts: NDArray[np.float64], **options: Any) -> list[NDArray[np.float64]]:
        """Candidate pulling actions for the tool at ``pts`` (gripper frame, the host's vertices in order),
        best first, at most ``limit`` (default 6).

        At each start yaw of ``yaws`` (default five across the action box) the tool's footprint (the union
        of its convex collision pieces' outlines, seen from above) is laid over every can position the
        action box allows, on a 1 cm grid. A position is a pull when the footprint clears the can by
        ``HOOK_GAP / 4`` (the tool comes down beside it, not on it) and, as the tool moves along -x, first
        touches the can within ``HOOK_GAP * 1.5`` of travel, near the can's centre line (less than half its
        radius off it: a face that pulls, not one that shoves the can aside). Pulls are ranked by how much
        of the can's width that face covers, then by how centred the contact is. Without any, the tool's
        tip (its far end, ``_tip_actions``) is put ``HOOK_GAP`` behind the can at three yaws."""
        yaws = options.get("yaws", tuple(np.linspace(-np.pi / 4, np.pi / 4, 5)))
        limit = int(options.get("limit", 6))
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c, task = self.config, self.task
        ref = np.asarray(scene["reference"])
        nominal = np.asarray(c.nominal_offset)
        grip_z = TABLE_GAP - float(pts[:, 2].min())
        pieces = np.split(pts[:, :2], np.cumsum(self.host.vertex_pieces)[:-1])
        # Can centres relative to the gripper that the action box allows (can - grip = -nominal - a).
        lo, hi = np.asarray(task.action_low[:2]), np.asarray(task.action_high[:2])
        gx = np.arange(-nominal[0] - hi[0], -nominal[0] - lo[0] + 1e-9, 0.01)
        gy = np.arange(-nominal[1] - hi[1], -nominal[1] - lo[1] + 1e-9, 0.01)
        cans = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
        found: list[tuple[float, float, NDArray[np.float64]]] = []
        for a_phi in yaws:
            rot = rot2(c.nominal_yaw + a_phi)
            for score, off, can in _pull_positions([p @ rot.T for p in pieces if len(p)], cans, c.can_radius):
                a = np.array([-can[0], -can[1], grip_z - ref[2], 0.0]) - np.array([*nominal, -a_phi])
                found.append((score, off, a))
        found.sort(key=lambda f: (-f[0], f[1]))
        out: list[NDArray[np.float64]] = []
        for _, _, a in found:  # distinct actions: another yaw, or 2 cm apart
            a = np.clip(a, task.action_low, task.action_high)
            if all(abs(a[3] - b[3]) > 1e-6 or np.linalg.norm(a[:2] - b[:2]) > 0.02 for b in out):
                out.append(a)
            if len(out) == limit:
                return out
        return out or self._tip_actions(pts, (-np.pi / 8, 0.0, np.pi / 8))

    def _tip_actions(self, pts: NDArray[np.float64], yaws: Any) -> list[NDArray[np.float64]]:
        """At each start yaw, the tool's tip (its points within 3 cm of its farthest reach along world +x)
        ``HOOK_GAP`` behind the can, the can's centre 4 cm inside either end of the tip in y, the tool's
        lowest point ``TABLE_GAP`` above the table."""
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c, task = self.config, self.task
        ref = np.asarray(scene["reference"])
        grip_z = TABLE_GAP - float(pts[:, 2].min())
        out = []
        for a_phi in yaws:
            xy = pts[:, :2] @ rot2(c.nominal_yaw + a_phi).T
            tip = xy[xy[:, 0] > xy[:, 0].max() - 0.03]
            x0 = ref[0] + c.can_radius + HOOK_GAP - float(tip[:, 0].min())
            for y_at in (float(tip[:, 1].min()) + 0.04, float(tip[:, 1].max()) - 0.04):
                grip = np.array([x0, ref[1] - y_at, grip_z])
                a = np.array([*(grip - ref - np.asarray(c.nominal_offset)), a_phi])
                out.append(np.clip(a, task.action_low, task.action_high))
        return out

    check_grasps = {
        # name: (grasp point, jaw axis, a point on the hook's pulling face, the direction it pulls), all in
        # the L tool's frame (long bar along +x, short bar, the hook, along +y at x = 0)
        "far_end": (
            (L_LONG - 0.04, 0.5 * L_WIDTH, 0.5 * L_WIDTH),
            (0.0, 1.0, 0.0),
            (L_WIDTH, 0.5 * (L_WIDTH + L_SHORT) + 0.0075, 0.5 * L_WIDTH),
            (1.0, 0.0, 0.0),
        ),
        "near_hook": (
            (0.07, 0.5 * L_WIDTH, 0.5 * L_WIDTH),
            (0.0, 1.0, 0.0),
            (L_WIDTH, 0.5 * (L_WIDTH + L_SHORT) + 0.0075, 0.5 * L_WIDTH),
            (1.0, 0.0, 0.0),
        ),
    }

    def check_action(
        self, grasp: str | tuple[Any, ...], clip: bool = True, yaw: float = 0.0
    ) -> NDArray[np.float64]:
        """Hand-computed pulling action for an L-tool grasp: the hook's pulling face ``HOOK_GAP`` behind
        the can's centre line, facing the robot (turned by ``yaw`` more), the tool ``TABLE_GAP`` above the
        table; clipped to the action box when ``clip``."""
        spec = self.check_grasps[grasp] if isinstance(grasp, str) else grasp
        point, jaw, face, direction = (np.asarray(v, dtype=np.float64) for v in spec)
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c = self.config
        ref = np.asarray(scene["reference"])
        f = in_gripper(face, point, jaw)
        n = in_gripper(direction + point, point, jaw)
        start_yaw = np.pi - float(np.arctan2(n[1], n[0])) + yaw  # the pull direction along world -x
        target = np.array([ref[0] + c.can_radius + HOOK_GAP, ref[1]])
        grip_xy = target - rot2(start_yaw) @ f[:2]
        grip_z = TABLE_GAP + float(point[2])  # the tool's bottom (object z = 0) TABLE_GAP above the table
        a = np.array([*(np.array([*grip_xy, grip_z]) - ref - np.asarray(c.nominal_offset)), 0.0])
        a[3] = _wrap(start_yaw - c.nominal_yaw)
        if clip:
            a = np.clip(a, self.task.action_low, self.task.action_high)
        return a


#: The scripted checks' grasps on the L tool, by name.
PULL_GRASPS = PullingProps.check_grasps


def pull_bar_grasp(x: float) -> tuple[Any, ...]:
    """A grasp across the L tool's long bar at ``x`` along it (0 = the hook's end), pulling as far_end."""
    far = PULL_GRASPS["far_end"]
    return ((x, far[0][1], far[0][2]), *far[1:])


def pull_actions(
    sim: Any, grasp: Grasp, yaws: tuple[float, ...] | None = None, in_hand: object = None
) -> list[NDArray[np.float64]]:
    """The oracle's pulling actions (:meth:`PullingProps.oracle_actions`, best first) for ``grasp`` in the
    settled scene of a pulling simulator ``sim``; ``in_hand`` as
    :func:`tognet.tasks.props.tool_in_gripper`."""
    assert isinstance(sim.props, PullingProps)
    options = {} if yaws is None else {"yaws": yaws}
    return sim.props.oracle_actions(tool_in_gripper(sim, grasp, in_hand), **options)
