"""Gripper control: teleporting the gripper, moving its setpoints (speed- and acceleration-limited),
waiting for the servos, and reading what the hand holds.

The hand's setpoint (x, y, z of the grasp centre, yaw) is the floating base's servo activations
(``data.act[:4]``); with an arm (``SimConfig.robot``) it is kept here and every chunk of a move hands it
to :class:`tognet.robot.driver.ArmDriver`, which turns it into joint-servo speeds.

:class:`GripperControl` is a part of :class:`tognet.sim.simulator.Simulator` (it steps through
:meth:`tognet.sim.physics.PhysicsCore._step` and reads the joint addresses the constructor sets).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry.transforms import rot_z
from tognet.robot.arms import ArmStuck
from tognet.sim.physics import FINGER_L, FINGER_R, HAND, OBJECT, TABLE, Landed, PhysicsCore


class GripperControl(PhysicsCore):
    """Setpoints, moves, waits and grip checks (see the module docstring)."""

    _qadr: dict[str, int]
    _dadr: dict[str, int]
    _dt: float
    _vertices: NDArray[np.float64]
    _arm: Any  # the ArmDriver, or None for the floating base
    _arm_sp: NDArray[np.float64]  # an arm's hand setpoint (x, y, z, yaw)
    _fingers_ctrl: tuple[int, int]  # the finger actuators

    # --- setpoints ------------------------------------------------------------------------------------
    def _setpoint(self) -> tuple[NDArray[np.float64], float]:
        """Where the hand is told to be: the grasp centre's position (a copy) and the yaw."""
        if self._arm is not None:
            return self._arm_sp[:3].copy(), float(self._arm_sp[3])
        return self.data.act[:3].copy(), float(self.data.act[3])

    def _close_fingers(self) -> None:
        a, b = self._fingers_ctrl
        self.data.ctrl[a] = self.data.ctrl[b] = -0.02

    def _set_gripper(
        self, pos: NDArray[np.float64], yaw: float, opening: float, q: NDArray[np.float64] | None = None
    ) -> None:
        """Teleport the gripper (joints and setpoints) to a pose, at rest; an arm to joint angles ``q``
        (solved for the pose when None)."""
        d = self.data
        if self._arm is not None:
            arm = self._arm
            arm.place(d, arm.solve(np.array([*pos, yaw]), "the start of the approach") if q is None else q)
            self._arm_sp = np.array([*pos, yaw], dtype=np.float64)
            half = 0.5 * opening
            for name, ctrl in zip(("finger_l", "finger_r"), self._fingers_ctrl, strict=True):
                d.qpos[self._qadr[name]] = half
                d.qvel[self._dadr[name]] = 0.0
                d.ctrl[ctrl] = half
            return
        for i, name in enumerate(("grip_x", "grip_y", "grip_z")):
            d.qpos[self._qadr[name]] = pos[i]
            d.act[i] = pos[i]
            d.ctrl[i] = 0.0
        d.qpos[self._qadr["grip_yaw"]] = yaw
        d.act[3] = yaw
        d.ctrl[3] = 0.0
        half = 0.5 * opening
        for name, ctrl in (("finger_l", 4), ("finger_r", 5)):
            d.qpos[self._qadr[name]] = half
            d.ctrl[ctrl] = half
        for name in ("grip_x", "grip_y", "grip_z", "grip_yaw", "finger_l", "finger_r"):
            d.qvel[self._dadr[name]] = 0.0

    def _move(
        self,
        target: NDArray[np.float64] | None,
        yaw: float | None,
        speed: float,
        yaw_speed: float,
        monitor: Any = None,
    ) -> None:
        """Move the setpoints in a straight line to ``target`` / ``yaw`` at the given rates."""
        dt = self._dt
        cur = self._arm_sp.copy() if self._arm is not None else self.data.act[:4].copy()
        goal = cur.copy()
        if target is not None:
            goal[:3] = target
        if yaw is not None:
            goal[3] = yaw
        delta = goal - cur
        t_lin = float(np.linalg.norm(delta[:3])) / max(speed, 1e-9)
        t_yaw = abs(float(delta[3])) / max(yaw_speed, 1e-9)
        every = self.config.episode.check_every
        chunk = every * dt
        # Trapezoidal speed profile in chunks: ramps of accel_time at each end (acceleration-limited).
        ramp = max(1, round(self.config.gripper.accel_time / chunk))
        n = max(1, math.ceil(max(t_lin, t_yaw) / chunk - 1e-9)) + ramp
        k = np.arange(n) + 0.5
        profile = np.minimum(1.0, np.minimum(k, n - k) / ramp)
        profile /= profile.sum() * chunk
        if self._arm is not None:
            self._arm_move(cur, delta, profile, chunk, monitor)
            return
        for weight in profile:
            self.data.ctrl[:4] = delta * weight
            self._step(every)
            if monitor is not None:
                monitor()  # first: a can that just hit the ground is parked before the stability check
            self._check_stable()
        self.data.ctrl[:4] = 0.0
        self.data.act[:4] = goal  # remove round-off

    def _arm_move(
        self,
        cur: NDArray[np.float64],
        delta: NDArray[np.float64],
        profile: NDArray[np.float64],
        chunk: float,
        monitor: Any,
    ) -> None:
        """An arm's move: the hand's setpoint follows ``profile`` from ``cur`` by ``delta``, the joint
        setpoints after it within the joints' limits; then they get ``robot.catch_up_time`` to arrive."""
        # self.data is read afresh every chunk: the world without the props is swapped in and out.
        arm, every, r = self._arm, self.config.episode.check_every, self.config.robot
        travelled = np.cumsum(profile) * chunk
        pinned = False
        for k in range(len(profile)):
            self._arm_sp = cur + delta * travelled[k]
            cmd = arm.command(self.data, self._arm_sp[:3], float(self._arm_sp[3]), chunk)
            pinned = cmd.pinned
            self._step(every)
            if monitor is not None:
                monitor()
            self._check_stable()
        goal = cur + delta
        self._arm_sp = goal
        waited, limit = 0.0, r.catch_up_time
        tol = r.tracking_tolerance
        while True:
            cmd = arm.command(self.data, goal[:3], float(goal[3]), chunk)
            if cmd.position_error < tol and cmd.angle_error < 5 * tol:
                break
            pinned = pinned or cmd.pinned
            if waited >= limit:
                arm.hold(self.data)
                reason = "joint_limit" if pinned else "unreachable"
                raise ArmStuck(reason, f"a move: {cmd.position_error * 100:.1f} cm and "
                               f"{np.degrees(cmd.angle_error):.0f} deg from the hand's setpoint")
            self._step(every)
            waited += chunk
            if monitor is not None:
                monitor()
            self._check_stable()
        arm.hold(self.data)

    def _converge(self, tol: float = 0.002, max_time: float = 0.2, monitor: Any = None) -> None:
        """Let the base catch up with its setpoints (servo lag) until within ``tol`` (m, rad) and slow."""
        if self._arm is not None:
            arm = self._arm

            def arrived() -> bool:
                lag, speed = arm.lag(self.data)
                return lag < 0.5 * tol and speed < 0.05

            # The arm's slower wrist catches up later (at the floating base's wrist torque scaled down with
            # its speed squared, tognet.sim.config.with_robot): it gets robot.catch_up_time.
            self._wait(max(max_time, self.config.robot.catch_up_time), monitor, until=arrived)
            return
        q = [self._qadr[n] for n in ("grip_x", "grip_y", "grip_z", "grip_yaw")]
        v = [self._dadr[n] for n in ("grip_x", "grip_y", "grip_z", "grip_yaw")]
        self._wait(
            max_time,
            monitor,
            until=lambda: bool(
                np.max(np.abs(self.data.qpos[q] - self.data.act[:4])) < tol
                and np.max(np.abs(self.data.qvel[v])) < 0.05
            ),
        )

    def _wait(self, duration: float, monitor: Any = None, until: Any = None) -> None:
        every = self.config.episode.check_every
        n = max(1, round(duration / self._dt))
        done = 0
        while done < n:
            k = min(every, n - done)
            self._step(k)
            done += k
            if monitor is not None:
                monitor()
            self._check_stable()
            if until is not None and until():
                return

    # --- what the hand holds --------------------------------------------------------------------------
    def _in_hand(self) -> NDArray[np.float64]:
        """(3, 4) pose [R | t] of the object's body in the gripper frame (x = jaw axis, z up, origin at the
        grasp centre), as it hangs in the hand now."""
        d = self.data
        if self._arm is not None:
            b = self._hand_body
            hrot = d.xmat[b].reshape(3, 3)
            pos, rot = self.object_pose()
            return np.column_stack([hrot.T @ rot, hrot.T @ (pos - d.xpos[b])])
        gpos = np.array([d.qpos[self._qadr[n]] for n in ("grip_x", "grip_y", "grip_z")])
        back = rot_z(-float(d.qpos[self._qadr["grip_yaw"]]))
        pos, rot = self.object_pose()
        return np.column_stack([back @ rot, back @ (pos - gpos)])

    def _watch_landing(self) -> None:
        """During the approach: a finger or the palm pressing into the object means it landed on it."""
        d = self.data
        n = d.ncon
        if not n:
            return
        cats = np.sort(self._cat[d.contact.geom[:n]], axis=1)
        hit = (cats[:, 0] == OBJECT) & HAND[cats[:, 1]]
        if np.any(hit & (d.contact.dist[:n] < -self.config.episode.landing_depth)):
            raise Landed()

    def _held(self) -> bool:
        pairs = self._contacts()
        if not len(pairs):
            return False
        left = np.any((pairs[:, 0] == OBJECT) & (pairs[:, 1] == FINGER_L))
        right = np.any((pairs[:, 0] == OBJECT) & (pairs[:, 1] == FINGER_R))
        return bool(left and right)

    def _object_clear(self) -> bool:
        pairs = self._contacts()
        touching = len(pairs) and np.any((pairs[:, 0] == TABLE) & (pairs[:, 1] == OBJECT))
        pos, rot = self.object_pose()
        lowest = float(np.min(self._vertices @ rot.T[:, 2] + pos[2]))
        return (not touching) and lowest > self.config.episode.lifted_clearance
