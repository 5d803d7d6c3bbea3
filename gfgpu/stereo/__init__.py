"""Dense disparity maps of rectified stereo pairs (chapter §5): :func:`disparity`.

``matching`` holds the methods (census + SGM with Green's-function sub-pixel samples, and the
chapter's G_u / G_U^(2) sweeps); ``kernels`` registers their fused device kernels;
``geometry`` turns disparities into depth and point clouds; ``matcher`` holds
:class:`StereoMatcher`, the matcher object for streams of pairs of one size and range.
"""

from .geometry import disparity_to_depth, reproject_to_3d, stereo_q
from .matcher import StereoMatcher
from .matching import (
                       METHODS,
                       default_penalties,
                       disparity,
                       disparity_memory,
                       disparity_work,
                       estimate_max_disparity,
                       fill_holes,
                       random_dot_stereogram,
                       sweep_finish,
)

__all__ = ["METHODS", "StereoMatcher", "default_penalties", "disparity", "disparity_memory", "disparity_work",
           "estimate_max_disparity", "fill_holes", "random_dot_stereogram", "sweep_finish", "disparity_to_depth",
           "reproject_to_3d", "stereo_q"]
