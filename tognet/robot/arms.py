"""Real arm models (the paper's Sawyer, a Panda) as MJCF that can stand beside tognet's table.

The models, meshes and grippers come from robosuite's wheel (``pip install 'tognet[robot]'``), read as
files from the installed package: robosuite's own Python modules are never imported (they pull in heavy
dependencies). Each arm is rebuilt into one MJCF tree with every name prefixed (``arm_``), its gripper
mounted on its hand, and a ``arm_tcp`` site at the grasp centre: the midpoint between the finger pads,
its x axis along the jaw axis (the line through both pads) and its z axis pointing out of the hand, so
a top-down grasp g = (x, y, z, phi) is the site at (x, y, z) with z axis down and x axis at yaw phi.

Joint limits are read from the model. MJCF has no joint speed limits, and robosuite's models carry none,
so each arm's are tabled below from its maker's published figures.
"""

from __future__ import annotations

import importlib.util
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.errors import TognetError
from tognet.robot.names import ARM_BASES

#: Prefix of every name in an arm's MJCF (bodies, joints, geoms, sites, meshes, materials, actuators).
PREFIX = "arm_"
#: The grasp-centre site (see the module docstring).
TCP_SITE = PREFIX + "tcp"
#: The body the arm is mounted on (its pose is the arm's base pose).
BASE_BODY = PREFIX + "mount"


@dataclass(frozen=True)
class HandMount:
    """A hand of the caller's own to mount on the arm's flange in place of the arm's gripper.

    ``body`` is one MJCF ``<body>`` element (as text, names left as they are) whose frame is the grasp
    centre with its z axis pointing back towards the flange and its x axis along the jaw: tognet's
    simulated hand (:mod:`tognet.sim.world`). It is mounted ``offset`` metres out of the flange, turned
    half a turn about x, and the ``arm_tcp`` site goes at its origin with z out of the hand."""

    body: str
    offset: float
    yaw: float = 0.0  # the hand turned by this (rad) about the flange's axis


class ArmStuck(Exception):
    """An arm cannot do what the trial asks (``reason``: "unreachable", a pose out of its reach, or
    "joint_limit", reachable only past a joint's range); ``what`` says which step."""

    def __init__(self, reason: str, what: str) -> None:
        super().__init__(f"{what}: {reason}")
        self.reason = reason
        self.what = what


class RobotExtraMissing(TognetError):
    """The optional ``robot`` extra (robosuite's models, mink) is not installed."""


EXTRA_HINT = "the robot arms need the optional extra: pip install 'tognet[robot]'"


@dataclass(frozen=True)
class ArmSpec:
    """Where an arm's model is in robosuite's assets and what the model itself does not say."""

    name: str
    robot_xml: str  # relative to robosuite/models/assets
    gripper_xml: str
    hand_body: str  # the body the gripper is mounted on (robosuite's name, unprefixed)
    eef_body: str  # the gripper's end-effector body (its z axis points out of the hand)
    pad_geoms: tuple[str, str]  # the two finger pads' collision geoms (unprefixed)
    joint_speed_limits: tuple[float, ...]  # rad/s, one per arm joint, from the maker's figures
    home: tuple[float, ...]  # a joint configuration with the hand above the table, pointing down
    # Default base pose in tognet's world frame (m, rad): the arm's tognet.robot.names.ARM_BASES.
    base_pos: tuple[float, float, float]
    base_yaw: float
    hand_yaw: float = 0.0  # a hand of tognet's turned by this about the flange axis (HandMount.yaw)
    # Bodies whose mass, centre of mass and diagonal inertia replace the model's, (body, mass, pos, inertia).
    inertials: tuple[tuple[str, float, tuple[float, float, float], tuple[float, float, float]], ...] = ()


ARMS: dict[str, ArmSpec] = {
    "panda": ArmSpec(
        name="panda",
        robot_xml="robots/panda/robot.xml",
        gripper_xml="grippers/panda_gripper.xml",
        hand_body="right_hand",
        eef_body="eef",
        pad_geoms=("finger1_pad_collision", "finger2_pad_collision"),
        # Franka Emika Panda datasheet: joints 1-4 2.175 rad/s, joints 5-7 2.61 rad/s.
        joint_speed_limits=(2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
        home=(0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785),
        base_pos=ARM_BASES["panda"].position,
        base_yaw=ARM_BASES["panda"].yaw,
        # Chosen by measurement (benchmarks/RESULTS.md): with the hand turned so on the flange, joint 7's
        # +-166 degrees hold the turns the tasks' trials make most often.
        hand_yaw=0.43,
        # robosuite's Panda gives each link a placeholder inertia (0.1 x its mass on each axis): link 7 and
        # the flange body it carries 0.05 kg m^2 each, 30 times what the wrist of the real arm turns (the
        # identified link 7: 0.74 kg, I_zz 0.0048 kg m^2) and what its 2.6 rad/s swing can accelerate.
        inertials=(
            ("link7", 0.735522, (0.0, 0.0, 0.08), (0.012516, 0.010027, 0.004815)),
            ("right_hand", 0.001, (0.0, 0.0, 0.0), (1e-6, 1e-6, 1e-6)),
        ),
    ),
    "sawyer": ArmSpec(
        name="sawyer",
        robot_xml="robots/sawyer/robot.xml",
        gripper_xml="grippers/rethink_gripper.xml",
        hand_body="right_hand",
        eef_body="eef",
        pad_geoms=("l_fingerpad_g0", "r_fingerpad_g0"),
        # Rethink Robotics' Sawyer description (URDF velocity limits), right_j0 ... right_j6.
        joint_speed_limits=(1.74, 1.328, 1.957, 1.957, 3.485, 3.485, 4.545),
        home=(0.0, -1.18, 0.0, 2.18, 0.0, 0.57, 3.3161),
        base_pos=ARM_BASES["sawyer"].position,
        base_yaw=ARM_BASES["sawyer"].yaw,
    ),
}
ARM_NAMES = tuple(ARMS)

#: Joint servos of :func:`add_servos` (tuning, not the makers' data): stiffness (N m/rad), damping of the
#: joint's speed (N m s/rad; at a constant speed v the joint lags its setpoint by about kv v / kp) and the
#: reflected inertia of each joint's drive (kg m^2), which keeps the explicit damping stable at 2 ms.
SERVO_KP = 10000.0
SERVO_KV = 300.0
SERVO_ARMATURE = 0.3

# Attributes that name (or refer to) an element, prefixed together so references stay consistent.
_NAME_ATTRS = ("name", "mesh", "material", "joint", "site", "body", "class", "childclass", "texture")


def assets_dir() -> Path:
    """robosuite's model assets folder, found without importing robosuite; RobotExtraMissing if absent."""
    spec = importlib.util.find_spec("robosuite")
    if spec is None or not spec.submodule_search_locations:
        raise RobotExtraMissing(f"robosuite is not installed: {EXTRA_HINT}")
    folder = Path(next(iter(spec.submodule_search_locations))) / "models" / "assets"
    if not folder.is_dir():
        raise RobotExtraMissing(f"robosuite's model assets are missing ({folder}): {EXTRA_HINT}")
    return folder


def arm_spec(name: str) -> ArmSpec:
    """The spec of an arm by name (ValueError naming the choices otherwise)."""
    if name not in ARMS:
        raise ValueError(f"unknown arm {name!r}: choose from {', '.join(ARM_NAMES)}")
    return ARMS[name]


def _is_visual(geom: ET.Element) -> bool:
    return (geom.get("contype") == "0" and geom.get("conaffinity") == "0" and geom.get("group") == "1") or (
        geom.get("class") == "visual")


def _prefix(root: ET.Element) -> None:
    for el in root.iter():
        for attr in _NAME_ATTRS:
            if el.get(attr):
                el.set(attr, PREFIX + el.get(attr))


def _absolute_files(root: ET.Element, folder: Path) -> None:
    for el in root.iter():
        if el.get("file"):
            el.set("file", str((folder / el.get("file")).resolve()))


def _strip_visuals(root: ET.Element) -> None:
    """Drop visual-only geoms (robosuite's high-resolution OBJ meshes), then the assets nobody uses."""
    for parent in root.iter():
        for child in list(parent):
            if child.tag == "geom" and _is_visual(child):
                parent.remove(child)
    used = {(attr, el.get(attr)) for el in root.iter() for attr in ("mesh", "material") if el.get(attr)}
    for asset in root.iter("asset"):
        for child in list(asset):
            if child.tag in ("mesh", "material") and (child.tag, child.get("name")) not in used:
                asset.remove(child)
    for default in root.iter("default"):
        for child in list(default):
            if child.tag == "default" and child.get("class") == "visual":
                default.remove(child)


def _load_part(path: Path, visual: bool) -> ET.Element:
    root = ET.parse(path).getroot()
    _absolute_files(root, path.parent)
    for tag in ("sensor", "camera", "actuator"):  # robosuite's torque motors, cameras and F/T sensors
        for parent in root.iter():
            for child in list(parent):
                if child.tag == tag:
                    parent.remove(child)
    if visual:
        # Visual-only meshes do not count for inertia (the bodies give theirs), and some are open shells
        # whose volume MuJoCo's compiler would reject.
        visual_meshes = {g.get("mesh") for g in root.iter("geom") if _is_visual(g)}
        for mesh in root.iter("mesh"):
            if mesh.get("name") in visual_meshes:
                mesh.set("inertia", "shell")
    else:
        _strip_visuals(root)
    return root


def _merge_section(dst: ET.Element, src: ET.Element, tag: str) -> None:
    part = src.find(tag)
    if part is None:
        return
    target = dst.find(tag)
    if target is None:
        target = ET.SubElement(dst, tag)
    target.extend(list(part))


@cache
def _tcp_frame(name: str) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """The TCP site's position and quaternion (w, x, y, z) in the end-effector body's frame, measured on
    the compiled model with the fingers open: the pads' midpoint, x along the jaw axis, z out of the hand."""
    spec = arm_spec(name)
    model = mujoco.MjModel.from_xml_string(_arm_xml(spec, (0.0, 0.0, 0.0), 0.0, None, False, None))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    eef = model.body(PREFIX + spec.eef_body).id
    rot, origin = data.xmat[eef].reshape(3, 3), data.xpos[eef]
    pads = [rot.T @ (data.geom(PREFIX + g).xpos - origin) for g in spec.pad_geoms]
    centre = 0.5 * (pads[0] + pads[1])
    jaw = pads[1] - pads[0]
    jaw[2] = 0.0
    jaw /= np.linalg.norm(jaw)
    z = np.array([0.0, 0.0, 1.0])
    frame = np.column_stack([jaw, np.cross(z, jaw), z])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, frame.reshape(-1))
    return tuple(float(v) for v in centre), tuple(float(v) for v in quat)


def _arm_xml(spec: ArmSpec, base_pos: tuple[float, float, float], base_yaw: float,
             ground_z: float | None, visual: bool,
             tcp: tuple[tuple[float, float, float], tuple[float, float, float, float]] | None,
             mount: HandMount | None = None) -> str:
    folder = assets_dir()
    robot = _load_part(folder / spec.robot_xml, visual)
    _prefix(robot)
    hand = next(b for b in robot.iter("body") if b.get("name") == PREFIX + spec.hand_body)
    for body_name, mass, com, inertia in spec.inertials:
        body = next(b for b in robot.iter("body") if b.get("name") == PREFIX + body_name)
        inertial = body.find("inertial")
        if inertial is None:
            inertial = ET.SubElement(body, "inertial")
        for key in list(inertial.attrib):
            del inertial.attrib[key]
        inertial.set("pos", " ".join(map(repr, com)))
        inertial.set("mass", repr(mass))
        inertial.set("diaginertia", " ".join(map(repr, inertia)))
    if mount is not None:
        c, s = math.cos(0.5 * mount.yaw), math.sin(0.5 * mount.yaw)
        # Turned by yaw about the flange's z, then half a turn about x: (c, 0, 0, s) * (0, 1, 0, 0).
        holder = ET.SubElement(hand, "body", name=PREFIX + "hand_mount", pos=f"0 0 {mount.offset!r}",
                               quat=f"0 {c!r} {s!r} 0")
        holder.append(ET.fromstring(mount.body))
        ET.SubElement(hand, "site", name=TCP_SITE, pos=f"0 0 {mount.offset!r}", quat=f"{c!r} 0 0 {s!r}",
                      size="0.005", rgba="0 1 0 0.5", group="3")
        tcp = None
    else:
        gripper = _load_part(folder / spec.gripper_xml, visual)
        _prefix(gripper)
        hand.extend(list(gripper.find("worldbody")))
        for tag in ("asset", "default"):
            _merge_section(robot, gripper, tag)
    if tcp is not None:
        eef = next(b for b in robot.iter("body") if b.get("name") == PREFIX + spec.eef_body)
        pos, quat = tcp
        ET.SubElement(eef, "site", name=TCP_SITE, pos=" ".join(map(repr, pos)),
                      quat=" ".join(map(repr, quat)), size="0.005", rgba="0 1 0 0.5", group="3")
    # Everything under one mount body placed at the base pose; a pedestal from the ground to the base.
    world = robot.find("worldbody")
    base = ET.Element("body", name=BASE_BODY, pos=" ".join(map(repr, base_pos)),
                      euler=f"0 0 {base_yaw!r}")
    base.extend(list(world))
    world.clear()
    world.append(base)
    if ground_z is not None and ground_z < base_pos[2]:
        half = 0.5 * (base_pos[2] - ground_z)
        ET.SubElement(base, "geom", name=PREFIX + "pedestal", type="cylinder", size=f"0.1 {half!r}",
                      pos=f"0 0 {-half!r}", rgba="0.3 0.3 0.3 1")
    compiler = robot.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(robot, "compiler")
    compiler.set("angle", "radian")
    return ET.tostring(robot, encoding="unicode")


def arm_xml(name: str, base_pos: tuple[float, float, float] | None = None, base_yaw: float | None = None,
            ground_z: float | None = None, visual: bool = False, mount: HandMount | None = None) -> str:
    """The arm ``name`` (with its gripper, or the hand ``mount`` in its place, and the ``arm_tcp`` site)
    as an MJCF document, its base at ``base_pos`` with yaw ``base_yaw`` (the spec's defaults when None),
    on a pedestal down to ``ground_z`` (none when None). ``visual`` keeps robosuite's high-resolution
    visual meshes (slow to load)."""
    spec = arm_spec(name)
    pos = spec.base_pos if base_pos is None else tuple(float(v) for v in base_pos)
    yaw = spec.base_yaw if base_yaw is None else float(base_yaw)
    return _arm_xml(spec, pos, yaw, ground_z, visual, None if mount else _tcp_frame(name), mount)


@dataclass(frozen=True)
class ArmModel:
    """A compiled arm: the model and what a controller needs to know about its joints."""

    spec: ArmSpec
    model: mujoco.MjModel
    joint_names: tuple[str, ...]  # the arm's hinge joints, base to wrist (prefixed)
    qpos_adr: NDArray[np.int64]  # their qpos addresses
    dof_adr: NDArray[np.int64]  # their dof addresses
    joint_limits: NDArray[np.float64]  # (n, 2) lower and upper, rad, from the model
    joint_speed_limits: NDArray[np.float64]  # (n,) rad/s, from the spec
    joint_torque_limits: NDArray[np.float64]  # (n,) N m, from the model (robosuite's motors)
    finger_dofs: NDArray[np.int64]  # the gripper's slide joints' dofs
    tcp_site: int

    @property
    def home(self) -> NDArray[np.float64]:
        """The model's default qpos with the arm joints at the spec's home configuration."""
        q = self.model.qpos0.copy()
        q[self.qpos_adr] = self.spec.home
        return q


def load_arm(name: str, base_pos: tuple[float, float, float] | None = None, base_yaw: float | None = None,
             ground_z: float | None = None, visual: bool = False, servos: bool = False,
             mount: HandMount | None = None) -> ArmModel:
    """Compile the arm ``name`` alone (see :func:`arm_xml`; with :func:`add_servos` if ``servos``) and
    read its joints, limits and TCP site."""
    spec = arm_spec(name)
    mjcf = arm_xml(name, base_pos, base_yaw, ground_z, visual, mount)
    model = mujoco.MjModel.from_xml_string(add_servos(mjcf, name) if servos else mjcf)
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    slides = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE]
    if len(hinges) != len(spec.joint_speed_limits) or len(spec.home) != len(hinges):
        raise RuntimeError(f"{name}: the model has {len(hinges)} hinge joints, the spec "
                           f"{len(spec.joint_speed_limits)} speed limits and {len(spec.home)} home angles")
    if not all(model.jnt_limited[j] for j in hinges):
        raise RuntimeError(f"{name}: every arm joint needs a range in the model")
    torques = _torque_limits(spec)
    return ArmModel(
        spec=spec,
        model=model,
        joint_names=tuple(model.joint(j).name for j in hinges),
        qpos_adr=np.array([model.jnt_qposadr[j] for j in hinges]),
        dof_adr=np.array([model.jnt_dofadr[j] for j in hinges]),
        joint_limits=np.array([model.jnt_range[j] for j in hinges], dtype=np.float64),
        joint_speed_limits=np.array(spec.joint_speed_limits, dtype=np.float64),
        joint_torque_limits=np.array([torques[model.joint(j).name[len(PREFIX):]] for j in hinges],
                                     dtype=np.float64),
        finger_dofs=np.array([model.jnt_dofadr[j] for j in slides]),
        tcp_site=model.site(TCP_SITE).id,
    )



def place_arm(world: str, name: str, base_pos: tuple[float, float, float] | None = None,
              base_yaw: float | None = None, ground_z: float | None = None, visual: bool = False) -> str:
    """The MJCF document ``world`` with the arm ``name`` added (see :func:`arm_xml`): its assets,
    defaults and mount body merged in, every arm name prefixed ``arm_`` so nothing clashes. The pedestal
    rests on the ground without a contact with it (it is fixed to the world anyway)."""
    root = ET.fromstring(world)
    arm = ET.fromstring(arm_xml(name, base_pos, base_yaw, ground_z, visual))
    for tag in ("asset", "default"):
        _merge_section(root, arm, tag)
    for geom in arm.iter("geom"):
        if geom.get("name") == PREFIX + "pedestal":
            geom.set("contype", "0")
            geom.set("conaffinity", "1")  # things that fall against it still hit it
    worldbody = root.find("worldbody")
    if worldbody is None:
        raise ValueError("the world MJCF has no <worldbody>")
    worldbody.extend(list(arm.find("worldbody")))
    return ET.tostring(root, encoding="unicode")


def _torque_limits(spec: ArmSpec) -> dict[str, float]:
    """Each arm joint's torque limit (N m, unprefixed joint name): robosuite's motors' control range."""
    root = ET.parse(assets_dir() / spec.robot_xml).getroot()
    return {m.get("joint"): max(abs(float(v)) for v in m.get("ctrlrange").split())
            for m in root.iter("motor")}


def add_servos(mjcf: str, name: str, wrist: tuple[float, float, float, float, float] | None = None,
               gripper: bool = True) -> str:
    """``mjcf`` (holding the arm ``name``, from :func:`arm_xml` or :func:`place_arm`) with the arm driven:
    each joint by an integrated-velocity servo (the control is the setpoint's speed, capped at the joint's
    speed limit; the setpoint stays within the joint's range; the torque within the model's limit), the
    arm's bodies gravity-compensated, and the gripper's own finger servos (robosuite's, names prefixed;
    none when ``gripper`` is False). ``wrist`` (kp, kv, armature, torque limit, joint damping) sets the
    last joint's servo apart from the others."""
    spec = arm_spec(name)
    root = ET.fromstring(mjcf)
    torques = _torque_limits(spec)
    joints = {j.get("name"): j for j in root.iter("joint") if j.get("name", "").startswith(PREFIX)}
    arm_joints = [PREFIX + j for j in torques]
    if len(arm_joints) != len(spec.joint_speed_limits) or not all(j in joints for j in arm_joints):
        raise ValueError(f"the MJCF does not hold the {name} arm's joints")
    for body in root.iter("body"):
        if body.get("name", "").startswith(PREFIX):
            body.set("gravcomp", "1")
    actuator = root.find("actuator")
    if actuator is None:
        actuator = ET.SubElement(root, "actuator")
    for joint, speed in zip(arm_joints, spec.joint_speed_limits, strict=True):
        joints[joint].set("armature", repr(SERVO_ARMATURE))
        lo, hi = joints[joint].get("range").split()
        torque = torques[joint[len(PREFIX):]]
        ET.SubElement(actuator, "intvelocity", name=joint + "_servo", joint=joint, kp=repr(SERVO_KP),
                      kv=repr(SERVO_KV), ctrlrange=f"{-speed!r} {speed!r}", actrange=f"{lo} {hi}",
                      forcerange=f"{-torque!r} {torque!r}")
    if wrist is not None:  # the last joint's servo: (kp, kv, armature, torque limit, joint damping)
        kp, kv, armature, torque, damping = wrist
        last = actuator.find(f"intvelocity[@joint='{arm_joints[-1]}']")
        assert last is not None
        last.set("kp", repr(kp))
        last.set("kv", repr(kv))
        last.set("forcerange", f"{-torque!r} {torque!r}")
        joints[arm_joints[-1]].set("armature", repr(armature))
        joints[arm_joints[-1]].set("damping", repr(damping))
    if gripper:
        parts = ET.parse(assets_dir() / spec.gripper_xml).getroot()
        _prefix(parts)
        fingers = parts.find("actuator")
        if fingers is not None:
            actuator.extend(list(fingers))
    return ET.tostring(root, encoding="unicode")
