"""Exact state carry: one recursion pass over lines cut into segments.

A pass of :mod:`gfgpu._core.recursion` is linear in its state.  Cut each line (traversal order)
into segments ``[t0, t1)``; with ``Φ`` the state entering a segment,

.. math::

    y[t] = y_0[t] + \\operatorname{Re} \\sum_s H_s[t]\\, Φ_s, \\qquad
    H_s[t] = \\prod_{t_0 \\le j < t} λ_s[j],

    Φ' = H_s[t_1]\\, Φ_s + E_s, \\qquad
    E_s = \\sum_{t_0 \\le k < t_1} \\Big(\\prod_{k < j < t_1} λ_s[j]\\Big) κ_s[k]\\, I[k],

where ``y_0`` is the segment's *zero-state* response (the same pass started from ``F = 0``,
run on the device by the backend's primitive) and ``Φ'`` enters the next segment.  The first
segment's ``Φ`` is the boundary mode's initial state ``Σ_j ω_j I[j] + ω_c cval``, a sum of
contributions of the segments that hold the samples ``j < L``.  So a chunked pass is:

1. per segment, in parallel: its end contribution ``E`` (from its last ``T`` samples, ``T``
   the length over which the weights exceed ``tol``) and its boundary contribution (from its
   first samples when they lie in ``j < L``) — cheap, no device work;
2. a scan over segments in traversal order of the affine maps ``Φ ↦ H[t1] Φ + E``
   (``S`` complex numbers per line per segment);
3. per segment, in parallel: ``y_0`` on the device plus the rank-``S`` correction
   ``Re Σ H Φ`` on its first ``R`` outputs.

Nothing is truncated that exceeds ``tol`` relative to the largest weight (1e-18 in float64,
1e-10 in float32, as for the boundary modes in :mod:`gfgpu._core.recursion`), so the result equals
the unsegmented pass within the input dtype's rounding.  The state is carried in complex128
on the host.  This is what :mod:`gfgpu._core.strips` (large images on one machine) and
:mod:`gfgpu.dask` (chunked arrays) run.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .lines import axis_view_shape
from .recursion import TOL, PassPlan

__all__ = ["Segment", "segments", "segments_at", "line_matrix", "end_state", "boundary_state", "carry_scan",
           "zero_state_pass", "add_correction"]


@dataclass(frozen=True, eq=False)
class Segment:
    """One segment ``[start, stop)`` (natural positions) of a pass over lines of ``n`` samples."""

    plan: PassPlan            # zero-state plan of the segment (no boundary weights)
    start: int
    stop: int
    reverse: bool
    end_weights: np.ndarray   # (S, T): weight of the segment's i-th LAST traversal sample in E
    response: np.ndarray      # (S, R): H at the segment's first R traversal outputs
    transfer: np.ndarray      # (S,):   H at t1 (product of lam over the segment)
    boundary: np.ndarray      # (S, B): omega on the segment's first B traversal samples
    boundary_c: np.ndarray    # (S,):   omega_c (first segment in traversal order only, else 0)

    @property
    def tail_rows(self):
        """Natural index range of the samples ``end_weights`` reads."""
        t = self.end_weights.shape[1]
        return (self.start, self.start + t) if self.reverse else (self.stop - t, self.stop)

    @property
    def head_rows(self):
        """Natural index range of the samples ``boundary`` reads."""
        b = self.boundary.shape[1]
        return (self.stop - b, self.stop) if self.reverse else (self.start, self.start + b)


def _trim(weights, tol):
    """Length of the prefix of ``weights`` (S, n) outside which every weight is below tol."""
    if weights.shape[1] == 0:
        return 0
    mag = np.abs(weights).max(axis=0)
    big = np.nonzero(mag > tol * max(float(mag.max()), 1e-300))[0]
    return int(big[-1]) + 1 if big.size else 0


def _cumprod(lam):
    """(S, n+1) products of lam[:, :k] for k = 0..n (first column 1)."""
    out = np.ones((lam.shape[0], lam.shape[1] + 1), np.complex128)
    with np.errstate(under="ignore", over="ignore", invalid="ignore"):
        np.cumprod(lam, axis=1, out=out[:, 1:])
    return out


@lru_cache(maxsize=256)
def _segment(plan, start, stop, dtype_str):
    tol = TOL[np.dtype(dtype_str)]
    n = plan.n
    t0, t1 = (n - stop, n - start) if plan.reverse else (start, stop)
    lam, kap = plan.lam[:, t0:t1], plan.kap[:, t0:t1]
    S, length = lam.shape
    sub = PassPlan(lam, kap, np.zeros((S, 0), np.complex128), np.zeros(S, np.complex128),
                   plan.tap, plan.reverse, plan.constant)
    # products of lam from the end backwards: weight of sample t1-1-i is (Π_{t1-i <= j < t1} lam) kap
    back = _cumprod(lam[:, ::-1])[:, :length]
    with np.errstate(under="ignore", invalid="ignore"):
        end = back * kap[:, ::-1]
    end = end[:, :_trim(end, tol)]
    fwd = _cumprod(lam)
    response, transfer = fwd[:, :length], fwd[:, length]
    response = response[:, :_trim(response, tol)]
    L = plan.omega.shape[1]
    boundary = plan.omega[:, t0:min(t1, L)] if t0 < L else np.zeros((S, 0), np.complex128)
    boundary = boundary[:, :_trim(boundary, tol)] if boundary.shape[1] else boundary
    boundary_c = plan.omega_c if t0 == 0 else np.zeros(S, np.complex128)
    seg = Segment(sub, start, stop, plan.reverse, np.ascontiguousarray(end),
                  np.ascontiguousarray(response), transfer, np.ascontiguousarray(boundary), boundary_c)
    for arr in (seg.end_weights, seg.response, seg.transfer, seg.boundary, seg.boundary_c):
        arr.setflags(write=False)
    return seg


def segments(plan, bounds, dtype):
    """Segments of ``plan``'s lines at natural ``bounds`` (``0 = b_0 < b_1 < ... = n``)."""
    bounds = [int(b) for b in bounds]
    if bounds[0] != 0 or bounds[-1] != plan.n or any(a >= b for a, b in zip(bounds[:-1], bounds[1:])):
        raise ValueError(f"bounds must rise strictly from 0 to the line length {plan.n}, got {bounds}")
    return [_segment(plan, a, b, np.dtype(dtype).str) for a, b in zip(bounds[:-1], bounds[1:])]


def segments_at(plan, start, stop, dtype):
    """The segment ``[start, stop)`` (natural positions) of ``plan``'s lines (cached)."""
    if not 0 <= start < stop <= plan.n:
        raise ValueError(f"segment [{start}, {stop}) must lie in [0, {plan.n})")
    return _segment(plan, int(start), int(stop), np.dtype(dtype).str)


def line_matrix(block, axis):
    """``block`` with ``axis`` first, as a 2-D ``(n, m)`` view when possible (lines = columns)."""
    moved = np.moveaxis(block, axis, 0)
    return moved.reshape(moved.shape[0], int(np.prod(moved.shape[1:], dtype=np.int64)))


def _traversal(rows, reverse):
    return rows[::-1] if reverse else rows


def _weighted(weights, rows):
    """``weights (S, T) @ rows (T, m)`` in float64, as complex (S, m)."""
    rows = np.asarray(rows, np.float64)
    return (weights.real @ rows) + 1j * (weights.imag @ rows)


def end_state(seg, tail):
    """Contribution ``E`` (S, m) of a segment, from its samples ``seg.tail_rows`` (natural order)."""
    t = seg.end_weights.shape[1]
    if t == 0:
        return np.zeros((seg.plan.sections, tail.shape[1]), np.complex128)
    rows = _traversal(tail, seg.reverse)      # traversal order, the segment's last t samples
    return _weighted(seg.end_weights, rows[::-1])


def boundary_state(seg, head, cval):
    """Boundary-mode contribution (S, m) of a segment, from its samples ``seg.head_rows``."""
    m = head.shape[1]
    out = np.zeros((seg.plan.sections, m), np.complex128) + (seg.boundary_c * float(cval))[:, None]
    if seg.boundary.shape[1]:
        out += _weighted(seg.boundary, _traversal(head, seg.reverse))
    return out


def carry_scan(segs, ends, initial):
    """States entering each segment (list in ``segs`` order) from the scan in traversal order.

    ``ends[i]`` is :func:`end_state` of ``segs[i]``; ``initial`` the summed boundary states.
    """
    order = range(len(segs) - 1, -1, -1) if segs[0].reverse else range(len(segs))
    states = [None] * len(segs)
    state = initial
    for i in order:
        states[i] = state
        state = segs[i].transfer[:, None] * state + ends[i]
    return states


def add_correction(seg, out, state, axis=0):
    """``out += Re Σ_s H_s Φ_s`` in place on the segment's first outputs along ``axis``.

    ``out`` is the segment's block (any shape); ``state`` is (S, m) with the lines in the
    order of :func:`line_matrix`.
    """
    r = seg.response.shape[1]
    if r == 0:
        return
    h = seg.response
    corr = h.real.T @ state.real - h.imag.T @ state.imag     # (r, m) float64, traversal order
    moved = np.moveaxis(out, axis, 0)                        # a view: written in place
    rows = moved[seg.stop - seg.start - r:] if seg.reverse else moved[:r]
    rows += _traversal(corr, seg.reverse).reshape(rows.shape).astype(out.dtype, copy=False)


def zero_state_pass(backend, src, dst, axis, segs_of_passes, shape=None):
    """Zero-state responses of a step's passes (summed) on device arrays ``src``, ``dst``.

    ``segs_of_passes``: one :class:`Segment` per pass, all covering the block's extent along
    ``axis``.  ``dst`` may not be ``src``.  ``shape``: the arrays' logical shape (default
    ``src.shape``; devices may fold leading axes).
    """
    view, line_axis = axis_view_shape(tuple(src.shape) if shape is None else tuple(shape), axis)
    s3, d3 = backend.reshape(src, view), backend.reshape(dst, view)
    for i, seg in enumerate(segs_of_passes):
        backend.recurse(s3, d3, line_axis, seg.plan, 0.0, accumulate=i > 0)
    return dst
