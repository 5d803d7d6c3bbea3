"""Warp kernels of motion blur: box windows along lines (per-pixel paths: ``field_kernels/_warp.py``,
polar resampling: ``polar_kernels/_warp.py``, modules of their own).

Executable specification: :mod:`gfgpu.motion.spec`; the OpenCL twins are in ``motion.cl``
beside this module; :mod:`gfgpu.motion.kernels` registers the ``launch_*`` functions
at the end.  Written for GPUs: one thread per line (box windows) or per output sample, arrays
passed flat with explicit strides.  Positions and weights are float64 (a ring of 10^4 samples
needs more than float32's 24 bits to place a sample to 1e-4 px); samples are accumulated in
the image's own type.
"""


from typing import Any

import numpy as np
import warp as wp

from .._core.boundary import MODE_CODES
from .._core.bspline import prefix_weights
from ..backends.warp import launch as wpl
from ..backends.warp.bspline import (
    MIRROR,
    NEAR_A,
    NEAR_B,
    NEAREST,
    POLE,
    REFLECT,
    extend,
    periodic,
    pole_power,
    tap_weight,
)
from .kernels import fixed_width
from .spec import NARROW

wp.set_module_options({"enable_backward": False})

# the constants of the Python definitions (none retyped here): mode codes, spline
_NARROW = wp.constant(wp.float64(NARROW))


@wp.func
def _geometric(m: int):
    """``Σ_{k=1}^{m} z^k``, ``m >= 0`` (gfgpu._core.bspline.pole_series)."""
    return POLE * (wp.float64(1.0) - pole_power(m)) / (wp.float64(1.0) - POLE)


@wp.func
def _edge(src: wp.array(dtype=Any), start: int, step: int, n: int, right: int, mode: int, cval: Any):
    """The extension's value beyond the left (right) end: ``cval``, or the edge sample for 'nearest'."""
    if mode != NEAREST:
        return cval
    j = 0
    j1 = wp.min(1, n - 1)
    if right != 0:
        j = n - 1
        j1 = wp.max(n - 2, 0)
    return src.dtype(NEAR_A) * src[start + j * step] + src.dtype(NEAR_B) * src[start + j1 * step]


@wp.func
def _coef(src: wp.array(dtype=Any), start: int, step: int, n: int, i: int, mode: int, cval: Any):
    """Coefficient ``i`` of the line at ``start`` (stride ``step``), extended by ``mode``."""
    if i >= 0 and i < n:
        return src[start + i * step]
    if periodic(mode):
        return src[start + extend(i, n, mode) * step]
    right = 0
    j = 0
    m = -i
    if i >= n:
        right = 1
        j = n - 1
        m = i - n + 1
    c = src[start + j * step]
    e = _edge(src, start, step, n, right, mode, cval)
    return e + src.dtype(pole_power(m)) * (c - e)


@wp.func
def _coef_run(src: wp.array(dtype=Any), start: int, step: int, n: int, a: int, b: int, mode: int, cval: Any):
    """``Σ_{a <= i < b}`` of the extended coefficients, by a compensated loop."""
    total = src.dtype(0.0)
    comp = src.dtype(0.0)
    for i in range(a, b):
        y = _coef(src, start, step, n, i, mode, cval) - comp
        s = total + y
        comp = (s - total) - y
        total = s
    return total - comp


@wp.func
def _coef_sum(src: wp.array(dtype=Any), start: int, step: int, n: int, a: int, b: int, mode: int, cval: Any):
    """``Σ_{a <= i < b}`` of the extended coefficients in O(n) whatever ``b - a``
    (spec._coef_prefix): whole periods, or the geometric tails, in closed form."""
    total = src.dtype(0.0)
    if b > a:
        if periodic(mode):
            per = n     # gfgpu._core.boundary.period
            if mode == REFLECT:
                per = 2 * n
            if mode == MIRROR:
                per = wp.max(2 * n - 2, 1)
            if b - a <= 3 * per:
                total = _coef_run(src, start, step, n, a, b, mode, cval)
            else:
                a1 = a + ((-a) % per + per) % per      # whole periods [a1, b1)
                b1 = b - (b % per + per) % per
                total = (_coef_run(src, start, step, n, a, a1, mode, cval)
                         + _coef_run(src, start, step, n, b1, b, mode, cval)
                         + src.dtype((b1 - a1) / per) * _coef_run(src, start, step, n, 0, per, mode, cval))
        else:
            if a < 0:
                top = wp.min(b, 0)
                e = _edge(src, start, step, n, 0, mode, cval)
                total = total + src.dtype(top - a) * e + src.dtype(_geometric(-a) - _geometric(-top)) * (src[start] - e)
            if wp.max(a, 0) < wp.min(b, n):
                total = total + _coef_run(src, start, step, n, wp.max(a, 0), wp.min(b, n), mode, cval)
            if b > n:
                bottom = wp.max(a, n)
                e = _edge(src, start, step, n, 1, mode, cval)
                total = total + src.dtype(b - bottom) * e + src.dtype(_geometric(b - n) - _geometric(bottom - n)) * (
                    src[start + (n - 1) * step] - e)
    return total


@wp.func
def _cells(src: wp.array(dtype=Any), start: int, step: int, n: int, a: int, b: int, mode: int, cval: Any):
    """The spline's whole cells ``j`` in ``[a, b)``: the coefficients' sum plus three at each end."""
    ends = (_coef(src, start, step, n, a - 1, mode, cval) - src.dtype(12.0) * _coef(src, start, step, n, a, mode, cval)
            - _coef(src, start, step, n, a + 1, mode, cval) - _coef(src, start, step, n, b - 1, mode, cval)
            + src.dtype(12.0) * _coef(src, start, step, n, b, mode, cval)
            + _coef(src, start, step, n, b + 1, mode, cval))
    return _coef_sum(src, start, step, n, a, b, mode, cval) + ends / src.dtype(24.0)


@wp.func
def _weight_integral(f: wp.float64, p: int):
    """``∫_0^f`` of the weight of offset ``p - 1`` (gfgpu._core.bspline.weight_integrals)."""
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
        value = value + src.dtype(tap_weight(f, p)) * c
    return total, value


@wp.kernel
def box_lines(src: wp.array(dtype=Any), dst: wp.array(dtype=Any), n: int, lines: int, batch_stride: int,
              line_stride: int, step: int, a0: wp.float64, a1: wp.float64, b0: wp.float64, b1: wp.float64,
              mode: int, cval: Any, less: wp.array(dtype=Any), has_less: int):
    """One line per thread: the window means of box_lines_reference, by one running sum of whole
    cells (compensated; the first window's in closed form) plus the two partial cells at the
    window's ends."""
    t = wp.tid()
    b = t / lines
    start = b * batch_stride + (t - b * lines) * line_stride
    ia = int(wp.floor(a0))
    ib = int(wp.floor(b0))
    total = _cells(src, start, step, n, ia, ib, mode, cval)
    comp = src.dtype(0.0)
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
        value = src.dtype(0.0)
        if width < _NARROW:     # the spline at the middle (spec.NARROW)
            m = wp.float64(0.5) * (a + e)
            im = int(wp.floor(m))
            pm, vm = _partial(src, start, step, n, im, m - wp.float64(im), mode, cval)
            value = vm
        else:
            pa, va = _partial(src, start, step, n, ia, a - wp.float64(ia), mode, cval)
            pb, vb = _partial(src, start, step, n, ib, e - wp.float64(ib), mode, cval)
            value = ((total - comp) + pb - pa) / src.dtype(width)
        if has_less != 0:      # dst may be less: the element is read before it is written
            value = value - less[start + k * step]
        dst[start + k * step] = value


@wp.kernel
def box_shift(src: wp.array(dtype=Any), dst: wp.array(dtype=Any), n: int, lines: int, batch_stride: int,
              line_stride: int, step: int, a: int, b: int, wa0: Any, wa1: Any, wa2: Any, wa3: Any, wb0: Any,
              wb1: Any, wb2: Any, wb3: Any, inv_width: Any, mode: int, cval: Any, less: wp.array(dtype=Any),
              has_less: int):
    """box_lines for windows of fixed width (``a1 = b1 = 1``, width >= NARROW), one line per thread,
    as motion.cl's box_shift: the whole cells telescope to a running sum of the coefficients over
    ``[a + k, b + k)`` (compensated; the first in closed form) plus four taps at each end whose weights
    (the partial cells' integrals, ``wa``, ``wb``: host-computed) do not change along the line, the
    taps slid along in registers: two coefficients read per step instead of sixteen."""
    t = wp.tid()
    plane = t / lines
    start = plane * batch_stride + (t - plane * lines) * line_stride
    total = _coef_sum(src, start, step, n, a, b, mode, cval)
    comp = src.dtype(0.0)
    am = _coef(src, start, step, n, a - 1, mode, cval)
    ac = _coef(src, start, step, n, a, mode, cval)
    ap = _coef(src, start, step, n, a + 1, mode, cval)
    aq = _coef(src, start, step, n, a + 2, mode, cval)
    bm = _coef(src, start, step, n, b - 1, mode, cval)
    bc = _coef(src, start, step, n, b, mode, cval)
    bp = _coef(src, start, step, n, b + 1, mode, cval)
    bq = _coef(src, start, step, n, b + 2, mode, cval)
    for k in range(n):
        ends = (wb0 * bm + wb1 * bc + wb2 * bp + wb3 * bq) - (wa0 * am + wa1 * ac + wa2 * ap + wa3 * aq)
        value = ((total - comp) + ends) * inv_width
        if has_less != 0:      # dst may be less: the element is read before it is written
            value = value - less[start + k * step]
        dst[start + k * step] = value
        y = (bc - ac) - comp       # slide: c[b + k] enters, c[a + k] leaves
        s = total + y
        comp = (s - total) - y
        total = s
        am = ac
        ac = ap
        ap = aq
        aq = _coef(src, start, step, n, a + k + 3, mode, cval)
        bm = bc
        bc = bp
        bp = bq
        bq = _coef(src, start, step, n, b + k + 3, mode, cval)


for _real in (wp.float32, wp.float64):
    _a = wp.array(dtype=_real)
    wp.overload(box_lines, {"src": _a, "dst": _a, "cval": _real, "less": _a})
    _weights = ("wa0", "wa1", "wa2", "wa3", "wb0", "wb1", "wb2", "wb3", "inv_width")
    wp.overload(box_shift, {"src": _a, "dst": _a, "cval": _real, "less": _a, **{w: _real for w in _weights}})
del _real, _a, _weights


def _flat(be, a):
    return be.reshape(a, (-1,))


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval, less=None):
    bsz, rows, cols = (int(s) for s in src.shape)
    n, lines = (cols, rows) if axis == 2 else (rows, cols)
    line_stride, step = (cols, 1) if axis == 2 else (1, cols)
    real = wpl.real_type(be, src)
    head = [_flat(be, src), _flat(be, dst), n, lines, rows * cols, line_stride, step]
    tail = [MODE_CODES[mode], real(cval), _flat(be, dst if less is None else less), int(less is not None)]
    if fixed_width(a0, a1, b0, b1):
        a, b = int(np.floor(a0)), int(np.floor(b0))
        wa, wb = (prefix_weights(x - np.floor(x)) for x in (a0, b0))
        wpl.launch(be, box_shift, dim=bsz * lines,
                   inputs=head + [a, b, *(real(w) for w in wa), *(real(w) for w in wb), real(1.0 / (b0 - a0))] + tail)
        return dst
    wpl.launch(be, box_lines, dim=bsz * lines,
               inputs=head + [wp.float64(a0), wp.float64(a1), wp.float64(b0), wp.float64(b1)] + tail)
    return dst
