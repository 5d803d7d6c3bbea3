"""The cubic B-spline that interpolates a line: its prefilter, tap weights and edge continuation.

The spline ``s(x) = Σ_k c[k] β3(x - k)`` through the samples ``I`` (scipy.ndimage's
``order=3``) has coefficients ``c = p * I``, the prefilter ``p[k] = c0 z^|k|`` with the pole
``z = sqrt(3) - 2`` (:data:`SPLINE_POLE`) and ``c0 = -6 z / (1 - z^2)`` (:data:`PREFILTER_GAIN`,
unit DC gain).  At ``x = j + f`` (``j`` an integer, ``0 <= f < 1``) the spline weighs the four
coefficients ``c[j - 1 .. j + 2]`` by :func:`tap_weights`; :func:`weight_integrals` and
:func:`prefix_weights` integrate it.  Beyond a line's ends the coefficients are those of the line
extended by a boundary mode (:mod:`gfgpu._core.boundary`), as :func:`coef_taps` says.

These are the one host definition of the spline's constants and weights; device kernels evaluate
the same polynomials and take the constants (pole, :data:`NEAREST_EDGE`) from here, passed by
their launchers.
"""

from __future__ import annotations

import math

import numpy as np

from .boundary import extend_index

__all__ = ["SPLINE_POLE", "PREFILTER_GAIN", "NEAREST_EDGE", "PREFIX_ENDS", "basis", "tap_weights",
           "weight_integrals", "prefix_weights", "pole_series", "coef_taps"]

#: pole of the cubic B-spline interpolation prefilter, sqrt(3) - 2
SPLINE_POLE = math.sqrt(3.0) - 2.0

#: gain ``c0`` of the prefilter ``p[k] = c0 z^|k|``: ``-6 z / (1 - z^2)``, unit DC gain
PREFILTER_GAIN = -6.0 * SPLINE_POLE / (1.0 - SPLINE_POLE * SPLINE_POLE)

#: weights of ``c[0]`` and ``c[1]`` in the edge sample ``I[0]`` of a line whose coefficients
#: continue as ``c[-m] = I[0] + z^m (c[0] - I[0])`` ('nearest', see :func:`coef_taps`): the
#: interpolation condition ``I[0] = (c[-1] + 4 c[0] + c[1]) / 6`` solved for ``I[0]``
NEAREST_EDGE = ((4.0 + SPLINE_POLE) / (5.0 + SPLINE_POLE), 1.0 / (5.0 + SPLINE_POLE))

#: weights of ``c[j - 1 .. j + 2]`` that the whole cells before ``j`` add to ``Σ_{i < j} c[i]``:
#: a cell integrates to ``(c[i-1] + 11 c[i] + 11 c[i+1] + c[i+2]) / 24``, and the cells'
#: sum telescopes to the coefficients' sum plus ``(-c[j-1] + 12 c[j] + c[j+1]) / 24``
PREFIX_ENDS = (-1.0 / 24.0, 12.0 / 24.0, 1.0 / 24.0, 0.0)


def basis(t):
    """The cubic B-spline ``β3(t)`` at one point ``t`` (a float): ``2/3 - t^2 + |t|^3/2`` for
    ``|t| < 1``, ``(2 - |t|)^3 / 6`` for ``1 <= |t| < 2``, 0 beyond."""
    t = abs(t)
    if t < 1.0:
        return 2.0 / 3.0 - t * t + 0.5 * t**3
    if t < 2.0:
        return (2.0 - t) ** 3 / 6.0
    return 0.0


def tap_weights(f):
    """The weights ``β3(f + 1), β3(f), β3(f - 1), β3(f - 2)`` of the coefficients at offsets
    -1, 0, 1, 2 for the fraction ``f`` (array_like, ``0 <= f <= 1``): shape ``(4,) + f.shape``."""
    f = np.asarray(f, np.float64)
    g = 1.0 - f
    return np.stack([g**3 / 6.0, (3.0 * f**3 - 6.0 * f * f + 4.0) / 6.0,
                     (3.0 * g**3 - 6.0 * g * g + 4.0) / 6.0, f**3 / 6.0])


def weight_integrals(f):
    """``∫_0^f`` of each of :func:`tap_weights` (1/24, 11/24, 11/24, 1/24 at ``f = 1``): shape
    ``(4,) + f.shape``."""
    f = np.asarray(f, np.float64)
    f2 = f * f
    f4 = f2 * f2
    return np.stack([(1.0 - (1.0 - f) ** 4) / 24.0, (0.75 * f4 - 2.0 * f2 * f + 4.0 * f) / 6.0,
                     (-0.75 * f4 + f2 * f + 1.5 * f2 + f) / 6.0, f4 / 24.0])


def prefix_weights(f):
    """Weights of ``c[j - 1 .. j + 2]`` in ``∫ s`` up to ``j + f``, beside ``Σ_{i < j} c[i]``:
    :func:`weight_integrals` plus :data:`PREFIX_ENDS`, shape ``(4,) + f.shape``.

    The integral of the spline from a fixed start to ``j + f`` is ``Σ_{i < j} c[i]`` (the whole
    cells, telescoped) plus these four taps, up to a constant of the start: a window's mean is a
    difference of two such sums, whatever its length.
    """
    parts = weight_integrals(f)
    return parts + np.asarray(PREFIX_ENDS).reshape((4,) + (1,) * (parts.ndim - 1))


def pole_series(m):
    """``Σ_{k=1}^{m} z^k`` for integers ``m >= 0`` (``z`` the pole): the sum of the geometric
    continuation of the coefficients over ``m`` samples beyond an end (:func:`coef_taps`)."""
    m = np.asarray(m, np.int64)
    return SPLINE_POLE * (1.0 - SPLINE_POLE ** m.astype(np.float64)) / (1.0 - SPLINE_POLE)


def coef_taps(i, n, mode):
    """``(j0, w0, j1, w1)``: the coefficient ``i`` of a line of ``n`` extended by ``mode`` is
    ``w0 c[j0] + w1 c[j1] + (1 - w0 - w1) cval`` (``cval`` only in ``"constant"`` mode).

    The coefficients are those of the line extended by ``mode`` (the prefilter's boundary
    states make them exact).  ``"wrap"``, ``"reflect"`` and ``"mirror"`` extensions are periodic,
    so the coefficients extend as the samples do: ``j0 = extend_index(i)``, ``w0 = 1``.  Where the
    extension is one value ``e`` (``cval``, or the edge sample for ``"nearest"``) the
    coefficients of the line minus ``e``, zero beyond the edge, continue geometrically,
    ``c[-m] = e + z^m (c[0] - e)`` (``z`` the prefilter's pole; the same at the right end); for
    ``"nearest"`` the edge sample is ``e = NEAREST_EDGE · (c[0], c[1])``, so coefficient ``-m``
    weighs ``c[0]`` and ``c[1]`` (one coefficient: ``e = c[0]``).  Copying the end coefficient
    instead is the spline of another image: it overshoots the edge by ``|c[0] - e|``.

    Parameters
    ----------
    i : array_like of int
        Coefficient indices, any integers.
    n : int
        Coefficients in the line, ``n >= 1``.
    mode : str
        A boundary mode (:data:`gfgpu._core.boundary.MODES`).

    Returns
    -------
    j0, j1 : ndarray of int64
        Indices into ``[0, n)``, ``i``'s shape.
    w0, w1 : ndarray of float64
        Their weights.
    """
    i = np.asarray(i, np.int64)
    if mode not in ("constant", "nearest"):
        j = extend_index(i, n, mode)
        return j, np.ones(i.shape), j, np.zeros(i.shape)
    j0 = np.clip(i, 0, n - 1)
    f = SPLINE_POLE ** np.abs(i - j0).astype(np.float64)         # 1 inside the line
    if mode == "constant":
        return j0, f, j0, np.zeros(i.shape)
    a, b = NEAREST_EDGE
    j1 = np.where(i < 0, min(1, n - 1), np.where(i >= n, max(n - 2, 0), j0))
    return j0, f + (1.0 - f) * a, j1, (1.0 - f) * b
