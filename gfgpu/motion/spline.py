"""Cubic B-spline coefficients of an image: the interpolation prefilter as recursions.

The fused kernels that sample an image at arbitrary points (per-pixel paths, polar grids)
evaluate the cubic B-spline ``s(x) = Σ c[k] β3(x - k)`` that interpolates the samples, as
scipy.ndimage's ``order=3`` does.  The coefficients are ``c = p * I`` with the prefilter
``p[k] = c0 z^|k|`` (``z = sqrt(3) - 2``, ``c0 = -6z/(1 - z^2)``, unit DC gain;
:mod:`gfgpu._core.bspline`): one causal and one anticausal first-order recursion per axis, exact
(boundary states from the mode), O(1) per pixel.
"""

from __future__ import annotations

from .._core.bspline import PREFILTER_GAIN, SPLINE_POLE
from .._core.passes import LinePass, Section
from .._core.program import run_axis_passes

__all__ = ["prefilter_passes", "line_coefficients", "spline_coefficients"]


def prefilter_passes():
    """The causal (with the tap ``c0``) and anticausal passes of the prefilter, summed."""
    z, c0 = SPLINE_POLE, PREFILTER_GAIN
    section = Section(lam=complex(z), kap=complex(c0 * z))
    return [LinePass((section,), c0, False), LinePass((section,), 0.0, True)]


def spline_coefficients(be, data, dtype, shape, modes, cval=0.0, tmp=None, out=None):
    """Coefficients of ``data`` (a device array of ``shape``, image plane last) along the rows
    then the columns; ``modes = (mode along the rows' axis -2, mode along axis -1)``, ``cval``
    the value beyond the border in ``"constant"`` mode.

    ``tmp`` and ``out`` (device arrays of ``shape``, distinct from each other; ``out`` may be
    ``data``, which is then overwritten) are allocated when not given.  Returns ``out``.
    """
    passes = prefilter_passes()
    tmp = be.empty(shape, dtype) if tmp is None else tmp
    out = be.empty(shape, dtype) if out is None else out
    run_axis_passes(be, data, tmp, dtype, passes, modes[1], cval, len(shape) - 1, shape)
    run_axis_passes(be, tmp, out, dtype, passes, modes[0], cval, len(shape) - 2, shape)
    return out


def line_coefficients(be, src, dst, dtype, shape, axis, mode, cval=0.0):
    """Coefficients of the lines of ``src`` along ``axis`` only (into ``dst``): what the box
    windows integrate, since they run along one axis."""
    run_axis_passes(be, src, dst, dtype, prefilter_passes(), mode, cval, axis, shape)
    return dst
