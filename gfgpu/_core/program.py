"""Programs: what an operator computes, as passes along axes or directions, and how to run one.

A :class:`Program` is independent of arrays and devices.  The in-memory operators
(:func:`gfgpu._core.job.apply_program`), the strip executor (:mod:`gfgpu._core.strips`) and the
Dask wrappers (:mod:`gfgpu.dask`) all run programs with :func:`run_steps`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from .lines import axis_view_shape, direction, normalize_axis
from .oblique import run_oblique_passes
from .recursion import plan_pass
from .translation import (
    crop_index,
    decay_length,
    padded_view,
    step_offset,
    translate_index,
    window_index,
    without_offset,
)
from .validation import finite_scalar

__all__ = ["Program", "run_passes", "run_translation_checked", "is_checkable", "run_passes_checked", "run_steps",
           "direction_steps", "plane_axes", "axes_list", "per_axis", "is_axis_angle", "is_translation", "line_index"]


class Program(NamedTuple):
    """What an operator computes, independent of arrays and devices.

    ``steps`` is a list of ``(passes, axis, angle)`` applied in turn; the passes of one step
    run along the same lines and are summed.  ``axis`` is an array axis (``angle`` None) or
    None for the image-plane direction ``angle`` (the plane is ``plane``, the last two axes).
    """

    steps: list
    plane: tuple | None = None


def run_passes(be, src, dst, dtype, passes, mode, cval, axis=None, angle=None, plane=None, shape=None):
    """Apply ``passes`` (summed: the first writes, the rest accumulate) along an axis or direction.

    ``src`` and ``dst`` are distinct device arrays of the same shape; ``src`` is not modified.
    ``shape`` is the arrays' logical shape (default ``src.shape``; a device may store arrays of
    many dimensions with their leading axes folded).
    """
    shape = tuple(src.shape) if shape is None else tuple(shape)
    if angle is None:
        return run_axis_passes(be, src, dst, dtype, passes, mode, cval, axis, shape)
    if tuple(plane) != (len(shape) - 2, len(shape) - 1):
        raise ValueError("oblique filtering needs the image plane on the last two axes of the working array")
    # the plane is the last two axes, also of a device array whose leading axes are folded
    plane = (len(src.shape) - 2, len(src.shape) - 1)
    return run_oblique_passes(be, src, dst, dtype, passes, mode, cval, angle, plane)


def run_axis_passes(be, src, dst, dtype, passes, mode, cval, axis, shape):
    """``passes`` along array axis ``axis`` (see :func:`run_passes`).

    Translated passes (``offset != 0``) gather the translated input by index arithmetic: a
    pure translation is that one gather; otherwise the passes run on a window padded by their
    decay length and are cropped (:mod:`gfgpu._core.translation`).
    """
    offset = step_offset(passes)
    view, line_axis = axis_view_shape(shape, axis)
    n = view[line_axis]
    s3, d3 = be.reshape(src, view), be.reshape(dst, view)
    if offset == 0:
        run_plans(be, s3, d3, line_axis, [plan_pass(lp, n, mode, dtype) for lp in passes], cval)
        return dst
    if len(passes) == 1 and passes[0].is_identity:
        be.translate(s3, d3, line_axis, line_index(n, offset, mode), cval)
        return dst
    pad = decay_length(passes, dtype)
    if be.recurses_windows:
        run_windowed(be, s3, d3, line_axis, passes, offset, mode, cval, dtype)
        return dst
    view, line_axis, padded = padded_view(shape, axis, pad)
    window = be.empty(padded, dtype)
    result = be.empty(padded, dtype)
    be.gather(be.reshape(src, (-1,)), translate_index(view, line_axis, offset, pad, mode), cval,
              be.reshape(window, (-1,)))
    # the window's own extension differs from E's, but its influence has decayed below the
    # plan tolerance at the samples kept: any mode will do
    for i, lp in enumerate(passes):
        plan = plan_pass(without_offset(lp), padded[line_axis], "nearest", dtype)
        be.recurse(window, result, line_axis, plan, cval, accumulate=i > 0)
    be.gather(be.reshape(result, (-1,)), crop_index(view, line_axis, pad), 0.0, be.reshape(dst, (-1,)))
    return dst


_TILE = 16     # samples of a CPU tile: windowed passes pad to whole tiles


def run_windowed(be, src, dst, line_axis, passes, offset, mode, cval, dtype, check=False):
    """Translated ``passes`` on ``(B, N, M)`` device arrays as windowed recursions (backends with
    ``recurses_windows``): each pass reads the translated, extended line through the window
    index and writes only the samples on the line (the pad rounded up to whole 16-sample tiles).
    With ``check`` the first pass also tests the samples it reads and the result is that bool
    (:func:`window_reads_all` must hold, so that they are every sample of ``src``)."""
    n = src.shape[line_axis]
    pad = -(-decay_length(passes, dtype) // _TILE) * _TILE
    index = line_window(n, offset, pad, mode)
    for i, lp in enumerate(passes):
        plan = plan_pass(without_offset(lp), n + 2 * pad, "nearest", dtype)
        finite = be.recurse(src, dst, line_axis, plan, cval, accumulate=i > 0, window=(index, pad),
                            check=check and i == 0)
        if check and i == 0 and not finite:
            return False
    return True if check else None


def window_reads_all(n, passes, offset, mode, dtype):
    """True when the windowed pass of :func:`run_windowed` reads every sample of a line of ``n``
    (so a finite check riding on its reads covers the whole input): false for translations
    that move part of the line out of the window for good (e.g. ``'constant'`` beyond a pad)."""
    pad = -(-decay_length(passes, dtype) // _TILE) * _TILE
    if abs(offset) <= pad:
        return True     # sample j is read at window position j + offset, inside the window
    return _covers(n, offset, pad, mode)


@lru_cache(maxsize=32)
def _covers(n, offset, pad, mode):
    index = line_window(n, offset, pad, mode)
    seen = np.zeros(n, bool)
    seen[index[index >= 0]] = True
    return bool(seen.all())


@lru_cache(maxsize=32)
def line_window(n, offset, pad, mode):
    """The window index of a translated pass (:func:`~gfgpu._core.translation.window_index`),
    int32 and read-only: backends cache its upload by identity."""
    index = np.ascontiguousarray(window_index(n, offset, pad, mode), np.int32 if n < 2**31 else np.int64)
    index.setflags(write=False)
    return index


@lru_cache(maxsize=32)
def line_index(n, offset, mode):
    """The source index of each sample of a line of ``n`` translated by ``offset`` (-1: cval),
    read-only: backends cache its upload by identity."""
    index = window_index(n, offset, 0, mode)
    index.setflags(write=False)
    return index


def is_translation(passes, angle):
    """True when a step is a pure integer translation along an axis (one :meth:`translate`)."""
    return angle is None and len(passes) == 1 and passes[0].is_identity and passes[0].offset != 0


def is_checkable(passes, angle):
    """True when a step's first pass may read every input sample in one recursion along an axis,
    so the finite check can ride along (:func:`run_passes_checked`, which says whether it did)."""
    return angle is None and bool(passes) and not any(lp.is_identity for lp in passes)


def run_passes_checked(be, src, dst, dtype, passes, mode, cval, axis, shape):
    """Run a step for which :func:`is_checkable` holds and test, in its first pass's read of
    ``src``, that ``src`` is finite; returns that bool (``dst`` is written either way, the
    later passes are skipped when the input is not finite).  A translated step is checked so
    when it runs as windowed recursions that read every sample (:func:`window_reads_all`);
    otherwise nothing runs and the result is None (the caller checks the input on its own)."""
    view, line_axis = axis_view_shape(tuple(shape), axis)
    n = view[line_axis]
    s3, d3 = be.reshape(src, view), be.reshape(dst, view)
    offset = step_offset(passes)
    if offset == 0:
        return run_plans(be, s3, d3, line_axis, [plan_pass(lp, n, mode, dtype) for lp in passes], cval,
                         check=True)
    if not (be.recurses_windows and window_reads_all(n, passes, offset, mode, dtype)):
        return None
    return run_windowed(be, s3, d3, line_axis, passes, offset, mode, cval, dtype, check=True)


def run_plans(be, src, dst, line_axis, plans, cval, check=False):
    """The passes of one step on ``(B, N, M)`` device arrays: the first writes ``dst``, the rest
    accumulate; a causal/anticausal pair runs as one kernel where the backend fuses it
    (``fuses_pair``: its second sweep reads the first's output from the cache).  With ``check``
    the first pass also tests that ``src`` is finite and the result is that bool (the later
    passes are skipped when it is not)."""
    fuses = getattr(be, "fuses_pair", None)
    if len(plans) == 2 and fuses is not None and fuses(line_axis, plans[0], plans[1]):
        finite = be.recurse_pair(src, dst, line_axis, plans[0], plans[1], cval, check=check)
        return bool(finite) if check else None
    for i, plan in enumerate(plans):
        finite = be.recurse(src, dst, line_axis, plan, cval, accumulate=i > 0, check=check and i == 0)
        if check and i == 0 and not finite:
            return False
    return True if check else None


def run_translation_checked(be, src, dst, passes, mode, cval, axis, shape):
    """Run a pure translation step (:func:`is_translation`) and test, in the same read, that
    ``src`` is finite; returns that bool (``dst`` is written either way)."""
    view, line_axis = axis_view_shape(tuple(shape), axis)
    return bool(be.translate(be.reshape(src, view), be.reshape(dst, view), line_axis,
                             line_index(view[line_axis], step_offset(passes), mode), cval, check=True))


def run_steps(be, data, dtype, steps, mode, cval, plane=None, shape=None):
    """Apply ``steps`` in turn to the device array ``data`` (kept); the last result is returned.

    The strip executor and the Dask tasks run their in-block steps with this; ``shape`` as in
    :func:`run_passes`.
    """
    shape = tuple(data.shape) if shape is None else tuple(shape)
    cur = data
    for passes, axis, angle in steps:
        nxt = be.empty(shape, dtype)
        run_passes(be, cur, nxt, dtype, passes, mode, cval, axis=axis, angle=angle, plane=plane, shape=shape)
        cur = nxt
    return cur


def is_axis_angle(angle):
    """True when the direction ``angle`` (radians) is one of the array axes."""
    _, _, gamma = direction(angle)
    return abs(gamma) < 1e-12


def plane_axes(axes, ndim):
    """The (row, column) axes of the image plane, normalised; default the last two."""
    if axes is None:
        axes = (-2, -1)
    if len(axes) != 2:
        raise ValueError(f"axes must name two axes (rows, columns) of the image plane, got {axes!r}")
    ya, xa = (normalize_axis(a, ndim, "axes") for a in axes)
    if ya == xa:
        raise ValueError(f"axes must name two different axes, got {axes!r}")
    return ya, xa


def direction_steps(ndim, passes, angle, axes):
    """(steps, plane) for filtering along ``angle`` in the plane ``axes``: an axis pass when aligned."""
    ya, xa = plane_axes(axes, ndim)
    steep, reverse, gamma = direction(angle)
    if abs(gamma) < 1e-12:
        axis = ya if steep else xa
        # a reversed direction runs the passes the other way; offsets count along the direction
        flipped = [replace(p, reverse=p.reverse != reverse, offset=-p.offset if reverse else p.offset)
                   for p in passes]
        return [(flipped, axis, None)], None
    if (ya, xa) != (ndim - 2, ndim - 1):
        raise ValueError("oblique directions need the image plane on the last two axes; move the "
                         "channel axis first (e.g. numpy.moveaxis(image, -1, 0)) or pass channel_axis")
    return [(passes, None, angle)], (ya, xa)


def per_axis(value, axes, name):
    """One float per axis in ``axes`` from a scalar or a sequence (array-axis order)."""
    if isinstance(value, np.ndarray) and value.ndim != 1:
        if value.ndim == 0:         # what numpy.asarray makes of a scalar: the scalar (as scipy)
            return [finite_scalar(name, value[()])] * len(axes)
        raise ValueError(f"{name} must be a scalar or one value per axis ({len(axes)}), got an array of shape "
                         f"{value.shape}")
    if isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, str):
        vals = [finite_scalar(name, v) for v in value]
        if len(vals) != len(axes):
            raise ValueError(f"{name} must have one value per axis ({len(axes)}), got {len(vals)}")
        return vals
    return [finite_scalar(name, value)] * len(axes)


def axes_list(axes, ndim):
    """Normalised, distinct axes; None means all ``ndim`` axes."""
    if axes is None:
        return list(range(ndim))
    axes = [normalize_axis(a, ndim, "axes") for a in np.atleast_1d(axes)]
    if len(set(axes)) != len(axes):
        raise ValueError(f"axes must not repeat, got {axes!r}")
    return axes
