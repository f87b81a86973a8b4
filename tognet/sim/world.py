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
from tognet.sim.groups import (
    GROUP_DECOR,
    GROUP_GRIPPER,
    GROUP_OBJECT_COLLISION,
    GROUP_OBJECT_VISUAL,
    GROUP_STATIC,
)
from tognet.sim.hand import (
    finger_actuators,
    hand_body_xml,
    hand_flange_offset,
    hand_lines,
    values_text,
)
from tognet.tasks.props import PropsMJCF

#: Where the gripper waits, out of the camera's view, while a scene settles.
PARK = (0.3, 0.0, 1.2)
# Travel of the gripper base's slide joints (m): x, y, z of the grasp centre.
BASE_RANGE = ((-2.0, 2.0), (-2.0, 2.0), (-0.2, 2.0))


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
    shift = f'pos="{values_text(-np.asarray(obj.com, dtype=np.float64))}"'
    body = [
        '<body name="object" pos="0 0 0.5">',
        '  <freejoint name="object"/>',
        f'  <inertial pos="0 0 0" mass="{obj.mass:.9g}" fullinertia="{values_text(full)}"/>',
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


def _gripper_xml(config: SimConfig) -> tuple[list[str], list[str]]:
    """The floating gripper: the hand on an x, y, z carriage (its yaw joint in the hand)."""
    g = config.gripper
    carriage = 'mass="1.0" diaginertia="0.01 0.01 0.01"'
    rx, ry, rz = (values_text(r) for r in BASE_RANGE)
    body = [
        '<body name="carriage_x" gravcomp="1">',
        f'  <joint name="grip_x" type="slide" axis="1 0 0" range="{rx}" damping="5"/>',
        f"  <inertial pos='0 0 0' {carriage}/>",
        '  <body name="carriage_y" gravcomp="1">',
        f'    <joint name="grip_y" type="slide" axis="0 1 0" range="{ry}" damping="5"/>',
        f"    <inertial pos='0 0 0' {carriage}/>",
        '    <body name="carriage_z" gravcomp="1">',
        f'      <joint name="grip_z" type="slide" axis="0 0 1" range="{rz}" damping="5"/>',
        f"      <inertial pos='0 0 0' {carriage}/>",
        *[f"      {line}" for line in hand_lines(config, floating=True)],
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
    return body, act + finger_actuators(config)


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
        grip_body, actuators = arm["worldbody"], arm["actuator"] + finger_actuators(config)
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
