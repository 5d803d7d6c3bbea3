"""Passes along an image-plane direction that is not an array axis: shear, run, shear back.

For a direction whose dominant axis is x (``γ = tan θ``, ``|γ| <= 1``; x and y swap roles for
steep directions), the line through ``(x, ℓ + γx)`` becomes line ``ℓ`` of a sheared layout
(:func:`gfgpu._core.lines.shear_maps`): column ``x`` is read at ``ℓ + γx``, at the integer part
``ℓ + r[x]`` by a gather (exact) and the remaining delay ``d[x]`` (0, or between 2.3 and
3.3 samples) by a fractional-delay filter along the column, two cascaded per-line recursions
(:meth:`Backend.recurse_lines`).  The passes then run along the lines with
:meth:`Backend.recurse`; the same filter mirrored (delaying by ``d[x]`` instead of advancing)
and a second gather put every pixel back.  Cost: two gathers and four single-section recursions
per pixel besides the passes themselves, whatever the kernel's length.

The filter is Thiran's third-order maximally flat allpass of delay ``d``,

    A_d(z) = z^-3 D(1/z) / D(z),   D(z) = 1 + a1 z^-1 + a2 z^-2 + a3 z^-3,
    a_k = (-1)^k C(3, k) Π_{n=0..3} (d - 3 + n) / (d - 3 + k + n),

split into a real pole and a complex-conjugate pair (:func:`allpass_delay`), each one section
``tap + Σ_m Re(kap lam^(m-1)) z^-m``: ``|A_d| = 1`` at every frequency (no blur), and taps whose
moments of order 0 to 6 equal ``d^p`` exactly (maximally flat group delay).  Its phase error,
spread over the delays of the range, is 8e-4 rad at 1/8 cycle/px and 6.6e-2 rad at 1/4 (the
former second-order filter on 2.05..3.05: 4.1e-2 and 0.58).  The forward filter runs
anticausally (it reads ahead by ``d``), the inverse one causally; where the passes leave a
column unchanged the two cancel exactly.  The displacement of every pixel is exact (both
filters have exact first moments), so nothing is quantised to whole pixels.  Measured in
``docs/derivations.md``, "Oblique directions".

A backend with ``shear_lines`` (OpenCL) runs each shear as one kernel: the gather by index
arithmetic on a table of O(H + W) numbers (:func:`gfgpu._core.lines.shear_geometry`) and both
allpass sections in the same sweep, each started at the steady state of the first sample its walk
reads (its line's first, or one up to a vector's spread of shear offsets before it: the CPU
kernels walk a vector of adjacent columns down the image rows together) (:class:`ShearPlan`);
the others run the gather with whole-image index maps and one per-line recursion per section.
Both read the same layout and give the same values (the start state's influence is below the
plan tolerance at the lines read back).  The layout holds about
``(across + |γ| steps + 2 margin) x steps`` samples: a thin strip along a slope can cost far
more than its pixels, so more than :data:`LAYOUT_PER_PIXEL` samples per pixel (beyond
:data:`LAYOUT_FLOOR`) are refused before any work (:func:`check_oblique_cost`).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import replace
from functools import lru_cache

import numpy as np

from . import lines as _lines
from .lines import direction, shear_geometry, shear_maps, shear_offsets
from .recursion import TOL, line_plans, plan_pass
from .translation import crop_index, decay_length, step_offset, translate_index, without_offset

__all__ = ["run_oblique_passes", "run_oblique_steps", "run_oblique_lines", "allpass_delay", "column_delays",
           "thiran_denominator", "ORDER", "ShearPlan", "shear_plan", "check_oblique_cost", "layout_samples",
           "LAYOUT_PER_PIXEL", "LAYOUT_FLOOR"]


#: order of the Thiran allpass that realises the columns' sub-pixel delays
ORDER = 3


def thiran_denominator(d, order=ORDER):
    """``(m, order + 1)`` denominator coefficients ``a[0] = 1, a[1], ..., a[order]`` of Thiran's
    maximally flat allpass of delay ``d`` (one row per delay; stable for ``d > order - 1``):
    ``a[k] = (-1)^k C(order, k) Π_{n=0..order} (d - order + n) / (d - order + k + n)``."""
    d = np.asarray(d, np.float64).reshape(-1)
    a = np.ones((len(d), order + 1))
    for k in range(1, order + 1):
        prod = np.full(len(d), (-1.0) ** k * math.comb(order, k))
        for n in range(order + 1):
            prod *= (d - order + n) / (d - order + k + n)
        a[:, k] = prod
    return a


def allpass_delay(d):
    """The stages of Thiran's third-order allpass of delay ``d`` (``2 < d < 4``), as two lists
    ``(lam, kap, tap)`` of arrays: a complex-conjugate pole pair and a real pole.

    Each stage is an allpass with impulse response ``tap`` at 0 and ``Re(kap lam^(m-1))`` at
    ``m >= 1``; their cascade is ``A_d(z) = z^-3 D(1/z) / D(z)``, ``D`` the Thiran denominator
    (module docstring).  The real pole ``p`` (a root of ``D``, found by eigenvalues and polished
    by Newton's method on ``D`` itself, so that it is accurate relative to its size even where the
    three poles gather near 0 as ``d -> 3``) gives ``(z^-1 - p) / (1 - p z^-1)``; the quadratic
    ``z^2 + b1 z + b2 = D / (z - p)`` (``b1 = a1 + p``, ``b2 = -a3 / p``) the second-order stage
    ``(b2 + b1 z^-1 + z^-2) / (1 + b1 z^-1 + b2 z^-2)``.
    """
    d = np.asarray(d, np.float64).reshape(-1)
    a = thiran_denominator(d, 3)
    comp = np.zeros((len(d), 3, 3))
    comp[:, 0, :] = -a[:, 1:]
    comp[:, 1, 0] = comp[:, 2, 1] = 1.0
    roots = np.linalg.eigvals(comp) if len(d) else np.zeros((0, 3), np.complex128)
    p = np.take_along_axis(roots, np.argmin(np.abs(roots.imag), axis=1)[:, None], 1)[:, 0].real
    for _ in range(6):     # Newton on D(p) = p^3 + a1 p^2 + a2 p + a3
        f = ((p + a[:, 1]) * p + a[:, 2]) * p + a[:, 3]
        df = (3 * p + 2 * a[:, 1]) * p + a[:, 2]
        p = p - np.where(df != 0, f / np.where(df != 0, df, 1.0), 0.0)
    b1 = a[:, 1] + p
    b2 = -a[:, 3] / p
    # the pair: h[0] = b2, h[1] = b1 (1 - b2), h[2] = 1 - b1 h[1] - b2 h[0]; Re kap = h[1], Re(kap lam) = h[2]
    h1 = b1 * (1.0 - b2)
    h2 = 1.0 - b1 * h1 - b2 * b2
    lam = 0.5 * (-b1 + 1j * np.sqrt(4.0 * b2 - b1 * b1))
    kap = h1 + 1j * (h1 * lam.real - h2) / lam.imag
    pair = (lam, kap, b2)
    real = (p + 0j, 1.0 - p * p + 0j, -p)
    return [pair, real]


@lru_cache(maxsize=16)
def column_delays(steps, gamma, dtype_str="<f8"):
    """``(stages, delay, margin)`` of the columns' delay filters (identity where d = 0).

    ``stages``: list of ``(lam, kap, tap)`` arrays over the columns, one per cascaded section;
    ``margin``: lines after which the cascade's response has decayed below the plan tolerance
    of ``dtype_str`` (the sum of the stages' decay lengths).  Read-only views of the direction's
    per-column table (:func:`_direction_columns`): column ``t`` depends on ``gamma`` and ``t``
    alone, so an image of another size reuses the columns already designed.
    """
    table = _direction_columns(int(steps), gamma, dtype_str)
    moving = table.moving[:steps]
    d = table.delay[:steps]
    if not moving.any():
        return [], d, 0
    stages = []
    margin = 0
    for (lam, kap, tap), decay in zip(table.stages, table.decay):
        margin += max(int(np.max(decay[:steps][moving])), 0) + 1
        stages.append((lam[:steps], kap[:steps], tap[:steps]))
    return stages, d, margin


class _Columns:
    """The per-column design of a direction for its first ``steps`` columns (:func:`_direction_columns`)."""

    def __init__(self, steps, delay, moving, stages, decay):
        self.steps, self.delay, self.moving, self.stages, self.decay = steps, delay, moving, stages, decay


_DIRECTIONS = 16            # directions whose column tables are kept (least recently used dropped)
_directions = OrderedDict()  # (gamma, dtype, design) -> _Columns
_directions_lock = threading.Lock()


def _direction_columns(steps, gamma, dtype_str):
    """The column delays of direction ``gamma`` for at least ``steps`` columns: delay ``d``,
    ``moving = d != 0``, per stage ``(lam, kap, tap)`` and the decay length of each column's
    section (``ceil(log(tol / max(|kap|, 1)) / log |lam|)``, where it moves).

    Every value of column ``t`` is computed from ``gamma * t`` alone, by element-wise operations
    and one 3 x 3 eigenvalue problem per column, so the table of the longest image seen serves
    every shorter one and a longer one designs only its extra columns; tables are made a quarter
    longer than asked, so an image that grows a little designs none.  At most
    :data:`_DIRECTIONS` directions are kept, each about 1.25 times as long as the longest image
    seen along it (about 100 bytes per column).
    """
    # the design in use is part of the key (a design study may swap the filter or the delay range)
    key = (float(gamma), dtype_str, allpass_delay, _lines.DELAY_MIN)
    with _directions_lock:
        hit = _directions.get(key)
        if hit is not None:
            _directions.move_to_end(key)
    if hit is not None and hit.steps >= steps:
        return hit
    have = 0 if hit is None else hit.steps
    # a quarter more columns than asked (whole 64s): an image that grows a little later designs none
    steps = -(-(steps + steps // 4) // 64) * 64
    _, d = shear_offsets(steps, gamma)
    moving = d != 0
    new = moving[have:]
    tol = TOL[np.dtype(dtype_str)]
    designed = allpass_delay(d[have:][new]) if new.any() else []
    count = len(hit.stages) if hit is not None and hit.stages else len(designed)
    stages, decay = [], []
    for i in range(count):
        # columns that do not move: the identity (lam = kap = 0, tap = 1), no decay
        lam = np.zeros(steps, np.complex128)
        kap = np.zeros(steps, np.complex128)
        tap = np.ones(steps)
        dec = np.full(steps, -np.inf)
        if hit is not None and hit.stages:
            for arr, old in zip((lam, kap, tap, dec), (*hit.stages[i], hit.decay[i])):
                arr[:have] = old
        if designed:
            lam_m, kap_m, tap_m = designed[i]
            part = slice(have, steps)
            lam[part][new], kap[part][new], tap[part][new] = lam_m, kap_m, tap_m
            mag = np.maximum(np.abs(lam_m), 1e-300)
            scale = np.maximum(np.abs(kap_m), 1.0)
            dec[part][new] = np.ceil(np.log(tol / scale) / np.log(mag))
        for arr in (lam, kap, tap, dec):
            arr.setflags(write=False)
        stages.append((lam, kap, tap))
        decay.append(dec)
    d.setflags(write=False)
    moving.setflags(write=False)
    table = _Columns(steps, d, moving, stages, decay)
    with _directions_lock:
        _directions[key] = table
        if len(_directions) > _DIRECTIONS:
            _directions.popitem(last=False)
    return table


@lru_cache(maxsize=16)
def _column_plans(steps, gamma, lines, dtype_str):
    """Per-column plans of the forward (advance by d) and inverse (delay by d) cascades: two
    lists of :class:`~gfgpu._core.recursion.LinePlans`, one per stage (empty: no delay)."""
    stages, d, _ = column_delays(steps, gamma, dtype_str)
    ident = d == 0
    # the layout's margin makes the state at the lines' ends irrelevant: any mode will do
    forward = [_one_sense(line_plans(lam, kap, tap, True, lines, "nearest", dtype_str, ident), True)
               for lam, kap, tap in stages]
    inverse = [line_plans(lam, kap, tap, False, lines, "nearest", dtype_str, ident) for lam, kap, tap in stages]
    return forward, inverse


def _one_sense(plans, reverse):
    """``plans`` with every line traversed in the sense ``reverse``, the identity lines too (their
    sense changes nothing): the backends run adjacent lines of one sense together in vector lanes
    and fall back to one line at a time where senses mix (every column with ``d = 0``)."""
    plans.reverse[:] = reverse      # a fresh array of line_plans'
    return plans


class ShearPlan:
    """The two shears of an oblique direction for a backend that fuses each one's gather and
    column allpass into one kernel (``Backend.shear_lines``): the layout's geometry
    (:func:`gfgpu._core.lines.shear_geometry`) and, per column, the two sections of
    :func:`column_delays` with their steady-state gains (``kap / (1 - lam)``: the state after a
    constant input, with which each line starts).  Immutable; ``packed(dtype)`` gives the arrays
    a kernel reads: coef ``(steps, 11)`` (lam re, im, kap re, im, tap, gain re, im of the pair;
    pole, kap, tap, gain of the real section), base, shift, start (int32)."""

    def __init__(self, geometry, stages, plane):
        self.geometry, self.plane = geometry, tuple(plane)
        (lam, kap, tap), (p, k, tapb) = stages
        gain = kap / (1.0 - lam)
        coef = np.stack([lam.real, lam.imag, kap.real, kap.imag, tap, gain.real, gain.imag,
                         p.real, k.real, tapb, (k / (1.0 - p)).real], axis=1)
        coef.setflags(write=False)
        self.coef = coef
        self._packed = {}

    def packed(self, dtype):
        return self.grouped(1).packed(dtype)

    def grouped(self, lanes):
        """The plan with its coefficients grouped for kernels that run ``lanes`` adjacent columns
        in vector lanes: ``packed(dtype)`` gives coef ``(groups, 11, lanes)`` (columns past the
        last repeat it), base, shift, start.  One object per ``lanes`` (backends key uploads by
        identity)."""
        hit = self._packed.get(lanes)
        if hit is None:
            hit = self._packed[lanes] = _GroupedShear(self, lanes)
        return hit


class _GroupedShear:
    """:meth:`ShearPlan.grouped`."""

    def __init__(self, plan, lanes):
        self.plan, self.lanes, self._arrays = plan, int(lanes), {}

    def packed(self, dtype):
        dtype = np.dtype(dtype)
        if dtype not in self._arrays:
            coef, g, lanes = self.plan.coef, self.plan.geometry, self.lanes
            groups = -(-len(coef) // lanes)
            cols = np.minimum(np.arange(groups * lanes), len(coef) - 1)
            grouped = np.ascontiguousarray(coef[cols].reshape(groups, lanes, -1).transpose(0, 2, 1), dtype)
            self._arrays[dtype] = (grouped, g.base, g.shift, g.start)
        return self._arrays[dtype]


@lru_cache(maxsize=8)
def shear_plan(height, width, angle, mode, margin, transposed, dtype_str):
    """The :class:`ShearPlan` of a direction on ``(height, width)`` planes (cached: backends
    upload its arrays once, keyed by identity)."""
    steep, _, gamma = direction(angle)
    steps = height if steep else width
    stages = column_delays(steps, gamma, dtype_str)[0]
    return ShearPlan(shear_geometry(height, width, angle, mode, margin, transposed), stages, (height, width))


#: a sheared layout may hold at most this many samples per pixel of the image plane, beyond
#: :data:`LAYOUT_FLOOR` samples: its lines span the long side times the slope, so a thin strip
#: along a steep-ish direction would otherwise cost far more than its size (3 x 5000 along
#: (3, 7): 12 M samples for 15,000 pixels)
LAYOUT_PER_PIXEL = 64

#: samples per plane that any sheared layout may hold, whatever the image's size
LAYOUT_FLOOR = 1 << 22


def layout_samples(height, width, angle, dtype):
    """Samples per plane of the sheared layout of ``angle`` on ``(height, width)`` planes."""
    steep, _, gamma = direction(angle)
    steps, across = (height, width) if steep else (width, height)
    margin = column_delays(steps, gamma, np.dtype(dtype).str)[2]
    r, _ = shear_offsets(steps, gamma)
    lines = across - int(r.min()) + int(r.max()) + 2 * margin
    return steps * lines


def check_oblique_cost(height, width, angle, dtype):
    """Refuse, before any work, a sheared layout whose size the plane's does not account for:
    more than :data:`LAYOUT_PER_PIXEL` samples per pixel beyond :data:`LAYOUT_FLOOR`."""
    samples = layout_samples(height, width, angle, dtype)
    if samples > LAYOUT_FLOOR + LAYOUT_PER_PIXEL * height * width:
        deg = math.degrees(float(angle))
        raise ValueError(f"an oblique pass at {deg:.4g} degrees over {height} x {width} pixels would run on "
                         f"{samples} sheared samples (at most {LAYOUT_PER_PIXEL} per pixel beyond {LAYOUT_FLOOR}): "
                         f"its lines span the long side times the direction's slope, so a strip this thin along "
                         f"this direction is refused; pad the image across its short side, or blur it along "
                         f"an axis")


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
    check_oblique_cost(height, width, angle, dtype)
    steep, reverse, gamma = direction(angle)
    steps = height if steep else width
    transposed = steep if transposed is None else bool(transposed)
    stages, _, margin = column_delays(steps, gamma, np.dtype(dtype).str)
    axis, across = (1, 2) if transposed else (2, 1)
    fused = getattr(be, "shear_lines", None)
    if fused is not None and len(stages) == 2:
        # gather and column allpass in one kernel each way (no index arrays, no extra sweeps)
        plan = shear_plan(height, width, float(angle), mode, margin, transposed, np.dtype(dtype).str)
        g = plan.geometry
        layout = (batch, g.steps, g.lines) if transposed else (batch, g.lines, g.steps)
        rows_in = be.empty(layout, dtype)
        rows_out = be.empty(layout, dtype)
        fused(src, rows_in, plan, True, cval)
        rows_in = along(be, rows_in, rows_out, axis, reverse)
        fused(rows_in, dst, plan, False, cval)
        return dst
    maps = shear_maps(height, width, batch, float(angle), mode, margin, transposed)
    lines = maps.lines
    forward, inverse = _column_plans(steps, gamma, lines, np.dtype(dtype).str)
    layout = (batch, steps, lines) if transposed else (batch, lines, steps)
    rows_in = be.empty(layout, dtype)
    rows_out = be.empty(layout, dtype)
    be.gather(be.reshape(src, (-1,)), maps.shear, cval, be.reshape(rows_in, (-1,)))
    for plans in forward:
        be.recurse_lines(rows_in, rows_in, across, plans, cval)
    rows_in = along(be, rows_in, rows_out, axis, reverse)
    for plans in inverse:
        be.recurse_lines(rows_in, rows_in, across, plans, cval)
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
