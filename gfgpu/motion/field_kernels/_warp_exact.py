"""Warp kernel of the velocity fields' ``"exact"`` rule (gfgpu.motion.spec.field_blur_reference):
a Warp module of its own, apart from the default Gauss rule's (``_warp.py``), because Warp builds a
module whole at its first launch: the default field call then builds only its own kernel (NVRTC for
sm_90: the pair took 20-25 s, the Gauss rule alone ~10 s; ``benchmarks/warp_compile.py``).
Positions and weights are float64; samples accumulate in the image's own type.
"""

from typing import Any

import warp as wp

from ..._core.boundary import MODE_CODES
from ...backends.warp import launch as wpl
from ...backends.warp.bspline import spline_at
from ..spec import GAUSS_NODES, GAUSS_WEIGHTS, GREEN_TAIL, PSF_CODES, PSF_MIN_CELLS

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
    base = plane * h * w
    ta = wp.float64(0.0)
    tb = wp.float64(0.0)
    mass = wp.float64(0.0)
    rest = wp.float64(0.0)
    q0 = wp.float64(0.0)
    q1 = wp.float64(0.0)
    q2 = wp.float64(0.0)
    # one spline_at call site for the three nodes of each cell (node i of cell k at step 3k + i):
    # Warp inlines every call site of the 16-tap spline, and three of them made this module the
    # slowest to build for CUDA (NVRTC, 16-42 s); the sums run in the same order as before
    for j in range(3 * n):
        k = j / 3
        i = j - 3 * k
        if i == 0:
            ta = t0 + span * wp.float64(k) / wp.float64(n)
            tb = t0 + span * wp.float64(k + 1) / wp.float64(n)
            c = _cdf(psf, tb, t0, t1)
            mass = c - prev
            prev = c
            if psf == _GREEN or psf == _GREEN_CENTRED:
                q0 = (tb - ta) * _GW0 * _density(psf, ta + _GU0 * (tb - ta))
                q1 = (tb - ta) * _GW1 * _density(psf, ta + _GU1 * (tb - ta))
                q2 = (tb - ta) * _GW2 * _density(psf, ta + _GU2 * (tb - ta))
            rest = mass - (q0 + q1 + q2)
        g = _GU0
        gw = _GW0
        q = q0
        if i == 1:
            g = _GU1
            gw = _GW1
            q = q1
        if i == 2:
            g = _GU2
            gw = _GW2
            q = q2
        s = ta + g * (tb - ta)
        acc = acc + coef.dtype(_node_weight(psf, gw, q, mass, rest)) * spline_at(
            coef, base, h, w, wp.float64(y) - s * vy, wp.float64(x) - s * vx, mode, mode, cval)
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
