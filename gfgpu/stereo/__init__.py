"""Dense disparity maps of rectified stereo pairs (chapter §5): :func:`disparity`.

``matching`` holds the methods (census + SGM with Green's-function sub-pixel samples, and the
chapter's G_u / G_U^(2) sweeps); ``kernels`` registers their fused device kernels.
"""

from .matching import METHODS, disparity, disparity_work, fill_holes, random_dot_stereogram, sweep_finish

__all__ = ["METHODS", "disparity", "disparity_work", "fill_holes", "random_dot_stereogram", "sweep_finish"]
