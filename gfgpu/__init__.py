"""gfgpu: image operators from the Green's functions of image-matching equations.

Exact O(N) recursive filters (shift, differentiation, projection, the chapter's G_u, H_u,
G_U^(1), G_U^(2)) and the applications built on them (stereo disparity, edges, shape from
shading, motion blur) on NVIDIA Warp (CPU/CUDA), OpenCL (PoCL/any GPU) or numpy, behind one
API.  Importing gfgpu creates no device context and compiles nothing.  Dask wrappers live in
:mod:`gfgpu.dask` (``import gfgpu.dask``).

Every per-axis tuple is in array-axis order (``..., row, col``), as in scipy.ndimage and
scikit-image: ``shift(img, (dy, dx))``; see ``docs/architecture.md``.
"""

from . import greens
from ._core.strips import get_working_set, set_working_set, working_set
from ._version import __version__
from .backends import BACKENDS, devices, get_backend, use_backend
from .edges import canny
from .filters import derivative, gradient, green_filter, projection, shift
from .greens import AffineGreen, AffineGreenApprox, HomogeneousGreen, UniformGreen
from .motion import estimate_translation, interpolate_frames, motion_blur, synthesize_motion
from .out_of_core import filter_npy
from .shading import estimate_illuminant, photometric_motion, shape_from_shading
from .stereo import disparity

__all__ = [
    "__version__", "greens", "BACKENDS", "devices", "get_backend", "use_backend",
    "green_filter", "shift", "derivative", "projection", "gradient", "canny",
    "UniformGreen", "HomogeneousGreen", "AffineGreen", "AffineGreenApprox",
    "shape_from_shading", "photometric_motion", "estimate_illuminant",
    "motion_blur", "synthesize_motion", "interpolate_frames", "estimate_translation",
    "disparity", "working_set", "set_working_set", "get_working_set", "filter_npy",
]
