"""Joint control of an arm with servos (:func:`tognet.robot.arms.add_servos`): following a joint path
at the speeds its joints allow, then waiting for the servos to catch up.

Each segment of a :class:`tognet.robot.ik.JointPath` is run in ``slack`` times its shortest time, the
servos' setpoints moving at constant joint speeds (within the speed limits, which are also the servos'
control ranges); the arm lags its setpoints by about kv v / kp while it moves and catches up after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.robot.arms import ArmModel
from tognet.robot.ik import JointPath


@dataclass(frozen=True)
class Tracking:
    """How a path was followed."""

    move_time: float  # s, the setpoints' motion
    settle_time: float  # s, waiting for the joints to catch up
    max_lag: float  # rad, the largest joint-setpoint gap during the motion
    final_error: float  # rad, the largest joint-setpoint gap at the end
    max_speed_ratio: float  # the fastest joint speed seen over its speed limit


def servo_ids(arm: ArmModel, model: mujoco.MjModel) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The arm joints' servo actuator ids and their activation (setpoint) addresses in ``model``."""
    ids = np.array([model.actuator(f"{j}_servo").id for j in arm.joint_names])
    return ids, np.array([model.actuator_actadr[i] for i in ids])


def set_joints(arm: ArmModel, model: mujoco.MjModel, data: mujoco.MjData, q: NDArray[np.float64]) -> None:
    """Put the arm at rest at joint angles ``q``, its servos' setpoints there too."""
    ids, act = servo_ids(arm, model)
    qadr = [model.jnt_qposadr[model.joint(j).id] for j in arm.joint_names]
    dadr = [model.jnt_dofadr[model.joint(j).id] for j in arm.joint_names]
    data.qpos[qadr] = q
    data.qvel[dadr] = 0.0
    data.act[act] = q
    data.ctrl[ids] = 0.0
    mujoco.mj_forward(model, data)


def follow(arm: ArmModel, model: mujoco.MjModel, data: mujoco.MjData, path: JointPath, slack: float = 1.25,
           tolerance: float = 1e-3, max_settle: float = 0.5) -> Tracking:
    """Drive the servos through ``path``'s waypoints (from where the setpoints are), then wait until every
    joint is within ``tolerance`` (rad) of its setpoint or ``max_settle`` (s) has passed."""
    ids, act = servo_ids(arm, model)
    qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in arm.joint_names])
    dadr = np.array([model.jnt_dofadr[model.joint(j).id] for j in arm.joint_names])
    dt = model.opt.timestep
    lag, speed, moved = 0.0, 0.0, 0
    for k in range(len(path.q) - 1):
        n = max(1, math.ceil(slack * path.min_times[k] / dt - 1e-9))
        data.ctrl[ids] = (path.q[k + 1] - path.q[k]) / (n * dt)
        for _ in range(n):
            mujoco.mj_step(model, data)
            lag = max(lag, float(np.max(np.abs(data.qpos[qadr] - data.act[act]))))
            speed = max(speed, float(np.max(np.abs(data.qvel[dadr]) / arm.joint_speed_limits)))
        moved += n
        data.act[act] = path.q[k + 1]  # remove round-off
    data.ctrl[ids] = 0.0
    waited = 0
    while waited * dt < max_settle:
        error = float(np.max(np.abs(data.qpos[qadr] - data.act[act])))
        if error < tolerance:
            break
        mujoco.mj_step(model, data)
        waited += 1
    final = float(np.max(np.abs(data.qpos[qadr] - data.act[act])))
    return Tracking(move_time=moved * dt, settle_time=waited * dt, max_lag=lag, final_error=final,
                    max_speed_ratio=speed)
