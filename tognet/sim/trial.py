"""The trial: one grasp and one action executed from the settled scene, and its labels.

``execute(grasp, action, seed)`` restores the saved state, so one scene serves many trials, and runs:

1. grasp: the gripper appears ``approach_height`` above the (noisy) grasp, descends (a finger or the
   palm pressing into the object on the way down fails the grasp), closes with a force limit, lifts the
   grasp centre to ``lift_height`` (at least ``min_lift``) and holds. S_G: both fingers touch the tool and
   its lowest point is clear of the table. ``info["in_hand"]`` is the tool's (3, 4) pose in the gripper
   frame after the hold (x = jaw axis), for oracles and diagnostics; ``info["lift_tilt"]`` how far the
   tool's axis that was vertical at rest has tilted by then (rad): a tool held off balance swings in the
   fingers.
2. transport: to ``start_clearance`` above the start pose (task reference + nominal offset + action, yaw
   nominal + a_phi, with noise), then down to it. Touching a prop on the way (a contact: near the props
   every step's contacts are read, through MuJoCo contact sensors; or a prop moved by ``prop_moved``) is
   COLLISION_BEFORE_MOTION; a tool no longer between both fingers is DROPPED.
3. primitive: the task's motion (speed- and force-limited servos, acceleration-limited setpoints), then
   a settling time; the task's rule labels S_T from the values its props measured (the props watch every
   checked step: a can that reaches the ground, say, has done its part and is taken out of the scene, its
   fast impact not simulated). The targets count as touched when a checked
   step saw the contact or when they moved by ``prop_moved``. A failed task with the tool no longer between
   both fingers after the motion and after the settling time is DROPPED (it slipped out during the
   primitive), else the task's reason.

Any NaN, joint speed above ``max_speed`` or contact deeper than ``max_penetration`` (ground contacts
excepted) makes the trial invalid (UNSTABLE), never a success or a failure. Afterwards the world is back
in the settled scene.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.geometry import Grasp
from tognet.robot.arms import ArmStuck
from tognet.sim.arm import GRASP_STEPS, plan_reach, reach_steps, task_steps
from tognet.sim.gripper import GripperControl
from tognet.sim.physics import IS_TARGET, TOOL_SIDE, Landed, SimulationError, Unstable
from tognet.sim.world import BASE_RANGE
from tognet.tasks import FailureReason, Task, TaskOutcome


@dataclass
class TrialResult:
    """Labels of one trial. An invalid trial (unstable physics) is neither a success nor a failure."""

    grasp_success: bool
    task_success: bool
    valid: bool
    failure: FailureReason
    info: dict[str, Any] = field(default_factory=dict)


class Trial(GripperControl):
    """Executing and labelling trials; a part of :class:`tognet.sim.simulator.Simulator`."""

    task: Task | None
    _saved: Any
    _scene: dict[str, Any]
    _grasp_held: bool = False  # the trial's grasp held the tool clear of the table (for an arm's failure)
    _arm_turn: float = 0.0  # an arm's extra whole turn of the wrist to the start yaw (its range needs it)

    def execute(self, grasp: Grasp, action: Any = None, seed: int = 0) -> TrialResult:
        """Run one trial from the settled scene (grasp, lift, transport, primitive) and label it.

        The world is put back in the settled scene afterwards, ready for the next trial.
        """
        if self._saved is None:
            raise SimulationError("call reset(seed) before execute()")
        if self.task is not None:
            action = self.task.check_action(np.zeros(4) if action is None else action)
        self._check_reach(grasp, action)
        mujoco.mj_setState(self.model, self.data, self._saved, self._state_spec)
        self._props.activate()  # props parked by an earlier trial are back in play
        rng = np.random.default_rng([int(self._scene["seed"]), int(seed), 0xE8EC])
        info: dict[str, Any] = {"seed": int(seed), "scene_seed": self._scene["seed"]}
        self._grasp_held = False
        try:
            result = self._execute(grasp, action, rng, info)
        except Unstable as exc:
            info["unstable"] = str(exc)
            result = TrialResult(False, False, False, FailureReason.UNSTABLE, info)
        except ArmStuck as exc:  # only with an arm: where it could not go, after the grasp or before
            info["arm_stuck"] = exc.what
            result = TrialResult(self._grasp_held, False, True, FailureReason(exc.reason), info)
        finally:
            info["sim_time"] = float(self.data.time)
            self._every_step = None
            self._back_to_full_model()
        # Back to the settled scene, so object_pose(), default_grasp() and the next trial see it.
        mujoco.mj_setState(self.model, self.data, self._saved, self._state_spec)
        self._props.activate()
        mujoco.mj_forward(self.model, self.data)
        return result

    def _check_reach(self, grasp: Grasp, action: Any) -> None:
        """ValueError when the grasp (with its approach and lift) or the action's start pose (with its
        clearance) lies outside the travel of the gripper base's joints (``world.BASE_RANGE``). An arm's
        reach is part of the trial (:func:`tognet.sim.arm.plan_reach`): nothing to check here."""
        if self._arm is not None:
            return
        g = self.config.gripper
        margin = 0.05  # room for the execution noise and the servo's overshoot
        points = [("grasp", np.array([grasp.x, grasp.y, grasp.z]), max(g.approach_height, g.min_lift))]
        if self.task is not None:
            start, _ = self.task.start_pose(self._scene["reference"], action)
            points.append(("the action's start pose", start, g.start_clearance))
        for what, p, above in points:
            for axis, (lo, hi), v, up in zip("xyz", BASE_RANGE, p, (0.0, 0.0, above), strict=True):
                if not (lo + margin <= v and v + up <= hi - margin):
                    raise ValueError(
                        f"{what} is out of the gripper's reach: {axis} = {v:.3f} m, the base travels "
                        f"{lo + margin:g} .. {hi - margin - up:g} m along {axis}"
                    )

    def _execute(
        self, grasp: Grasp, action: Any, rng: np.random.Generator, info: dict[str, Any]
    ) -> TrialResult:
        g, e = self.config.gripper, self.config.episode
        pn, hn, yn = e.grasp_position_noise, e.grasp_height_noise, e.grasp_yaw_noise
        pos = grasp.position + rng.uniform([-pn, -pn, -hn], [pn, pn, hn])
        yaw = float(grasp.phi + rng.uniform(-yn, yn))
        min_z = 0.5 * g.pad_size[2] + 0.003
        if pos[2] < min_z:
            info["grasp_z_clamped"] = float(pos[2])
            pos[2] = min_z
        lift_z = max(g.lift_height, pos[2] + g.min_lift)
        q0, stuck = self._arm_start(pos, yaw, action)
        self._set_gripper(pos + np.array([0, 0, g.approach_height]), yaw, g.max_opening, q0)
        mujoco.mj_forward(self.model, self.data)
        props_at_rest = self._props.positions()
        rest_rot = self.object_pose()[1]
        self._props.hold()  # props far from the tool leave the physics until it comes near
        # Approach, close, lift, hold.
        try:
            self._move(pos, None, g.approach_speed, g.yaw_speed, self._watch_landing)
            self._converge(monitor=self._watch_landing)
        except Landed:
            info["landed_on_object"] = True
            return TrialResult(False, False, True, FailureReason.GRASP_FAILED, info)
        self._close_fingers()
        fingers = [self._dadr["finger_l"], self._dadr["finger_r"]]
        closing = {"steps": 0}

        def closed() -> bool:  # both fingers stopped (on the object or fully closed)
            closing["steps"] += 1
            return closing["steps"] >= 3 and bool(np.max(np.abs(self.data.qvel[fingers])) < 0.03)

        self._wait(g.close_time, until=closed)
        self._move(np.array([pos[0], pos[1], lift_z]), None, g.lift_speed, g.yaw_speed)
        self._wait(g.hold_time)
        held = self._held()
        lifted = self._object_clear()
        info["in_hand"] = self._in_hand().tolist()
        info["lift_tilt"] = _tilt(rest_rot, self.object_pose()[1])
        info["object_lift"] = float(self.data.xipos[self._obj_body][2] - self._scene["object_com"][2])
        grasp_ok = held and lifted
        self._grasp_held = grasp_ok
        if not grasp_ok:
            return TrialResult(False, False, True, FailureReason.GRASP_FAILED, info)
        if stuck is not None:
            raise stuck  # the grasp held, but the arm cannot make the task's moves from it
        if self.task is None:
            return TrialResult(True, False, True, FailureReason.NONE, info)
        start, start_yaw = self._start_pose(action, rng, info, min_z)
        return self._transport(start, start_yaw, props_at_rest, info)

    def _arm_start(self, pos: Any, yaw: float, action: Any) -> tuple[Any, ArmStuck | None]:
        """With an arm: its joint angles at the start of the approach, from which it reaches the grasp and
        the rest of the trial (ArmStuck raised when the grasp itself is out of reach; returned when a
        later step is, so that the grasp still runs and S_G is measured). (None, None) without one."""
        self._arm_turn = 0.0
        if self._arm is None:
            return None, None
        reference = self._scene["reference"]
        reach = plan_reach(self.config, self.task, self._arm.solver, pos, yaw, reference, action)
        if reach.stuck is not None and reach.stuck.what in GRASP_STEPS:
            raise reach.stuck  # the grasp itself is out of reach
        self._arm_turn = reach.turn
        return reach.path.q[0], reach.stuck

    def _start_pose(
        self, action: Any, rng: np.random.Generator, info: dict[str, Any], min_z: float
    ) -> tuple[NDArray[np.float64], float]:
        """The motion's start pose (with execution noise) and yaw, the wrist turned to it the short way
        round (an arm: the way its reach check chose); with an arm, checked within reach from here."""
        assert self.task is not None
        e = self.config.episode
        start, start_yaw = self.task.start_pose(self._scene["reference"], action)
        an, ayn = e.action_position_noise, e.action_yaw_noise
        start = start + rng.uniform(-an, an, size=3)
        start_yaw += float(rng.uniform(-ayn, ayn))
        # Turn the wrist the short way round to the start yaw.
        cur_yaw = self._setpoint()[1]
        start_yaw = cur_yaw + (start_yaw - cur_yaw + np.pi) % (2 * np.pi) - np.pi + self._arm_turn
        if start[2] < min_z:  # the arm does not drive the fingertips into the table
            info["start_z_clamped"] = float(start[2])
            start[2] = min_z
        info["start_pose"] = [*map(float, start), float(start_yaw)]
        if self._arm is not None:  # the transport, the start pose and the motion, from where the arm is
            here, here_yaw = self._setpoint()
            steps = [("the lift", here, here_yaw), *task_steps(self.config, self.task, start, start_yaw)]
            tol = self.config.robot.tracking_tolerance
            stuck = reach_steps(self._arm.solver, steps, self._arm.setpoints(self.data), tol).stuck
            if stuck is not None:
                raise stuck
        return start, start_yaw

    def _transport(
        self, start: NDArray[np.float64], start_yaw: float, props_at_rest: Any, info: dict[str, Any]
    ) -> TrialResult:
        """Transport to the start pose, high above the props, then down; then the primitive."""
        g, e = self.config.gripper, self.config.episode
        high = start[2] + g.start_clearance
        hit_before = [False]

        def watch_props() -> None:
            if not hit_before[0] and self.data.sensordata[self._touch].any():
                hit_before[0] = True

        self._every_step = watch_props  # near the props, every step's contacts are looked at
        self._move(np.array([start[0], start[1], high]), start_yaw, g.linear_speed, g.yaw_speed, watch_props)
        if self._arm is not None:  # an arm's slower wrist finishes turning above the props, not among them
            self._converge(monitor=watch_props)
        self._move(start, None, g.linear_speed, g.yaw_speed, watch_props)
        self._converge(monitor=watch_props)
        self._every_step = None
        info["in_hand_start"] = self._in_hand().tolist()  # how the tool hangs at the start pose
        info["prop_shift_before_motion"] = self._prop_shift(props_at_rest)
        if hit_before[0] or info["prop_shift_before_motion"] > e.prop_moved:
            return TrialResult(True, False, True, FailureReason.COLLISION_BEFORE_MOTION, info)
        if not self._held():
            return TrialResult(True, False, True, FailureReason.DROPPED, info)
        return self._primitive(info)

    def _primitive(self, info: dict[str, Any]) -> TrialResult:
        assert self.task is not None
        props = self._props
        props.release()  # the primitive always runs with every prop in play
        props_before = props.positions()
        d, g = self.data, self.config.gripper
        touched = [False]
        watch_props = props.primitive_watch()
        touch = self._pair_table(TOOL_SIDE, IS_TARGET)

        def watch() -> None:
            n = d.ncon
            geoms = d.contact.geom[:n] if n else None
            if geoms is not None and not touched[0] and touch[geoms[:, 0], geoms[:, 1]].any():
                touched[0] = True
            if watch_props is not None:
                watch_props(geoms)

        for motion in self.task.primitive():
            here, here_yaw = self._setpoint()
            target = here + np.asarray(motion.delta)
            yaw = here_yaw + motion.dyaw
            self._move(target, yaw, motion.speed or g.linear_speed, motion.yaw_speed or g.yaw_speed, watch)
        held_after = self._held()
        settle = getattr(self.task.config, "settle_time", 0.2)
        self._wait(settle, watch, until=props.settled())
        values, still = props.outcome()
        # A short blow can fall between two checked steps: a target that moved was touched.
        touched[0] = touched[0] or self._prop_shift(props_before) > self.config.episode.prop_moved
        outcome = TaskOutcome(touched_targets=touched[0], still_moving=still, values=values)
        success, failure = self.task.evaluate(outcome)
        # The finger contacts flicker while the tool strikes or drags: out of the hand means not held at
        # the end of the motion and still not held once everything settled.
        held_settled = self._held()
        if not success and not held_after and not held_settled:
            failure = FailureReason.DROPPED  # the tool slipped out of the fingers during the primitive
        info.update(values)
        info["held_after_primitive"] = held_after
        info["held_after_settling"] = held_settled
        info["touched_targets"] = touched[0]
        return TrialResult(True, success, True, failure, info)

    def _prop_shift(self, before: NDArray[np.float64]) -> float:
        """How far (m) the props moved at most since ``before`` (``TaskProps.positions``); 0 without props."""
        now = self._props.positions()
        return float(np.max(np.linalg.norm(now - before, axis=1))) if len(now) else 0.0


def _tilt(before: NDArray[np.float64], after: NDArray[np.float64]) -> float:
    """The angle (rad) between the world z axis and where the rotation from ``before`` to ``after``
    (object rotations, world frame) takes it: how far the object's upright axis tilted."""
    return float(np.arccos(np.clip((after @ before.T)[2, 2], -1.0, 1.0)))
