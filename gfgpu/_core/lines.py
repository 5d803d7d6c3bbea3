"""Line geometry: which samples form a line, for an array axis or an image-plane direction.

Axis lines need no data movement: an N-D C-contiguous array is viewed as ``(B, N, M)`` with
the filtered axis in the middle (or as ``(1, B, N)`` when it is the last axis).

Oblique lines follow the chapter's lines ``y = ℓ + γx`` along the continuous direction: for a
direction at angle ``θ`` whose dominant axis is x (``|cos θ| >= |sin θ|``, ``γ = tan θ``;
x and y swap roles for steep directions), line ``ℓ`` passes through ``(x, ℓ + γx)`` at every
column ``x``.  The recursion steps one column at a time, so kernel lengths along an oblique line
are measured in steps of the dominant axis (the chapter's convention: ``u`` is the
x-component of the flow).  The image is *sheared* so that these lines become rows: column
``x`` is read at ``ℓ + γx``, split (:func:`shear_offsets`) into an integer part ``r[x]``,
done here by a gather (index arithmetic, exact), and a remaining sub-pixel delay ``d[x] =
γx - r[x]``, done by :mod:`gfgpu._core.oblique` with a fractional-delay filter along the column;
after the passes along the rows the image is sheared back the same way.  Lines that leave the
image through its top or bottom continue through the image extended by ``mode`` across that
axis (what an explicitly padded image would give); at the two ends of the dominant axis a line
is extended along itself by the recursion's boundary state.

:func:`shear_maps` gives the two gathers: the sheared layout is a ``(B, lines, steps)`` array
(or ``(B, steps, lines)``) whose line ``q`` holds ``ℓ = first + q`` read at integer offsets
``r[x]``, with ``margin`` extra lines beyond the ones the output reads on either side (room for
the delay filters' decay), so the oblique case runs the same row primitive as the axis case.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from .boundary import extend_index
from .validation import finite_scalar, integer


def axis_view_shape(shape, axis):
    """``((B, N, M), line_axis)`` for filtering ``axis`` of a C-contiguous array of ``shape``."""
    b = int(np.prod(shape[:axis], dtype=np.int64))
    n = int(shape[axis])
    m = int(np.prod(shape[axis + 1:], dtype=np.int64))
    if m == 1:
        return (1, b, n), 2
    return (b, n, m), 1


def normalize_axis(axis, ndim, name="axis"):
    """``axis`` in ``[0, ndim)``; ``TypeError`` for a non-integer, ``ValueError`` out of range."""
    a = integer(name, axis)
    if not -ndim <= a < ndim:
        raise ValueError(f"{name}={axis} is out of range for an array of {ndim} dimension(s)")
    return a % ndim


#: largest |angle| (radians) accepted: float64 spacing there is 1e-10 rad
MAX_ANGLE = 1e6


def direction(angle):
    """``(steep, reverse, gamma)`` of a direction: dominant axis y if steep, traversal sense."""
    theta = finite_scalar("angle", angle)   # radians
    if abs(theta) > MAX_ANGLE:
        raise ValueError(f"angle must lie within ±{MAX_ANGLE:g} radians, got {angle!r} (beyond, float64 cannot "
                         f"place a direction to better than 1e-9 rad)")
    c, s = math.cos(theta), math.sin(theta)
    if abs(c) >= abs(s) - 1e-12:
        return False, c < 0, s / c
    return True, s < 0, c / s


#: the sub-pixel remainder of the shear lies in ``[DELAY_MIN, DELAY_MIN + 1)`` (or is 0)
DELAY_MIN = 2.3


def shear_offsets(steps, gamma):
    """``(r, d)`` for ``t < steps``: ``γ t = r[t] + d[t]``, ``r`` an integer and the delay ``d``
    either 0 (``γ t`` an integer: no resampling) or in ``[DELAY_MIN, DELAY_MIN + 1)``.

    The column filter that realises the delay, Thiran's third-order allpass
    (:mod:`gfgpu._core.oblique`), is stable for delays above 2 and most accurate just above 2,
    where its poles approach the unit circle; from 2.3 its poles stay within 0.71 (short tails,
    a margin of 84 lines in float32) and its phase error at 1/4 cycle/px within 0.066 rad.
    """
    exact = gamma * np.arange(steps)
    r = np.floor(exact - (DELAY_MIN - 1)).astype(np.int64) - 1
    d = exact - r
    whole = np.abs(exact - np.round(exact)) < 1e-12
    r[whole] = np.round(exact[whole]).astype(np.int64)
    d[whole] = 0.0
    return r, d


#: the sheared layout's line count is a multiple of this (16 float32 lanes, a cache line: the CPU
#: passes' vector groups and the OpenCL steep shears' 16 x 16 tiles, which need whole groups)
LINE_GROUP = 16


class ShearMaps(NamedTuple):
    """Gathers of a sheared layout (:func:`shear_maps`)."""

    shear: np.ndarray      # layout sample -> source pixel (flat, -1: cval)
    unshear: np.ndarray    # pixel -> layout sample (flat)
    lines: int
    steps: int
    delay: np.ndarray      # (steps,) d[t]: the column's remaining sub-pixel delay (0: none)
    transposed: bool       # layout (batch, steps, lines) instead of (batch, lines, steps)


@lru_cache(maxsize=8)
def shear_maps(height, width, batch, angle, mode, margin, transposed=False):
    """The sheared layout of an oblique direction (module docstring), as two gathers.

    Line ``q`` of the layout (row ``q`` of ``(batch, lines, steps)``, or column ``q`` of
    ``(batch, steps, lines)`` when ``transposed``) holds, at step ``t`` (dominant axis), the
    pixel at minor coordinate ``first + q + r[t]``, extended by ``mode`` beyond the image (-1
    in ``shear`` where that is ``cval``).  Pixel ``(minor m, step t)`` is read back from line
    ``m - r[t] - first``.  The lines span the ones read back plus ``margin`` on each side.
    Arrays are read-only and cached.
    """
    steep, _, gamma = direction(angle)
    steps, across = (height, width) if steep else (width, height)
    r, d = shear_offsets(steps, gamma)
    margin = int(margin)
    first = -int(r.max()) - margin
    lines = across - int(r.min()) + int(r.max()) + 2 * margin
    # whole groups of LINE_GROUP lines: the CPU kernels run that many adjacent lines in vector
    # lanes and fall back to one line at a time for a partial group (the extra lines, past the
    # last margin, are never read back)
    lines = -(-lines // LINE_GROUP) * LINE_GROUP
    plane = height * width
    total = batch * max(lines * steps, plane)
    itype = np.int32 if total < 2**31 - 1 else np.int64
    # the source pixel of minor coordinate c = lo + k, as a flat index without the step term
    # (-1 - steps*tstride where the extension is cval: stays negative after adding the step)
    lo = first + int(r.min())
    span = np.arange(lo, first + lines - 1 + int(r.max()) + 1)
    ext = extend_index(span, across, mode)
    stride = 1 if steep else width           # pixel (minor c, step t): c * stride + t * tstride
    tstride = width if steep else 1
    base = np.where(ext >= 0, ext * stride, -1 - steps * tstride).astype(itype)
    t = np.arange(steps, dtype=itype)
    q = np.arange(lines, dtype=itype)
    shift = (r - int(r.min())).astype(itype)         # line q at step t: base[q + shift[t]]
    if transposed:
        idx = shift[:, None] + q[None, :]
        flat = base[idx]
        del idx
        flat += (t * tstride)[:, None]
    else:
        idx = q[:, None] + shift[None, :]
        flat = base[idx]
        del idx
        flat += (t * tstride)[None, :]
    np.maximum(flat, -1, out=flat)
    if batch > 1:
        offsets = (np.arange(batch, dtype=itype) * plane).reshape((batch,) + (1,) * flat.ndim)
        flat = np.where(flat[None] >= 0, flat[None] + offsets, -1).astype(itype, copy=False)
    # unshear: pixel (minor m, step t) sits on line m - r[t] - first, at step t; built in the
    # image's own (height, width) order
    mm = np.arange(across, dtype=itype)
    start = (r + first).astype(itype)
    if transposed:      # layout (steps, lines): t * lines + m - r[t] - first
        lead, inner = t * lines - start, mm
    else:               # layout (lines, steps): (m - r[t] - first) * steps + t
        lead, inner = t - start * steps, mm * steps
    pos = lead[:, None] + inner[None, :] if steep else inner[:, None] + lead[None, :]
    if batch > 1:
        pos = pos[None] + (np.arange(batch, dtype=itype) * (lines * steps)).reshape(batch, 1, 1)
    shear = flat.reshape(-1)
    unshear = pos.reshape(-1)
    for a in (shear, unshear, d):
        a.setflags(write=False)
    return ShearMaps(shear, unshear, lines, steps, d, bool(transposed))


class ShearGeometry(NamedTuple):
    """What a kernel needs to read the sheared layout from the image and write it back by index
    arithmetic (:func:`shear_geometry`), in place of the two index arrays of :func:`shear_maps`."""

    base: np.ndarray       # (span,) minor coordinate first + r.min() + k -> its pixel's offset (-1: cval)
    shift: np.ndarray      # (steps,) line q at step t reads base[q + shift[t]]
    start: np.ndarray      # (steps,) line q at step t is pixel (minor q + start[t], step t)
    lines: int
    steps: int
    across: int
    stride: int            # pixel (minor c, step t) at c * stride + t * tstride
    tstride: int
    transposed: bool


@lru_cache(maxsize=8)
def shear_geometry(height, width, angle, mode, margin, transposed=False):
    """The sheared layout of :func:`shear_maps` (same lines, same samples) as a base table and
    per-step offsets instead of whole-image index arrays: O(width + height) numbers."""
    steep, _, gamma = direction(angle)
    steps, across = (height, width) if steep else (width, height)
    r, _ = shear_offsets(steps, gamma)
    margin = int(margin)
    first = -int(r.max()) - margin
    lines = across - int(r.min()) + int(r.max()) + 2 * margin
    lines = -(-lines // LINE_GROUP) * LINE_GROUP
    lo = first + int(r.min())
    span = np.arange(lo, first + lines - 1 + int(r.max()) + 1)
    ext = extend_index(span, across, mode)
    stride = 1 if steep else width
    tstride = width if steep else 1
    base = np.where(ext >= 0, ext * stride, -1).astype(np.int32)
    shift = (r - int(r.min())).astype(np.int32)
    start = (r + first).astype(np.int32)
    for a in (base, shift, start):
        a.setflags(write=False)
    return ShearGeometry(base, shift, start, lines, steps, across, stride, tstride, bool(transposed))

