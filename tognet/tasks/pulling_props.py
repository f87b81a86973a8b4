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
from numpy.typing import NDArray

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
        self._hand_qadr = host.hand_qadr

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
        hx, hy = float(d.qpos[self._hand_qadr]), float(d.qpos[self._hand_qadr + 1])
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
        }
        return values, speed > 0.05

    # --- privileged knowledge -------------------------------------------------------------------------
    def oracle_actions(self, pts: NDArray[np.float64], **options: Any) -> list[NDArray[np.float64]]:
        """Candidate pulling actions for the tool at ``pts`` (gripper frame): at each start yaw of ``yaws``
        (default three across the action box), the tool's tip (its points within 3 cm of its farthest
        reach along world +x) lands ``HOOK_GAP`` behind the can, the can's centre 4 cm inside either end
        of the tip in y, the tool's lowest point ``TABLE_GAP`` above the table."""
        yaws = options.get("yaws", (-np.pi / 8, 0.0, np.pi / 8))
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
    sim: Any, grasp: Grasp, yaws: tuple[float, ...] = (-np.pi / 8, 0.0, np.pi / 8), in_hand: object = None
) -> list[NDArray[np.float64]]:
    """The oracle's pulling actions (:meth:`PullingProps.oracle_actions`) for ``grasp`` in the settled
    scene of a pulling simulator ``sim``; ``in_hand`` as :func:`tognet.tasks.props.tool_in_gripper`."""
    assert isinstance(sim.props, PullingProps)
    return sim.props.oracle_actions(tool_in_gripper(sim, grasp, in_hand), yaws=yaws)
