"""Pure-numpy geometry: poses, 4-DoF grasps, the pinhole camera model and mesh depth (``raster``).

Imports nothing from tognet.
"""

from tognet.geometry.camera import Camera, CameraIntrinsics, DepthImageError, validate_depth
from tognet.geometry.grasp import Grasp, grasps_to_array, wrap_angle
from tognet.geometry.transforms import (
    invert_pose,
    make_pose,
    mat_to_quat,
    quat_to_mat,
    rot_x,
    rot_y,
    rot_z,
    transform_points,
)

__all__ = [
    "Camera",
    "CameraIntrinsics",
    "DepthImageError",
    "Grasp",
    "grasps_to_array",
    "invert_pose",
    "make_pose",
    "mat_to_quat",
    "quat_to_mat",
    "rot_x",
    "rot_y",
    "rot_z",
    "transform_points",
    "validate_depth",
    "wrap_angle",
]
