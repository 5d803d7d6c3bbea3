"""Passes along an image-plane direction that is not an array axis: shear, run, shear back.

For a direction whose dominant axis is x (``γ = tan θ``, ``|γ| <= 1``; x and y swap roles for
steep directions), the line through ``(x, ℓ + γx)`` becomes line ``ℓ`` of a sheared layout
(:func:`gfgpu._core.lines.shear_maps`): column ``x`` is read at ``ℓ + γx``, at the integer part
``ℓ + r[x]`` by a gather (exact) and the remaining delay ``d[x]`` (0, or between 2.05 and
3.05 samples) by a fractional-delay filter along the column, one per-line recursion
(:meth:`Backend.recurse_lines`).  The passes then run along the lines with
:meth:`Backend.recurse`; the same filter mirrored (delaying by ``d[x]`` instead of advancing)
and a second gather put every pixel back.  Cost: two gathers and two single-section recursions
per pixel besides the passes themselves, whatever the kernel's length.

The filter is Thiran's second-order allpass of delay ``d``,

    A_d(z) = (a2 + a1 z^-1 + z^-2) / (1 + a1 z^-1 + a2 z^-2),
    a1 = -2 (d - 2) / (d + 1),   a2 = (d - 1)(d - 2) / ((d + 1)(d + 2)),

whose complex-conjugate poles make it one section ``tap + Σ_m Re(kap lam^(m-1)) z^-m``:
``|A_d| = 1`` at every frequency (no blur), unit DC gain, and taps whose mean is exactly ``d``
and whose variance is exactly 0 (maximally flat group delay).  The forward filter runs
anticausally (it reads ahead by ``d``), the inverse one causally; where the passes leave a
column unchanged the two cancel exactly.  What remains is a dispersion at high frequencies
across the direction (measured in ``docs/derivations.md``, "Oblique directions"); the
displacement of every pixel is exact (both filters have exact first moments), so nothing is
quantised to whole pixels.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from .lines import direction, shear_maps, shear_offsets
from .recursion import TOL, line_plans, plan_pass
from .translation import crop_index, decay_length, step_offset, translate_index, without_offset

__all__ = ["run_oblique_passes", "run_oblique_steps", "run_oblique_lines", "allpass_delay", "column_delays"]


def allpass_delay(d):
    """``(lam, kap, tap)`` arrays of Thiran's second-order allpass of delay ``d`` (2 < d < 4):
    impulse response ``tap`` at 0 and ``Re(kap lam^(m-1))`` at ``m >= 1`` (module docstring)."""
    d = np.asarray(d, np.float64)
    a1 = -2.0 * (d - 2.0) / (d + 1.0)
    a2 = (d - 1.0) * (d - 2.0) / ((d + 1.0) * (d + 2.0))
    # impulse response h[0], h[1], h[2] of the difference equation
    h0 = a2
    h1 = a1 * (1.0 - a2)
    h2 = 1.0 - a1 * h1 - a2 * h0
    lam = 0.5 * (-a1 + 1j * np.sqrt(4.0 * a2 - a1 * a1))    # complex poles for d > 2
    # h[m] = Re(kap lam^(m-1)): Re kap = h[1], Re(kap lam) = h[2]
    kap = h1 + 1j * (h1 * lam.real - h2) / lam.imag
    return lam, kap, h0


@lru_cache(maxsize=16)
def column_delays(steps, gamma):
    """``(lam, kap, tap, delay, margin)`` of the columns' delay filters (identity where d = 0).

    ``margin``: lines after which every filter's response has decayed below the float64 plan
    tolerance (about 40: ``|lam|`` is at most 0.33).
    """
    _, d = shear_offsets(steps, gamma)
    moving = d != 0
    lam = np.zeros(steps, np.complex128)
    kap = np.zeros(steps, np.complex128)
    tap = np.ones(steps)
    margin = 0
    if moving.any():
        lam[moving], kap[moving], tap[moving] = allpass_delay(d[moving])
        mag = np.abs(lam[moving])
        scale = np.maximum(np.abs(kap[moving]), 1.0)
        margin = int(np.max(np.ceil(np.log(TOL[np.dtype(np.float64)] / scale) / np.log(mag)))) + 1
    for a in (lam, kap, tap):
        a.setflags(write=False)
    return lam, kap, tap, d, margin


@lru_cache(maxsize=16)
def _column_plans(steps, gamma, lines, dtype_str):
    """Per-column plans of the forward (advance by d) and inverse (delay by d) filters, or None."""
    lam, kap, tap, d, _ = column_delays(steps, gamma)
    if not d.any():
        return None, None
    ident = d == 0
    # the layout's margin makes the state at the lines' ends irrelevant: any mode will do
    forward = line_plans(lam, kap, tap, True, lines, "nearest", dtype_str, ident)
    inverse = line_plans(lam, kap, tap, False, lines, "nearest", dtype_str, ident)
    return forward, inverse


def run_oblique_passes(be, src, dst, dtype, passes, mode, cval, angle, plane, transposed=None):
    """Apply ``passes`` (summed) along the image-plane direction ``angle`` (radians from +x toward +y)
    in the plane ``plane`` = (row axis, column axis), the last two axes of ``src``.

    ``src`` and ``dst`` are distinct device arrays of the same shape; ``src`` is not modified.
    A pass's ``offset`` translates along the direction of traversal, in steps of the dominant
    axis.  ``transposed`` chooses the layout of the sheared lines, ``(B, steps, lines)`` or
    ``(B, lines, steps)``; by default the one whose last axis is the image's x axis (transposed
    for steep directions), so that both gathers read and write along rows.
    """
    return run_oblique_steps(be, src, dst, dtype, [passes], mode, cval, angle, plane, transposed)


def run_oblique_steps(be, src, dst, dtype, groups, mode, cval, angle, plane, transposed=None):
    """Apply several steps along the same direction ``angle`` in turn, inside one shear: each
    group of ``groups`` is a list of passes (summed), as :func:`run_oblique_passes` takes.

    The result equals running the steps one after another except that the image is resampled
    twice in all rather than twice per step.
    """
    def along(be, rows_in, rows_out, axis, reverse):
        for passes in groups:
            oriented = [replace(lp, reverse=lp.reverse != reverse, offset=-lp.offset if reverse else lp.offset)
                        for lp in passes]
            _passes_along(be, rows_in, rows_out, axis, dtype, oriented, mode, cval)
            rows_in, rows_out = rows_out, rows_in
        return rows_in

    return run_oblique_lines(be, src, dst, dtype, along, mode, cval, angle, plane, transposed)


def run_oblique_lines(be, src, dst, dtype, along, mode, cval, angle, plane, transposed=None):
    """Run any line operation along the direction ``angle``: shear, ``along``, shear back.

    ``along(be, rows_in, rows_out, axis, reverse)`` processes the lines of the sheared layout,
    which run along ``axis`` (1 or 2) of two ``(B, N, M)`` device arrays, and returns the one that
    holds its result (it may overwrite ``rows_in``); ``reverse`` is True where the direction
    points toward decreasing indices along the lines.  Lines carry the continuous direction:
    one sample per step of the dominant axis.  Arguments otherwise as :func:`run_oblique_passes`.
    """
    shape = tuple(src.shape)
    ya, xa = plane
    if (ya, xa) != (len(shape) - 2, len(shape) - 1):
        raise ValueError("oblique filtering needs the image plane on the last two axes of the "
                         "working array")
    height, width = shape[-2], shape[-1]
    batch = int(np.prod(shape[:-2], dtype=np.int64))
    steep, reverse, gamma = direction(angle)
    steps = height if steep else width
    transposed = steep if transposed is None else bool(transposed)
    margin = column_delays(steps, gamma)[4]
    maps = shear_maps(height, width, batch, float(angle), mode, margin, transposed)
    lines = maps.lines
    forward, inverse = _column_plans(steps, gamma, lines, np.dtype(dtype).str)
    layout = (batch, steps, lines) if transposed else (batch, lines, steps)
    axis, across = (1, 2) if transposed else (2, 1)
    rows_in = be.empty(layout, dtype)
    rows_out = be.empty(layout, dtype)
    be.gather(be.reshape(src, (-1,)), maps.shear, cval, be.reshape(rows_in, (-1,)))
    if forward is not None:
        be.recurse_lines(rows_in, rows_in, across, forward, cval)
    rows_in = along(be, rows_in, rows_out, axis, reverse)
    if inverse is not None:
        be.recurse_lines(rows_in, rows_in, across, inverse, cval)
    be.gather(be.reshape(rows_in, (-1,)), maps.unshear, 0.0, be.reshape(dst, (-1,)))
    return dst


def _passes_along(be, src, dst, axis, dtype, passes, mode, cval):
    """``passes`` along ``axis`` (1 or 2) of the ``(B, N, M)`` layout; a translated step
    (``offset``) runs as :mod:`gfgpu._core.translation` describes: gather, padded passes, crop."""
    view = tuple(src.shape)
    n = view[axis]
    offset = step_offset(passes)
    if offset == 0:
        for i, lp in enumerate(passes):
            be.recurse(src, dst, axis, plan_pass(lp, n, mode, dtype), cval, accumulate=i > 0)
        return
    if len(passes) == 1 and passes[0].is_identity:
        be.gather(be.reshape(src, (-1,)), translate_index(view, axis, offset, 0, mode), cval,
                  be.reshape(dst, (-1,)))
        return
    pad = decay_length(passes, dtype)
    padded = list(view)
    padded[axis] += 2 * pad
    window = be.empty(tuple(padded), dtype)
    result = be.empty(tuple(padded), dtype)
    be.gather(be.reshape(src, (-1,)), translate_index(view, axis, offset, pad, mode), cval,
              be.reshape(window, (-1,)))
    for i, lp in enumerate(passes):
        be.recurse(window, result, axis, plan_pass(without_offset(lp), padded[axis], "nearest", dtype), cval,
                   accumulate=i > 0)
    be.gather(be.reshape(result, (-1,)), crop_index(view, axis, pad), 0.0, be.reshape(dst, (-1,)))
