"""The MJCF of the world: table, ground, the object, the gripper and the task's props (their MJCF comes
from the task, :class:`tognet.tasks.props.TaskProps`).

Geom groups (what the depth camera sees is chosen by group):
0 table and ground (seen), 1 the object's visual mesh (seen), 2 the gripper, 3 the object's convex
collision pieces, 4 task props, 5 decoration (table legs; no collisions).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

from tognet.objects.record import ObjectRecord
from tognet.sim.config import SimConfig
from tognet.tasks.props import PropsMJCF

GROUP_STATIC, GROUP_OBJECT_VISUAL, GROUP_GRIPPER, GROUP_OBJECT_COLLISION, GROUP_PROPS, GROUP_DECOR = range(6)
#: Geom groups the depth camera's rays can hit.
CAMERA_GROUPS = (GROUP_STATIC, GROUP_OBJECT_VISUAL)
#: Where the gripper waits, out of the camera's view, while a scene settles.
PARK = (0.3, 0.0, 1.2)
#: Damping of the wrist joint (N m s/rad): the floating base's, and an arm's last joint's.
WRIST_DAMPING = 0.01
# Travel of the gripper base's slide joints (m): x, y, z of the grasp centre.
BASE_RANGE = ((-2.0, 2.0), (-2.0, 2.0), (-0.2, 2.0))


def _v(values: object) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def _object_xml(config: SimConfig, obj: ObjectRecord) -> tuple[list[str], list[str]]:
    w = config.world
    inertia = np.asarray(obj.inertia, dtype=np.float64)
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    assets = [
        f'<mesh name="piece_{i:02d}" file={quoteattr(str(path))}/>'
        for i, path in enumerate(obj.collision_paths)
    ]
    assets.append(f'<mesh name="object_visual" file={quoteattr(str(obj.path(obj.visual_mesh)))}/>')
    friction = f"{obj.friction:.6g} {w.object_torsional_friction:g} {w.object_rolling_friction:g}"
    # The body's frame is the object's frame moved to its centre of mass (the meshes are shifted back),
    # so the free joint moves the centre of mass: no velocity-product (centripetal) coupling between its
    # translation and rotation for the integrator to lag behind on (Simulator.object_pose() gives the
    # object's own frame).
    shift = f'pos="{_v(-np.asarray(obj.com, dtype=np.float64))}"'
    body = [
        '<body name="object" pos="0 0 0.5">',
        '  <freejoint name="object"/>',
        f'  <inertial pos="0 0 0" mass="{obj.mass:.9g}" fullinertia="{_v(full)}"/>',
    ]
    body += [
        f'  <geom name="piece_{i:02d}" type="mesh" mesh="piece_{i:02d}" {shift} friction="{friction}" '
        'condim="3" '
        f'solref="{w.table_solref[0]:g} {w.table_solref[1]:g}" '
        f'priority="1" group="{GROUP_OBJECT_COLLISION}" rgba="0.8 0.5 0.2 1"/>'
        for i in range(len(obj.collision_paths))
    ]
    body.append(
        f'  <geom name="object_visual" type="mesh" mesh="object_visual" {shift} contype="0" conaffinity="0" '
        f'group="{GROUP_OBJECT_VISUAL}" rgba="0.85 0.55 0.25 1"/>'
    )
    body.append("</body>")
    return assets, body


def _hand_lines(config: SimConfig, floating: bool) -> list[str]:
    """The hand's ``<body>`` (palm and two slide fingers; its frame at the grasp centre, z up, x along the
    jaw): on the floating base with its yaw joint and a wrist, on an arm without them (the arm's own
    wrist turns it)."""
    g = config.gripper
    t, pw, ph = g.pad_size
    half_open = 0.5 * g.max_opening
    top = 0.5 * ph + g.finger_length  # finger top = palm bottom, above the grasp centre
    link_h = 0.5 * (top + 0.5 * ph)
    link_z = top - link_h
    pad = (
        f'friction="{g.pad_friction:g} {g.pad_torsional_friction:g} 0.0001" condim="4" priority="2" '
        f'solref="{g.pad_solref[0]:g} {g.pad_solref[1]:g}" solimp="{_v(g.pad_solimp)} 0.5 2" '
        f'group="{GROUP_GRIPPER}" rgba="0.2 0.2 0.25 1"'
    )
    body = ['<body name="hand" gravcomp="1">']
    if floating:
        body.append(
            f'  <joint name="grip_yaw" type="hinge" axis="0 0 1" armature="{g.yaw_armature:g}" '
            f'damping="{WRIST_DAMPING:g}"/>'
        )
    body += [
        f'  <inertial pos="0 0 {top + 0.015:.4f}" mass="{g.hand_mass:g}" diaginertia="4e-4 2e-4 4e-4"/>',
        f'  <geom name="palm" type="box" size="{half_open + t + 0.01:.4f} 0.025 0.015" '
        f'pos="0 0 {top + 0.015:.4f}" group="{GROUP_GRIPPER}" rgba="0.3 0.3 0.35 1"/>',
    ]
    if floating:
        body.append(
            f'  <geom name="wrist" type="cylinder" size="0.03 0.05" pos="0 0 {top + 0.08:.4f}" '
            f'group="{GROUP_GRIPPER}" rgba="0.5 0.5 0.55 1"/>'
        )
    for side, sign in (("l", -1.0), ("r", 1.0)):
        body += [
            f'  <body name="finger_{side}" gravcomp="1">',
            f'    <joint name="finger_{side}" type="slide" axis="{sign:g} 0 0" '
            f'range="0 {half_open:.4f}" '
            f'damping="2" armature="{g.finger_armature:g}"/>',
            '    <inertial pos="0 0 0.02" mass="0.03" diaginertia="1e-5 1e-5 1e-5"/>',
            f'    <geom name="finger_{side}" type="box" '
            f'size="{0.5 * t:.4f} {0.5 * pw:.4f} {link_h:.4f}" '
            f'pos="{sign * 0.5 * t:.4f} 0 {link_z:.4f}" {pad}/>',
            "  </body>",
        ]
    body.append("</body>")
    return body


def hand_flange_offset(config: SimConfig) -> float:
    """How far the grasp centre lies out of an arm's flange (m): the top of the hand's palm is on it."""
    g = config.gripper
    return 0.5 * g.pad_size[2] + g.finger_length + 0.03


def hand_body_xml(config: SimConfig) -> str:
    """The hand's ``<body>`` as an arm carries it (:mod:`tognet.sim.arm`)."""
    return "\n".join(_hand_lines(config, floating=False))


def _finger_actuators(config: SimConfig) -> list[str]:
    g = config.gripper
    half_open = 0.5 * g.max_opening
    return [
        f'<position name="act_finger_{side}" joint="finger_{side}" kp="{g.finger_kp:g}" '
        f'kv="{g.finger_kv:g}" '
        f'ctrlrange="-0.02 {half_open:.4f}" forcerange="{-g.finger_force:g} {g.finger_force:g}"/>'
        for side in ("l", "r")
    ]


def _gripper_xml(config: SimConfig) -> tuple[list[str], list[str]]:
    """The floating gripper: the hand on an x, y, z carriage (its yaw joint in the hand)."""
    g = config.gripper
    carriage = 'mass="1.0" diaginertia="0.01 0.01 0.01"'
    body = [
        '<body name="carriage_x" gravcomp="1">',
        f'  <joint name="grip_x" type="slide" axis="1 0 0" range="{_v(BASE_RANGE[0])}" damping="5"/>',
        f"  <inertial pos='0 0 0' {carriage}/>",
        '  <body name="carriage_y" gravcomp="1">',
        f'    <joint name="grip_y" type="slide" axis="0 1 0" range="{_v(BASE_RANGE[1])}" damping="5"/>',
        f"    <inertial pos='0 0 0' {carriage}/>",
        '    <body name="carriage_z" gravcomp="1">',
        f'      <joint name="grip_z" type="slide" axis="0 0 1" range="{_v(BASE_RANGE[2])}" damping="5"/>',
        f"      <inertial pos='0 0 0' {carriage}/>",
        *[f"      {line}" for line in _hand_lines(config, floating=True)],
        "    </body>",
        "  </body>",
        "</body>",
    ]
    v, vy = g.linear_speed, g.yaw_speed
    act = [
        f'<intvelocity name="act_{ax}" joint="grip_{ax}" kp="{g.linear_kp:g}" kv="{g.linear_kv:g}" '
        f'ctrlrange="{-v:g} {v:g}" actrange="-2 2" forcerange="{-g.linear_force:g} {g.linear_force:g}"/>'
        for ax in ("x", "y", "z")
    ]
    act.append(
        f'<intvelocity name="act_yaw" joint="grip_yaw" kp="{g.yaw_kp:g}" kv="{g.yaw_kv:g}" '
        f'ctrlrange="{-vy:g} {vy:g}" actrange="-30 30" forcerange="{-g.yaw_torque:g} {g.yaw_torque:g}"/>'
    )
    return body, act + _finger_actuators(config)


def _touch_pairs(props: PropsMJCF, hand_root: str = "hand") -> list[tuple[str, str, str]]:
    """(sensor name, tool-side MJCF attribute, prop body) of each touch sensor of the props; the hand's
    side is the subtree of ``hand_root`` (the hand, or the arm carrying it)."""
    sides = (("object", 'body1="object"'), ("hand", f'subtree1="{hand_root}"'))
    return [(f"touch_{side}_{prop}", attr, prop) for prop in props.touch_bodies for side, attr in sides]


def touch_sensor_names(props: PropsMJCF) -> list[str]:
    """Names of the contact sensors that count the tool's and the hand's contacts with the props."""
    return [name for name, _, _ in _touch_pairs(props)]


def _touch_sensors_xml(props: PropsMJCF, hand_root: str = "hand") -> list[str]:
    """Contact sensors (MuJoCo computes them every step, cheaply) for a prop touch check after any step."""
    lines = [
        f'    <contact name="{name}" {side} subtree2="{prop}" data="found"/>'
        for name, side, prop in _touch_pairs(props, hand_root)
    ]
    return ["  <sensor>", *lines, "  </sensor>"] if lines else []


def world_xml(config: SimConfig, obj: ObjectRecord, props: PropsMJCF) -> str:
    """The whole world as an MJCF string (meshes by absolute path), with the task's ``props``
    (:meth:`tognet.tasks.props.TaskProps.mjcf`; an empty ``PropsMJCF()``: no props)."""
    p, w = config.physics, config.world
    lx, ly = 0.5 * w.table_size[0], 0.5 * w.table_size[1]
    h = w.table_height
    assets, obj_body = _object_xml(config, obj)
    stiff = f'solref="{w.table_solref[0]:g} {w.table_solref[1]:g}"'
    arm: dict[str, list[str]] = {"asset": [], "default": [], "contact": []}
    hand_root = "hand"
    if config.robot.name == "floating":
        grip_body, actuators = _gripper_xml(config)
    else:
        from tognet.sim.arm import arm_parts

        arm = arm_parts(config, hand_body_xml(config), hand_flange_offset(config), GROUP_GRIPPER)
        grip_body, actuators = arm["worldbody"], arm["actuator"] + _finger_actuators(config)
        hand_root = "arm_mount"
    contact = [*props.contact, *arm["contact"]]
    legs = [
        f'<geom type="box" size="0.03 0.03 {0.5 * h:.4f}" pos="{sx * (lx - 0.05):.4f} {sy * (ly - 0.05):.4f} '
        f'{-0.5 * h - 0.02:.4f}" contype="0" conaffinity="0" group="{GROUP_DECOR}" rgba="0.45 0.35 0.25 1"/>'
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    lines = [
        '<mujoco model="tognet_world">',
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{p.timestep:g}" integrator="{p.integrator}" cone="elliptic" '
        f'impratio="{p.impratio:g}" iterations="{p.iterations}" noslip_iterations="{p.noslip_iterations}" '
        f'gravity="0 0 {-p.gravity:g}">',
        f'    <flag autoreset="disable" sleep="{"enable" if p.sleep else "disable"}"/>',
        "  </option>",
        '  <visual><global offwidth="640" offheight="480"/><quality shadowsize="1024"/></visual>',
        "  <asset>",
        '    <texture name="grid" type="2d" builtin="checker" rgb1="0.85 0.85 0.85" rgb2="0.75 0.75 0.75" '
        'width="256" height="256"/>',
        '    <material name="floor" texture="grid" texrepeat="8 8"/>',
        *[f"    {a}" for a in assets],
        *[f"    {a}" for a in arm["asset"]],
        "  </asset>",
        *(["  <default>", *[f"    {a}" for a in arm["default"]], "  </default>"] if arm["default"] else []),
        "  <worldbody>",
        '    <light pos="0 -0.6 2.0" dir="0 0.3 -1" diffuse="0.8 0.8 0.8"/>',
        f'    <geom name="ground" type="plane" size="4 4 0.1" pos="0 0 {-h:g}" material="floor" '
        f'friction="{w.table_friction:g} 0.005 0.0001" group="{GROUP_STATIC}" {stiff}/>',
        f'    <geom name="table" type="box" size="{lx:g} {ly:g} 0.02" pos="0 0 -0.02" '
        f'friction="{w.table_friction:g} 0.005 0.0001" group="{GROUP_STATIC}" {stiff} rgba="0.6 0.5 0.4 1"/>',
        *[f"    {leg}" for leg in legs],
        *[f"    {line}" for line in obj_body],
        *[f"    {line}" for line in grip_body],
        *[f"    {line}" for line in props.bodies],
        "  </worldbody>",
        "  <actuator>",
        *[f"    {a}" for a in actuators],
        "  </actuator>",
        *([f"  <contact>{''.join(contact)}</contact>"] if contact else []),
        *_touch_sensors_xml(props, hand_root),
        "</mujoco>",
        "",
    ]
    return "\n".join(lines)
