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
