"""Boundary extension and the cubic B-spline in Warp functions, shared by the kernels of the features
(gfgpu.motion's box, field and polar modules): one definition each, compiled into whichever module
calls it.  Executable specifications: :mod:`gfgpu._core.boundary` (``extend_index``) and
:mod:`gfgpu._core.bspline` (``coef_taps``, ``tap_weights``); the OpenCL twins are in
``gfgpu/motion/spline.cl``.  Positions and weights are float64; samples in the array's own type.
"""

from typing import Any

import warp as wp

from ..._core.boundary import MODE_CODES
from ..._core.bspline import NEAREST_EDGE, SPLINE_POLE

__all__ = ["CONSTANT", "NEAREST", "WRAP", "REFLECT", "MIRROR", "POLE", "NEAR_A", "NEAR_B", "periodic", "extend",
           "pole_power", "coef_taps", "tap_weight", "spline_at"]

wp.set_module_options({"enable_backward": False})

# the constants of the Python definitions (none retyped here): mode codes, the spline's pole and the
# weights of 'nearest' beyond the border
CONSTANT = wp.constant(MODE_CODES["constant"])
NEAREST = wp.constant(MODE_CODES["nearest"])
WRAP = wp.constant(MODE_CODES["wrap"])
REFLECT = wp.constant(MODE_CODES["reflect"])
MIRROR = wp.constant(MODE_CODES["mirror"])
POLE = wp.constant(wp.float64(SPLINE_POLE))
NEAR_A = wp.constant(wp.float64(NEAREST_EDGE[0]))
NEAR_B = wp.constant(wp.float64(NEAREST_EDGE[1]))


@wp.func
def periodic(mode: int):
    """Whether ``mode`` repeats with a period (gfgpu._core.boundary.PERIODIC_MODES)."""
    return mode == WRAP or mode == REFLECT or mode == MIRROR


@wp.func
def extend(i: int, n: int, mode: int):
    """Index of sample ``i`` of a line of ``n`` extended by ``mode`` (-1: cval);
    gfgpu._core.boundary.extend_index."""
    if mode == CONSTANT:
        if i < 0 or i >= n:
            return -1
        return i
    if mode == NEAREST:
        return wp.clamp(i, 0, n - 1)
    if mode == WRAP:
        r = i % n
        if r < 0:
            r = r + n
        return r
    if mode == REFLECT:
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
def pole_power(m: int):
    """``z^m`` for ``m >= 0``; 0 beyond ``m = 64`` (below 1e-36)."""
    f = wp.float64(1.0)
    for _k in range(wp.min(m, 65)):
        f = f * POLE
    if m > 64:
        f = wp.float64(0.0)
    return f


@wp.func
def coef_taps(i: int, n: int, mode: int):
    """``(j0, w0, j1, w1)`` of spline coefficient ``i`` (gfgpu._core.bspline.coef_taps)."""
    if i >= 0 and i < n:
        return i, wp.float64(1.0), i, wp.float64(0.0)
    if periodic(mode):
        j = extend(i, n, mode)
        return j, wp.float64(1.0), j, wp.float64(0.0)
    j0 = 0
    j1 = wp.min(1, n - 1)
    m = -i
    if i >= n:
        j0 = n - 1
        j1 = wp.max(n - 2, 0)
        m = i - n + 1
    f = pole_power(m)
    if mode == CONSTANT:
        return j0, f, j0, wp.float64(0.0)
    return j0, f + (wp.float64(1.0) - f) * NEAR_A, j1, (wp.float64(1.0) - f) * NEAR_B


@wp.func
def tap_weight(t: wp.float64, p: int):
    """Cubic B-spline weight of offset ``p - 1`` for the fraction ``t`` (gfgpu._core.bspline.tap_weights)."""
    g = wp.float64(1.0) - t
    if p == 0:
        return g * g * g / wp.float64(6.0)
    if p == 1:
        return (wp.float64(3.0) * t * t * t - wp.float64(6.0) * t * t + wp.float64(4.0)) / wp.float64(6.0)
    if p == 2:
        return (wp.float64(3.0) * g * g * g - wp.float64(6.0) * g * g + wp.float64(4.0)) / wp.float64(6.0)
    return t * t * t / wp.float64(6.0)


@wp.func
def spline_at(src: wp.array(dtype=Any), plane: int, h: int, w: int, py: wp.float64, px: wp.float64,
            mode_y: int, mode_x: int, cval: Any):
    """The 2-D cubic B-spline of one plane at ``(py, px)`` (spec.spline_sample); beyond the
    border a coefficient may weigh two ('nearest')."""
    fy = wp.floor(py)
    fx = wp.floor(px)
    iy = int(fy)
    ix = int(fx)
    ty = py - fy
    tx = px - fx
    base = src.dtype(0.0)
    if mode_x == CONSTANT:
        base = cval
    acc = src.dtype(0.0)
    for p in range(4):
        ry0, gy0, ry1, gy1 = coef_taps(iy + p - 1, h, mode_y)
        row0 = src.dtype(0.0)
        row1 = src.dtype(0.0)
        for q in range(4):
            rx0, gx0, rx1, gx1 = coef_taps(ix + q - 1, w, mode_x)
            wx0 = src.dtype(tap_weight(tx, q) * gx0)
            wx1 = src.dtype(tap_weight(tx, q) * gx1)
            row0 = row0 + wx0 * (src[plane + ry0 * w + rx0] - base) + wx1 * (src[plane + ry0 * w + rx1] - base)
            if gy1 != wp.float64(0.0):
                row1 = row1 + wx0 * (src[plane + ry1 * w + rx0] - base) + wx1 * (src[plane + ry1 * w + rx1] - base)
        wy = tap_weight(ty, p)
        acc = acc + src.dtype(wy * gy0) * row0 + src.dtype(wy * gy1) * row1
    return acc + base
