"""Sweeping's props in the simulator: up to two cans, free bodies standing on the table.

The cans are the task's targets: a can counts as on the ground when it touches the ground or is wholly
beside the table, unsupported (its fall is not simulated); it is then parked (out of the scene, costing
nothing). While the tool is far from them the standing cans are put on hold: the world is stepped without
them (built once more without the cans) and they come back as they stood before the tool or the hand can
reach them (``SweepingConfig.can_hold_margin``), a pure speed-up.

Also the task's privileged knowledge: the oracle's hand-computed actions for a grasp and the scripted
checks on the hand-made L tool (:mod:`tognet.objects.handmade`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.objects.handmade import L_LONG, L_SHORT, L_WIDTH
from tognet.tasks.props import PropsHost, PropsMJCF, StepWatch, TaskProps, in_gripper, rot2, tool_in_gripper
from tognet.tasks.sweeping import SweepingConfig

#: Cans built into the world (a scene uses the first ``n``; the others stay parked).
MAX_CANS = 2


def _parked(i: int, table_height: float, can_height: float) -> tuple[float, float, float]:
    """Where can ``i`` waits out of play: beside the table, far from anything, standing on the ground."""
    return (1.5 + 0.3 * i, 1.5, -table_height + 0.5 * can_height)


class SweepingProps(TaskProps):
    """The cans (see the module docstring)."""

    can_hold = True
    check_object = "l_tool"
    demo_grasp = "short_end"
    check_texts = {
        "short_end": "L tool held at its short end",
        "long_middle": "L tool held in the middle of its long edge",
    }
    outcome_keys = ("cans_on_ground",)
    config: SweepingConfig

    def __init__(self, task: Any = None) -> None:
        super().__init__(task)
        self._on_ground: list[bool] = []  # per can in play, during and after a primitive run

    # --- world ----------------------------------------------------------------------------------------
    def mjcf(self, sim_config: Any, group: int) -> PropsMJCF:
        """Free cylinders ``can_i``, parked beside the table until a scene places them."""
        c, h = self.config, sim_config.world.table_height
        out = []
        for i in range(MAX_CANS):
            out += [
                f'<body name="can_{i}" pos="{1.5 + 0.3 * i:g} 1.5 {-h + 0.5 * c.can_height:.4f}">',
                f'  <freejoint name="can_{i}"/>',
                f'  <geom name="can_{i}" type="cylinder" size="{c.can_radius:g} {0.5 * c.can_height:g}" '
                f'mass="0.2" friction="{c.can_friction:g} 0.005 0.0001" group="{group}" '
                'rgba="0.75 0.1 0.1 1"/>',
                "</body>",
            ]
        cans = [f"can_{i}" for i in range(MAX_CANS)]
        return PropsMJCF(bodies=out, touch_bodies=cans, target_geoms=cans)

    def bind(self, host: PropsHost) -> None:
        """The cans' geom, joint and body ids; the reach of the hand and the object around a can."""
        super().bind(host)
        m = host.model
        self._geoms = [m.geom(f"can_{i}").id for i in range(MAX_CANS)]
        self._qadr = [int(m.jnt_qposadr[m.joint(f"can_{i}").id]) for i in range(MAX_CANS)]
        self._dadr = [int(m.jnt_dofadr[m.joint(f"can_{i}").id]) for i in range(MAX_CANS)]
        self._bodies = [m.body(f"can_{i}").id for i in range(MAX_CANS)]
        c, g = self.config, host.config.gripper
        self._table_height = host.config.world.table_height
        margin = c.can_hold_margin + c.can_radius
        self._margin = margin
        self._hand_reach = 0.5 * g.max_opening + g.pad_size[0] + 0.03 + margin
        self._obj_reach = host.object_reach + margin
        self._obj_body = host.object_body
        self._body_vertices = host.body_vertices
        # A can whose centre is below the table top by more than its half-diagonal is wholly beside the
        # table, unsupported: it will reach the ground, so it counts as there (its fall is not simulated).
        self._fallen_z = -(math.hypot(c.can_radius, 0.5 * c.can_height) + c.fallen_margin)

    # --- scene ----------------------------------------------------------------------------------------
    @property
    def n_cans(self) -> int:
        """Cans in play in this scene."""
        return len(self.layout.get("cans", []))

    def place(self, layout: dict[str, Any]) -> None:
        """The scene's cans standing at their (x, y) with their masses; the others parked."""
        super().place(layout)
        assert self.host is not None
        m, d = self.host.model, self.host.data
        c = self.config
        h = self._table_height
        for i in range(MAX_CANS):
            qa = self._qadr[i]
            if i < len(layout["cans"]):
                x, y, mass = layout["cans"][i]
                d.qpos[qa : qa + 3] = (x, y, 0.5 * c.can_height)
            else:
                mass = 0.2
                d.qpos[qa : qa + 3] = _parked(i, h, c.can_height)
            d.qpos[qa + 3 : qa + 7] = (1, 0, 0, 0)
            self._can_active(i, i < len(layout["cans"]))
            body = self._bodies[i]
            r, hh = c.can_radius, c.can_height
            m.body_mass[body] = mass
            ixx = mass * (3 * r * r + hh * hh) / 12
            m.body_inertia[body] = (ixx, ixx, 0.5 * mass * r * r)

    def activate(self) -> None:
        """The scene's cans in play, the others parked (cans parked by an earlier trial come back)."""
        n = self.n_cans
        for i in range(len(self._geoms)):
            self._can_active(i, i < n)

    def _can_active(self, i: int, active: bool) -> None:
        """Switch can ``i``'s contacts and gravity on (in play) or off (parked). These are model fields,
        so every trial sets them again from its scene (see :meth:`activate`)."""
        assert self.host is not None
        m, g = self.host.model, self._geoms[i]
        m.geom_contype[g] = m.geom_conaffinity[g] = 1 if active else 0
        m.body_gravcomp[self._bodies[i]] = 0.0 if active else 1.0

    def _park(self, i: int) -> None:
        """Take a can that reached the ground out of the scene (it has done its part): a fast-falling
        can's impact on the ground at 2 ms steps is not worth simulating. A parked can touches nothing
        and floats at rest (gravity compensated), so it costs no contacts (it used to stand on the
        ground, about 4 contacts of every step for nothing)."""
        assert self.host is not None
        d = self.host.data
        qa, da = self._qadr[i], self._dadr[i]
        d.qpos[qa : qa + 7] = (*_parked(i, self._table_height, self.config.can_height), 1, 0, 0, 0)
        d.qvel[da : da + 6] = 0.0
        self._can_active(i, False)

    # --- while a trial runs ---------------------------------------------------------------------------
    def positions(self) -> NDArray[np.float64]:
        """Each can in play (where it stands, on hold or not). A parked can is far from anywhere it stood."""
        assert self.host is not None
        d = self.host.data
        rows = []
        for i in range(self.n_cans):
            held = self.held.get(i)
            qa = self._qadr[i]
            rows.append(held[0][:3] if held is not None else d.qpos[qa : qa + 3])
        return np.array(rows, dtype=np.float64).reshape(-1, 3)

    def near(self) -> bool:
        """A can in play (cans are on hold, out of the world, until the tool comes near)."""
        return bool(self.layout.get("cans")) and not self.held

    def hold(self) -> None:
        """Put the cans in play on hold while the tool is far from them: standing still on the table they
        are a fixed point of the physics, yet they cost a good part of every step (their table contacts,
        and their 6 degrees of freedom each even without contacts). On hold a can keeps its state aside
        and is given it back (:meth:`release`) before the tool or the hand can reach it, so it goes on
        exactly as it stood. Meanwhile the world is stepped without it: in the same world built without
        the cans (the cans are the model's last bodies, so every other index is the same and the other
        bodies' motion is the same to the last bit), or, when the host cannot (e.g. a recorder needs the
        full model), with the cans floating contact-free and gravity-compensated."""
        n = self.n_cans
        if not n or self._near_cans(range(n)):
            return
        assert self.host is not None
        d = self.host.data
        for i in range(n):
            qa, da = self._qadr[i], self._dadr[i]
            ws = d.qacc_warmstart[da : da + 6].copy()
            self.held[i] = (d.qpos[qa : qa + 7].copy(), d.qvel[da : da + 6].copy(), ws)
        if self.host.use_world_without_props():
            return
        for i in range(n):
            da = self._dadr[i]
            d.qvel[da : da + 6] = 0.0
            self._can_active(i, False)

    def release(self) -> None:
        """Every can on hold back in play, in the state it was put on hold in."""
        assert self.host is not None
        self.host.use_full_world()
        d = self.host.data
        for i, (qpos, qvel, warmstart) in self.held.items():
            qa, da = self._qadr[i], self._dadr[i]
            d.qpos[qa : qa + 7] = qpos
            d.qvel[da : da + 6] = qvel
            d.qacc_warmstart[da : da + 6] = warmstart  # the solver starts from where it stood
            self._can_active(i, True)
        self.held = {}

    def near_held(self) -> bool:
        """The tool or the hand near a can on hold (:meth:`_near_cans`)."""
        return self._near_cans()

    def _near_cans(self, cans: Any = None) -> bool:
        """The object (a sphere around its body holding all its geometry) or the hand within
        ``can_hold_margin`` of a can on hold (or of ``cans``), in x and y."""
        assert self.host is not None
        d = self.host.data
        margin, obj_body = self._margin, self._obj_body
        ox, oy = float(d.xpos[obj_body, 0]), float(d.xpos[obj_body, 1])
        hx, hy = self.host.hand_xy()
        if cans is None:
            where = [(float(q[0]), float(q[1])) for q, *_ in self.held.values()]
        else:
            where = [(float(d.qpos[self._qadr[i]]), float(d.qpos[self._qadr[i] + 1])) for i in cans]
        pts: NDArray[np.float64] | None = None
        for cx, cy in where:
            if math.hypot(hx - cx, hy - cy) < self._hand_reach:
                return True
            if math.hypot(ox - cx, oy - cy) < self._obj_reach:
                if pts is None:  # near the bounding sphere: look at the collision vertices themselves
                    rot = d.xmat[obj_body].reshape(3, 3)
                    pts = self._body_vertices @ rot[:2].T + d.xpos[obj_body, :2]
                if np.min((pts[:, 0] - cx) ** 2 + (pts[:, 1] - cy) ** 2) < margin * margin:
                    return True
        return False

    def primitive_watch(self) -> StepWatch | None:
        """Marks each can that reached the ground (touching it, or wholly beside the table) and parks it."""
        assert self.host is not None
        n_cans = self.n_cans
        on_ground = self._on_ground = [False] * n_cans
        d = self.host.data
        qpos, fallen_z, qadr, geoms_of = d.qpos, self._fallen_z, self._qadr, self._geoms
        ground = self.host.model.geom("ground").id

        def watch(geoms: NDArray[np.int32] | None) -> None:
            for i in range(n_cans):
                if not on_ground[i] and qpos[qadr[i] + 2] < fallen_z:
                    on_ground[i] = True
                    self._park(i)
            if geoms is None or not n_cans or all(on_ground):
                return
            on = (geoms[:, 0] == ground) | (geoms[:, 1] == ground)
            if on.any():
                hit = geoms[on]
                for i in range(n_cans):
                    if not on_ground[i] and np.any(hit == geoms_of[i]):
                        on_ground[i] = True
                        self._park(i)

        return watch

    def settled(self) -> Callable[[], bool] | None:
        """Every can is down, or those left on the table have come to rest ``rest_checks`` checks in a row."""
        n_cans = self.n_cans
        if not n_cans:
            return None
        assert self.host is not None
        d, c, on_ground = self.host.data, self.config, self._on_ground
        resting = [0]

        def done() -> bool:
            if all(on_ground):
                return True
            rest = all(
                on_ground[i]
                or (
                    np.linalg.norm(d.qvel[a : a + 3]) < c.rest_speed
                    and np.linalg.norm(d.qvel[a + 3 : a + 6]) < 10 * c.rest_speed
                )
                for i, a in enumerate(self._dadr[:n_cans])
            )
            resting[0] = resting[0] + 1 if rest else 0
            return resting[0] >= c.rest_checks

        return done

    def outcome(self) -> tuple[dict[str, Any], bool]:
        """``cans_on_ground`` (per can); still moving: a can on the table faster than 5 cm/s."""
        n_cans = self.n_cans
        if not n_cans:
            return {}, False
        assert self.host is not None
        d = self.host.data
        speeds = [float(np.linalg.norm(d.qvel[a : a + 3])) for a in self._dadr[:n_cans]]
        on_ground = self._on_ground
        return {"cans_on_ground": list(on_ground)}, any(s > 0.05 for s in speeds) and not all(on_ground)

    # --- privileged knowledge -------------------------------------------------------------------------
    def oracle_actions(self, pts: NDArray[np.float64], **options: Any) -> list[NDArray[np.float64]]:
        """Candidate sweeping actions for the tool at ``pts`` (gripper frame): at each start yaw of
        ``yaws`` (default five across the action box), the tool's footprint centred on the cans in x, its
        leading edge 3 cm behind the nearest can, its lowest point 8 mm above the table."""
        yaws = options.get("yaws", (-np.pi / 4, -np.pi / 8, 0.0, np.pi / 8, np.pi / 4))
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c, task = self.config, self.task
        ref = np.asarray(scene["reference"])
        can_y_min = min(y for _, y, _ in scene["layout"]["cans"])
        out = []
        for a_phi in yaws:
            yaw = c.nominal_yaw + a_phi
            xy = pts[:, :2] @ rot2(yaw).T
            centre_x = 0.5 * (xy[:, 0].min() + xy[:, 0].max())
            front = xy[:, 1].max()
            grip = np.array(
                [ref[0] - centre_x, can_y_min - c.can_radius - 0.03 - front, 0.008 - pts[:, 2].min()]
            )
            a = np.array([*(grip - ref - np.asarray(c.nominal_offset)), a_phi])
            out.append(np.clip(a, task.action_low, task.action_high))
        return out

    check_grasps = {
        # name: (grasp point, jaw axis) in the L tool's frame (long bar along +x, short bar along +y at x = 0)
        "short_end": ((0.5 * L_WIDTH, L_SHORT - 0.02, 0.5 * L_WIDTH), (1.0, 0.0, 0.0)),
        "long_middle": ((0.5 * L_LONG, 0.5 * L_WIDTH, 0.5 * L_WIDTH), (0.0, 1.0, 0.0)),
    }

    def check_config(self, task_config: Any) -> Any:
        """Two cans in every scene: the grasp must catch both."""
        return task_config.replace(n_cans=(2,))

    def check_action(
        self, grasp: str | tuple[Any, ...], clip: bool = True, yaw: float = 0.0
    ) -> NDArray[np.float64]:
        """Hand-computed sweeping action: the L tool's long bar centred on the cans, just behind them.

        The start yaw is the nominal one turned by ``yaw`` (a_phi, within the action box when ``clip``):
        the grasp decides how the tool lies across the cans' path.
        """
        spec = self.check_grasps[grasp] if isinstance(grasp, str) else grasp
        point, jaw = (np.asarray(v) for v in spec[:2])
        assert self.host is not None and self.task is not None
        scene = self.host.scene
        assert scene is not None
        c = self.config
        ref = np.asarray(scene["reference"])
        cans = scene["layout"]["cans"]
        # The tool's footprint in the gripper frame (yaw = nominal = 0: gripper x = world x).
        corners = np.array(
            [[x, y, 0.0] for x in (0.0, L_LONG) for y in (0.0, L_WIDTH)]
            + [[x, y, 0.0] for x in (0.0, L_WIDTH) for y in (L_WIDTH, L_SHORT)]
        )
        pts = np.array([in_gripper(p, point, jaw) for p in corners])
        c_, s_ = np.cos(yaw), np.sin(yaw)  # the start yaw turns the tool's footprint with the gripper
        xs, ys = c_ * pts[:, 0] - s_ * pts[:, 1], s_ * pts[:, 0] + c_ * pts[:, 1]
        front = ys.max()  # the tool's leading edge, gripper frame (y = direction of the stroke)
        centre_x = 0.5 * (xs.min() + xs.max())
        can_y_min = min(y for _, y, _ in cans)
        grip = np.array([ref[0] - centre_x, can_y_min - c.can_radius - 0.03 - front, 0.05])
        a = np.array([*(grip - ref - np.asarray(c.nominal_offset)), yaw])
        if clip:
            a = np.clip(a, self.task.action_low, self.task.action_high)
        return a


#: The scripted checks' grasps on the L tool, by name.
SWEEP_GRASPS = SweepingProps.check_grasps


def sweep_action(sim: Any, grasp_name: str, clip: bool = True, yaw: float = 0.0) -> NDArray[np.float64]:
    """:meth:`SweepingProps.check_action` of a sweeping simulator ``sim`` (in its settled scene)."""
    return sim.props.check_action(grasp_name, clip=clip, yaw=yaw)


def sweep_actions(
    sim: Any,
    grasp: Grasp,
    yaws: tuple[float, ...] = (-np.pi / 4, -np.pi / 8, 0.0, np.pi / 8, np.pi / 4),
    in_hand: object = None,
) -> list[NDArray[np.float64]]:
    """The oracle's sweeping actions (:meth:`SweepingProps.oracle_actions`) for ``grasp`` in the settled
    scene of a sweeping simulator ``sim``; ``in_hand`` as :func:`tognet.tasks.props.tool_in_gripper`."""
    assert isinstance(sim.props, SweepingProps)
    return sim.props.oracle_actions(tool_in_gripper(sim, grasp, in_hand), yaws=yaws)
