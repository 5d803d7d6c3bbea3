"""OpenCL launcher of the field kernel (``field.cl``), registered by :mod:`gfgpu.motion.kernels`;
specification: :func:`gfgpu.motion.spec.field_blur_reference`."""

from __future__ import annotations

import math
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
    rule_support,
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

#: work-group of the rule kernel on a CPU device (PoCL): one size for every image, so that a new shape builds
#: nothing (the driver's choice depends on the shape, and each choice is a build of about a second: the first call
#: on a new 1001 x 1503 shape took 1.6-1.8 s, now 0.15 s); as fast as the driver's groups at 2048^2 (A/B in one
#: process: within the noise of a shared machine)
CPU_TILE = (64, 16)

#: work-group of ``pair_rows`` on a CPU device (one work-item a row of pairs; on a GPU one a pair): one build for
#: every shape
CPU_ROWS = 16

#: the rule kernel samples from the coefficients' rows in pairs (``pair_rows`` in ``field.cl``: twice their
#: memory, a window in two loads instead of four) when the coefficients take at most this many bytes
#: (4096^2 float32) with their margin (:func:`margin`), or without it; larger images read the four rows apart
PAIRED_BYTES = 64 << 20


#: the paired rows take a margin (:func:`margin`) while it adds at most this many times the image's pixels (or
#: up to 2^20 pixels in all): a small image with long paths would otherwise pair a large extended image
MARGIN_GROWTH = 4


def margin(psf, reach):
    """Coefficients of the extended image around the paired rows, each side, so that every path of a
    field whose components are at most ``reach`` px lies in them (``None``: no margin): its farthest node
    ``max |t|`` velocities from the pixel (:func:`gfgpu.motion.spec.rule_support`), its window one
    coefficient before and two after, one more for the rounding of the nodes' offsets.  The kernel
    still tests each path against the margin (one beyond it samples node by node)."""
    if reach is None or not reach > 0:
        return 0
    t0, t1 = rule_support(psf)
    return int(math.ceil(float(reach) * max(abs(t0), abs(t1)))) + 4


def _paired(be, coef, real, pad, mode, cval):
    """The coefficients' rows side by side in pairs with a margin of ``pad`` extended coefficients
    (``pair_rows``), a new device array ``(B, H + 2 pad, 2 (W + 2 pad))``."""
    bsz, h, w = (int(s) for s in coef.shape)
    ph, pw = h + 2 * pad, w + 2 * pad
    pairs = be.empty((bsz, ph, 2 * pw), coef.dtype)
    knl = ocl.kernel(be, __package__, "field.cl", "pair_rows", coef.dtype, POS=real, GRID=real, **_constants())
    if be.kind == "cpu":         # a work-item a row, in groups of one size for every shape
        gsize, lsize, chunk = (1, -(-ph // CPU_ROWS) * CPU_ROWS, bsz), (1, CPU_ROWS, 1), pw
    else:                        # a work-item a pair: neighbouring work-items write neighbouring pairs
        gsize, lsize, chunk = (pw, ph, bsz), None, 1
    ocl.launch(be, knl, gsize, lsize, [coef], [pairs],
               (coef.data, pairs.data, np.int32(h), np.int32(w), np.int32(pad), np.int32(boundary.MODE_CODES[mode]),
                coef.dtype.type(cval), np.int32(chunk)))
    return pairs


def launch_field_rule(be, coef, field, out, psf, mode, cval, most=None, reach=None):
    """``reach``: the field's largest component in px (``max |field|``, known to the caller), which sizes the
    paired rows' margin (:func:`margin`); ``None``: no margin (paths across the border sample node by node)."""
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
    pad = margin(psf, reach)
    padded = (h + 2 * pad) * (w + 2 * pad)
    if bsz * padded * dtype.itemsize > PAIRED_BYTES or padded > max(MARGIN_GROWTH * h * w, 1 << 20):
        pad = 0
    pairs = _paired(be, coef, real, pad, mode, cval) if coef.nbytes <= PAIRED_BYTES else coef
    lsize = CPU_TILE if be.kind == "cpu" else GPU_TILE
    gsize = tuple(-(-n // g) * g for n, g in zip((w, h), lsize))
    most = top if most is None else min(max(int(most), first), top)
    ocl.launch(be, knl, gsize, lsize, [coef, pairs, field] + tables, [out],
               (coef.data, pairs.data, np.int32(pairs is not coef), np.int32(pad), fbuf, foff, obuf, np.int32(h),
                np.int32(w), np.int32(bsz), pos(per_px), np.int32(extra), np.int32(first), np.int32(most),
                np.int32(psf in EUCLIDEAN_RULES), tables[0].data, tables[1].data, tables[2].data, tables[3].data,
                np.int32(boundary.MODE_CODES[mode]), dtype.type(cval), ooff))
    return out
