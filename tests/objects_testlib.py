"""Helpers for the objects tests: drop an object on a plane in MuJoCo and measure how it rests."""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh

from tognet.objects import ObjectRecord


def drop_on_plane(
    record: ObjectRecord, tilt: float = 0.4, height: float = 0.12, seconds: float = 2.0, seed: int = 0
) -> dict[str, float]:
    """Drop the object's MJCF from ``height`` with a random tilt; report its state after ``seconds``."""
    spec = mujoco.MjSpec.from_file(str(record.mjcf_path))
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.0, 1.0, 0.1])
    spec.option.timestep = 0.002
    model = spec.compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(0.0, tilt)
    data.qpos[:3] = [0.0, 0.0, height]
    data.qpos[3:7] = [np.cos(angle / 2), *(np.sin(angle / 2) * axis)]
    mujoco.mj_forward(model, data)
    for _ in range(int(round(seconds / model.opt.timestep))):
        mujoco.mj_step(model, data)
    vertices = np.asarray(trimesh.load(record.path(record.visual_mesh), force="mesh", process=False).vertices)
    body = model.body("object").id
    rotation = data.xmat[body].reshape(3, 3)
    lowest = float((vertices @ rotation.T + data.xpos[body])[:, 2].min())
    return {
        "lowest": lowest,
        "speed": float(np.linalg.norm(data.qvel[:3])),
        "spin": float(np.linalg.norm(data.qvel[3:6])),
        "mass": float(model.body_mass[body]),
        "time": float(data.time),
    }
