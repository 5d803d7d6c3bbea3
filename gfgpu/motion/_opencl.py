"""OpenCL launchers of the motion-blur fused kernels (``motion.cl``), registered by
:mod:`gfgpu.motion.kernels`; specifications: :mod:`gfgpu.motion.spec`."""

from __future__ import annotations

import numpy as np

from ..backends.opencl import launch as ocl
from .spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, MODE_CODES, NARROW, NEAREST_EDGE, PSF_MIN_CELLS


def _setup(be, a):
    """The kernel build's dtype and the position type (double where the device has it)."""
    dtype = np.dtype(a.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    return dtype, pos


def _kernel(be, name, dtype, pos, grid=None, **defines):
    grid = pos if grid is None else grid
    return ocl.kernel(be, __package__, "motion.cl", name, dtype, POS="double" if pos == np.float64 else "float",
                      GRID="double" if grid == np.float64 else "float", GRID_IS_FLOAT=int(grid == np.float32),
                      GREEN_TAIL=repr(float(GREEN_TAIL)), NARROW=repr(float(NARROW)),
                      NEAR_A=repr(NEAREST_EDGE[0]), NEAR_B=repr(NEAREST_EDGE[1]), GAUSS_U0=repr(GAUSS_NODES[0]),
                      GAUSS_W0=repr(GAUSS_WEIGHTS[0]), GAUSS_W1=repr(GAUSS_WEIGHTS[1]),
                      MIN_CELLS_G=PSF_MIN_CELLS[1], MIN_CELLS_CG=PSF_MIN_CELLS[3], PAD=_PAD, **defines)


def _grid(dtype, pos):
    """Positions of the polar resampling: the image's own precision (float32: 1e-7 relative,
    1e-4 px on a ring of radius 1500, far below the spline's own resampling error)."""
    return np.float32 if dtype == np.float32 else pos


def _end_weights(frac):
    """The four tap weights at one end of a fixed-width window (``box_shift`` in motion.cl): the
    partial cell's spline integral over ``[0, frac)`` on ``c[j - 1 .. j + 2]`` plus the telescoped
    whole cells' ``(-1, 12, 1, 0) / 24``."""
    f = float(frac)
    f2, f4, g = f * f, f ** 4, 1.0 - f
    partial = np.array([(1.0 - g ** 4) / 24.0, (0.75 * f4 - 2.0 * f2 * f + 4.0 * f) / 6.0,
                        (-0.75 * f4 + f2 * f + 1.5 * f2 + f) / 6.0, f4 / 24.0])
    return partial + np.array([-1.0, 12.0, 1.0, 0.0]) / 24.0


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
            wa, wb = (_end_weights(x - np.floor(x)) for x in (a0, b0))
            ocl.launch(be, _kernel(be, "box_shift", dtype, pos, **defines), (total,), (1,), inputs, [dst],
                       (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(groups), np.int32(a),
                        np.int32(b), *(dtype.type(w) for w in wa), *(dtype.type(w) for w in wb),
                        dtype.type(1.0 / (b0 - a0)), np.int32(MODE_CODES[mode]), dtype.type(cval),
                        np.int32(total), lbuf, loff))
            return dst
        ocl.launch(be, _kernel(be, "box_vec", dtype, pos, **defines), (total,), (1,), inputs, [dst],
                   (src.data, dbuf, doff, np.int32(n), np.int32(cols), np.int32(groups), pos(a0), pos(a1),
                    pos(b0), pos(b1), np.int32(MODE_CODES[mode]), dtype.type(cval), np.int32(total), lbuf, loff))
        return dst
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    total = bsz * lines
    gsize, lsize = _group(be, total)
    ocl.launch(be, _kernel(be, "box_lines", dtype, pos, LESS=int(less is not None)), (gsize,), (lsize,), inputs, [dst],
               (src.data, dbuf, np.int32(n), np.int32(lines), np.int64(rows * cols), np.int64(line_stride),
                np.int64(step), pos(a0), pos(a1), pos(b0), pos(b1), np.int32(MODE_CODES[mode]), dtype.type(cval),
                np.int32(total), doff, lbuf, loff))
    return dst


def launch_field_blur(be, coef, field, out, psf, density, mode, cval):
    coef, field = ocl.plain(be, coef, "coef"), ocl.plain(be, field, "field")
    obuf, ooff = ocl.written(be, out, "out")
    dtype, pos = _setup(be, coef)
    bsz, h, w = (int(s) for s in coef.shape)
    ocl.launch(be, _kernel(be, "field_blur", dtype, pos), (w, h), None, [coef, field], [out],
               (coef.data, field.data, obuf, np.int32(h), np.int32(w), np.int32(bsz), np.int32(psf), pos(density),
                np.int32(MODE_CODES[mode]), dtype.type(cval), ooff))
    return out


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
                    np.int32(MODE_CODES[mode]), dtype.type(cval)))
        coef, mode, fast = padded, "nearest", {"MODE_Y": MODE_CODES["nearest"], "MODE_X": MODE_CODES["nearest"]}
    else:
        # the modes as build constants where every coefficient read lies within one period of the image
        reach = r0 + n_r + 3
        if (h > 3 and w > 3 and cy - reach >= -(h - 3) and cy + reach <= 2 * h - 4 and cx - reach >= -(w - 3)
                and cx + reach <= 2 * w - 4):
            fast = {"MODE_Y": MODE_CODES[mode], "MODE_X": MODE_CODES[mode]}
    chunk = _CHUNK if be.kind == "cpu" else 1
    ocl.launch(be, _kernel(be, "to_polar", dtype, pos, grid, CHUNK=chunk, **fast), _global((-(-n_phi // chunk), n_r)),
               _LOCAL, [coef, trig], [out],
               (coef.data, obuf, ooff, trig.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), grid(cy), grid(cx), np.int32(r0), np.int32(MODE_CODES[mode]), dtype.type(cval)))
    return out


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, keep=0.0):
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
    fast = {"MODE_Y": MODE_CODES["mirror"], "MODE_X": MODE_CODES["wrap"]} if n_r > 3 and n_phi > 3 else {}
    ocl.launch(be, _kernel(be, "from_polar", dtype, pos, grid, **fast), _global((x1 - x0, y1 - y0)), _LOCAL,
               [pcoef, base], [out],
               (pcoef.data, bbuf, obuf, ooff, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), grid(cy), grid(cx), np.int32(r0), grid(r_lo), grid(reach),
                np.int32(x0), np.int32(y0), np.int32(x1 - x0), np.int32(y1 - y0), boff, grid(keep)))
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
