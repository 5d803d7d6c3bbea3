"""OpenCL launcher of the field kernel (``field.cl``), registered by :mod:`gfgpu.motion.kernels`;
specification: :func:`gfgpu.motion.spec.field_blur_reference`."""

from __future__ import annotations

import numpy as np

from ..._core import boundary
from ...backends.opencl import launch as ocl
from ..spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, PSF_CODES, PSF_MIN_CELLS


def _constants():
    """The ``-D`` defines that carry constants of the Python definitions (read at each build, so
    the kernel cannot drift from them; the same values every call: one build)."""
    green, centred = PSF_CODES["green", True], PSF_CODES["green", False]
    return dict(
        **ocl.spline_defines(), PSF_BOX=PSF_CODES["box", True], PSF_GREEN=green,
        PSF_BOX_CENTRED=PSF_CODES["box", False],
        PSF_GREEN_CENTRED=centred, MIN_CELLS_G=PSF_MIN_CELLS[green], MIN_CELLS_CG=PSF_MIN_CELLS[centred],
        GREEN_TAIL=repr(float(GREEN_TAIL)),
        **{f"GAUSS_U{i}": repr(float(u)) for i, u in enumerate(GAUSS_NODES)},
        **{f"GAUSS_W{i}": repr(float(g)) for i, g in enumerate(GAUSS_WEIGHTS)})


def launch_field_blur(be, coef, field, out, psf, density, mode, cval, most=0):
    coef, field = ocl.plain(be, coef, "coef"), ocl.plain(be, field, "field")
    obuf, ooff = ocl.written(be, out, "out")
    dtype = np.dtype(coef.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    real = "double" if pos == np.float64 else "float"
    knl = ocl.kernel(be, __package__, "field.cl", "field_blur", dtype, POS=real, GRID=real, **_constants())
    bsz, h, w = (int(s) for s in coef.shape)
    ocl.launch(be, knl, (w, h), None, [coef, field], [out],
               (coef.data, field.data, obuf, np.int32(h), np.int32(w), np.int32(bsz), np.int32(psf), pos(density),
                np.int32(boundary.MODE_CODES[mode]), dtype.type(cval), ooff, np.int32(most)))
    return out
