"""Executable numpy specification of the edge detector's fused kernel: non-maximum suppression.

Every backend's kernel (``_warp.py``, ``edges.cl`` through ``_opencl.py``) must compute what
:func:`suppress_nonmaxima_reference` (and :func:`suppress_classes_reference`) computes, to
rounding; the numpy backend runs them itself (``_numpy.py``), and ``tests/edges`` checks every
backend against them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TIE_RTOL", "suppress_nonmaxima_reference", "suppress_classes_reference", "class_thresholds"]

#: relative difference below which two magnitudes are a tie in non-maximum suppression
TIE_RTOL = 1e-5


def suppress_nonmaxima_reference(gy, gx):
    """Interpolated non-maximum suppression (numpy; the kernels' specification).

    Returns ``|g|`` where it is not smaller than the magnitudes interpolated at ``±g/|g|``
    (linear interpolation between the two pixels of the next row, if ``|gy| >= |gx|``, or
    column, that straddle the gradient line), else 0.  A tie with the ``-g`` (darker)
    neighbour keeps this pixel and a tie with the ``+g`` neighbour does not, so a symmetric
    two-pixel crest gives one edge pixel, on the brighter side; magnitudes within a relative
    ``TIE_RTOL`` (1e-5) count as tied, since a crest straddling two pixels is only equal up to
    the gradient's rounding.  Border pixels are 0.
    """
    gy = np.asarray(gy)
    gx = np.asarray(gx)
    mag = np.hypot(gy, gx)
    out = np.zeros_like(mag)
    if min(mag.shape) < 3:
        return out
    c = (slice(1, -1), slice(1, -1))
    vy, vx, m = gy[c], gx[c], mag[c]
    s = np.where(vy * vx < 0, -1, 1)
    ay, ax = np.abs(vy), np.abs(vx)
    steep = ay >= ax
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(steep, ax / ay, ay / ax)
    t = np.nan_to_num(t)
    ii, jj = np.meshgrid(np.arange(1, mag.shape[0] - 1), np.arange(1, mag.shape[1] - 1), indexing="ij")
    # neighbours on the +g side (a) and -g side (b): (row, column) offsets
    a1 = np.where(steep, mag[ii + 1, jj], mag[ii, jj + 1])
    a2 = np.where(steep, mag[ii + 1, np.clip(jj + s, 0, mag.shape[1] - 1)],
                  mag[np.clip(ii + s, 0, mag.shape[0] - 1), jj + 1])
    b1 = np.where(steep, mag[ii - 1, jj], mag[ii, jj - 1])
    b2 = np.where(steep, mag[ii - 1, np.clip(jj - s, 0, mag.shape[1] - 1)],
                  mag[np.clip(ii - s, 0, mag.shape[0] - 1), jj - 1])
    plus = (1 - t) * a1 + t * a2
    minus = (1 - t) * b1 + t * b2
    tol = TIE_RTOL * m
    out[c] = np.where((m > 0) & (m > plus + tol) & (m >= minus - tol), m, 0)
    return out


def class_thresholds(dtype, low, high):
    """``(low, high)`` as scalars of the float ``dtype`` the magnitudes are compared in (a value
    beyond its range: infinite), as numpy compares a float array with a Python float."""
    t = np.dtype(dtype).type
    with np.errstate(over="ignore"):
        return t(low), t(high)


def suppress_classes_reference(gy, gx, low, high, strict=False):
    """The hysteresis classes of the suppressed magnitude ``s = suppress_nonmaxima_reference(gy, gx)``.

    Returns a uint8 array: 1 where ``s`` is a candidate (``s > low`` if ``strict``, else
    ``s >= low``), 3 where a candidate is also ``>= high`` (a seed), else 0.  The thresholds are
    compared in the gradient's dtype (:func:`class_thresholds`).  One pass on the device writes
    these bytes where the magnitude would take 4 or 8 per pixel, and the host reads them back.
    """
    s = suppress_nonmaxima_reference(gy, gx)
    lo, hi = class_thresholds(s.dtype, low, high)
    weak = s > lo if strict else s >= lo
    strong = weak & (s >= hi)
    return weak.astype(np.uint8) | (strong.astype(np.uint8) << 1)
