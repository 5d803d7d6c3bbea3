"""OpenCL launchers of the motion-blur fused kernels (``motion.cl``), registered by
:mod:`gfgpu.motion.kernels`; specifications: :mod:`gfgpu.backends.specs_motion`."""

from __future__ import annotations

import numpy as np

from ..specs_motion import GREEN_TAIL, MODE_CODES, NARROW


def _plain(be, a, name):
    """``a`` as this context's C-contiguous array without offset (motion.cl takes plain pointers)."""
    if not be.owns(a):
        raise TypeError(f"{name} must be a pyopencl.array.Array in the context of {be.device}, "
                        f"got {type(a).__name__}")
    return a if a.offset == 0 and a.flags.c_contiguous else a.copy()


def _written(a, name):
    if a.offset != 0 or not a.flags.c_contiguous:
        raise ValueError(f"{name} must be a C-contiguous array without offset")
    return a


def _setup(be, a):
    """The kernel build's dtype and the position type (double where the device has it)."""
    dtype = np.dtype(a.dtype)
    pos = np.float64 if be.supports_float64 else np.float32
    return dtype, pos


def _kernel(be, name, dtype, pos):
    return be._kernel(name, dtype, source="motion.cl", POS="double" if pos == np.float64 else "float",
                      GREEN_TAIL=repr(float(GREEN_TAIL)), NARROW=repr(float(NARROW)))


def _group(be, count):
    g = be._group()
    return -(-count // g) * g, g


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval):
    src = _plain(be, src, "src")
    _written(dst, "dst")
    dtype, pos = _setup(be, src)
    bsz, rows, cols = (int(s) for s in src.shape)
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    total = bsz * lines
    gsize, lsize = _group(be, total)
    be._launch(_kernel(be, "box_lines", dtype, pos), (gsize,), (lsize,), [src], [dst],
               (src.data, dst.data, np.int32(n), np.int32(lines), np.int64(rows * cols), np.int64(line_stride),
                np.int64(step), pos(a0), pos(a1), pos(b0), pos(b1), np.int32(MODE_CODES[mode]), dtype.type(cval),
                np.int32(total)))
    return dst


def launch_field_blur(be, coef, field, out, psf, density, mode, cval):
    coef, field = _plain(be, coef, "coef"), _plain(be, field, "field")
    _written(out, "out")
    dtype, pos = _setup(be, coef)
    bsz, h, w = (int(s) for s in coef.shape)
    be._launch(_kernel(be, "field_blur", dtype, pos), (w, h), None, [coef, field], [out],
               (coef.data, field.data, out.data, np.int32(h), np.int32(w), np.int32(bsz), np.int32(psf), pos(density),
                np.int32(MODE_CODES[mode]), dtype.type(cval)))
    return out


def launch_to_polar(be, coef, out, cy, cx, mode, cval):
    coef = _plain(be, coef, "coef")
    _written(out, "out")
    dtype, pos = _setup(be, coef)
    bsz, h, w = (int(s) for s in coef.shape)
    n_r, n_phi = int(out.shape[1]), int(out.shape[2])
    phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
    trig = be.asarray(np.stack([np.cos(phi), np.sin(phi)], axis=1).astype(pos).reshape(-1))
    be._launch(_kernel(be, "to_polar", dtype, pos), (n_phi, n_r), None, [coef, trig], [out],
               (coef.data, out.data, trig.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), pos(cy), pos(cx), np.int32(MODE_CODES[mode]), dtype.type(cval)))
    return out


def launch_from_polar(be, pcoef, out, cy, cx):
    pcoef = _plain(be, pcoef, "pcoef")
    _written(out, "out")
    dtype, pos = _setup(be, pcoef)
    bsz, n_r, n_phi = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    be._launch(_kernel(be, "from_polar", dtype, pos), (w, h), None, [pcoef], [out],
               (pcoef.data, out.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi), np.int32(bsz),
                pos(cy), pos(cx)))
    return out
