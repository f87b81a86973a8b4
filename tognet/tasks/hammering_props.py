"""Hammering's props in the simulator: a fixed slot block and a peg that slides along its axis in it.

The peg is the target; it resists with stiff dry friction (see ``HammeringConfig``). The outcome value
is ``peg_out``: how much of the peg still sticks out of the slot face (m).

Also the task's privileged knowledge: the oracle's hand-computed actions for a grasp and the scripted
checks on the hand-made T hammer (:mod:`tognet.objects.handmade`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.objects.handmade import HAMMER_HANDLE, HAMMER_HEAD, HAMMER_WIDTH
from tognet.tasks.hammering import HammeringConfig
from tognet.tasks.props import PropsHost, PropsMJCF, TaskProps, in_gripper, rot2, tool_in_gripper


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class HammeringProps(TaskProps):
    """The slot and the peg (see the module docstring)."""

    check_object = "t_hammer"
    demo_grasp = "far_end"
    check_texts = {
        "far_end": "T hammer held at the far end of its handle",
        "head": "T hammer held by its head",
    }
    outcome_keys = ("peg_out",)
    config: HammeringConfig

    # --- world ----------------------------------------------------------------------------------------
    def mjcf(self, sim_config: Any, group: int) -> PropsMJCF:
        """The slot body (a box) with the peg on a slide joint, half inserted; the two never collide."""
        c = self.config
        depth, width, height = c.slot_size
        s, length = c.peg_size, c.peg_length
        # The slot body sits on the slot face at the peg's axis height; the peg slides along +x into it.
        # A very stiff friction-loss constraint (solreffriction at the minimum safe time constant) stops
        # the creep MuJoCo's soft dry friction shows under a slow push. The joint's limits are as stiff
        # (solreflimit): the slot's floor stops a hard-driven peg (MuJoCo's default limit let it sink 3-5 mm
        # past the floor on a good blow).
        dt = sim_config.physics.timestep
        bodies = [
            f'<body name="slot" pos="0.3 0 {c.peg_height:g}">',
            f'  <geom name="slot" type="box" size="{0.5 * depth:g} {0.5 * width:g} {0.5 * height:g}" '
            f'pos="{0.5 * depth:g} 0 {0.5 * height - c.peg_height:g}" group="{group}" priority="3" '
            f'solref="{c.contact_solref[0]:g} {c.contact_solref[1]:g}" '
            'rgba="0.3 0.45 0.7 1"/>',
            '  <body name="peg">',
            f'    <joint name="peg" type="slide" axis="1 0 0" range="-0.001 {0.5 * length + 0.001:g}" '
            f'frictionloss="{c.peg_friction:g}" solreffriction="{2 * dt:g} 1" solreflimit="{2 * dt:g} 1" '
            f'solimpfriction="{c.peg_friction_impedance:g} {c.peg_friction_impedance:g} 0.001"/>',
            f'    <geom name="peg" type="box" size="{0.5 * length:g} {0.5 * s:g} {0.5 * s:g}" '
            f'mass="{c.peg_mass:g}" '
            f'friction="0.5 0.005 0.0001" priority="3" '
            f'solref="{c.contact_solref[0]:g} {c.contact_solref[1]:g}" '
            f'group="{group}" rgba="0.9 0.8 0.2 1"/>',
            "  </body>",
            "</body>",
        ]
        return PropsMJCF(
            bodies=bodies,
            contact=['<exclude body1="slot" body2="peg"/>'],
            touch_bodies=["slot"],
            target_geoms=["peg"],
            other_geoms=["slot"],
        )

    def bind(self, host: PropsHost) -> None:
        """The peg's slide and the slot's body."""
        super().bind(host)
        m = host.model
        self._peg_qadr = int(m.jnt_qposadr[m.joint("peg").id])
        self._slot_body = m.body("slot").id
        self._object_reach = host.object_reach
        self._obj_body = host.object_body

    # --- scene ----------------------------------------------------------------------------------------
    def place(self, layout: dict[str, Any]) -> None:
        """The slot face at the layout's (x, y), the peg half inserted."""
        super().place(layout)
        assert self.host is not None
        m, d = self.host.model, self.host.data
        x, y = layout["slot"]
        c = self.config
        m.body_pos[self._slot_body] = (x, y, c.peg_height)
        # A circle around the slot and its peg (which sticks out toward -x), grown by the object's
        # reach, the hand around the grasp and a chunk's travel (0.1 m): see near().
        depth, width, _ = c.slot_size
        half_peg = 0.5 * c.peg_length
        radius = math.hypot(0.5 * (depth + half_peg), 0.5 * width)
        self._slot_reach = (x + 0.5 * (depth - half_peg), y, self._object_reach + radius + 0.1)
        d.qpos[self._peg_qadr] = 0.0

    # --- while a trial runs ---------------------------------------------------------------------------
    def positions(self) -> NDArray[np.float64]:
        """The peg's slide (x only)."""
        assert self.host is not None
        return np.array([[float(self.host.data.qpos[self._peg_qadr]), 0.0, 0.0]])

    def near(self) -> bool:
        """The object's bounding sphere within reach of a circle around the slot and its peg."""
        assert self.host is not None
        cx, cy, reach = self._slot_reach
        x, y = self.host.data.xpos[self._obj_body, :2]
        return math.hypot(float(x) - cx, float(y) - cy) < reach

    def outcome(self) -> tuple[dict[str, Any], bool]:
        """``peg_out``: how much of the peg sticks out of the slot face (m)."""
        assert self.host is not None
        return {"peg_out": float(0.5 * self.config.peg_length - self.host.data.qpos[self._peg_qadr])}, False

    # --- privileged knowledge -------------------------------------------------------------------------
    def oracle_actions(self, pts: NDArray[np.float64], **options: Any) -> list[NDArray[np.float64]]:
        """Candidate hammering actions for the tool at ``pts`` (gripper frame): its farthest points from
        the grasp axis (``n_points``, default 3) strike the peg's free end (moving along +x at impact,
        each of ``impact_angles`` before that), 45 degrees into the swing (or wherever the action box's
        yaw limits put it), at the peg's height. Clipped to the action box."""
        n_points = int(options.get("n_points", 3))
        impact_angles = options.get("impact_angles", (-0.1, 0.15))
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c, task = self.config, self.task
        radius = np.hypot(pts[:, 0], pts[:, 1])
        ref = np.asarray(scene["reference"])
        target = np.array([ref[0] - 0.5 * c.peg_length, ref[1]])
        bottom = float(pts[:, 2].min())
        lo, hi = task.action_low, task.action_high
        out: list[NDArray[np.float64]] = []
        # Striking candidates: the farthest vertex in each of a few angular sectors around the grasp axis.
        ang = np.arctan2(pts[:, 1], pts[:, 0])
        sectors = np.floor((ang + np.pi) / (np.pi / 4)).astype(int)
        best = []
        for s in np.unique(sectors):
            idx = np.flatnonzero(sectors == s)
            best.append(idx[np.argmax(radius[idx])])
        best = sorted(best, key=lambda i: -radius[i])[:n_points]
        for i in best:
            p = pts[i]
            alpha = float(np.arctan2(p[1], p[0]))
            # Vertices near the striking point (within 2 cm in xy) give the height of the striking region.
            near = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1]) < 0.02
            mid = 0.5 * float(pts[near, 2].min() + pts[near, 2].max())
            grip_z = max(ref[2] - mid, ref[2] - 0.5 * c.peg_size + 0.004 - float(pts[near, 2].min()))
            grip_z = max(grip_z, 0.004 - bottom)
            for impact in impact_angles:
                yaw_imp = -np.pi / 2 - alpha + impact
                yaw_start = yaw_imp - np.pi / 4
                a_phi = _wrap(yaw_start - c.nominal_yaw)
                a_phi = float(np.clip(a_phi, lo[3], hi[3]))
                # If the yaw was clipped, the impact comes earlier or later in the swing: keep the geometry.
                grip_xy = target - rot2(yaw_imp) @ p[:2]
                a = np.array([*(np.array([*grip_xy, grip_z]) - ref - np.asarray(c.nominal_offset)), a_phi])
                out.append(np.clip(a, lo, hi))
        return out

    check_grasps = {
        # name: (grasp point in the object frame, jaw axis, striking point, striking direction)
        "far_end": (
            (0.03, 0.0, 0.018),
            (0.0, 1.0, 0.0),
            (HAMMER_HANDLE + 0.5 * HAMMER_HEAD[0], 0.5 * HAMMER_HEAD[1], 0.5 * HAMMER_HEAD[2]),
            (0.0, 1.0, 0.0),
        ),
        "head": (
            (HAMMER_HANDLE + 0.5 * HAMMER_HEAD[0], 0.035, 0.5 * HAMMER_HEAD[2]),
            (1.0, 0.0, 0.0),
            (0.015, -0.5 * HAMMER_WIDTH, 0.5 * HAMMER_WIDTH),
            (0.0, -1.0, 0.0),
        ),
    }

    def check_action(
        self, grasp: str | tuple[Any, ...], clip: bool = True, yaw: float = 0.0
    ) -> NDArray[np.float64]:
        """Hand-computed hammering action for a T-hammer grasp (``yaw`` unused): see :func:`hammer_action`."""
        return hammer_action(self.host, grasp, clip=clip)


def hammer_handle_grasp(x: float) -> tuple[Any, ...]:
    """A grasp across the T hammer's handle at ``x`` along it (0 = the far end), striking as far_end."""
    far = HammeringProps.check_grasps["far_end"]
    return ((x, 0.0, far[0][2]), far[1], far[2], far[3])


def hammer_action(
    sim: Any, grasp: str | tuple[Any, ...], impact_angle: float = -0.1, clip: bool = True
) -> NDArray[np.float64]:
    """Hand-computed hammering action for a T-hammer grasp (a name of ``check_grasps`` or a spec as
    :func:`hammer_handle_grasp` gives) in the settled scene of ``sim`` (a hammering simulator): the
    striking face meets the peg's free end ``impact_angle`` (rad) before the striking direction points
    along world +x."""
    spec = HammeringProps.check_grasps[grasp] if isinstance(grasp, str) else grasp
    point, jaw, strike, direction = (np.asarray(v) for v in spec)
    props = sim.props
    assert isinstance(props, HammeringProps) and props.task is not None
    scene = sim.scene
    assert scene is not None
    c = props.config
    f = in_gripper(strike, point, jaw)
    n = in_gripper(direction + point, point, jaw)  # striking direction in the gripper frame
    # Yaw at which the striking direction points along world +x; impact a little before it.
    yaw_push = -np.arctan2(n[1], n[0])
    yaw_impact = yaw_push + impact_angle
    rot = np.array([[np.cos(yaw_impact), -np.sin(yaw_impact)], [np.sin(yaw_impact), np.cos(yaw_impact)]])
    ref = np.asarray(scene["reference"])
    target = np.array([ref[0] - 0.5 * c.peg_length, ref[1]])
    grip_xy = target - rot @ f[:2]
    grip_z = ref[2] - f[2]
    start_yaw = yaw_impact - np.pi / 4  # meet the peg 45 degrees into the swing
    a = np.array(
        [
            *(np.array([*grip_xy, grip_z]) - ref - np.asarray(c.nominal_offset)),
            (start_yaw - c.nominal_yaw + np.pi) % (2 * np.pi) - np.pi,
        ]
    )
    if clip:
        a = np.clip(a, props.task.action_low, props.task.action_high)
    return a


#: The scripted checks' grasps on the T hammer, by name.
HAMMER_GRASPS = HammeringProps.check_grasps


def hammer_actions(
    sim: Any,
    grasp: Grasp,
    n_points: int = 3,
    impact_angles: tuple[float, ...] = (-0.1, 0.15),
    in_hand: object = None,
) -> list[NDArray[np.float64]]:
    """The oracle's hammering actions (:meth:`HammeringProps.oracle_actions`) for ``grasp`` in the settled
    scene of a hammering simulator ``sim``; ``in_hand`` as :func:`tognet.tasks.props.tool_in_gripper`."""
    assert isinstance(sim.props, HammeringProps)
    pts = tool_in_gripper(sim, grasp, in_hand)
    return sim.props.oracle_actions(pts, n_points=n_points, impact_angles=impact_angles)
