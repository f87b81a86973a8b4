"""Inverse kinematics of an arm to a top-down gripper pose (x, y, z, yaw), by mink's differential IK.

The target is tognet's 4-DoF grasp frame (:mod:`tognet.geometry.grasp`): the ``arm_tcp`` site at
(x, y, z), its z axis straight down and its x axis (the jaw axis) at yaw phi from the world x axis.
mink integrates joint velocities that reduce the pose error under the model's joint limits until the
error is within tolerance, from a few seeds (:meth:`ArmIK.seeds`). Where every seed stalls, the same
solve without joint limits tells the failures apart: it does not converge -> the pose is out of the
arm's reach (``unreachable``); it converges to angles that whole turns bring within the ranges -> a
solution the seeds missed, polished within the limits (``reached``); otherwise the pose is reachable
only past a joint limit (``joint_limit``). That last verdict rests on the one unconstrained solution
found from the home configuration: another branch within the limits could exist (a search over more
seeds would tell).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from enum import StrEnum

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from tognet.robot.arms import BASE_BODY, EXTRA_HINT, ArmModel, RobotExtraMissing, assets_dir

try:
    import mink
except ImportError:  # the robot extra is optional
    mink = None


class IKStatus(StrEnum):
    """What an IK solve found (the values are the trial's failure reasons where it fails)."""

    REACHED = "reached"
    UNREACHABLE = "unreachable"
    JOINT_LIMIT = "joint_limit"


@dataclass(frozen=True)
class IKResult:
    """The joint angles an IK solve came closest at (the arm's joints, base to wrist) and how close."""

    status: IKStatus
    q: NDArray[np.float64]
    position_error: float  # m
    angle_error: float  # rad, the rotation between the reached and the target frame
    iterations: int  # integration steps, both solves where the first one failed
    seconds: float

    @property
    def reached(self) -> bool:
        return self.status is IKStatus.REACHED


@dataclass(frozen=True)
class IKSettings:
    """Tolerances and step sizes of the solve."""

    position_tolerance: float = 1e-3  # m
    angle_tolerance: float = 1e-2  # rad
    max_iterations: int = 300
    dt: float = 0.05  # s per integration step (a step's joint change is velocity x dt)
    damping: float = 1e-3  # Levenberg-Marquardt damping of the pose task
    posture_cost: float = 1e-3  # a weak pull towards the seed, to pick a solution near it
    solver: str = "daqp"  # mink's QP back end (installed with mink)
    refine: float = 0.1  # keep iterating until the errors are this fraction of the tolerances


def _require_mink() -> None:
    if mink is None:
        raise RobotExtraMissing(f"mink is not installed: {EXTRA_HINT}")


def require_extra() -> None:
    """RobotExtraMissing (one line, with the install hint) unless the robot extra is installed: robosuite's
    arm models and mink."""
    assets_dir()
    _require_mink()


def grasp_frame(pose: ArrayLike) -> NDArray[np.float64]:
    """The 4x4 world transform of the TCP for a top-down pose (x, y, z, phi)."""
    x, y, z, phi = np.asarray(pose, dtype=np.float64).reshape(4)
    c, s = np.cos(phi), np.sin(phi)
    frame = np.eye(4)
    # x along the jaw axis at yaw phi, z down, y = z cross x.
    frame[:3, 0] = (c, s, 0.0)
    frame[:3, 2] = (0.0, 0.0, -1.0)
    frame[:3, 1] = np.cross(frame[:3, 2], frame[:3, 0])
    frame[:3, 3] = (x, y, z)
    return frame


def tcp_errors(arm: ArmModel, data: mujoco.MjData, target: NDArray[np.float64]) -> tuple[float, float]:
    """Position (m) and rotation angle (rad) between the TCP site (after mj_kinematics) and ``target``."""
    pos = data.site_xpos[arm.tcp_site]
    rot = data.site_xmat[arm.tcp_site].reshape(3, 3)
    rel = target[:3, :3].T @ rot
    angle = float(np.arccos(np.clip(0.5 * (np.trace(rel) - 1.0), -1.0, 1.0)))
    return float(np.linalg.norm(pos - target[:3, 3])), angle


class ArmIK:
    """Differential IK of one compiled arm (reused across solves: the QP set-up is built once)."""

    def __init__(self, arm: ArmModel, settings: IKSettings | None = None) -> None:
        _require_mink()
        self.arm = arm
        self.settings = settings or IKSettings()
        s = self.settings
        model = arm.model
        self._config = mink.Configuration(model)
        self._frame_task = mink.FrameTask(model.site(arm.tcp_site).name, "site", position_cost=1.0,
                                          orientation_cost=1.0, lm_damping=s.damping)
        self._posture = mink.PostureTask(model, cost=s.posture_cost)
        self._limits = [mink.ConfigurationLimit(model)]
        self._freeze = [mink.DofFreezingTask(model, dof_indices=[int(d) for d in arm.finger_dofs])]
        self._fk_data = mujoco.MjData(model)

    def _run(self, target: NDArray[np.float64], q0: NDArray[np.float64],
             limits: list) -> tuple[NDArray[np.float64], float, float, int]:
        """Integrate from ``q0`` until the pose error is ``settings.refine`` times the tolerances, the
        steps stall or the iterations run out; the closest configuration seen (by position error, then
        angle) and its errors."""
        s = self.settings
        self._config.update(q0)
        self._frame_task.set_target(mink.SE3.from_matrix(target))
        self._posture.set_target(q0)
        data = self._config.data
        best = (*tcp_errors(self.arm, data, target), q0.copy())
        it = 0
        while it < s.max_iterations:
            it += 1
            v = mink.solve_ik(self._config, [self._frame_task, self._posture], s.dt, s.solver,
                              damping=1e-12, limits=limits, constraints=self._freeze)
            self._config.integrate_inplace(v, s.dt)
            pos_err, ang_err = tcp_errors(self.arm, data, target)
            if (pos_err / s.position_tolerance + ang_err / s.angle_tolerance
                    < best[0] / s.position_tolerance + best[1] / s.angle_tolerance):
                best = (pos_err, ang_err, self._config.q.copy())
            if pos_err <= s.refine * s.position_tolerance and ang_err <= s.refine * s.angle_tolerance:
                break
            if np.max(np.abs(v)) * s.dt < 1e-7:  # stalled
                break
        return best[2], best[0], best[1], it

    def _fk(self, q: NDArray[np.float64]) -> mujoco.MjData:
        data = self._fk_data
        data.qpos[:] = q
        mujoco.mj_kinematics(self.arm.model, data)
        return data

    def _tcp_yaw(self, q: NDArray[np.float64]) -> float:
        rot = self._fk(q).site_xmat[self.arm.tcp_site].reshape(3, 3)
        return float(np.arctan2(rot[1, 0], rot[0, 0]))

    def seeds(self, pose: ArrayLike, q0: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """Start configurations for a pose: ``q0`` with the first joint turned towards the target and the
        last (the wrist) turned to the target's yaw, each way round that its range allows, the smallest
        turn first. A differential solve from one seed takes the shortest turn of the wrist and can stall
        against its limit where the turn the other way round reaches the pose."""
        arm = self.arm
        x, y, _, phi = np.asarray(pose, dtype=np.float64).reshape(4)
        first, last = arm.qpos_adr[0], arm.qpos_adr[-1]
        (lo0, hi0), (lo7, hi7) = arm.joint_limits[0], arm.joint_limits[-1]
        q = q0.copy()
        data = self._fk(q)
        base = data.xpos[arm.model.body(BASE_BODY).id]
        tcp = data.site_xpos[arm.tcp_site]
        turn = np.arctan2(y - base[1], x - base[0]) - np.arctan2(tcp[1] - base[1], tcp[0] - base[0])
        q[first] = np.clip(q[first] + (turn + np.pi) % (2 * np.pi) - np.pi, lo0, hi0)
        # How the TCP's yaw follows the wrist joint (about -1 or +1 with the hand pointing down).
        step = 1e-3
        probe = q.copy()
        probe[last] += step
        gain = ((self._tcp_yaw(probe) - self._tcp_yaw(q) + np.pi) % (2 * np.pi) - np.pi) / step
        if abs(gain) < 0.5:
            return [q0, q]
        delta = (phi - self._tcp_yaw(q) + np.pi) % (2 * np.pi) - np.pi
        turns = sorted((delta + 2 * np.pi * k for k in range(-2, 3)), key=abs)
        found = [q0]
        for t in turns:
            wrist = q[last] + t / gain
            if lo7 <= wrist <= hi7:
                seed = q.copy()
                seed[last] = wrist
                found.append(seed)
        return found

    def _into_limits(self, q: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """``q`` with each arm joint turned by whole turns into its range (None where one does not fit)."""
        q = q.copy()
        lo, hi = self.arm.joint_limits.T
        angles = q[self.arm.qpos_adr]
        turned = angles - 2 * np.pi * np.ceil((angles - hi) / (2 * np.pi))  # the largest one <= hi
        if np.any(turned < lo):
            return None
        q[self.arm.qpos_adr] = turned
        return q

    def solve(self, pose: ArrayLike, q0: ArrayLike | None = None) -> IKResult:
        """Joint angles that put the TCP at the top-down pose (x, y, z, phi), from ``q0`` (the model's
        full qpos; the arm's home when None) or, where that stalls, from the other :meth:`seeds`."""
        start = time.perf_counter()
        s = self.settings
        target = grasp_frame(pose)
        home = self.arm.home if q0 is None else np.asarray(q0, dtype=np.float64).copy()
        its = 0
        best: tuple[NDArray[np.float64], float, float] | None = None
        for seed in self.seeds(pose, home):
            q, pos_err, ang_err, n = self._run(target, seed, self._limits)
            its += n
            if best is None or (pos_err, ang_err) < best[1:]:
                best = (q, pos_err, ang_err)
            if pos_err <= s.position_tolerance and ang_err <= s.angle_tolerance:
                break
        q, pos_err, ang_err = best
        status = IKStatus.REACHED
        if pos_err > s.position_tolerance or ang_err > s.angle_tolerance:
            # Without joint limits: no solution -> out of reach. A solution whose angles, turned by whole
            # turns, fit the ranges is one the seeds missed: solve again from it, within the limits.
            free_q, free_pos, free_ang, n = self._run(target, home, [])
            its += n
            status = IKStatus.UNREACHABLE
            if free_pos <= s.position_tolerance and free_ang <= s.angle_tolerance:
                status = IKStatus.JOINT_LIMIT
                wrapped = self._into_limits(free_q)
                if wrapped is not None:
                    q2, pos2, ang2, n = self._run(target, wrapped, self._limits)
                    its += n
                    if pos2 <= s.position_tolerance and ang2 <= s.angle_tolerance:
                        q, pos_err, ang_err, status = q2, pos2, ang2, IKStatus.REACHED
        return IKResult(status=status, q=q[self.arm.qpos_adr], position_error=pos_err, angle_error=ang_err,
                        iterations=its, seconds=time.perf_counter() - start)


@dataclass(frozen=True)
class JointPath:
    """Joint waypoints through a sequence of poses and the shortest time each segment can take."""

    status: IKStatus  # REACHED when every pose was, else the first failure's
    failed_at: int | None  # index of the first pose not reached
    q: NDArray[np.float64]  # (n, joints) the waypoints reached (up to the failure)
    min_times: NDArray[np.float64]  # (n - 1,) s: max over joints of |dq| / speed limit per segment
    limiting_joint: NDArray[np.int64]  # (n - 1,) the joint that sets each segment's time

    @property
    def min_duration(self) -> float:
        return float(self.min_times.sum())

    @classmethod
    def timed(cls, status: IKStatus, failed_at: int | None, q: ArrayLike,
              speed_limits: NDArray[np.float64]) -> JointPath:
        """The path through waypoints ``q`` ((n, joints)), each segment's shortest time from the joints'
        ``speed_limits``."""
        q = np.asarray(q, dtype=np.float64).reshape(-1, len(speed_limits))
        per_joint = np.abs(np.diff(q, axis=0)) / speed_limits
        times = per_joint.max(axis=1) if len(per_joint) else np.zeros(0)
        limiting = per_joint.argmax(axis=1) if len(per_joint) else np.zeros(0, dtype=np.int64)
        return cls(status=status, failed_at=failed_at, q=q, min_times=times, limiting_joint=limiting)


def joint_path(ik: ArmIK, poses: ArrayLike, q0: ArrayLike | None = None) -> JointPath:
    """IK through ``poses`` ((n, 4) top-down poses), each solve seeded from the last solution so the arm
    moves continuously; the joints' speed limits give each segment's shortest time. A straight Cartesian
    move is a dense sequence of poses on the line; a wrist turn, poses that only change phi."""
    arm = ik.arm
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 4)
    q_full = arm.home if q0 is None else np.asarray(q0, dtype=np.float64).copy()
    reached: list[NDArray[np.float64]] = []
    status, failed = IKStatus.REACHED, None
    for i, pose in enumerate(poses):
        result = ik.solve(pose, q_full)
        if not result.reached:
            status, failed = result.status, i
            break
        reached.append(result.q)
        q_full = q_full.copy()
        q_full[arm.qpos_adr] = result.q
    return JointPath.timed(status, failed, np.array(reached), arm.joint_speed_limits)
