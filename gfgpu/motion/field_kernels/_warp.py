"""Warp kernel of per-pixel velocity fields (gfgpu.motion.spec.field_blur_reference): a Warp
module of its own, so the first field call compiles only field code.  The OpenCL twin is
``field.cl`` beside this module; :mod:`gfgpu.motion.kernels` registers ``launch_field_blur``.
Positions and weights are float64; samples accumulate in the image's own type.
"""

from typing import Any

import warp as wp

from ..._core.boundary import MODE_CODES
from ...backends.warp import launch as wpl
from ...backends.warp.bspline import spline_at
from ..spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, PSF_CODES, PSF_MIN_CELLS, rule_limits, rule_table

wp.set_module_options({"enable_backward": False})

_BOX = wp.constant(PSF_CODES["box", True])
_GREEN = wp.constant(PSF_CODES["green", True])
_BOX_CENTRED = wp.constant(PSF_CODES["box", False])
_GREEN_CENTRED = wp.constant(PSF_CODES["green", False])
_TAIL = wp.constant(wp.float64(GREEN_TAIL))
_GU0 = wp.constant(wp.float64(GAUSS_NODES[0]))
_GU1 = wp.constant(wp.float64(GAUSS_NODES[1]))
_GU2 = wp.constant(wp.float64(GAUSS_NODES[2]))
_GW0 = wp.constant(wp.float64(GAUSS_WEIGHTS[0]))
_GW1 = wp.constant(wp.float64(GAUSS_WEIGHTS[1]))
_GW2 = wp.constant(wp.float64(GAUSS_WEIGHTS[2]))
_MIN_G = wp.constant(PSF_MIN_CELLS[PSF_CODES["green", True]])
_MIN_CG = wp.constant(PSF_MIN_CELLS[PSF_CODES["green", False]])

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
        acc = acc + coef.dtype(_node_weight(psf, _GW0, q0, mass, rest)) * spline_at(
            coef, base, h, w, wp.float64(y) - s0 * vy, wp.float64(x) - s0 * vx, mode, mode, cval)
        acc = acc + coef.dtype(_node_weight(psf, _GW1, q1, mass, rest)) * spline_at(
            coef, base, h, w, wp.float64(y) - s1 * vy, wp.float64(x) - s1 * vx, mode, mode, cval)
        acc = acc + coef.dtype(_node_weight(psf, _GW2, q2, mass, rest)) * spline_at(
            coef, base, h, w, wp.float64(y) - s2 * vy, wp.float64(x) - s2 * vx, mode, mode, cval)
    out[t] = acc

@wp.kernel
def field_rule(coef: wp.array(dtype=Any), field: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               per_px: wp.float64, extra: int, first: int, most: int, offsets: wp.array(dtype=wp.int32),
               nodes: wp.array(dtype=wp.float64), weights: wp.array(dtype=Any), mode: int, cval: Any):
    """One thread per output pixel: the Gauss rule of its path from the tables (field_rule_reference)."""
    t = wp.tid()
    plane = t / (h * w)
    pix = t - plane * h * w
    y = pix / w
    x = pix - y * w
    vy = wp.float64(field[pix])
    vx = wp.float64(field[h * w + pix])
    length = wp.max(wp.abs(vy), wp.abs(vx))
    n = wp.min(wp.max(first, int(wp.ceil(length * per_px - wp.float64(1e-9))) + extra), most)
    base = plane * h * w
    acc = coef.dtype(0.0)
    if length > wp.float64(0.0):
        for k in range(int(offsets[n - first]), int(offsets[n - first + 1])):
            s = nodes[k]
            acc = acc + weights[k] * spline_at(coef, base, h, w, wp.float64(y) - s * vy, wp.float64(x) - s * vx,
                                               mode, mode, cval)
    else:
        acc = spline_at(coef, base, h, w, wp.float64(y), wp.float64(x), mode, mode, cval)
    out[t] = acc

for _real in (wp.float32, wp.float64):
    _a = wp.array(dtype=_real)
    wp.overload(field_blur, {"coef": _a, "field": _a, "out": _a, "cval": _real})
    wp.overload(field_rule, {"coef": _a, "field": _a, "out": _a, "weights": _a, "cval": _real})
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


def launch_field_rule(be, coef, field, out, psf, mode, cval, most=None):
    bsz, h, w = (int(s) for s in coef.shape)
    real = wpl.real_type(be, coef)
    first, top, per_px, extra = rule_limits(psf)
    _, offsets, nodes, weights = rule_table(psf)
    tables = [be.asarray(offsets), be.asarray(nodes), be.asarray(weights.astype(be.dtype_of(coef)))]
    wpl.launch(be, field_rule, dim=bsz * h * w,
               inputs=[_flat(be, coef), _flat(be, field), _flat(be, out), h, w, wp.float64(per_px), int(extra),
                       int(first), int(top if most is None else min(max(int(most), first), top)), *tables,
                       MODE_CODES[mode], real(cval)])
    return out
