"""Warp kernel of per-pixel velocity fields' default rule (gfgpu.motion.spec.field_rule_reference):
a Warp module of its own, so the first field call compiles only field code (the ``"exact"`` rule's
kernel is in ``_warp_exact.py``, a module of its own too: Warp builds a module whole at its first
launch).  The OpenCL twin is ``field.cl`` beside this module; :mod:`gfgpu.motion.kernels` registers
``launch_field_rule`` from here and ``launch_field_blur`` from ``_warp_exact.py``.
Positions and weights are float64; samples accumulate in the image's own type.
"""

from typing import Any

import warp as wp

from ..._core.boundary import MODE_CODES
from ...backends.warp import launch as wpl
from ...backends.warp.bspline import spline_at
from ..spec import EUCLIDEAN_RULES, rule_limits, rule_table

wp.set_module_options({"enable_backward": False})


@wp.kernel
def field_rule(coef: wp.array(dtype=Any), field: wp.array(dtype=Any), out: wp.array(dtype=Any), h: int, w: int,
               per_px: wp.float64, extra: int, first: int, most: int, euclid: int, offsets: wp.array(dtype=wp.int32),
               nodes: wp.array(dtype=wp.float64), weights: wp.array(dtype=Any), mode: int, cval: Any):
    """One thread per output pixel: the rule of its path from the tables (field_rule_reference), sized by
    the Euclidean length (``euclid``, G_u) or the dominant component (box): spec.rule_length."""
    t = wp.tid()
    plane = t / (h * w)
    pix = t - plane * h * w
    y = pix / w
    x = pix - y * w
    vy = wp.float64(field[pix])
    vx = wp.float64(field[h * w + pix])
    length = wp.max(wp.abs(vy), wp.abs(vx))
    if euclid != 0:
        length = wp.sqrt(vy * vy + vx * vx)
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
    wp.overload(field_rule, {"coef": _a, "field": _a, "out": _a, "weights": _a, "cval": _real})
del _real, _a


def _flat(be, a):
    return be.reshape(a, (-1,))


def launch_field_rule(be, coef, field, out, psf, mode, cval, most=None, reach=None):
    # reach: the OpenCL kernel's margin only (ignored here)
    bsz, h, w = (int(s) for s in coef.shape)
    real = wpl.real_type(be, coef)
    first, top, per_px, extra = rule_limits(psf)
    _, offsets, nodes, weights = rule_table(psf)
    tables = [be.asarray(offsets), be.asarray(nodes), be.asarray(weights.astype(be.dtype_of(coef)))]
    wpl.launch(be, field_rule, dim=bsz * h * w,
               inputs=[_flat(be, coef), _flat(be, field), _flat(be, out), h, w, wp.float64(per_px), int(extra),
                       int(first), int(top if most is None else min(max(int(most), first), top)),
                       int(psf in EUCLIDEAN_RULES), *tables,
                       MODE_CODES[mode], real(cval)])
    return out
