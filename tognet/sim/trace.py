"""An episode as poses over time: every moving body's pose after each chunk of physics, and the shapes of
its geoms once (for 3-D viewers: ``tognet sim --rerun``). Attach with ``sim.recording(PoseTrace(sim))``.

The bodies kept are those with a geom the camera or a viewer would show: the object (its visual mesh),
the gripper (hand, fingers and an arm's links) and the task's props; the table and the static scenery
are kept once, as shapes at their place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from tognet.sim.groups import GROUP_DECOR, GROUP_GRIPPER, GROUP_OBJECT_VISUAL, GROUP_PROPS, GROUP_STATIC

#: MuJoCo's geom types, by the names a viewer knows.
_KINDS = {int(mujoco.mjtGeom.mjGEOM_BOX): "box", int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
          int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere", int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
          int(mujoco.mjtGeom.mjGEOM_MESH): "mesh", int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): "ellipsoid"}
_SHOWN = (GROUP_STATIC, GROUP_OBJECT_VISUAL, GROUP_GRIPPER, GROUP_PROPS, GROUP_DECOR)


@dataclass(frozen=True)
class Shape:
    """One geom: its body, kind, MuJoCo size, pose in the body (position, quaternion w x y z), colour
    (RGBA 0-1), and for a mesh its vertices (V, 3) and triangles (F, 3) in the geom's frame."""

    body: str
    kind: str
    size: NDArray[np.float64]
    pos: NDArray[np.float64]
    quat: NDArray[np.float64]
    rgba: NDArray[np.float64]
    vertices: NDArray[np.float32] | None = None
    faces: NDArray[np.int32] | None = None


@dataclass
class PoseTrace:
    """Callable recorder of body poses (see the module docstring): ``times`` (s), ``positions`` per body
    (T, 3) and ``quats`` (T, 4, w x y z)."""

    sim: Any
    shapes: list[Shape] = field(default_factory=list)
    bodies: list[str] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    positions: list[NDArray[np.float64]] = field(default_factory=list)
    quats: list[NDArray[np.float64]] = field(default_factory=list)

    def __post_init__(self) -> None:
        m = self.sim.model
        ids: list[int] = []
        for g in range(m.ngeom):
            kind = _KINDS.get(int(m.geom_type[g]))
            if kind is None or int(m.geom_group[g]) not in _SHOWN or m.geom_rgba[g][3] == 0:
                continue
            body = int(m.geom_bodyid[g])
            if body not in ids:
                ids.append(body)
            self.shapes.append(self._shape(m, g, kind))
        self._ids = np.array(ids, dtype=np.intp)
        self.bodies = [m.body(i).name or f"body_{i}" for i in ids]

    @staticmethod
    def _shape(m: mujoco.MjModel, g: int, kind: str) -> Shape:
        body = int(m.geom_bodyid[g])
        verts = faces = None
        if kind == "mesh":
            mesh = int(m.geom_dataid[g])
            v0, nv = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            f0, nf = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
            verts = np.array(m.mesh_vert[v0:v0 + nv], dtype=np.float32)
            faces = np.array(m.mesh_face[f0:f0 + nf], dtype=np.int32)
        return Shape(m.body(body).name or f"body_{body}", kind, np.array(m.geom_size[g], dtype=np.float64),
                     np.array(m.geom_pos[g], dtype=np.float64), np.array(m.geom_quat[g], dtype=np.float64),
                     np.array(m.geom_rgba[g], dtype=np.float64), verts, faces)

    def __call__(self, sim: Any) -> None:
        self.capture(sim.data)

    def capture(self, data: mujoco.MjData) -> None:
        """Keep the bodies' poses now."""
        self.times.append(float(data.time))
        self.positions.append(np.array(data.xpos[self._ids], dtype=np.float64))
        self.quats.append(np.array(data.xquat[self._ids], dtype=np.float64))
