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
from ...backends.warp import launch as wpl
from ...backends.warp.bspline import MIRROR, WRAP, extend, spline_at, tap_weight

wp.set_module_options({"enable_backward": False})

# the constants of the Python definitions (none retyped here): mode codes, spline
_TWO_PI = wp.constant(wp.float64(2.0 * np.pi))


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
    out[t] = spline_at(coef, plane * h * w, h, w, cy - r * wp.sin(phi), cx + r * wp.cos(phi), mode, mode, cval)


@wp.kernel
def from_polar(pcoef: wp.array(dtype=Any), base: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               n_r: int, n_phi: int, cy: wp.float64, cx: wp.float64, r0: int, r_lo: wp.float64, r_hi: wp.float64,
               wcoef: wp.array(dtype=Any), weighted: int, only_band: int):
    """One thread per pixel (from_polar_reference): ``base``, at the radii ``[r_lo, r_hi)`` weighted
    by the radial spline of ``wcoef`` (if ``weighted``) plus the polar spline of a band from ring
    ``r0``, whose radius mirrors and angle wraps (``out`` may be ``base``); beyond those radii ``base``,
    or nothing written (``only_band``)."""
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
    if only_band != 0 and not (r >= r_lo and r < r_hi):
        return
    if r >= r_lo and r < r_hi:
        ring = r - wp.float64(r0)
        change = spline_at(pcoef, plane * n_r * n_phi, n_r, n_phi, ring, jf, MIRROR, WRAP, pcoef.dtype(0.0))
        if weighted != 0:
            fr = wp.floor(ring)
            ir = int(fr)
            tr = ring - fr
            weight = pcoef.dtype(0.0)
            for p in range(4):
                weight = weight + pcoef.dtype(tap_weight(tr, p)) * wcoef[extend(ir + p - 1, n_r, MIRROR)]
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


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None, only_band=False):
    bsz, n_r, n_phi = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    real = np.float64 if be.dtype_of(pcoef) == np.float64 else np.float32
    weights = be.asarray(np.ascontiguousarray(np.ones(1) if wcoef is None else wcoef, real))
    wpl.launch(be, from_polar, dim=bsz * h * w,
               inputs=[_flat(be, pcoef), _flat(be, base), _flat(be, out), h, w, n_r, n_phi, wp.float64(cy),
                       wp.float64(cx), int(r0), wp.float64(r_lo), wp.float64(min(float(r_hi), 1e300)),
                       weights, int(wcoef is not None), int(bool(only_band))])
    return out

def launch_add_rows(be, src, dst, scale):
    bsz, n, m = (int(s) for s in dst.shape)
    weights = be.asarray(np.ascontiguousarray(scale, np.float64 if be.dtype_of(dst) == np.float64 else np.float32))
    wpl.launch(be, add_rows, dim=bsz * n * m,
               inputs=[_flat(be, src), _flat(be, dst), weights, n, m])
    return dst
