"""Gripper control: teleporting the gripper, moving its setpoints (speed- and acceleration-limited),
waiting for the servos, and reading what the hand holds.

:class:`GripperControl` is a part of :class:`tognet.sim.simulator.Simulator` (it steps through
:meth:`tognet.sim.physics.PhysicsCore._step` and reads the joint addresses the constructor sets).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.geometry.transforms import rot_z
from tognet.sim.physics import FINGER_L, FINGER_R, HAND, OBJECT, TABLE, Landed, PhysicsCore


class GripperControl(PhysicsCore):
    """Setpoints, moves, waits and grip checks (see the module docstring)."""

    _qadr: dict[str, int]
    _dadr: dict[str, int]
    _dt: float
    _vertices: NDArray[np.float64]

    # --- setpoints ------------------------------------------------------------------------------------
    def _set_gripper(self, pos: NDArray[np.float64], yaw: float, opening: float) -> None:
        """Teleport the gripper (joints and setpoints) to a pose, at rest."""
        d = self.data
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
        cur = self.data.act[:4].copy()
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
        for weight in profile:
            self.data.ctrl[:4] = delta * weight
            self._step(every)
            if monitor is not None:
                monitor()  # first: a can that just hit the ground is parked before the stability check
            self._check_stable()
        self.data.ctrl[:4] = 0.0
        self.data.act[:4] = goal  # remove round-off

    def _converge(self, tol: float = 0.002, max_time: float = 0.2, monitor: Any = None) -> None:
        """Let the base catch up with its setpoints (servo lag) until within ``tol`` (m, rad) and slow."""
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
