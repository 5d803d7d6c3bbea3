"""Warp kernels of motion blur: box windows along lines, per-pixel paths, polar resampling.

Executable specification: :mod:`gfgpu.backends.specs_motion`; the OpenCL twins are in
``backends/opencl/motion.cl``; :mod:`gfgpu.motion.kernels` registers the ``launch_*`` functions
at the end.  Written for GPUs: one thread per line (box windows) or per output sample, arrays
passed flat with explicit strides.  Positions and weights are float64 (a ring of 10^4 samples
needs more than float32's 24 bits to place a sample to 1e-4 px); samples are accumulated in
the image's own type.
"""



from typing import Any

import numpy as np
import warp as wp

from ..specs_motion import GREEN_TAIL, MODE_CODES, NARROW, SPLINE_POLE

wp.set_module_options({"enable_backward": False})

_Z = wp.constant(wp.float64(SPLINE_POLE))
_TAIL = wp.constant(wp.float64(GREEN_TAIL))
_NARROW = wp.constant(wp.float64(NARROW))
_TWO_PI = wp.constant(wp.float64(2.0 * np.pi))


@wp.func
def _extend(i: int, n: int, mode: int):
    """Index of sample ``i`` of a line of ``n`` extended by ``mode`` (-1: cval); specs_motion.extend_index."""
    if mode == 0:
        if i < 0 or i >= n:
            return -1
        return i
    if mode == 1:
        return wp.clamp(i, 0, n - 1)
    if mode == 2:
        r = i % n
        if r < 0:
            r = r + n
        return r
    if mode == 3:
        q = i % (2 * n)
        if q < 0:
            q = q + 2 * n
        if q >= n:
            q = 2 * n - 1 - q
        return q
    if n == 1:
        return 0
    q = i % (2 * n - 2)
    if q < 0:
        q = q + 2 * n - 2
    if q >= n:
        q = 2 * n - 2 - q
    return q


@wp.func
def _coef_index(i: int, n: int, mode: int):
    """``(index, factor)`` of spline coefficient ``i`` (specs_motion._spline_index)."""
    if mode == 0:
        j = wp.clamp(i, 0, n - 1)
        m = wp.abs(i - j)
        f = wp.float64(1.0)
        for _k in range(m):
            f = f * _Z
        return j, f
    return _extend(i, n, mode), wp.float64(1.0)


@wp.func
def _coef(src: wp.array(dtype=Any), start: int, step: int, n: int, i: int, mode: int, cval: Any):
    """Coefficient ``i`` of the line at ``start`` (stride ``step``), extended by ``mode``."""
    j, f = _coef_index(i, n, mode)
    if mode == 0:
        return cval + src.dtype(f) * (src[start + j * step] - cval)
    return src[start + j * step]


@wp.func
def _weight(t: wp.float64, p: int):
    """Cubic B-spline weight of offset ``p - 1`` for the fraction ``t``."""
    g = wp.float64(1.0) - t
    if p == 0:
        return g * g * g / wp.float64(6.0)
    if p == 1:
        return (wp.float64(3.0) * t * t * t - wp.float64(6.0) * t * t + wp.float64(4.0)) / wp.float64(6.0)
    if p == 2:
        return (wp.float64(3.0) * g * g * g - wp.float64(6.0) * g * g + wp.float64(4.0)) / wp.float64(6.0)
    return t * t * t / wp.float64(6.0)


@wp.func
def _weight_integral(f: wp.float64, p: int):
    """``∫_0^f`` of the weight of offset ``p - 1`` (specs_motion._bspline_integrals)."""
    f2 = f * f
    f4 = f2 * f2
    if p == 0:
        g = wp.float64(1.0) - f
        return (wp.float64(1.0) - g * g * g * g) / wp.float64(24.0)
    if p == 1:
        return (wp.float64(0.75) * f4 - wp.float64(2.0) * f2 * f + wp.float64(4.0) * f) / wp.float64(6.0)
    if p == 2:
        return (wp.float64(-0.75) * f4 + f2 * f + wp.float64(1.5) * f2 + f) / wp.float64(6.0)
    return f4 / wp.float64(24.0)


@wp.func
def _cell(src: wp.array(dtype=Any), start: int, step: int, n: int, j: int, mode: int, cval: Any):
    """``∫_j^{j+1}`` of the line's spline."""
    return (_coef(src, start, step, n, j - 1, mode, cval) + src.dtype(11.0) * _coef(src, start, step, n, j, mode, cval)
            + src.dtype(11.0) * _coef(src, start, step, n, j + 1, mode, cval)
            + _coef(src, start, step, n, j + 2, mode, cval)) / src.dtype(24.0)


@wp.func
def _partial(src: wp.array(dtype=Any), start: int, step: int, n: int, j: int, f: wp.float64, mode: int, cval: Any):
    """``(∫_j^{j+f} s, s(j + f))`` of the line's spline."""
    total = src.dtype(0.0)
    value = src.dtype(0.0)
    for p in range(4):
        c = _coef(src, start, step, n, j + p - 1, mode, cval)
        total = total + src.dtype(_weight_integral(f, p)) * c
        value = value + src.dtype(_weight(f, p)) * c
    return total, value


@wp.kernel
def box_lines(src: wp.array(dtype=Any), dst: wp.array(dtype=Any), n: int, lines: int, batch_stride: int,
              line_stride: int, step: int, a0: wp.float64, a1: wp.float64, b0: wp.float64, b1: wp.float64,
              mode: int, cval: Any):
    """One line per thread: the window means of box_lines_reference, by one running sum of whole
    cells (compensated) plus the two partial cells at the window's ends."""
    t = wp.tid()
    b = t / lines
    start = b * batch_stride + (t - b * lines) * line_stride
    ia = int(wp.floor(a0))
    ib = int(wp.floor(b0))
    total = src.dtype(0.0)
    comp = src.dtype(0.0)
    for j in range(ia, ib):
        y = _cell(src, start, step, n, j, mode, cval) - comp
        s = total + y
        comp = (s - total) - y
        total = s
    for k in range(n):
        a = a0 + a1 * wp.float64(k)
        e = b0 + b1 * wp.float64(k)
        na = int(wp.floor(a))
        nb = int(wp.floor(e))
        while ib < nb:
            y = _cell(src, start, step, n, ib, mode, cval) - comp
            s = total + y
            comp = (s - total) - y
            total = s
            ib = ib + 1
        while ia < na:
            y = -_cell(src, start, step, n, ia, mode, cval) - comp
            s = total + y
            comp = (s - total) - y
            total = s
            ia = ia + 1
        width = e - a
        if width < _NARROW:     # the spline at the middle (specs_motion.NARROW)
            m = wp.float64(0.5) * (a + e)
            im = int(wp.floor(m))
            pm, vm = _partial(src, start, step, n, im, m - wp.float64(im), mode, cval)
            dst[start + k * step] = vm
        else:
            pa, va = _partial(src, start, step, n, ia, a - wp.float64(ia), mode, cval)
            pb, vb = _partial(src, start, step, n, ib, e - wp.float64(ib), mode, cval)
            dst[start + k * step] = ((total - comp) + pb - pa) / src.dtype(width)


@wp.func
def _spline(src: wp.array(dtype=Any), plane: int, h: int, w: int, py: wp.float64, px: wp.float64,
            mode_y: int, mode_x: int, cval: Any):
    """The 2-D cubic B-spline of one plane at ``(py, px)`` (specs_motion.spline_sample)."""
    fy = wp.floor(py)
    fx = wp.floor(px)
    iy = int(fy)
    ix = int(fx)
    ty = py - fy
    tx = px - fx
    base = src.dtype(0.0)
    if mode_x == 0:
        base = cval
    acc = src.dtype(0.0)
    for p in range(4):
        ry, gy = _coef_index(iy + p - 1, h, mode_y)
        wy = _weight(ty, p) * gy
        row = src.dtype(0.0)
        for q in range(4):
            rx, gx = _coef_index(ix + q - 1, w, mode_x)
            v = base
            if ry >= 0 and rx >= 0:
                v = src[plane + ry * w + rx]
            row = row + src.dtype(_weight(tx, q) * gx) * (v - base)
        acc = acc + src.dtype(wy) * row
    return acc + base


@wp.func
def _support(psf: int):
    if psf == 0:
        return wp.float64(0.0), wp.float64(1.0)
    if psf == 1:
        return wp.float64(0.0), _TAIL
    if psf == 2:
        return wp.float64(-0.5), wp.float64(0.5)
    return -_TAIL / wp.float64(2.0), _TAIL / wp.float64(2.0)


@wp.func
def _cdf(psf: int, t: wp.float64, t0: wp.float64, t1: wp.float64):
    """specs_motion.psf_cdf."""
    if t <= t0:
        return wp.float64(0.0)
    if t >= t1:
        return wp.float64(1.0)
    if psf == 0 or psf == 2:
        return (t - t0) / (t1 - t0)
    if psf == 1:
        return wp.float64(1.0) - wp.exp(-t) * (wp.sin(t) + wp.cos(t))
    s = wp.float64(2.0) * wp.abs(t)
    c = wp.float64(0.5) * (wp.float64(1.0) - wp.exp(-s) * wp.cos(s))
    if t < wp.float64(0.0):
        return wp.float64(0.5) - c
    return wp.float64(0.5) + c


@wp.kernel
def field_blur(coef: wp.array(dtype=Any), field: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               psf: int, density: wp.float64, mode: int, cval: Any):
    """One thread per output pixel: its own path's samples (field_blur_reference)."""
    t = wp.tid()
    plane = t / (h * w)
    pix = t - plane * h * w
    y = pix / w
    x = pix - y * w
    vy = wp.float64(field[pix])
    vx = wp.float64(field[h * w + pix])
    t0, t1 = _support(psf)
    span = t1 - t0
    n = wp.max(1, int(wp.ceil(wp.max(wp.abs(vy), wp.abs(vx)) * span * density - wp.float64(1e-9))))
    acc = coef.dtype(0.0)
    prev = wp.float64(0.0)
    for k in range(n):
        ta = t0 + span * wp.float64(k) / wp.float64(n)
        tb = t0 + span * wp.float64(k + 1) / wp.float64(n)
        c = _cdf(psf, tb, t0, t1)
        tm = wp.float64(0.5) * (ta + tb)
        s = _spline(coef, plane * h * w, h, w, wp.float64(y) - tm * vy, wp.float64(x) - tm * vx, mode, mode, cval)
        acc = acc + coef.dtype(c - prev) * s
        prev = c
    out[t] = acc


@wp.kernel
def to_polar(coef: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int, n_r: int, n_phi: int,
             cy: wp.float64, cx: wp.float64, mode: int, cval: Any):
    """One thread per polar sample (to_polar_reference): layout (B, n_phi, n_r), radius last."""
    t = wp.tid()
    plane = t / (n_r * n_phi)
    rest = t - plane * n_r * n_phi
    j = rest / n_r
    i = rest - j * n_r
    r = wp.float64(i)
    phi = _TWO_PI * wp.float64(j) / wp.float64(n_phi)
    out[t] = _spline(coef, plane * h * w, h, w, cy - r * wp.sin(phi), cx + r * wp.cos(phi), mode, mode, cval)


@wp.kernel
def from_polar(pcoef: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int, n_r: int, n_phi: int,
               cy: wp.float64, cx: wp.float64):
    """One thread per pixel (from_polar_reference): angle wraps, radius mirrors."""
    t = wp.tid()
    plane = t / (h * w)
    pix = t - plane * h * w
    y = pix / w
    x = pix - y * w
    dy = cy - wp.float64(y)
    dx = wp.float64(x) - cx
    r = wp.sqrt(dx * dx + dy * dy)
    phi = wp.atan2(dy, dx)
    if phi < wp.float64(0.0):
        phi = phi + _TWO_PI
    jf = phi * wp.float64(n_phi) / _TWO_PI
    out[t] = _spline(pcoef, plane * n_r * n_phi, n_phi, n_r, jf, r, 2, 4, pcoef.dtype(0.0))


for _real in (wp.float32, wp.float64):
    _a = wp.array(dtype=_real)
    wp.overload(box_lines, {"src": _a, "dst": _a, "cval": _real})
    wp.overload(field_blur, {"coef": _a, "field": _a, "out": _a, "cval": _real})
    wp.overload(to_polar, {"coef": _a, "out": _a, "cval": _real})
    wp.overload(from_polar, {"pcoef": _a, "out": _a})
del _real, _a


def _flat(be, a):
    return be.reshape(a, (-1,))


def _real(be, a):
    return be._wp.float64 if be.dtype_of(a) == np.float64 else be._wp.float32


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval):
    bsz, rows, cols = (int(s) for s in src.shape)
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    real = _real(be, src)
    be._wp.launch(box_lines, dim=bsz * lines, device=be._device,
                  inputs=[_flat(be, src), _flat(be, dst), n, lines, rows * cols, line_stride, step, wp.float64(a0),
                          wp.float64(a1), wp.float64(b0), wp.float64(b1), MODE_CODES[mode], real(cval)])
    return dst


def launch_field_blur(be, coef, field, out, psf, density, mode, cval):
    bsz, h, w = (int(s) for s in coef.shape)
    real = _real(be, coef)
    be._wp.launch(field_blur, dim=bsz * h * w, device=be._device,
                  inputs=[_flat(be, coef), _flat(be, field), _flat(be, out), h, w, int(psf), wp.float64(density),
                          MODE_CODES[mode], real(cval)])
    return out


def launch_to_polar(be, coef, out, cy, cx, mode, cval):
    bsz, h, w = (int(s) for s in coef.shape)
    n_phi, n_r = int(out.shape[1]), int(out.shape[2])
    real = _real(be, coef)
    be._wp.launch(to_polar, dim=bsz * n_r * n_phi, device=be._device,
                  inputs=[_flat(be, coef), _flat(be, out), h, w, n_r, n_phi, wp.float64(cy), wp.float64(cx),
                          MODE_CODES[mode], real(cval)])
    return out


def launch_from_polar(be, pcoef, out, cy, cx):
    bsz, n_phi, n_r = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    be._wp.launch(from_polar, dim=bsz * h * w, device=be._device,
                  inputs=[_flat(be, pcoef), _flat(be, out), h, w, n_r, n_phi, wp.float64(cy), wp.float64(cx)])
    return out

