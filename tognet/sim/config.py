"""Every physical and episode parameter of the simulated world, typed and documented.

A :class:`SimConfig` is logged with every result; changing physics means changing this config, never
the control code. Each registered task's config is a section of it named after the task (its class
comes from the task registry, :mod:`tognet.tasks`), so a saved SimConfig reads as before: the core
sections, then one section per task.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from tognet.config import Config, ConfigRangeError, doc
from tognet.geometry.camera import focal_length_problem
from tognet.robot.names import FLOATING, check_robot_name
from tognet.tasks import TASK_NAMES, check_task_name, task_config_class


@dataclass(frozen=True)
class PhysicsConfig(Config):
    """MuJoCo solver options."""

    timestep: float = doc(0.002, "Simulation timestep (s).", gt=0, le=0.05)
    integrator: str = doc(
        "Euler",
        "MuJoCo integrator: Euler (semi-implicit, joint damping implicit), implicit, implicitfast or RK4. "
        "Euler: fewer instructions per episode than implicit with labels that agree as well with a 1 ms "
        "reference (benchmarks/RESULTS.md, 'Why the config values are what they are').",
    )
    impratio: float = doc(
        10.0, "Frictional-to-normal impedance ratio (elliptic cones; firmer grip friction).",
        gt=0,
    )
    iterations: int = doc(30, "Maximum constraint-solver iterations per step.", ge=1)
    noslip_iterations: int = doc(
        0,
        "Noslip solver iterations (0 = off). Off: the pads' own stiff contact parameters hold the grip "
        "without creep, and the solver costs time (benchmarks/RESULTS.md).",
        ge=0,
    )
    gravity: float = doc(9.81, "Gravity (m/s^2), along -z.", ge=0)
    sleep: bool = doc(
        False,
        "Let MuJoCo put resting bodies to sleep. Off: a sleeping prop or tool misses the first contacts of "
        "an impact, and good grasps then fail their task (benchmarks/RESULTS.md).",
    )


@dataclass(frozen=True)
class WorldConfig(Config):
    """The table, the ground and where things go on it."""

    table_size: tuple[float, float] = doc(
        (1.22, 0.76), "Table top size (m) along x and y (48 x 30 in).", gt=0
    )
    table_height: float = doc(
        0.75, "Height of the table top above the ground (m); the top is at z = 0.", gt=0
    )
    table_friction: float = doc(0.5, "Sliding friction of the table top and the ground.", ge=0)
    table_solref: tuple[float, float] = doc(
        (0.005, 1.0),
        "Contact solref of the table, the ground and the object's pieces (time constant s, damping "
        "ratio): stiff, so a tool pressed down by the arm does not sink into the table.",
    )
    drop_x: tuple[float, float] = doc(
        (-0.45, -0.16), "Range of the object's drop x (m), grasping half (x < 0)."
    )
    drop_y: tuple[float, float] = doc((-0.18, 0.18), "Range of the object's drop y (m).")
    drop_height: float = doc(
        0.01, "Gap between the table and the object's lowest point when dropped (m).", ge=0
    )
    settle_time: float = doc(0.5, "Maximum time to let the dropped object settle (s).", gt=0)
    settle_speed: float = doc(0.01, "The object counts as settled below this speed (m/s and rad/s).", gt=0)
    object_torsional_friction: float = doc(
        0.005, "Torsional friction coefficient of the object's pieces (m).",
        ge=0,
    )
    object_rolling_friction: float = doc(
        0.0001, "Rolling friction coefficient of the object's pieces (m).", ge=0
    )


@dataclass(frozen=True)
class CameraConfig(Config):
    """The overhead Kinect2-like depth camera and its per-episode disturbance."""

    width: int = doc(512, "Image width (px).", ge=8)
    height: int = doc(424, "Image height (px).", ge=8)
    fx: float = doc(365.0, "Nominal focal length x (px).", gt=0)
    fy: float = doc(365.0, "Nominal focal length y (px).", gt=0)
    position: tuple[float, float, float] = doc(
        (-0.305, 0.0, 0.72), "Nominal camera centre (m): above the middle of the grasping half."
    )
    yaw: float = doc(np.pi / 2, "Nominal yaw of the image x axis (rad): image x along world +y.")
    translation_noise: tuple[float, float, float] = doc(
        (0.05, 0.1, 0.03), "Uniform +- disturbance of the camera position per episode (m), as the authors'.",
        ge=0,
    )
    rotation_noise: float = doc(
        np.pi / 70, "Uniform +- disturbance of roll, pitch and yaw per episode (rad).",
        ge=0,
    )
    focal_noise: float = doc(0.03, "Relative uniform +- disturbance of fx and fy per episode.", ge=0, lt=1)
    principal_noise: float = doc(4.0, "Uniform +- disturbance of cx and cy per episode (px).", ge=0)
    depth_noise: float = doc(0.0, "Std-dev of Gaussian depth noise (m) per pixel; 0 disables it.", ge=0)
    hole_fraction: float = doc(
        0.0, "Fraction of pixels dropped to NaN at random (sensor holes); 0 disables it.",
        ge=0, lt=1,
    )
    max_range: float = doc(4.5, "Rays longer than this (m) see nothing (NaN), as a Kinect2.", gt=0)

    def check(self) -> None:
        """A focal length must give a depth camera's field of view (pixels, for this image size)."""
        for name, focal, size in (("fx", self.fx, self.width), ("fy", self.fy, self.height)):
            problem = focal_length_problem(name, focal, size)
            if problem is not None:
                raise ConfigRangeError("CameraConfig", name, problem.removeprefix(f"{name} "))


@dataclass(frozen=True)
class GripperConfig(Config):
    """Parallel-jaw gripper on an x, y, z, yaw base; every motion is speed- and force-limited."""

    max_opening: float = doc(0.08, "Maximum distance between the finger pads (m).", gt=0)
    finger_force: float = doc(60.0, "Force limit of each finger's closing actuator (N).", gt=0)
    finger_kp: float = doc(
        2000.0, "Finger position-servo stiffness (N/m); saturates at the force limit.", gt=0
    )
    finger_kv: float = doc(
        200.0,
        "Finger servo damping (N s/m): the fingers close at about finger_kp (q - ctrl) / finger_kv, "
        "0.6 m/s fully open and 0.4 m/s at 2 cm (the force limit caps their acceleration).",
        gt=0,
    )
    finger_armature: float = doc(
        0.4,
        "Reflected inertia of each finger's drive (kg; a screw-driven jaw's motor reflects far more). It "
        "keeps the servo's damping stable when the force limit is reached: MuJoCo then leaves the damping "
        "out of the implicit step, and a bare 30 g finger (kv dt / m = 13 at 2 ms) chatters between "
        "+-finger_force every step, so grasps close differently at each time step. With it kv dt / m < 1 "
        "(benchmarks/RESULTS.md).",
        ge=0,
    )
    pad_friction: float = doc(1.0, "Sliding friction of the finger pads.", ge=0)
    pad_torsional_friction: float = doc(0.02, "Torsional friction of the pads (m), condim 4.", ge=0)
    pad_solref: tuple[float, float] = doc(
        (0.01, 1.0), "Pad contact solref (time constant s, damping ratio): how stiff the grip is."
    )
    pad_solimp: tuple[float, float, float] = doc(
        (0.95, 0.99, 0.001), "Pad contact solimp (dmin, dmax, width): impedance of the grip contacts."
    )
    pad_size: tuple[float, float, float] = doc(
        (0.008, 0.04, 0.03), "Finger pad box (m): thickness along the jaw axis, width, height.",
        gt=0,
    )
    finger_length: float = doc(0.06, "Finger length above the pad (m), up to the palm.", gt=0)
    linear_speed: float = doc(1.0, "Maximum linear speed of the base (m/s).", gt=0)
    accel_time: float = doc(
        0.06, "Time the base takes to ramp up to (and down from) a move's speed (s).", ge=0
    )
    lift_speed: float = doc(0.8, "Speed of the lift after closing (m/s).", gt=0)
    approach_speed: float = doc(0.5, "Speed of the last approach to the grasp (m/s).", gt=0)
    yaw_speed: float = doc(
        9.0, "The wrist's full turning speed (rad/s): the hammer swing runs at it; transports too.",
        gt=0,
    )
    linear_force: float = doc(100.0, "Force limit of each linear base actuator (N).", gt=0)
    yaw_torque: float = doc(
        1.1,
        "Torque limit of the wrist (N m). Kept below peg_friction x the shortest useful lever, so the "
        "motor cannot push the peg home slowly.",
        gt=0,
    )
    linear_kp: float = doc(8000.0, "Stiffness of the linear base servos (N/m).", gt=0)
    linear_kv: float = doc(250.0, "Damping of the linear base servos (N s/m).", ge=0)
    yaw_kp: float = doc(40.0, "Stiffness of the wrist servo (N m/rad).", gt=0)
    yaw_kv: float = doc(0.6, "Damping of the wrist servo (N m s/rad).", ge=0)
    yaw_armature: float = doc(0.002, "Reflected rotor inertia of the wrist (kg m^2).", ge=0)
    hand_mass: float = doc(0.4, "Mass of the hand (palm), kg; gravity-compensated like the whole base.", gt=0)
    approach_height: float = doc(0.05, "The gripper starts this far above the grasp and descends (m).", ge=0)
    close_time: float = doc(0.15, "Time allowed for the fingers to close (s).", gt=0)
    lift_height: float = doc(
        0.2, "Height of the grasp centre after the lift and during transports (m).", ge=0
    )
    min_lift: float = doc(0.15, "The lift raises the grasp by at least this much (m).", ge=0)
    hold_time: float = doc(0.06, "Hold after the lift before checking the grasp (s).", ge=0)
    start_clearance: float = doc(
        0.1, "The transport ends this far above the start pose, then the gripper descends to it (m).",
        ge=0,
    )


@dataclass(frozen=True)
class EpisodeConfig(Config):
    """Execution noise and what counts as success, failure or an invalid episode."""

    grasp_position_noise: float = doc(0.004, "Uniform +- noise on the grasp's x, y (m).", ge=0)
    grasp_height_noise: float = doc(0.002, "Uniform +- noise on the grasp's z (m).", ge=0)
    grasp_yaw_noise: float = doc(np.pi / 60, "Uniform +- noise on the grasp's yaw (rad).", ge=0)
    action_position_noise: float = doc(0.004, "Uniform +- noise on the start position (m).", ge=0)
    action_yaw_noise: float = doc(np.pi / 90, "Uniform +- noise on the start yaw (rad).", ge=0)
    lifted_clearance: float = doc(
        0.01, "S_G needs the tool's lowest point this far above the table (m).", ge=0
    )
    landing_depth: float = doc(
        0.004,
        "On the way down to the grasp, a finger or palm pressing this deep into the object means the "
        "gripper landed on it: the grasp fails there (the arm would stop on contact).",
        ge=0,
    )
    max_penetration: float = doc(0.02, "A contact deeper than this (m) makes the episode invalid.", gt=0)
    prop_moved: float = doc(
        0.001,
        "A task prop (a can, the peg) displaced this far (m) was touched, even when no checked step saw the "
        "contact (contacts are looked at every check_every steps; a 9 rad/s blow can fall between two).",
        ge=0,
    )
    max_speed: float = doc(
        100.0, "Any joint velocity above this (m/s or rad/s) makes the episode invalid.", gt=0
    )
    check_every: int = doc(10, "Contacts and stability are checked every this many steps.", ge=1)


@dataclass(frozen=True)
class RobotConfig(Config):
    """What carries the hand: the floating x, y, z, yaw base (the default, as VGN's), or a real arm beside
    the table (``pip install 'tognet[robot]'``, :mod:`tognet.robot`) carrying the same hand.

    An arm runs the same trial through joint servos: every move of the hand's setpoint is turned into
    joint speeds by resolved-rate inverse kinematics, each capped at its joint's speed limit (the arm then
    falls behind and catches up) and kept inside the joint ranges. Its last joint is the hand's wrist and
    takes the wrist servo of ``SimConfig.gripper`` (its stiffness, torque limit and rotor inertia: a task
    whose tool strikes may rely on the wrist's torque being low) but the arm's own speed limit."""

    name: Literal["floating", "sawyer", "panda"] = doc(  # tognet.robot.names.ROBOT_NAMES
        "floating", "What carries the hand: floating, sawyer or panda."
    )
    base_position: tuple[float, float, float] | None = doc(
        None,
        "The arm's base (m, world frame; the table top is z = 0); None: the arm's default, beside the "
        "table's long side at y > 0, facing it (tognet.robot.names.ARM_BASES).",
    )
    base_yaw: float | None = doc(None, "The arm's base yaw (rad); None: the arm's default (facing -y).")
    park: tuple[float, float, float] = doc(
        (0.3, 0.0, 0.45),
        "Where the hand waits while a scene settles (m, in the base's frame): ahead of the base, to its "
        "left, above it: clear of the object's drop region and of the props.",
    )
    tracking_tolerance: float = doc(
        0.002, "A move has arrived when the joint setpoints put the hand within this (m; rad / 5) of it.",
        gt=0,
    )
    catch_up_time: float = doc(
        1.5,
        "After a move's setpoint has arrived, the arm gets this long (s) to catch up with it: a joint at "
        "its speed limit falls behind; one that cannot arrive at all means a joint limit or out of reach.",
        gt=0,
    )
    joint_margin: float = doc(
        0.01, "The joint setpoints stay this far (rad) inside each joint's range.", ge=0
    )
    damping: float = doc(
        0.02, "Damping of the least-squares inverse kinematics (m): smooth near singular poses.", gt=0
    )
    wrist_weight: float = doc(
        100.0,
        "How much more readily the last joint (the hand's wrist) moves than the others in the inverse "
        "kinematics: a turn of the hand about its vertical axis is then the wrist's alone, as on the "
        "floating base, and the stiff shoulder and elbow do not push a struck peg (tasks' wrist torque).",
        gt=0,
    )
    posture_gain: float = doc(
        0.2,
        "Share of the way back to the trial's first joint configuration the arm's spare degree of "
        "freedom moves each control step (null space): the elbow does not drift.",
        ge=0, le=1,
    )


def _with_task_sections(cls: type) -> type:
    """Add a field per registered task (``TASK_NAMES``, in order) holding its config, default the task's
    defaults: applied before ``@dataclass`` so they are ordinary fields (saved, loaded and replaced like
    the others)."""
    for name in TASK_NAMES:
        kind = task_config_class(name)
        cls.__annotations__[name] = kind
        setattr(cls, name, doc(factory=kind, text=f"The {name} task's set-up ({kind.__name__})."))
    return cls


@dataclass(frozen=True)
@_with_task_sections
class SimConfig(Config):
    """The whole simulated world: physics, table, camera, gripper, episode rules and every task's set-up
    (one section per registered task, named after it: ``config.task_config(name)``)."""

    physics: PhysicsConfig = doc(factory=PhysicsConfig, text="Solver options.")
    world: WorldConfig = doc(factory=WorldConfig, text="Table, ground and object drop.")
    camera: CameraConfig = doc(factory=CameraConfig, text="Overhead depth camera.")
    gripper: GripperConfig = doc(factory=GripperConfig, text="Parallel-jaw gripper and its base.")
    episode: EpisodeConfig = doc(factory=EpisodeConfig, text="Execution noise and episode rules.")
    robot: RobotConfig = doc(
        factory=RobotConfig, text="What carries the hand: the floating base or an arm."
    )

    def task_config(self, name: str) -> Any:
        """The config of the task called ``name`` (a registered task)."""
        return getattr(self, check_task_name(name))

    @property
    def tasks(self) -> Mapping[str, Any]:
        """Every task's config, by task name."""
        return {name: getattr(self, name) for name in TASK_NAMES}


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merge(out[key], value) if isinstance(value, Mapping) and isinstance(out.get(key), dict) \
            else value
    return out


def with_robot(config: SimConfig, name: str) -> SimConfig:
    """``config`` with the hand carried by ``name`` (one of :data:`tognet.robot.names.ROBOT_NAMES`): for an
    arm, its preset (``tognet/robot/presets/<name>.json``) on top.

    An arm's wrist turns slower than the floating base's (``gripper.yaw_speed``: the Sawyer's last joint
    4.545 rad/s, the Panda's 2.61, against 9), and a swing carries energy in proportion to the speed
    squared. The presets scale what a swing works against by that ratio squared (0.255 for the Sawyer,
    0.084 for the Panda): the wrist's torque limit and the struck prop's dry friction. The prop then
    moves as far per unit of the swing's energy as with the floating base, the wrist still cannot push
    it home slowly (torque / lever below the friction, scaled alike), and the grasps that hammer with
    the floating base hammer with the arm (benchmarks/RESULTS.md)."""
    if check_robot_name(name) == FLOATING:
        return config.replace(robot=config.robot.replace(name=FLOATING))
    import json
    from importlib import resources

    text = resources.files("tognet.robot").joinpath("presets", f"{name}.json").read_text()
    return SimConfig.from_dict(_merge(config.to_dict(), json.loads(text)), where=f"robot preset {name}")
