"""gfgpu: image operators from the Green's functions of image-matching equations.

Exact O(N) recursive filters (shift, differentiation, projection, the chapter's G_u, H_u,
G_U^(1), G_U^(2)) and the applications built on them (stereo disparity, edges, shape from
shading, motion blur) on NVIDIA Warp (CPU/CUDA), OpenCL (PoCL/any GPU) or numpy, behind one
API.  Importing gfgpu creates no device context and compiles nothing.  Dask wrappers live in
:mod:`gfgpu.dask` (``import gfgpu.dask``).

Every per-axis tuple is in array-axis order (``..., row, col``), as in scipy.ndimage and
scikit-image: ``shift(img, (dy, dx))``; see ``docs/architecture.md``.
"""

# The public names are loaded on first use (PEP 562): ``import gfgpu`` (and so the ``gfgpu``
# command's start and ``--help``) does not pay for numpy, scipy and every operator's module.
# ``gfgpu.shift``, ``from gfgpu import shift``, ``from gfgpu import *`` and ``dir(gfgpu)`` are as
# with eager imports; a name is added here and to ``__all__`` together (tests/test_api.py checks).

import importlib as _importlib

from ._version import __version__

#: the module of each public name (``greens`` is the module itself)
_SOURCES = {
    "greens": ("greens", None),
    "working_set": ("_core.strips", "working_set"),
    "set_working_set": ("_core.strips", "set_working_set"),
    "get_working_set": ("_core.strips", "get_working_set"),
    "BACKENDS": ("backends", "BACKENDS"),
    "devices": ("backends", "devices"),
    "get_backend": ("backends", "get_backend"),
    "use_backend": ("backends", "use_backend"),
    "canny": ("edges", "canny"),
    "derivative": ("filters", "derivative"),
    "gradient": ("filters", "gradient"),
    "green_filter": ("filters", "green_filter"),
    "projection": ("filters", "projection"),
    "shift": ("filters", "shift"),
    "AffineGreen": ("greens", "AffineGreen"),
    "AffineGreenApprox": ("greens", "AffineGreenApprox"),
    "HomogeneousGreen": ("greens", "HomogeneousGreen"),
    "UniformGreen": ("greens", "UniformGreen"),
    "estimate_translation": ("motion", "estimate_translation"),
    "interpolate_frames": ("motion", "interpolate_frames"),
    "motion_blur": ("motion", "motion_blur"),
    "synthesize_motion": ("motion", "synthesize_motion"),
    "filter_npy": ("out_of_core", "filter_npy"),
    "estimate_illuminant": ("shading", "estimate_illuminant"),
    "photometric_motion": ("shading", "photometric_motion"),
    "shape_from_shading": ("shading", "shape_from_shading"),
    "StereoMatcher": ("stereo", "StereoMatcher"),
    "disparity": ("stereo", "disparity"),
}

#: the subpackages an eager ``import gfgpu`` used to leave as attributes (``gfgpu.io`` after
#: ``import gfgpu``); ``gfgpu.cli``, ``gfgpu.batch`` and ``gfgpu.dask`` are imported by name
_SUBMODULES = ("_core", "_version", "backends", "edges", "filters", "greens", "io", "motion", "out_of_core",
               "shading", "stereo")

__all__ = [
    "__version__", "greens", "BACKENDS", "devices", "get_backend", "use_backend",
    "green_filter", "shift", "derivative", "projection", "gradient", "canny",
    "UniformGreen", "HomogeneousGreen", "AffineGreen", "AffineGreenApprox",
    "shape_from_shading", "photometric_motion", "estimate_illuminant",
    "motion_blur", "synthesize_motion", "interpolate_frames", "estimate_translation",
    "disparity", "StereoMatcher", "working_set", "set_working_set", "get_working_set", "filter_npy",
]


def __getattr__(name):
    """A public name or subpackage, imported on first access and then kept in the module."""
    if name in _SOURCES:
        module, attribute = _SOURCES[name]
        value = _importlib.import_module(f".{module}", __name__)
        if attribute is not None:
            value = getattr(value, attribute)
    elif name in _SUBMODULES:
        value = _importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


#: this module's lazy-loading machinery, left out of ``dir(gfgpu)`` (which lists what eager imports listed)
_MACHINERY = frozenset({"_importlib", "_SOURCES", "_SUBMODULES", "_MACHINERY", "__getattr__", "__dir__"})


def __dir__():
    return sorted((set(globals()) - _MACHINERY) | set(__all__) | set(_SUBMODULES))
