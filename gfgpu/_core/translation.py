"""Integer translation of lines by index arithmetic, and the padded window a translated pass runs on.

A pass with ``offset = n`` (:class:`~gfgpu._core.passes.LinePass`) computes, at every sample
``x`` of a line of length ``N``, the pass applied to the boundary mode's extension ``E`` of the
line, read at ``x - n``.  The extension is exact index arithmetic (any ``n``, also beyond the
line's length).  A pass with sections is then run on a window ``E[-n - P, N - n + P)`` padded by
``P`` samples on each side, where ``P`` is the decay length of its sections (the number of
steps after which ``|λ|^P`` falls below the plan tolerance); the padded ends, whose own
boundary state differs from ``E``'s, are cropped, so the result equals the pass on ``E`` to
the tolerance of the boundary plans themselves (1e-10 in float32, 1e-18 in float64).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np

from .boundary import extend_index, period
from .lines import axis_view_shape
from .recursion import TOL

__all__ = ["step_offset", "without_offset", "decay_length", "window_index", "translate_index",
           "crop_index", "reduce_offset"]


def step_offset(passes):
    """The offset the passes of one step share (0 when none translates)."""
    offsets = {int(lp.offset) for lp in passes}
    if len(offsets) != 1:
        raise ValueError(f"the passes of one step must share one offset, got {sorted(offsets)}")
    return offsets.pop()


def without_offset(lp):
    return lp if lp.offset == 0 else replace(lp, offset=0)


def decay_length(passes, dtype):
    """Samples after which every section's response has decayed below the plan tolerance."""
    tol = TOL[np.dtype(dtype)]
    pad = 1
    for lp in passes:
        for sec in lp.sections:
            if sec.kernel is not None:
                raise ValueError("translated passes must be shift invariant")
            mag = abs(sec.lam)
            if mag >= 1:
                raise ValueError(f"a translated pass needs decaying sections, got |lam| = {mag}")
            if mag > 0:
                scale = max(abs(sec.kap), 1.0)
                pad = max(pad, math.ceil(math.log(tol / scale) / math.log(mag)) + 1)
    return pad


def reduce_offset(offset, n, pad, mode):
    """An offset equivalent to ``offset`` on a line of ``n`` samples, small enough for int64.

    Periodic extensions (wrap: period n; reflect: 2n; mirror: 2n - 2) reduce modulo their
    period; constant and nearest extensions saturate beyond the line and its padding.
    """
    offset = int(offset)
    repeat = period(n, mode)
    if repeat is not None:
        return offset % repeat
    limit = n + 2 * pad + 1
    return max(-limit, min(limit, offset))


def window_index(n, offset, pad, mode):
    """Source index (-1: cval) of each sample of the translated window ``E[-offset - pad + q]``,
    ``q`` in ``[0, n + 2 pad)``."""
    k = np.arange(n + 2 * pad, dtype=np.int64) - pad - reduce_offset(offset, n, pad, mode)
    return extend_index(k, n, mode)


def _flat_index(view, line_axis, along):
    """Flat gather index over a (B, N, M) view with the line axis replaced by ``along`` (-1 kept)."""
    b, n, m = view
    along = np.asarray(along, np.int64)
    if line_axis == 1:
        idx = (np.arange(b)[:, None, None] * (n * m) + along[None, :, None] * m + np.arange(m)[None, None, :])
        bad = np.broadcast_to((along < 0)[None, :, None], idx.shape)
    else:
        idx = (np.arange(b)[:, None, None] * (n * m) + np.arange(n)[None, :, None] * m + along[None, None, :])
        bad = np.broadcast_to((along < 0)[None, None, :], idx.shape)
    idx = np.where(bad, -1, idx)
    itype = np.int32 if max(idx.size, b * n * m) < 2**31 else np.int64
    out = np.ascontiguousarray(idx, itype).reshape(-1)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=16)
def translate_index(view, line_axis, offset, pad, mode):
    """Gather index filling the padded, translated (B, N + 2 pad, M) or (B, N, M + 2 pad) window
    from the (B, N, M) view ``view``."""
    return _flat_index(view, line_axis, window_index(view[line_axis], offset, pad, mode))


@lru_cache(maxsize=16)
def crop_index(view, line_axis, pad):
    """Gather index reading the (B, N, M) result out of the padded window."""
    padded = list(view)
    padded[line_axis] += 2 * pad
    return _flat_index(tuple(padded), line_axis, np.arange(view[line_axis]) + pad)


def padded_view(shape, axis, pad):
    """(view, line_axis, padded view) of an array of ``shape`` translated along ``axis``."""
    view, line_axis = axis_view_shape(tuple(shape), axis)
    padded = list(view)
    padded[line_axis] += 2 * pad
    return view, line_axis, tuple(padded)
