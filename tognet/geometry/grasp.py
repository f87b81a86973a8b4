"""The 4-DoF parallel-jaw grasp g = (x, y, z, phi).

(x, y, z) is the gripper centre (midpoint between the fingertips) in the world frame, metres.
phi is the yaw of the jaw axis, the line through both fingers, measured from the world x axis about
the world z axis, in [0, 2*pi). The gripper always points straight down (perpendicular to the table).
phi and phi + pi close the fingers on the same points but put the gripper frame, and so the tool in
hand, the other way round; the motion primitive's start yaw is relative to this frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap angle(s) into [0, 2*pi)."""
    wrapped = np.mod(np.asarray(angle, dtype=np.float64), 2.0 * np.pi)
    return float(wrapped) if wrapped.ndim == 0 else wrapped


@dataclass(frozen=True)
class Grasp:
    """A top-down parallel-jaw grasp in the world frame (see module docstring)."""

    x: float
    y: float
    z: float
    phi: float

    def as_array(self) -> NDArray[np.float64]:
        """(x, y, z, phi) as a float64 array."""
        return np.array([self.x, self.y, self.z, self.phi], dtype=np.float64)

    @classmethod
    def from_array(cls, values: ArrayLike) -> Grasp:
        """Build from a length-4 sequence (x, y, z, phi); phi is wrapped into [0, 2*pi)."""
        arr = np.asarray(values, dtype=np.float64).reshape(-1)
        if arr.shape != (4,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"a grasp is 4 finite numbers (x, y, z, phi), got {values!r}")
        return cls(float(arr[0]), float(arr[1]), float(arr[2]), float(wrap_angle(arr[3])))

    @property
    def position(self) -> NDArray[np.float64]:
        """Gripper centre (x, y, z)."""
        return np.array([self.x, self.y, self.z])

    @property
    def axis(self) -> NDArray[np.float64]:
        """Unit vector along the jaw axis, in the table plane."""
        return np.array([np.cos(self.phi), np.sin(self.phi), 0.0])


def grasps_to_array(grasps: Iterable[Grasp]) -> NDArray[np.float64]:
    """Stack grasps into an (N, 4) array (an empty list gives shape (0, 4))."""
    rows = [g.as_array() for g in grasps]
    return np.stack(rows) if rows else np.zeros((0, 4))
