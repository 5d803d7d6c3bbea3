"""gfgpu: image operators from the Green's functions of image-matching equations.

Exact O(N) recursive filters (shift, differentiation, projection, the chapter's G_u, H_u,
G_U^(1), G_U^(2)) on NVIDIA Warp (CPU/CUDA), OpenCL (PoCL/any GPU) or numpy, behind one API.
Importing gfgpu creates no device context and compiles nothing.  Dask wrappers live in
:mod:`gfgpu.dask` (``import gfgpu.dask``); images larger than memory in :mod:`gfgpu.strips`.
"""

from . import greens
from .backends import BACKENDS, devices, get_backend, use_backend
from .edges import canny
from .filters import derivative, gradient, green_filter, projection, shift
from .greens import AffineGreen, AffineGreenApprox, HomogeneousGreen, UniformGreen
from .motion import estimate_translation, interpolate_frames, motion_blur, synthesize_motion
from .shading import estimate_illuminant, photometric_motion, shape_from_shading
from .stereo import disparity
from .strips import filter_npy, get_working_set, set_working_set, working_set

__version__ = "0.1.0"

__all__ = [
    "greens", "BACKENDS", "devices", "get_backend", "use_backend",
    "green_filter", "shift", "derivative", "projection", "gradient", "canny",
    "UniformGreen", "HomogeneousGreen", "AffineGreen", "AffineGreenApprox",
    "shape_from_shading", "photometric_motion", "estimate_illuminant",
    "motion_blur", "synthesize_motion", "interpolate_frames", "estimate_translation",
    "disparity", "working_set", "set_working_set", "get_working_set", "filter_npy",
]
