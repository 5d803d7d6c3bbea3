"""OpenCL launchers of the motion-blur fused kernels (``motion.cl``), registered by
:mod:`gfgpu.motion.kernels`; specifications: :mod:`gfgpu.motion.spec`."""

from __future__ import annotations

import numpy as np

from .._core import boundary, bspline
from ..backends.opencl import launch as ocl
from .kernels import fixed_width
from .spec import NARROW


def _setup(be, a):
    """The kernel build's dtype and the position type (double where the device has it)."""
    dtype = np.dtype(a.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    return dtype, pos


def _constants():
    """The ``-D`` defines of every motion.cl build: the boundary and spline constants
    (:func:`~gfgpu.backends.opencl.launch.spline_defines`) and the box kernels' ``NARROW``
    (:data:`gfgpu.motion.spec.NARROW`)."""
    return dict(**ocl.spline_defines(), NARROW=repr(float(NARROW)))


def _code(mode):
    """The integer code of boundary ``mode`` that the kernels take (gfgpu._core.boundary.MODE_CODES)."""
    return boundary.MODE_CODES[mode]


def _kernel(be, name, dtype, pos, **defines):
    return ocl.kernel(be, __package__, "motion.cl", name, dtype, POS="double" if pos == np.float64 else "float",
                      **_constants(), **defines)


def _group(be, count):
    g = ocl.group_size(be)
    return -(-count // g) * g, g


#: bytes of one step of a CPU work-item's lines: one cache line (16 floats, 8 doubles), each access
#: a plain unaligned vector access (never a 512-bit vloadn, which PoCL mis-compiles: recurse.cl)
_CACHE_LINE = 64
#: bytes of box_vec's vectors along rows, each gathered element by element across its rows
#: (16 gathered lanes cost more than twice 8: 2.4x slower at 4096^2)
_GATHER_BYTES = 32
#: most vectors of adjacent columns per box_shift work-item (a band of cache lines per row: 4 gave
#: 1.9-2.2x over one at 4096^2, 2 1.6-1.8x; 8 spilled its state and was slower), fewer where
#: every compute unit would not get two bands
_COLUMN_VECS = 4


def _shift_args(dtype, a0, b0):
    """The window's arguments of box_shift and box_shift_lines: its first whole cells ``a``, ``b``,
    the four taps' weights at each end (the partial cell's integral plus the telescoped whole
    cells) and ``1 / width``."""
    a, b = int(np.floor(a0)), int(np.floor(b0))
    wa, wb = (bspline.prefix_weights(x - np.floor(x)) for x in (a0, b0))
    return ((np.int32(a), np.int32(b)) + tuple(dtype.type(w) for w in wa) + tuple(dtype.type(w) for w in wb)
            + (dtype.type(1.0 / (b0 - a0)),))


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval, less=None):
    src = ocl.plain(be, src, "src")
    dbuf, doff = ocl.written(be, dst, "dst")
    # less: read where it lies (it may be dst itself); without it the kernels read nothing
    lbuf, loff = (dbuf, doff) if less is None else ocl.written(be, less, "less")
    dtype, pos = _setup(be, src)
    bsz, rows, cols = (int(s) for s in src.shape)
    inputs = [src] if less is None else [src, less]
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    planes, done = bsz, 0
    if be.kind == "cpu":
        tiled = axis == 1 or fixed_width(a0, a1, b0, b1)
        lanes = (_CACHE_LINE if tiled else _GATHER_BYTES) // dtype.itemsize
        if axis == 2:
            # rows: the B N rows are one run of lines; whole groups of LANES in vector lanes
            planes, lines, done = 1, bsz * rows, (bsz * rows) // lanes * lanes
        else:
            done = cols // lanes * lanes
        if done:
            _box_vectors(be, (src, dbuf, doff, lbuf, loff, inputs, dst), axis, lanes, done // lanes,
                         a0, a1, b0, b1, mode, cval)
    if done < lines:
        # one line per work-item: every line (GPU shapes), or the lines of a partial lane group
        # (a 5-7x cliff when the whole array fell back to box_lines)
        run = lines - done
        total = planes * run
        gsize, lsize = _group(be, total)
        head = (src.data, dbuf, np.int32(n), np.int64(rows * cols), np.int64(line_stride), np.int64(step))
        tail = (np.int32(_code(mode)), dtype.type(cval), np.int32(total), doff, lbuf, loff, np.int32(done),
                np.int32(run))
        if fixed_width(a0, a1, b0, b1):
            ocl.launch(be, _kernel(be, "box_shift_lines", dtype, pos, LESS=int(less is not None)), (gsize,),
                       (lsize,), inputs, [dst], head + _shift_args(dtype, a0, b0) + tail)
        else:
            ocl.launch(be, _kernel(be, "box_lines", dtype, pos, LESS=int(less is not None)), (gsize,), (lsize,),
                       inputs, [dst], head + (pos(a0), pos(a1), pos(b0), pos(b1)) + tail)
    return dst


def _box_vectors(be, bufs, axis, lanes, vecs, a0, a1, b0, b1, mode, cval):
    """box_vec / box_shift on ``vecs`` whole groups of ``lanes`` lines: adjacent columns (axis 1,
    contiguous loads, ``vecs`` per plane; box_shift takes them in bands of ``_COLUMN_VECS``) or
    consecutive rows (axis 2, ``vecs`` in all: box_shift loads tiles of ``lanes`` steps, box_vec
    gathers across the rows)."""
    src, dbuf, doff, lbuf, loff, inputs, dst = bufs
    dtype, pos = _setup(be, src)
    bsz, rows, cols = (int(s) for s in src.shape)
    by_rows = axis == 2
    n = cols if by_rows else rows
    defines = dict(LANES=lanes, ROWS=int(by_rows), LESS=int(len(inputs) > 1))
    if fixed_width(a0, a1, b0, b1):
        units = int(be.cl_device.max_compute_units)
        per = 1 if by_rows else max(1, min(_COLUMN_VECS, (bsz * vecs) // (2 * units)))
        groups = -(-vecs // per)
        total = groups if by_rows else bsz * groups
        ocl.launch(be, _kernel(be, "box_shift", dtype, pos, VECS=per, **defines), (total,), (1,), inputs, [dst],
                   (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(groups))
                   + _shift_args(dtype, a0, b0)
                   + (np.int32(_code(mode)), dtype.type(cval), np.int32(total), lbuf, loff, np.int32(vecs)))
        return
    total = vecs if by_rows else bsz * vecs
    ocl.launch(be, _kernel(be, "box_vec", dtype, pos, **defines), (total,), (1,), inputs, [dst],
               (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(vecs), pos(a0), pos(a1),
                pos(b0), pos(b1), np.int32(_code(mode)), dtype.type(cval), np.int32(total), lbuf, loff))
