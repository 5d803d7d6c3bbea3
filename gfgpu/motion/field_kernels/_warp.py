"""Warp kernel of per-pixel velocity fields (gfgpu.motion.spec.field_blur_reference): a Warp
module of its own, so the first field call compiles only field code.  The OpenCL twin is
``field.cl`` beside this module; :mod:`gfgpu.motion.kernels` registers ``launch_field_blur``.
Positions and weights are float64; samples accumulate in the image's own type.
"""

from typing import Any

import warp as wp

from ..._core.boundary import MODE_CODES
from ..._core.bspline import NEAREST_EDGE, SPLINE_POLE
from ...backends.warp import launch as wpl
from ..spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, PSF_CODES, PSF_MIN_CELLS

wp.set_module_options({"enable_backward": False})

_CONSTANT = wp.constant(MODE_CODES["constant"])
_NEAREST = wp.constant(MODE_CODES["nearest"])
_WRAP = wp.constant(MODE_CODES["wrap"])
_REFLECT = wp.constant(MODE_CODES["reflect"])
_MIRROR = wp.constant(MODE_CODES["mirror"])
_BOX = wp.constant(PSF_CODES["box", True])
_GREEN = wp.constant(PSF_CODES["green", True])
_BOX_CENTRED = wp.constant(PSF_CODES["box", False])
_GREEN_CENTRED = wp.constant(PSF_CODES["green", False])
_Z = wp.constant(wp.float64(SPLINE_POLE))
_TAIL = wp.constant(wp.float64(GREEN_TAIL))
_NEAR_A = wp.constant(wp.float64(NEAREST_EDGE[0]))
_NEAR_B = wp.constant(wp.float64(NEAREST_EDGE[1]))
_GU0 = wp.constant(wp.float64(GAUSS_NODES[0]))
_GU1 = wp.constant(wp.float64(GAUSS_NODES[1]))
_GU2 = wp.constant(wp.float64(GAUSS_NODES[2]))
_GW0 = wp.constant(wp.float64(GAUSS_WEIGHTS[0]))
_GW1 = wp.constant(wp.float64(GAUSS_WEIGHTS[1]))
_GW2 = wp.constant(wp.float64(GAUSS_WEIGHTS[2]))
_MIN_G = wp.constant(PSF_MIN_CELLS[PSF_CODES["green", True]])
_MIN_CG = wp.constant(PSF_MIN_CELLS[PSF_CODES["green", False]])

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


@wp.func
def _support(psf: int):
    """spec.psf_support."""
    if psf == _BOX:
        return wp.float64(0.0), wp.float64(1.0)
    if psf == _GREEN:
        return wp.float64(0.0), _TAIL
    if psf == _BOX_CENTRED:
        return wp.float64(-0.5), wp.float64(0.5)
    return -_TAIL / wp.float64(2.0), _TAIL / wp.float64(2.0)


@wp.func
def _cdf(psf: int, t: wp.float64, t0: wp.float64, t1: wp.float64):
    """spec.psf_cdf."""
    if t <= t0:
        return wp.float64(0.0)
    if t >= t1:
        return wp.float64(1.0)
    if psf == _BOX or psf == _BOX_CENTRED:
        return (t - t0) / (t1 - t0)
    if psf == _GREEN:
        return wp.float64(1.0) - wp.exp(-t) * (wp.sin(t) + wp.cos(t))
    s = wp.float64(2.0) * wp.abs(t)
    c = wp.float64(0.5) * (wp.float64(1.0) - wp.exp(-s) * wp.cos(s))
    if t < wp.float64(0.0):
        return wp.float64(0.5) - c
    return wp.float64(0.5) + c


@wp.func
def _density(psf: int, t: wp.float64):
    """G_u's density at ``t`` (spec.psf_density; the G_u codes)."""
    if psf == _GREEN:
        return wp.float64(2.0) * wp.exp(-t) * wp.sin(t)
    s = wp.float64(2.0) * wp.abs(t)
    return wp.exp(-s) * (wp.cos(s) + wp.sin(s))


@wp.func
def _node_weight(psf: int, g: wp.float64, q: wp.float64, mass: wp.float64, rest: wp.float64):
    """Weight of one Gauss-Legendre node: its share of the cell's mass (box), or the quadrature
    weight ``q`` plus its share of what the quadrature missed (G_u)."""
    if psf == _BOX or psf == _BOX_CENTRED:
        return g * mass
    return q + g * rest


@wp.kernel
def field_blur(coef: wp.array(dtype=Any), field: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               psf: int, density: wp.float64, mode: int, cval: Any, most: int):
    """One thread per output pixel: its own path in cells of three Gauss-Legendre nodes
    (field_blur_reference)."""
    t = wp.tid()
    plane = t / (h * w)
    pix = t - plane * h * w
    y = pix / w
    x = pix - y * w
    vy = wp.float64(field[pix])
    vx = wp.float64(field[h * w + pix])
    t0, t1 = _support(psf)
    span = t1 - t0
    length = wp.max(wp.abs(vy), wp.abs(vx))
    fewest = 1
    if psf == _GREEN:
        fewest = _MIN_G
    if psf == _GREEN_CENTRED:
        fewest = _MIN_CG
    n = 1
    if length > wp.float64(0.0):
        n = wp.max(fewest, int(wp.ceil(length * span * density - wp.float64(1e-9))))
        if most > 0:
            n = wp.min(n, most)     # the budget: longer paths get longer cells
    acc = coef.dtype(0.0)
    prev = wp.float64(0.0)
    for k in range(n):
        ta = t0 + span * wp.float64(k) / wp.float64(n)
        tb = t0 + span * wp.float64(k + 1) / wp.float64(n)
        c = _cdf(psf, tb, t0, t1)
        mass = c - prev
        prev = c
        s0 = ta + _GU0 * (tb - ta)
        s1 = ta + _GU1 * (tb - ta)
        s2 = ta + _GU2 * (tb - ta)
        q0 = wp.float64(0.0)
        q1 = wp.float64(0.0)
        q2 = wp.float64(0.0)
        if psf == _GREEN or psf == _GREEN_CENTRED:
            q0 = (tb - ta) * _GW0 * _density(psf, s0)
            q1 = (tb - ta) * _GW1 * _density(psf, s1)
            q2 = (tb - ta) * _GW2 * _density(psf, s2)
        rest = mass - (q0 + q1 + q2)
        base = plane * h * w
        acc = acc + coef.dtype(_node_weight(psf, _GW0, q0, mass, rest)) * _spline(
            coef, base, h, w, wp.float64(y) - s0 * vy, wp.float64(x) - s0 * vx, mode, mode, cval)
        acc = acc + coef.dtype(_node_weight(psf, _GW1, q1, mass, rest)) * _spline(
            coef, base, h, w, wp.float64(y) - s1 * vy, wp.float64(x) - s1 * vx, mode, mode, cval)
        acc = acc + coef.dtype(_node_weight(psf, _GW2, q2, mass, rest)) * _spline(
            coef, base, h, w, wp.float64(y) - s2 * vy, wp.float64(x) - s2 * vx, mode, mode, cval)
    out[t] = acc

for _real in (wp.float32, wp.float64):
    _a = wp.array(dtype=_real)
    wp.overload(field_blur, {"coef": _a, "field": _a, "out": _a, "cval": _real})
del _real, _a


def _flat(be, a):
    return be.reshape(a, (-1,))


def launch_field_blur(be, coef, field, out, psf, density, mode, cval, most=0):
    bsz, h, w = (int(s) for s in coef.shape)
    real = wpl.real_type(be, coef)
    wpl.launch(be, field_blur, dim=bsz * h * w,
               inputs=[_flat(be, coef), _flat(be, field), _flat(be, out), h, w, int(psf), wp.float64(density),
                       MODE_CODES[mode], real(cval), int(most)])
    return out
