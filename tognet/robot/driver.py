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
(:class:`tognet.robot.arms.ArmStuck`). The kinematics run on the arm's own small model
(:class:`ArmModel` with the same hand), never on the world's data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.robot.arms import ArmModel, ArmStuck
from tognet.robot.ik import ArmIK


@dataclass
class Command:
    """What one control chunk asked of the joints and how far the setpoints were from the target."""

    position_error: float  # m, joint setpoints' hand to the target, before the chunk
    angle_error: float  # rad
    slowed: float  # >= 1: the factor the joint speeds were scaled down by to keep within their limits
    pinned: bool  # a joint was stopped at the margin of its range


class ArmSolver:
    """The arm's kinematics (its own small model, the same hand) and the resolved-rate step both the
    world's driver and the dry run of a trial's moves (:meth:`dry_run`) take."""

    def __init__(self, arm: ArmModel, ik: ArmIK, joint_margin: float, damping: float, posture_gain: float,
                 wrist_weight: float = 1.0) -> None:
        self.arm = arm
        self.ik = ik
        self.damping = damping
        self.posture_gain = posture_gain
        lo, hi = arm.joint_limits.T
        self.lo, self.hi = lo + joint_margin, hi - joint_margin
        self.speed = arm.joint_speed_limits
        # How readily each joint moves in the least-squares solve: the wrist (last) ``wrist_weight``
        # times the others, so that a turn of the hand about its axis is the wrist's alone.
        self.weights = np.ones(len(arm.joint_names))
        self.weights[-1] = wrist_weight
        self._kin = mujoco.MjData(arm.model)
        self._jacp = np.zeros((3, arm.model.nv))
        self._jacr = np.zeros((3, arm.model.nv))
        self.posture = np.array(arm.home[arm.qpos_adr])  # the trial's first configuration
        self._damping_eye = damping**2 * np.eye(6)

    def solve(self, pose: NDArray[np.float64], what: str) -> NDArray[np.float64]:
        """Joint angles for a top-down pose (x, y, z, yaw), from the arm's home; ArmStuck if none."""
        result = self.ik.solve(pose)
        if not result.reached:
            raise ArmStuck(result.status.value, what)
        return result.q

    def hand_pose(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The TCP's position and rotation at joint angles ``q``."""
        kin = self._kin
        kin.qpos[self.arm.qpos_adr] = q
        mujoco.mj_kinematics(self.arm.model, kin)
        site = self.arm.tcp_site
        return kin.site_xpos[site].copy(), kin.site_xmat[site].reshape(3, 3).copy()

    def step(self, q: NDArray[np.float64], pos: NDArray[np.float64],
             yaw: float) -> tuple[NDArray[np.float64], float, float]:
        """The joint change that brings the hand from where ``q`` puts it towards (``pos``, ``yaw``): damped,
        weighted least squares, with the spare freedom pulled back towards :attr:`posture`; and the
        position (m) and angle (rad) still to go."""
        arm, kin = self.arm, self._kin
        kin.qpos[arm.qpos_adr] = q
        mujoco.mj_kinematics(arm.model, kin)
        mujoco.mj_comPos(arm.model, kin)
        site = arm.tcp_site
        mujoco.mj_jacSite(arm.model, kin, self._jacp, self._jacr, site)
        jac = np.vstack([self._jacp[:, arm.dof_adr], self._jacr[:, arm.dof_adr]])
        rot = kin.site_xmat[site].reshape(3, 3)
        c, s = math.cos(yaw), math.sin(yaw)
        goal = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])  # grasp_frame's axes as columns
        # Orientation error 0.5 * sum_i r_i x g_i (columns of the current and the goal rotation): the axial
        # vector of G R^T - R G^T.
        skew = goal @ rot.T
        skew -= skew.T
        err = np.empty(6)
        err[:3] = pos - kin.site_xpos[site]
        err[3:] = 0.5 * skew[2, 1], 0.5 * skew[0, 2], 0.5 * skew[1, 0]
        wj = jac * self.weights  # weighted least squares: J W^-1 with W^-1 = diag(weights)
        jjt = wj @ jac.T + self._damping_eye
        if self.posture_gain > 0:
            pull = self.posture_gain * (self.posture - q)
            sol = np.linalg.solve(jjt, np.column_stack([err, jac @ pull]))
            dq = wj.T @ (sol[:, 0] - sol[:, 1]) + pull
        else:
            dq = wj.T @ np.linalg.solve(jjt, err)
        return dq, float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))

    def dry_run(self, q: NDArray[np.float64], poses: list[tuple[NDArray[np.float64], float]],
                tolerance: float, max_step: float = 0.02, max_turn: float = 0.1,
                iterations: int = 60) -> tuple[list[NDArray[np.float64]], int | None, str]:
        """The trial's moves without physics: from ``q`` (which puts the hand at ``poses[0]``) along the
        straight line to each next pose, in steps of at most ``max_step`` m / ``max_turn`` rad, as the
        world's servos follow them (the same step, within the joint ranges), then up to ``iterations``
        steps to arrive within ``tolerance`` (m; rad / 5). Returns the joint angles at each pose reached,
        the index of the first pose not reached (None: all) and why ("joint_limit" when a joint stopped
        at its range on the way, else "unreachable")."""
        saved = self.posture
        self.posture = np.array(q, dtype=np.float64)
        q = self.posture.copy()
        reached = [q.copy()]
        try:
            for i in range(1, len(poses)):
                (p0, y0), (p1, y1) = poses[i - 1], poses[i]
                n = max(1, math.ceil(max(float(np.linalg.norm(p1 - p0)) / max_step, abs(y1 - y0) / max_turn)))
                pinned = False
                for k in range(1, n + 1):
                    dq, _, _ = self.step(q, p0 + (p1 - p0) * (k / n), y0 + (y1 - y0) * (k / n))
                    q, hit = self._clip(q + dq)
                    pinned = pinned or hit
                for _ in range(iterations):
                    dq, ep, ea = self.step(q, p1, y1)
                    if ep < tolerance and ea < 5 * tolerance:
                        break
                    q, hit = self._clip(q + dq)
                    pinned = pinned or hit
                else:
                    return reached, i, "joint_limit" if pinned else "unreachable"
                reached.append(q.copy())
            return reached, None, ""
        finally:
            self.posture = saved

    def _clip(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], bool]:
        clipped = np.clip(q, self.lo, np.maximum(self.lo, self.hi))
        return clipped, bool(np.any(clipped != q))


class ArmDriver:
    """One arm in one compiled world (see the module docstring)."""

    def __init__(self, solver: ArmSolver, world: mujoco.MjModel) -> None:
        self.solver = solver
        self.arm = solver.arm
        self.ik = solver.ik
        names = self.arm.joint_names
        self.servos = np.array([world.actuator(f"{j}_servo").id for j in names])
        self.act_adr = np.array([world.actuator_actadr[i] for i in self.servos])
        self.qpos_adr = np.array([world.jnt_qposadr[world.joint(j).id] for j in names])
        self.dof_adr = np.array([world.jnt_dofadr[world.joint(j).id] for j in names])
        self.base_position = np.zeros(3)  # the arm's base in the world (m), set by its builder
        self.base_yaw = 0.0  # and its yaw (rad)

    def solve(self, pose: NDArray[np.float64], what: str) -> NDArray[np.float64]:
        """Joint angles for a top-down pose (x, y, z, yaw), from the arm's home; ArmStuck if none."""
        return self.solver.solve(pose, what)

    # --- the world's joints ----------------------------------------------------------------------------
    def setpoints(self, data: mujoco.MjData) -> NDArray[np.float64]:
        return data.act[self.act_adr].copy()

    def place(self, data: mujoco.MjData, q: NDArray[np.float64]) -> None:
        """Put the arm at rest at ``q`` (joints and servo setpoints) and make it the trial's posture."""
        data.qpos[self.qpos_adr] = q
        data.qvel[self.dof_adr] = 0.0
        data.act[self.act_adr] = q
        data.ctrl[self.servos] = 0.0
        self.solver.posture = np.array(q, dtype=np.float64)

    def hold(self, data: mujoco.MjData) -> None:
        """Stop the setpoints where they are."""
        data.ctrl[self.servos] = 0.0

    def command(self, data: mujoco.MjData, pos: NDArray[np.float64], yaw: float, horizon: float) -> Command:
        """Set the servos' speeds so that the joint setpoints bring the hand to (``pos``, ``yaw``) in
        ``horizon`` seconds, within every joint's speed limit and range (see the module docstring)."""
        solver = self.solver
        q = data.act[self.act_adr]
        dq, ep, ea = solver.step(q, pos, yaw)
        v = dq / horizon
        slowed = max(1.0, float(np.max(np.abs(v) / solver.speed)))
        v /= slowed
        nxt = q + v * horizon
        pinned = bool(np.any((nxt < solver.lo) & (v < 0)) or np.any((nxt > solver.hi) & (v > 0)))
        if pinned:
            v = (np.clip(nxt, solver.lo, np.maximum(solver.lo, solver.hi)) - q) / horizon
        data.ctrl[self.servos] = v
        return Command(ep, ea, slowed, pinned)

    def lag(self, data: mujoco.MjData) -> tuple[float, float]:
        """The largest gap between a joint and its setpoint (rad) and the fastest joint speed (rad/s)."""
        return (float(np.max(np.abs(data.qpos[self.qpos_adr] - data.act[self.act_adr]))),
                float(np.max(np.abs(data.qvel[self.dof_adr]))))
