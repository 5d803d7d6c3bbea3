"""OpenCL launcher of the field kernel (``field.cl``), registered by :mod:`gfgpu.motion.kernels`;
specification: :func:`gfgpu.motion.spec.field_blur_reference`."""

from __future__ import annotations

import os

import numpy as np

from ..._core import boundary
from ...backends.opencl import launch as ocl
from ..spec import (
    EUCLIDEAN_RULES,
    GAUSS_NODES,
    GAUSS_WEIGHTS,
    GREEN_TAIL,
    PSF_CODES,
    PSF_MIN_CELLS,
    rule_limits,
    rule_table,
)


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


#: the rule tables on each device, by (context, PSF code, image type, position type): uploaded once
_TABLES = {}
os.register_at_fork(after_in_child=_TABLES.clear)      # a forked child has contexts of its own


def _tables(be, psf, dtype, pos):
    """``[offsets, nodes (positions' type), weights, nodes (image type)]`` of :func:`rule_table` on ``be``."""
    key = (be.context, psf, np.dtype(dtype), np.dtype(pos))
    if key not in _TABLES:
        _, offsets, nodes, weights = rule_table(psf)
        _TABLES[key] = [be.asarray(offsets), be.asarray(nodes.astype(pos)), be.asarray(weights.astype(dtype)),
                        be.asarray(nodes.astype(dtype))]
    return _TABLES[key]


#: work-group of the rule kernel on a GPU: 16 x 16 pixels, whose paths read neighbouring coefficients
GPU_TILE = (16, 16)

#: the rule kernel samples from the coefficients' rows in pairs (``pair_rows`` in ``field.cl``: twice their
#: memory, a window in two loads instead of four) when the coefficients take at most this many bytes
#: (4096^2 float32); larger images read the four rows apart
PAIRED_BYTES = 64 << 20


def _paired(be, coef, real):
    """The coefficients' rows side by side in pairs (``pair_rows``), a new device array."""
    bsz, h, w = (int(s) for s in coef.shape)
    pairs = be.empty((bsz, h, 2 * w), coef.dtype)
    knl = ocl.kernel(be, __package__, "field.cl", "pair_rows", coef.dtype, POS=real, GRID=real, **_constants())
    ocl.launch(be, knl, (w, h, bsz), None, [coef], [pairs], (coef.data, pairs.data, np.int32(h), np.int32(w)))
    return pairs


def launch_field_rule(be, coef, field, out, psf, mode, cval, most=None):
    coef = ocl.plain(be, coef, "coef")
    # the field at an element offset: a host array the device reads in place (host_view) starts at an
    # aligned address below it, and copying its 2 x H x W values would cost a tenth of the kernel
    if not (be.owns(field) and field.flags.c_contiguous):
        field = ocl.plain(be, field, "field")
    fbuf, foff = ocl.written(be, field, "field")
    obuf, ooff = ocl.written(be, out, "out")
    dtype = np.dtype(coef.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    real = "double" if pos == np.float64 else "float"
    knl = ocl.kernel(be, __package__, "field.cl", "field_rule", dtype, POS=real, GRID=real, **_constants())
    first, top, per_px, extra = rule_limits(psf)
    tables = _tables(be, psf, dtype, pos)
    bsz, h, w = (int(s) for s in coef.shape)
    pairs = _paired(be, coef, real) if coef.nbytes <= PAIRED_BYTES else coef
    if be.kind == "cpu":
        gsize, lsize = (w, h), None         # PoCL: the driver's groups (rows of work-items in vector lanes)
    else:
        lsize = GPU_TILE
        gsize = tuple(-(-n // g) * g for n, g in zip((w, h), lsize))
    most = top if most is None else min(max(int(most), first), top)
    ocl.launch(be, knl, gsize, lsize, [coef, pairs, field] + tables, [out],
               (coef.data, pairs.data, np.int32(pairs is not coef), fbuf, foff, obuf, np.int32(h), np.int32(w),
                np.int32(bsz), pos(per_px), np.int32(extra), np.int32(first), np.int32(most),
                np.int32(psf in EUCLIDEAN_RULES), tables[0].data, tables[1].data, tables[2].data, tables[3].data,
                np.int32(boundary.MODE_CODES[mode]), dtype.type(cval), ooff))
    return out
