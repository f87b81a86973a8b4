"""Grasp candidates from depth images: antipodal sampling, aligned crops, NMS and the cross-entropy method.

Pure numpy/scipy image and geometry code (torch only for batched bilinear sampling); no simulator.
Prepare an image once with :func:`prepare_depth` and pass the :class:`DepthScene` to both
:func:`sample_antipodal` and :func:`extract_crops` to validate and fill holes only once::

    scene = prepare_depth(depth, camera)
    cands = sample_antipodal(scene, None, AntipodalConfig(), rng)        # up to 200, maybe 0
    crops = extract_crops(scene, None, cands.grasps, CropConfig())       # (N, 64, 64) metres
    z = grasp_depths(camera, cands.grasps)                               # (N,) network z input
    modes = nms(cands.grasps, cands.quality, NMSConfig())                # exploration grasps

    def score_fn(g):                                                     # any (M, 4) -> (M,)
        c = extract_crops(scene, None, g, CropConfig())
        return net(c, center_crops(c), grasp_depths(camera, g))
    best = cem(score_fn, cands.grasps, CEMConfig(), rng).best           # needs >= 1 initial grasp

No candidates (an empty table, an object wider than the opening) is an explicit empty result all the
way through: ``sample_antipodal`` returns an empty :class:`GraspCandidates` (``len() == 0``, arrays of
shape (0, 4), (0, 2), ...), ``extract_crops`` of 0 grasps gives (0, 64, 64), ``grasp_depths`` (0,),
``nms`` an empty index array. ``cem`` has nothing to start from and raises ValueError ("cem needs
initial grasps of shape (N >= 1, 4)"), so check ``len(cands)`` first. Bad images (wrong shape or
dtype, millimetres, all holes) raise :class:`tognet.geometry.DepthImageError` naming the problem.
"""

from typing import TYPE_CHECKING

# Imported now: these functions share their modules' names, and a lazy name would lose to the module
# once anything imports it (both are light).
from tognet.grasping.cem import CEMConfig, CEMResult, GaussianMixture, ScoreFn, cem, fit_gmm
from tognet.grasping.nms import NMSConfig, angle_difference, grasp_distances, nms
from tognet.lazy_names import lazy_names

if TYPE_CHECKING:  # the names below, for type checkers; at run time they load on first use
    from tognet.grasping.antipodal import AntipodalConfig, GraspCandidates, grasp_depths, sample_antipodal
    from tognet.grasping.crops import CropConfig, center_crops, crop_grid, extract_crops
    from tognet.grasping.depth import DepthScene, fill_holes, height_map, load_depth_file, prepare_depth

# name -> the module that defines it; loaded on first use (tognet.lazy_names).
_WHERE = {
    "AntipodalConfig": "tognet.grasping.antipodal",
    "GraspCandidates": "tognet.grasping.antipodal",
    "grasp_depths": "tognet.grasping.antipodal",
    "sample_antipodal": "tognet.grasping.antipodal",
    "CropConfig": "tognet.grasping.crops",
    "center_crops": "tognet.grasping.crops",
    "crop_grid": "tognet.grasping.crops",
    "extract_crops": "tognet.grasping.crops",
    "DepthScene": "tognet.grasping.depth",
    "fill_holes": "tognet.grasping.depth",
    "height_map": "tognet.grasping.depth",
    "load_depth_file": "tognet.grasping.depth",
    "prepare_depth": "tognet.grasping.depth",
}


__getattr__, __dir__ = lazy_names(__name__, _WHERE)


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
