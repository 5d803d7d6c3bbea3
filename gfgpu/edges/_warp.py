"""Warp kernels of the edge detector: interpolated non-maximum suppression, as the magnitude or as
hysteresis classes.

Executable specifications: :func:`gfgpu.edges.spec.suppress_nonmaxima_reference` and
:func:`gfgpu.edges.spec.suppress_classes_reference`; the launchers at the end are registered by
:mod:`gfgpu.edges.kernels`.
"""

from typing import Any

import warp as wp

from ..backends.warp import launch as wpl
from .spec import TIE_RTOL, class_thresholds

wp.set_module_options({"enable_backward": False})

_TIE_RTOL = wp.constant(TIE_RTOL)


@wp.func
def _magnitude(gy: wp.array2d(dtype=Any), gx: wp.array2d(dtype=Any), i: int, j: int):
    return wp.sqrt(gy[i, j] * gy[i, j] + gx[i, j] * gx[i, j])


@wp.func
def _suppressed(gy: wp.array2d(dtype=Any), gx: wp.array2d(dtype=Any), i: int, j: int):
    """``|g|`` at (i, j) where it is a maximum along the gradient (interpolated), else 0.

    The two neighbours along ±g are interpolated linearly between the two pixels that
    straddle the gradient line in the next row (|gy| >= |gx|) or column; a tie with the -g
    neighbour keeps the pixel, a tie with the +g neighbour does not (one edge pixel per
    symmetric crest, on the brighter side).  Border pixels are 0.
    """
    h = gy.shape[0]
    w = gy.shape[1]
    zero = type(gy[i, j])(0.0)
    if i == 0 or j == 0 or i == h - 1 or j == w - 1:
        return zero
    ay = wp.abs(gy[i, j])
    ax = wp.abs(gx[i, j])
    m = _magnitude(gy, gx, i, j)
    if m == zero:
        return zero
    s = 1
    if gy[i, j] * gx[i, j] < zero:
        s = -1
    plus = zero
    minus = zero
    if ay >= ax:
        t = ax / ay
        plus = (type(t)(1.0) - t) * _magnitude(gy, gx, i + 1, j) + t * _magnitude(gy, gx, i + 1, j + s)
        minus = (type(t)(1.0) - t) * _magnitude(gy, gx, i - 1, j) + t * _magnitude(gy, gx, i - 1, j - s)
    else:
        t = ay / ax
        plus = (type(t)(1.0) - t) * _magnitude(gy, gx, i, j + 1) + t * _magnitude(gy, gx, i + s, j + 1)
        minus = (type(t)(1.0) - t) * _magnitude(gy, gx, i, j - 1) + t * _magnitude(gy, gx, i - s, j - 1)
    tol = type(m)(_TIE_RTOL) * m   # equal up to rounding is a tie
    if m > plus + tol and m >= minus - tol:
        return m
    return zero


@wp.kernel
def suppress_nonmaxima(gy: wp.array2d(dtype=Any), gx: wp.array2d(dtype=Any), out: wp.array2d(dtype=Any)):
    """``out = |g|`` where it is a maximum along the gradient (interpolated), else 0 (:func:`_suppressed`)."""
    i, j = wp.tid()
    out[i, j] = _suppressed(gy, gx, i, j)


@wp.kernel
def suppress_classes(gy: wp.array2d(dtype=Any), gx: wp.array2d(dtype=Any), out: wp.array2d(dtype=wp.uint8),
                     lo: Any, hi: Any, strict: int):
    """``out`` = 1 where the suppressed magnitude is a candidate (``> lo`` if ``strict``, else
    ``>= lo``), 3 where it is also ``>= hi``, else 0."""
    i, j = wp.tid()
    v = _suppressed(gy, gx, i, j)
    weak = v >= lo
    if strict != 0:
        weak = v > lo
    c = wp.uint8(0)
    if weak:
        c = wp.uint8(1)
        if v >= hi:
            c = wp.uint8(3)
    out[i, j] = c


for _real in (wp.float32, wp.float64):
    wp.overload(suppress_nonmaxima, {"gy": wp.array2d(dtype=_real), "gx": wp.array2d(dtype=_real),
                                     "out": wp.array2d(dtype=_real)})
    wp.overload(suppress_classes, {"gy": wp.array2d(dtype=_real), "gx": wp.array2d(dtype=_real),
                                   "out": wp.array2d(dtype=wp.uint8), "lo": _real, "hi": _real, "strict": int})


def launch_nms(be, gy, gx, out):
    """Launcher of the fused kernel ``edges.nms`` (spec: gfgpu.edges.spec.suppress_nonmaxima_reference)."""
    if not (gy.shape == gx.shape == out.shape) or len(out.shape) != 2:
        raise ValueError(f"gy, gx and out must be 2-D arrays of one shape, got {gy.shape}, "
                         f"{gx.shape}, {out.shape}")
    wpl.launch(be, suppress_nonmaxima, dim=out.shape, inputs=[gy, gx, out])
    return out


def launch_nms_classes(be, gy, gx, out, low, high, strict=False):
    """Launcher of ``edges.nms_classes`` (spec: gfgpu.edges.spec.suppress_classes_reference)."""
    if not (gy.shape == gx.shape == out.shape) or len(out.shape) != 2:
        raise ValueError(f"gy, gx and out must be 2-D arrays of one shape, got {gy.shape}, "
                         f"{gx.shape}, {out.shape}")
    lo, hi = class_thresholds(wp.dtype_to_numpy(gy.dtype), low, high)
    real = gy.dtype
    wpl.launch(be, suppress_classes, dim=out.shape, inputs=[gy, gx, out, real(lo), real(hi), int(bool(strict))])
    return out
