"""Executable numpy specification of the edge detector's fused kernel: non-maximum suppression.

Every backend's kernel (``_warp.py``, ``edges.cl`` through ``_opencl.py``) must compute what
:func:`suppress_nonmaxima_reference` computes, to rounding; the numpy backend runs it itself
(``_numpy.py``), and ``tests/edges`` checks every backend against it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TIE_RTOL", "suppress_nonmaxima_reference"]

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
