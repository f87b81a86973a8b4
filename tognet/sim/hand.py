"""The hand: palm and two slide fingers with their pads, as the floating base and every arm carry it (its
MJCF and its finger servos; the frame at the grasp centre, z up, x along the jaw)."""

from __future__ import annotations

import numpy as np

from tognet.sim.config import SimConfig
from tognet.sim.groups import GROUP_GRIPPER

#: Damping of the wrist joint (N m s/rad): the floating base's, and an arm's last joint's.
WRIST_DAMPING = 0.01


def values_text(values: object) -> str:
    """Numbers as MJCF writes them (space-separated, 9 significant digits)."""
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def hand_lines(config: SimConfig, floating: bool) -> list[str]:
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
        f'solref="{g.pad_solref[0]:g} {g.pad_solref[1]:g}" solimp="{values_text(g.pad_solimp)} 0.5 2" '
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
    return "\n".join(hand_lines(config, floating=False))


def finger_actuators(config: SimConfig) -> list[str]:
    g = config.gripper
    half_open = 0.5 * g.max_opening
    return [
        f'<position name="act_finger_{side}" joint="finger_{side}" kp="{g.finger_kp:g}" '
        f'kv="{g.finger_kv:g}" '
        f'ctrlrange="-0.02 {half_open:.4f}" forcerange="{-g.finger_force:g} {g.finger_force:g}"/>'
        for side in ("l", "r")
    ]
