"""An arm in the simulator's world (``SimConfig.robot``; the optional ``robot`` extra): its MJCF beside
the table, carrying the simulator's own hand, and the driver that turns the hand's setpoint into joint
commands (:class:`tognet.robot.driver.ArmDriver`).

The arm (robosuite's model files, :mod:`tognet.robot.arms`) stands on a pedestal from the ground to
its base. Its links are the gripper's category for contacts (touching a prop with the elbow is a
collision like touching it with the palm), are seen by no camera, and collide with the world but not
with each other or with the hand they carry. Its last joint is the hand's wrist (see
:class:`tognet.sim.config.RobotConfig`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cache
from typing import Any

import mujoco
import numpy as np

from tognet.robot.arms import ArmStuck
from tognet.sim.config import SimConfig
from tognet.sim.hand import WRIST_DAMPING, hand_body_xml, hand_flange_offset

#: The hand's bodies (tognet.sim.world), none of which collides with the arm carrying it.
HAND_BODIES = ("hand", "finger_l", "finger_r")


def _arm_mjcf(config: SimConfig, hand_body: str, flange_offset: float) -> str:
    from tognet.robot.arms import HandMount, add_servos, arm_spec, arm_xml

    r, g = config.robot, config.gripper
    mount = HandMount(hand_body, flange_offset, arm_spec(r.name).hand_yaw)
    ground = -config.world.table_height
    xml = arm_xml(r.name, r.base_position, r.base_yaw, ground_z=ground, mount=mount)
    wrist = (g.yaw_kp, g.yaw_kv, g.yaw_armature, g.yaw_torque, WRIST_DAMPING)
    return add_servos(xml, r.name, wrist=wrist, gripper=False)


def arm_parts(config: SimConfig, hand_body: str, flange_offset: float, group: int) -> dict[str, list[str]]:
    """The arm's MJCF for the world, by section (``asset``, ``default``, ``worldbody``, ``actuator``,
    ``contact``), each a list of element strings; the hand's body (``hand_body``) on its flange."""
    root = ET.fromstring(_arm_mjcf(config, hand_body, flange_offset))
    hand_names = set(HAND_BODIES)
    arm_bodies = []
    for body in root.iter("body"):
        name = body.get("name", "")
        if name in hand_names:
            continue
        if any(child.tag == "geom" for child in body):
            arm_bodies.append(name)
        for geom in body.findall("geom"):
            geom.set("group", str(group))
            if geom.get("name", "").endswith("pedestal"):
                geom.set("contype", "0")
                geom.set("conaffinity", "1")
            elif geom.get("contype") != "0" or geom.get("conaffinity") != "0":
                geom.set("contype", "2")  # no contact between the arm's own links
                geom.set("conaffinity", "1")
    parts: dict[str, list[str]] = {}
    for tag in ("asset", "default", "worldbody", "actuator", "contact"):
        section = root.find(tag)
        parts[tag] = [ET.tostring(c, encoding="unicode") for c in section] if section is not None else []
    parts["contact"] += [f'<exclude body1="{h}" body2="{a}"/>' for h in HAND_BODIES for a in arm_bodies]
    return parts


@cache
def _kinematic_arm(config: SimConfig, hand_body: str, flange_offset: float) -> Any:
    from tognet.robot.arms import HandMount, arm_spec, load_arm

    r = config.robot
    mount = HandMount(hand_body, flange_offset, arm_spec(r.name).hand_yaw)
    return load_arm(r.name, r.base_position, r.base_yaw, mount=mount)


def arm_solver(config: SimConfig) -> Any:
    """The :class:`~tognet.robot.driver.ArmSolver` of ``config.robot``: the arm alone carrying the
    simulator's hand, its IK and the resolved-rate step the simulator drives it with (built once per
    config and process)."""
    return _solver(config, hand_body_xml(config), hand_flange_offset(config))


@cache
def _solver(config: SimConfig, hand_body: str, flange_offset: float) -> Any:
    from tognet.robot.driver import ArmSolver
    from tognet.robot.ik import ArmIK

    arm = _kinematic_arm(config, hand_body, flange_offset)
    r = config.robot
    return ArmSolver(arm, ArmIK(arm), r.joint_margin, r.damping, r.posture_gain, r.wrist_weight)


def arm_driver(config: SimConfig, world: mujoco.MjModel) -> Any:
    """The :class:`~tognet.robot.driver.ArmDriver` of the arm in the compiled ``world``."""
    from tognet.robot.driver import ArmDriver

    driver = ArmDriver(arm_solver(config), world)
    base = world.body("arm_mount").id
    driver.base_position = np.array(world.body_pos[base], dtype=np.float64)
    w, _, _, z = world.body_quat[base]
    driver.base_yaw = float(2.0 * np.arctan2(z, w))
    return driver


# --- reach: every pose a trial asks of the arm ------------------------------------------------------------
#: A pose of the hand a trial needs: (what it is for, grasp-centre position (3,), yaw).
Step = tuple[str, Any, float]
#: The steps of a trial that belong to the grasp (out of reach there: S_G fails too).
GRASP_STEPS = ("the approach", "the grasp", "the lift")


@dataclass(frozen=True)
class Reach:
    """Whether an arm reaches a trial's steps: the joint path (``tognet.robot.ik.JointPath``, up to
    the first step out of reach), the ArmStuck naming that step (None: every step reached) and the extra
    whole turn of the wrist to the start yaw that the path takes."""

    steps: list[Step]
    path: Any
    stuck: ArmStuck | None
    turn: float = 0.0


def task_steps(config: SimConfig, task: Any, start: Any, start_yaw: float) -> list[Step]:
    """The hand's poses from the transport to the end of the task's motion (``task.primitive()``)."""
    high = start[2] + config.gripper.start_clearance
    steps: list[Step] = [("the transport", np.array([start[0], start[1], high]), start_yaw),
                         ("the start pose", np.asarray(start, dtype=np.float64), start_yaw)]
    end, end_yaw = np.array(start, dtype=np.float64), start_yaw
    for motion in task.primitive():
        end, end_yaw = end + np.asarray(motion.delta), end_yaw + motion.dyaw
        steps.append(("the motion", end.copy(), end_yaw))
    return steps


def trial_steps(config: SimConfig, task: Any, pos: Any, yaw: float, reference: Any, action: Any,
                turn: float = 0.0) -> list[Step]:
    """Every pose of a trial the arm must reach, in order: the grasp's (:data:`GRASP_STEPS`), then, with
    a task, the task's (the start pose as planned, without execution noise; the wrist turned to the start
    yaw the short way round plus ``turn``)."""
    g = config.gripper
    pos = np.asarray(pos, dtype=np.float64)
    lift_z = max(g.lift_height, pos[2] + g.min_lift)
    steps: list[Step] = [("the approach", pos + np.array([0, 0, g.approach_height]), yaw),
                         ("the grasp", pos, yaw), ("the lift", np.array([pos[0], pos[1], lift_z]), yaw)]
    if task is not None:
        start, start_yaw = task.start_pose(reference, action)
        start_yaw = yaw + (start_yaw - yaw + np.pi) % (2 * np.pi) - np.pi + turn
        start[2] = max(start[2], 0.5 * g.pad_size[2] + 0.003)
        steps += task_steps(config, task, start, start_yaw)
    return steps


def reach_steps(solver: Any, steps: list[Step], q: Any = None, tolerance: float = 0.002) -> Reach:
    """Whether the arm follows ``steps`` as the simulator drives it: IK for the first step (from the arm's
    joints ``q``, or when None from each start the IK tries: its wrist turned either way round, since the
    wrist's range has to hold every turn the trial makes), then a dry run of the straight moves between
    the steps (:meth:`~tognet.robot.driver.ArmSolver.dry_run`); the start that gets furthest. The
    path's times are the joints' speed limits' (``JointPath.min_times``)."""
    from tognet.robot.ik import IKStatus, JointPath

    arm = solver.arm
    poses = [(np.asarray(p, dtype=np.float64), float(yaw)) for _, p, yaw in steps]
    first = np.array([*poses[0][0], poses[0][1]])
    # The IK result from the arm's home (the first seed): why no start reached the first step, if none did.
    first_result: list[Any] = []

    def starts() -> Any:  # lazily: most trials need the first only
        if q is not None:
            yield np.asarray(q, dtype=np.float64)
            return
        tried: list[Any] = []
        for seed in solver.ik.seeds(first, arm.home):
            result = solver.ik.solve(first, seed)
            if not first_result:
                first_result.append(result)
            if result.reached and not any(np.allclose(result.q, t, atol=1e-2) for t in tried):
                tried.append(result.q)
                yield result.q

    best: tuple[list[Any], int | None, str] | None = None
    for start in starts():
        run = solver.dry_run(start, poses, tolerance)
        if run[1] is None:
            best = run
            break
        if best is None or run[1] > (best[1] or 0):
            best = run
    if best is None:  # no IK solution for the first step
        status = first_result[0].status if first_result else solver.ik.solve(first).status
        path = JointPath.timed(status, 0, np.zeros((0, len(arm.qpos_adr))), arm.joint_speed_limits)
        return Reach(steps, path, ArmStuck(status.value, steps[0][0]))
    qs, failed, reason = best
    status = IKStatus.REACHED if failed is None else IKStatus(reason)
    path = JointPath.timed(status, failed, np.array(qs), arm.joint_speed_limits)
    return Reach(steps, path, None if failed is None else ArmStuck(reason, steps[failed][0]))


def plan_reach(config: SimConfig, task: Any, solver: Any, pos: Any, yaw: float, reference: Any,
               action: Any) -> Reach:
    """Whether the arm reaches every pose of a trial (:func:`trial_steps`), turning its wrist to the
    task's start yaw the short way round or, where the wrist's range does not allow it, the long way;
    the first that reaches everything, else the one that got furthest."""
    best: Reach | None = None
    for turn in (0.0, 2 * np.pi, -2 * np.pi) if task is not None else (0.0,):
        reach = reach_steps(solver, trial_steps(config, task, pos, yaw, reference, action, turn),
                            tolerance=config.robot.tracking_tolerance)
        reach = Reach(reach.steps, reach.path, reach.stuck, turn)
        if reach.stuck is None:
            return reach
        if best is None or len(reach.path.q) > len(best.path.q):
            best = reach
    assert best is not None
    return best
