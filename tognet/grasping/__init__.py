"""Grasp candidates from depth images: antipodal sampling, aligned crops, NMS and the cross-entropy method.

Pure numpy/scipy image and geometry code (torch only for batched bilinear sampling); no simulator.
Prepare an image once with :func:`prepare_depth` and pass the :class:`DepthScene` to both
:func:`sample_antipodal` and :func:`extract_crops` to validate and fill holes only once.
"""

from tognet.grasping.antipodal import AntipodalConfig, GraspCandidates, grasp_depths, sample_antipodal
from tognet.grasping.cem import CEMConfig, CEMResult, GaussianMixture, ScoreFn, cem, fit_gmm
from tognet.grasping.crops import CropConfig, center_crops, crop_grid, extract_crops
from tognet.grasping.depth import DepthScene, fill_holes, height_map, load_depth_file, prepare_depth
from tognet.grasping.nms import NMSConfig, angle_difference, grasp_distances, nms

__all__ = [
    "AntipodalConfig",
    "CEMConfig",
    "CEMResult",
    "CropConfig",
    "DepthScene",
    "GaussianMixture",
    "GraspCandidates",
    "NMSConfig",
    "ScoreFn",
    "angle_difference",
    "cem",
    "center_crops",
    "crop_grid",
    "extract_crops",
    "fill_holes",
    "fit_gmm",
    "grasp_depths",
    "grasp_distances",
    "height_map",
    "load_depth_file",
    "nms",
    "prepare_depth",
    "sample_antipodal",
]
