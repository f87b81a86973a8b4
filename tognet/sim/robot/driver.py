"""Driving an arm in the simulator's world: the hand's Cartesian setpoint (x, y, z, yaw, pointing down)
turned into joint-servo commands by resolved-rate inverse kinematics.

The simulator moves the hand's setpoint as it moves the floating base's (straight lines with a
trapezoidal speed profile, :mod:`tognet.sim.gripper`); for an arm, every control chunk :meth:`ArmDriver.
command` solves damped least squares on the arm's Jacobian at the joint *setpoints* (the servos'
integrated activations, so the solve does not chase the arm's lag) for the joint speeds that bring the
setpoints onto the hand's setpoint by the chunk's end (the wrist weighted to do the turning alone, as the
floating base's wrist does), then scales them all down until every joint is
within its speed limit (the hand falls behind its setpoint and catches up: the arm's speed, not the
plan's, sets the pace) and stops any joint at the margin of its range. The spare degree of freedom of a
7-joint arm is pulled back towards the trial's first configuration (null space), so the elbow does not
drift. A move whose setpoint cannot be caught up with is the trial's ``unreachable`` or ``joint_limit``
(:class:`tognet.sim.physics.ArmStuck`). The kinematics run on the arm's own small model
(:class:`ArmModel` with the same hand), never on the world's data.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.sim.physics import ArmStuck
from tognet.sim.robot.arms import ArmModel
from tognet.sim.robot.ik import ArmIK, grasp_frame


@dataclass
class Command:
    """What one control chunk asked of the joints and how far the setpoints were from the target."""

    position_error: float  # m, joint setpoints' hand to the target, before the chunk
    angle_error: float  # rad
    slowed: float  # >= 1: the factor the joint speeds were scaled down by to keep within their limits
    pinned: bool  # a joint was stopped at the margin of its range


class ArmDriver:
    """One arm in one compiled world (see the module docstring)."""

    def __init__(self, arm: ArmModel, ik: ArmIK, world: mujoco.MjModel, joint_margin: float,
                 damping: float, posture_gain: float, wrist_weight: float = 1.0) -> None:
        self.arm = arm
        self.ik = ik
        self.margin = joint_margin
        self.damping = damping
        self.posture_gain = posture_gain
        names = arm.joint_names
        self.servos = np.array([world.actuator(f"{j}_servo").id for j in names])
        self.act_adr = np.array([world.actuator_actadr[i] for i in self.servos])
        self.qpos_adr = np.array([world.jnt_qposadr[world.joint(j).id] for j in names])
        self.dof_adr = np.array([world.jnt_dofadr[world.joint(j).id] for j in names])
        lo, hi = arm.joint_limits.T
        self.lo, self.hi = lo + joint_margin, hi - joint_margin
        self.speed = arm.joint_speed_limits
        # How readily each joint moves in the least-squares solve: the wrist (last) ``wrist_weight``
        # times the others, so that a turn of the hand about its axis is the wrist's alone.
        self.weights = np.ones(len(names))
        self.weights[-1] = wrist_weight
        self._kin = mujoco.MjData(arm.model)
        self._jacp = np.zeros((3, arm.model.nv))
        self._jacr = np.zeros((3, arm.model.nv))
        self.posture = np.array(arm.home[arm.qpos_adr])  # set by teleport
        self.base_position = np.zeros(3)  # the arm's base in the world (m), set by its builder

    # --- poses ---------------------------------------------------------------------------------------
    def solve(self, pose: NDArray[np.float64], what: str) -> NDArray[np.float64]:
        """Joint angles for a top-down pose (x, y, z, yaw), from the arm's home; ArmStuck if none."""
        result = self.ik.solve(pose)
        if not result.reached:
            raise ArmStuck(result.status.value, what)
        return result.q

    def hand_pose(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The TCP's position and rotation at joint angles ``q`` (the arm's own model)."""
        kin = self._kin
        kin.qpos[self.arm.qpos_adr] = q
        mujoco.mj_kinematics(self.arm.model, kin)
        site = self.arm.tcp_site
        return kin.site_xpos[site].copy(), kin.site_xmat[site].reshape(3, 3).copy()

    # --- the world's joints ----------------------------------------------------------------------------
    def setpoints(self, data: mujoco.MjData) -> NDArray[np.float64]:
        return data.act[self.act_adr].copy()

    def place(self, data: mujoco.MjData, q: NDArray[np.float64]) -> None:
        """Put the arm at rest at ``q`` (joints and servo setpoints) and make it the trial's posture."""
        data.qpos[self.qpos_adr] = q
        data.qvel[self.dof_adr] = 0.0
        data.act[self.act_adr] = q
        data.ctrl[self.servos] = 0.0
        self.posture = np.array(q, dtype=np.float64)

    def hold(self, data: mujoco.MjData) -> None:
        """Stop the setpoints where they are."""
        data.ctrl[self.servos] = 0.0

    def command(self, data: mujoco.MjData, pos: NDArray[np.float64], yaw: float, horizon: float) -> Command:
        """Set the servos' speeds so that the joint setpoints bring the hand to (``pos``, ``yaw``) in
        ``horizon`` seconds, within every joint's speed limit and range (see the module docstring)."""
        arm, kin = self.arm, self._kin
        q = data.act[self.act_adr]
        kin.qpos[arm.qpos_adr] = q
        mujoco.mj_kinematics(arm.model, kin)
        mujoco.mj_comPos(arm.model, kin)
        site = arm.tcp_site
        mujoco.mj_jacSite(arm.model, kin, self._jacp, self._jacr, site)
        jac = np.vstack([self._jacp[:, arm.dof_adr], self._jacr[:, arm.dof_adr]])
        rot = kin.site_xmat[site].reshape(3, 3)
        goal = grasp_frame((0.0, 0.0, 0.0, yaw))[:3, :3]
        err = np.concatenate([pos - kin.site_xpos[site], 0.5 * np.cross(rot.T, goal.T).sum(axis=0)])
        wj = jac * self.weights  # weighted least squares: J W^-1 with W^-1 = diag(weights)
        jjt = wj @ jac.T + self.damping**2 * np.eye(6)
        dq = wj.T @ np.linalg.solve(jjt, err)
        if self.posture_gain > 0:
            pull = self.posture_gain * (self.posture - q)
            dq += pull - wj.T @ np.linalg.solve(jjt, jac @ pull)
        v = dq / horizon
        slowed = max(1.0, float(np.max(np.abs(v) / self.speed)))
        v /= slowed
        nxt = q + v * horizon
        pinned = bool(np.any((nxt < self.lo) & (v < 0)) or np.any((nxt > self.hi) & (v > 0)))
        if pinned:
            v = (np.clip(nxt, self.lo, np.maximum(self.lo, self.hi)) - q) / horizon
        data.ctrl[self.servos] = v
        return Command(float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:])), slowed, pinned)

    def lag(self, data: mujoco.MjData) -> tuple[float, float]:
        """The largest gap between a joint and its setpoint (rad) and the fastest joint speed (rad/s)."""
        return (float(np.max(np.abs(data.qpos[self.qpos_adr] - data.act[self.act_adr]))),
                float(np.max(np.abs(data.qvel[self.dof_adr]))))
