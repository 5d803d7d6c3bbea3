"""OpenCL launchers of the motion-blur fused kernels (``motion.cl``), registered by
:mod:`gfgpu.motion.kernels`; specifications: :mod:`gfgpu.motion.spec`."""

from __future__ import annotations

import numpy as np

from .._core import boundary, bspline
from ..backends.opencl import launch as ocl
from .spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, NARROW, PSF_CODES, PSF_MIN_CELLS


def _setup(be, a):
    """The kernel build's dtype and the position type (double where the device has it)."""
    dtype = np.dtype(a.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    return dtype, pos


def _constants():
    """The ``-D`` defines of every motion.cl build that carry constants of the Python definitions:
    the mode codes (:mod:`gfgpu._core.boundary`), the spline's pole and edge weights
    (:mod:`gfgpu._core.bspline`), the PSF codes and quadrature (:mod:`gfgpu.motion.spec`).  Read at
    each build, so the kernels cannot drift from them (the same values every call: one build)."""
    green, centred = PSF_CODES["green", True], PSF_CODES["green", False]
    near_a, near_b = bspline.NEAREST_EDGE
    return dict(
        **{f"MODE_{name.upper()}": code for name, code in boundary.MODE_CODES.items()},
        PSF_BOX=PSF_CODES["box", True], PSF_GREEN=green, PSF_BOX_CENTRED=PSF_CODES["box", False],
        PSF_GREEN_CENTRED=centred, MIN_CELLS_G=PSF_MIN_CELLS[green], MIN_CELLS_CG=PSF_MIN_CELLS[centred],
        SPLINE_POLE=repr(float(bspline.SPLINE_POLE)), NEAR_A=repr(float(near_a)), NEAR_B=repr(float(near_b)),
        GREEN_TAIL=repr(float(GREEN_TAIL)), NARROW=repr(float(NARROW)),
        **{f"GAUSS_U{i}": repr(float(u)) for i, u in enumerate(GAUSS_NODES)},
        **{f"GAUSS_W{i}": repr(float(g)) for i, g in enumerate(GAUSS_WEIGHTS)})


def _code(mode):
    """The integer code of boundary ``mode`` that the kernels take (gfgpu._core.boundary.MODE_CODES)."""
    return boundary.MODE_CODES[mode]


def _kernel(be, name, dtype, pos, grid=None, **defines):
    grid = pos if grid is None else grid
    return ocl.kernel(be, __package__, "motion.cl", name, dtype, POS="double" if pos == np.float64 else "float",
                      GRID="double" if grid == np.float64 else "float", GRID_IS_FLOAT=int(grid == np.float32),
                      PAD=_PAD, **_constants(), **defines)


def _grid(dtype, pos):
    """Positions of the polar resampling: the image's own precision (float32: 1e-7 relative,
    1e-4 px on a ring of radius 1500, far below the spline's own resampling error)."""
    return np.float32 if dtype == np.float32 else pos


def _global(size):
    """The global size rounded up to whole work-groups of ``_LOCAL`` (the kernels check bounds)."""
    if _LOCAL is None:
        return size
    return tuple(-(-n // g) * g for n, g in zip(size, _LOCAL))


def _group(be, count):
    g = ocl.group_size(be)
    return -(-count // g) * g, g


#: bytes of one vector step of the column kernels (AVX2: 8 floats, 4 doubles; PoCL mis-compiles
#: 512-bit vloadn, see recurse.cl)
_VECTOR_BYTES = 32

#: work-group size of the polar resampling kernels (None: the driver's choice)
_LOCAL = None

#: angles per work-item of to_polar on a CPU
_CHUNK = 16

#: coefficients that to_polar materialises beyond every border in 'constant' and 'nearest' mode
#: (read clamped beyond them: the extension to z^32, below 1e-18)
_PAD = 32


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval, less=None):
    src = ocl.plain(be, src, "src")
    dbuf, doff = ocl.written(be, dst, "dst")
    # less: read where it lies (it may be dst itself); without it the kernels read nothing
    lbuf, loff = (dbuf, doff) if less is None else ocl.written(be, less, "less")
    dtype, pos = _setup(be, src)
    bsz, rows, cols = (int(s) for s in src.shape)
    lanes = _VECTOR_BYTES // dtype.itemsize
    by_rows = axis == 2 and (bsz * rows) % lanes == 0
    inputs = [src] if less is None else [src, less]
    if be.kind == "cpu" and (by_rows or (axis == 1 and cols % lanes == 0)):
        # LANES lines per work-item in vector lanes (the window is the same on every line):
        # adjacent columns (contiguous loads) or consecutive rows (loads gathered across them)
        total = bsz * rows // lanes if by_rows else bsz * (cols // lanes)
        groups = total if by_rows else cols // lanes
        n = cols if by_rows else rows
        defines = dict(LANES=lanes, ROWS=int(by_rows), LESS=int(less is not None))
        if a1 == 1.0 and b1 == 1.0 and b0 - a0 >= NARROW:
            a, b = int(np.floor(a0)), int(np.floor(b0))
            # the taps at each end of the window: the partial cell's integral plus the telescoped
            # whole cells (box_shift in motion.cl)
            wa, wb = (bspline.prefix_weights(x - np.floor(x)) for x in (a0, b0))
            ocl.launch(be, _kernel(be, "box_shift", dtype, pos, **defines), (total,), (1,), inputs, [dst],
                       (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(groups), np.int32(a),
                        np.int32(b), *(dtype.type(w) for w in wa), *(dtype.type(w) for w in wb),
                        dtype.type(1.0 / (b0 - a0)), np.int32(_code(mode)), dtype.type(cval),
                        np.int32(total), lbuf, loff))
            return dst
        ocl.launch(be, _kernel(be, "box_vec", dtype, pos, **defines), (total,), (1,), inputs, [dst],
                   (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(groups), pos(a0), pos(a1),
                    pos(b0), pos(b1), np.int32(_code(mode)), dtype.type(cval), np.int32(total), lbuf, loff))
        return dst
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    total = bsz * lines
    gsize, lsize = _group(be, total)
    ocl.launch(be, _kernel(be, "box_lines", dtype, pos, LESS=int(less is not None)), (gsize,), (lsize,), inputs, [dst],
               (src.data, dbuf, np.int32(n), np.int32(lines), np.int64(rows * cols), np.int64(line_stride),
                np.int64(step), pos(a0), pos(a1), pos(b0), pos(b1), np.int32(_code(mode)), dtype.type(cval),
                np.int32(total), doff, lbuf, loff))
    return dst


def launch_to_polar(be, coef, out, cy, cx, r0, mode, cval):
    coef = ocl.plain(be, coef, "coef")
    obuf, ooff = ocl.written(be, out, "out")
    dtype, pos = _setup(be, coef)
    grid = _grid(dtype, pos)
    bsz, h, w = (int(s) for s in coef.shape)
    n_r, n_phi = int(out.shape[1]), int(out.shape[2])
    phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
    trig = be.asarray(np.stack([np.cos(phi), np.sin(phi)], axis=1).astype(grid).reshape(-1))
    fast = {}
    if mode in ("constant", "nearest"):
        # the extension materialised _PAD coefficients beyond every border, then read clamped
        h, w, cy, cx = h + 2 * _PAD, w + 2 * _PAD, cy + _PAD, cx + _PAD
        padded = be.empty((bsz, h, w), dtype)
        ocl.launch(be, _kernel(be, "pad_coef", dtype, pos), _global((w, h)), _LOCAL, [coef], [padded],
                   (coef.data, padded.data, np.int32(h - 2 * _PAD), np.int32(w - 2 * _PAD), np.int32(bsz),
                    np.int32(_code(mode)), dtype.type(cval)))
        coef, mode, fast = padded, "nearest", {"MODE_Y": _code("nearest"), "MODE_X": _code("nearest")}
    else:
        # the modes as build constants where every coefficient read lies within one period of the image
        reach = r0 + n_r + 3
        if (h > 3 and w > 3 and cy - reach >= -(h - 3) and cy + reach <= 2 * h - 4 and cx - reach >= -(w - 3)
                and cx + reach <= 2 * w - 4):
            fast = {"MODE_Y": _code(mode), "MODE_X": _code(mode)}
    chunk = _CHUNK if be.kind == "cpu" else 1
    ocl.launch(be, _kernel(be, "to_polar", dtype, pos, grid, CHUNK=chunk, **fast), _global((-(-n_phi // chunk), n_r)),
               _LOCAL, [coef, trig], [out],
               (coef.data, obuf, ooff, trig.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), grid(cy), grid(cx), np.int32(r0), np.int32(_code(mode)), dtype.type(cval)))
    return out


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None):
    pcoef = ocl.plain(be, pcoef, "pcoef")
    obuf, ooff = ocl.written(be, out, "out")
    bbuf, boff = ocl.written(be, base, "base")      # base may be out
    dtype, pos = _setup(be, pcoef)
    grid = _grid(dtype, pos)
    bsz, n_r, n_phi = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    x0, y0, x1, y1 = 0, 0, w, h
    reach = min(float(r_hi), 4.0 * (h + w))     # beyond every pixel: the centre lies within 2 diagonals
    if bbuf == obuf and boff == ooff:       # in place: only the pixels within r_hi of the centre change
        x0, y0 = max(0, int(np.floor(cx - reach))), max(0, int(np.floor(cy - reach)))
        x1, y1 = min(w, int(np.ceil(cx + reach)) + 1), min(h, int(np.ceil(cy + reach)) + 1)
        if x1 <= x0 or y1 <= y0:
            return out
    # radius within the band's rings (mirrored at their ends), angle within one turn: always near
    fast = {"MODE_Y": _code("mirror"), "MODE_X": _code("wrap")} if n_r > 3 and n_phi > 3 else {}
    weights = be.asarray(np.ascontiguousarray(np.ones(1) if wcoef is None else wcoef, dtype))
    ocl.launch(be, _kernel(be, "from_polar", dtype, pos, grid, **fast), _global((x1 - x0, y1 - y0)), _LOCAL,
               [pcoef, base, weights], [out],
               (pcoef.data, bbuf, obuf, ooff, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), grid(cy), grid(cx), np.int32(r0), grid(r_lo), grid(reach),
                np.int32(x0), np.int32(y0), np.int32(x1 - x0), np.int32(y1 - y0), boff, weights.data,
                np.int32(wcoef is not None)))
    return out


def launch_add_rows(be, src, dst, scale):
    sbuf, soff = ocl.written(be, src, "src")        # src may be dst
    dbuf, doff = ocl.written(be, dst, "dst")
    dtype, pos = _setup(be, dst)
    bsz, n, m = (int(s) for s in dst.shape)
    weights = be.asarray(np.ascontiguousarray(scale, dtype))
    ocl.launch(be, _kernel(be, "add_rows", dtype, pos), _global((m, bsz * n)), _LOCAL, [src, weights], [dst],
               (sbuf, dbuf, doff, weights.data, np.int32(n), np.int32(m), np.int32(bsz * n), soff))
    return dst
