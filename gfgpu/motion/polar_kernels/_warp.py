"""Warp kernels of the polar resampling behind the spin and zoom blurs, a Warp module of their own
(a spin or zoom compiles only this).

Executable specification: :mod:`gfgpu.motion.spec`; the OpenCL twins are in ``polar.cl`` beside this
module; :mod:`gfgpu.motion.kernels` registers the ``launch_*`` functions at the end.  Written for GPUs:
one thread per output sample, arrays passed flat.  Positions and weights are float64 (a ring of 10^4
samples needs more than float32's 24 bits to place a sample to 1e-4 px); samples are accumulated in the
image's own type.
"""

from typing import Any

import numpy as np
import warp as wp

from ..._core.boundary import MODE_CODES
from ..._core.bspline import NEAREST_EDGE, SPLINE_POLE
from ...backends.warp import launch as wpl

wp.set_module_options({"enable_backward": False})

# the constants of the Python definitions (none retyped here): mode codes, spline
_CONSTANT = wp.constant(MODE_CODES["constant"])
_NEAREST = wp.constant(MODE_CODES["nearest"])
_WRAP = wp.constant(MODE_CODES["wrap"])
_REFLECT = wp.constant(MODE_CODES["reflect"])
_MIRROR = wp.constant(MODE_CODES["mirror"])
_Z = wp.constant(wp.float64(SPLINE_POLE))
_TWO_PI = wp.constant(wp.float64(2.0 * np.pi))
_NEAR_A = wp.constant(wp.float64(NEAREST_EDGE[0]))
_NEAR_B = wp.constant(wp.float64(NEAREST_EDGE[1]))


@wp.func
def _periodic(mode: int):
    """Whether ``mode`` repeats with a period (gfgpu._core.boundary.PERIODIC_MODES)."""
    return mode == _WRAP or mode == _REFLECT or mode == _MIRROR


@wp.func
def _extend(i: int, n: int, mode: int):
    """Index of sample ``i`` of a line of ``n`` extended by ``mode`` (-1: cval);
    gfgpu._core.boundary.extend_index."""
    if mode == _CONSTANT:
        if i < 0 or i >= n:
            return -1
        return i
    if mode == _NEAREST:
        return wp.clamp(i, 0, n - 1)
    if mode == _WRAP:
        r = i % n
        if r < 0:
            r = r + n
        return r
    if mode == _REFLECT:
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
def _pole_power(m: int):
    """``z^m`` for ``m >= 0``; 0 beyond ``m = 64`` (below 1e-36)."""
    f = wp.float64(1.0)
    for _k in range(wp.min(m, 65)):
        f = f * _Z
    if m > 64:
        f = wp.float64(0.0)
    return f


@wp.func
def _coef_taps(i: int, n: int, mode: int):
    """``(j0, w0, j1, w1)`` of spline coefficient ``i`` (gfgpu._core.bspline.coef_taps)."""
    if i >= 0 and i < n:
        return i, wp.float64(1.0), i, wp.float64(0.0)
    if _periodic(mode):
        j = _extend(i, n, mode)
        return j, wp.float64(1.0), j, wp.float64(0.0)
    j0 = 0
    j1 = wp.min(1, n - 1)
    m = -i
    if i >= n:
        j0 = n - 1
        j1 = wp.max(n - 2, 0)
        m = i - n + 1
    f = _pole_power(m)
    if mode == _CONSTANT:
        return j0, f, j0, wp.float64(0.0)
    return j0, f + (wp.float64(1.0) - f) * _NEAR_A, j1, (wp.float64(1.0) - f) * _NEAR_B


@wp.func
def _weight(t: wp.float64, p: int):
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
def _spline(src: wp.array(dtype=Any), plane: int, h: int, w: int, py: wp.float64, px: wp.float64,
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
    if mode_x == _CONSTANT:
        base = cval
    acc = src.dtype(0.0)
    for p in range(4):
        ry0, gy0, ry1, gy1 = _coef_taps(iy + p - 1, h, mode_y)
        row0 = src.dtype(0.0)
        row1 = src.dtype(0.0)
        for q in range(4):
            rx0, gx0, rx1, gx1 = _coef_taps(ix + q - 1, w, mode_x)
            wx0 = src.dtype(_weight(tx, q) * gx0)
            wx1 = src.dtype(_weight(tx, q) * gx1)
            row0 = row0 + wx0 * (src[plane + ry0 * w + rx0] - base) + wx1 * (src[plane + ry0 * w + rx1] - base)
            if gy1 != wp.float64(0.0):
                row1 = row1 + wx0 * (src[plane + ry1 * w + rx0] - base) + wx1 * (src[plane + ry1 * w + rx1] - base)
        wy = _weight(ty, p)
        acc = acc + src.dtype(wy * gy0) * row0 + src.dtype(wy * gy1) * row1
    return acc + base


@wp.kernel
def to_polar(coef: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int, n_r: int, n_phi: int,
             cy: wp.float64, cx: wp.float64, r0: int, mode: int, cval: Any):
    """One thread per polar sample (to_polar_reference): layout (B, n_r, n_phi), angle last, ring i
    at radius r0 + i."""
    t = wp.tid()
    plane = t / (n_r * n_phi)
    rest = t - plane * n_r * n_phi
    i = rest / n_phi
    j = rest - i * n_phi
    r = wp.float64(r0 + i)
    phi = _TWO_PI * wp.float64(j) / wp.float64(n_phi)
    out[t] = _spline(coef, plane * h * w, h, w, cy - r * wp.sin(phi), cx + r * wp.cos(phi), mode, mode, cval)


@wp.kernel
def from_polar(pcoef: wp.array(dtype=Any), base: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               n_r: int, n_phi: int, cy: wp.float64, cx: wp.float64, r0: int, r_lo: wp.float64, r_hi: wp.float64,
               wcoef: wp.array(dtype=Any), weighted: int):
    """One thread per pixel (from_polar_reference): ``base``, at the radii ``[r_lo, r_hi)`` weighted
    by the radial spline of ``wcoef`` (if ``weighted``) plus the polar spline of a band from ring
    ``r0``, whose radius mirrors and angle wraps (``out`` may be ``base``)."""
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
    value = base[t]
    if r >= r_lo and r < r_hi:
        ring = r - wp.float64(r0)
        change = _spline(pcoef, plane * n_r * n_phi, n_r, n_phi, ring, jf, _MIRROR, _WRAP, pcoef.dtype(0.0))
        if weighted != 0:
            fr = wp.floor(ring)
            ir = int(fr)
            tr = ring - fr
            weight = pcoef.dtype(0.0)
            for p in range(4):
                weight = weight + pcoef.dtype(_weight(tr, p)) * wcoef[_extend(ir + p - 1, n_r, _MIRROR)]
            value = weight * value
        value = value + change
    out[t] = value


@wp.kernel
def add_rows(src: wp.array(dtype=Any), dst: wp.array(dtype=Any), scale: wp.array(dtype=Any), n: int, m: int):
    """One thread per element: ``dst += scale[i] src`` (add_rows_reference)."""
    t = wp.tid()
    i = (t / m) % n
    dst[t] = dst[t] + scale[i] * src[t]


for _real in (wp.float32, wp.float64):
    _a = wp.array(dtype=_real)
    wp.overload(to_polar, {"coef": _a, "out": _a, "cval": _real})
    wp.overload(from_polar, {"pcoef": _a, "base": _a, "out": _a, "wcoef": _a})
    wp.overload(add_rows, {"src": _a, "dst": _a, "scale": _a})
del _real, _a


def _flat(be, a):
    return be.reshape(a, (-1,))


def launch_to_polar(be, coef, out, cy, cx, r0, mode, cval):
    bsz, h, w = (int(s) for s in coef.shape)
    n_r, n_phi = int(out.shape[1]), int(out.shape[2])
    real = wpl.real_type(be, coef)
    wpl.launch(be, to_polar, dim=bsz * n_r * n_phi,
               inputs=[_flat(be, coef), _flat(be, out), h, w, n_r, n_phi, wp.float64(cy), wp.float64(cx), int(r0),
                       MODE_CODES[mode], real(cval)])
    return out


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None):
    bsz, n_r, n_phi = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    real = np.float64 if be.dtype_of(pcoef) == np.float64 else np.float32
    weights = be.asarray(np.ascontiguousarray(np.ones(1) if wcoef is None else wcoef, real))
    wpl.launch(be, from_polar, dim=bsz * h * w,
               inputs=[_flat(be, pcoef), _flat(be, base), _flat(be, out), h, w, n_r, n_phi, wp.float64(cy),
                       wp.float64(cx), int(r0), wp.float64(r_lo), wp.float64(min(float(r_hi), 1e300)),
                       weights, int(wcoef is not None)])
    return out

def launch_add_rows(be, src, dst, scale):
    bsz, n, m = (int(s) for s in dst.shape)
    weights = be.asarray(np.ascontiguousarray(scale, np.float64 if be.dtype_of(dst) == np.float64 else np.float32))
    wpl.launch(be, add_rows, dim=bsz * n * m,
               inputs=[_flat(be, src), _flat(be, dst), weights, n, m])
    return dst
