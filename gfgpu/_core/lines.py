"""Line geometry: which samples form a line, for an array axis or an image-plane direction.

Axis lines need no data movement: an N-D C-contiguous array is viewed as ``(B, N, M)`` with
the filtered axis in the middle (or as ``(1, B, N)`` when it is the last axis).

Oblique lines follow the chapter's lines ``y + γx`` as *digital lines*: for a direction at
angle ``θ`` whose dominant axis is x (``|cos θ| >= |sin θ|``), line ``ℓ`` visits the pixels
``(x, ℓ + r[x])`` for every column ``x``, with ``r[x] = floor(γx + 1/2)`` and ``γ = tan θ``
(x and y swap roles for steep directions).  Each pixel lies on exactly one line, every line
has one sample per column, and the recursion steps one pixel along the dominant axis, so
kernel lengths along an oblique line are measured in steps of that axis (the chapter's
convention: ``u`` is the x-component of the flow).  Lines that leave the image through its
top or bottom continue through the image extended by ``mode`` across that axis (what an
explicitly padded image would give); at the two ends of the dominant axis the line is
extended along itself by the recursion's boundary state.  No interpolation is involved, so
the operator along each line is exact; the price is that the minor-axis displacement of a
feature is quantised to whole pixels per line (use axis passes for sub-pixel shifts).

The gather maps below lay the lines out as the rows of a ``(B, lines, steps)`` array, so the
oblique case runs the same row primitive as the axis case.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .recursion import extension_index
from .validation import finite_scalar


def axis_view_shape(shape, axis):
    """``((B, N, M), line_axis)`` for filtering ``axis`` of a C-contiguous array of ``shape``."""
    b = int(np.prod(shape[:axis], dtype=np.int64))
    n = int(shape[axis])
    m = int(np.prod(shape[axis + 1:], dtype=np.int64))
    if m == 1:
        return (1, b, n), 2
    return (b, n, m), 1


def normalize_axis(axis, ndim, name="axis"):
    try:
        a = int(axis)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an integer, got {axis!r}") from None
    if not -ndim <= a < ndim:
        raise ValueError(f"{name}={axis} is out of range for an array of {ndim} dimension(s)")
    return a % ndim


def _extend(idx, size, mode):
    """Map indices outside [0, size) by the boundary mode; -1 means cval."""
    idx = np.asarray(idx, np.int64)
    out = idx.copy()
    low = idx < 0
    if low.any():
        out[low] = extension_index(idx[low], size, mode)
    high = idx >= size
    if high.any():
        # the right side mirrors the left side's rule on the reversed line
        e = extension_index(size - 1 - idx[high], size, mode)
        out[high] = np.where(e < 0, -1, size - 1 - e)
    return out


def direction(angle):
    """``(steep, reverse, gamma)`` of a direction: dominant axis y if steep, traversal sense."""
    theta = finite_scalar("angle", angle)   # radians
    c, s = math.cos(theta), math.sin(theta)
    if abs(c) >= abs(s) - 1e-12:
        return False, c < 0, s / c
    return True, s < 0, c / s


@lru_cache(maxsize=8)
def oblique_maps(height, width, batch, angle, mode):
    """Gather indices ``(shear, unshear, lines)`` for an oblique direction.

    ``shear`` (size ``batch*lines*steps``) fills the row layout from the ``(batch, height,
    width)`` image (-1 where the extension is ``cval``); ``unshear`` (size ``batch*height*
    width``) reads each pixel back from the row layout.
    """
    steep, _, gamma = direction(angle)
    steps, across = (height, width) if steep else (width, height)
    t = np.arange(steps)
    r = np.floor(gamma * t + 0.5).astype(np.int64)
    first = -int(r.max())
    lines = across - int(r.min()) - first
    ell = first + np.arange(lines)
    minor = ell[:, None] + r[None, :]                      # (lines, steps)
    minor_ext = _extend(minor, across, mode)
    if steep:   # dominant axis y: pixel (y=t, x=minor)
        flat = np.where(minor_ext >= 0, t[None, :] * width + minor_ext, -1)
    else:       # dominant axis x: pixel (y=minor, x=t)
        flat = np.where(minor_ext >= 0, minor_ext * width + t[None, :], -1)
    itype = np.int32 if batch * max(lines * steps, height * width) < 2**31 else np.int64
    plane = height * width
    shear = (flat[None] + np.where(flat[None] >= 0, np.arange(batch)[:, None, None] * plane, 0)).astype(itype)
    # unshear: pixel (y, x) sits on line index (minor - r[t]) - first, at step t
    yy, xx = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    tt, mm = (yy, xx) if steep else (xx, yy)
    pos = (mm - r[tt] - first) * steps + tt
    unshear = (pos[None] + np.arange(batch)[:, None, None] * (lines * steps)).astype(itype)
    for a in (shear, unshear):
        a.setflags(write=False)
    return shear.reshape(-1), unshear.reshape(-1), lines, steps
