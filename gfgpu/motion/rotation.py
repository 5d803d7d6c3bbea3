"""Spin blur: a rotation by three Green's shears (Paeth), each line shifted by its own amount."""

from __future__ import annotations

import math

import numpy as np

from .. import greens
from .._core import strips
from .._core.job import copy_of_input
from .._core.recursion import line_plans
from .._core.validation import finite_scalar
from .params import center_point

__all__ = ["ROTATION_MAX_DEGREES", "rotation_angle", "rotation_shears", "apply_rotation"]

ROTATION_MAX_DEGREES = 90.0   # tan(θ/2) <= 1: the shears stay at most one pixel per pixel


def rotation_angle(velocity):
    theta = finite_scalar("velocity (rotation angle in degrees)", velocity)
    if abs(theta) > ROTATION_MAX_DEGREES:
        raise ValueError(f"velocity (rotation angle) must lie in [-{ROTATION_MAX_DEGREES:g}, "
                         f"{ROTATION_MAX_DEGREES:g}] degrees for the three-shear rotation, got {theta!r}")
    return theta


def rotation_shears(degrees):
    """``[(axis, rate), ...]``: the three shears whose product is the rotation by ``degrees``.

    In (x, y) = (column, row) coordinates a point p moves to ``c + R (p - c)``,
    R = [[cos θ, sin θ], [-sin θ, cos θ]] (counter-clockwise on screen for θ > 0, since y
    points down), and ``R = X(a) Y(b) X(a)`` with ``a = tan(θ/2)``, ``b = -sin θ`` (Paeth
    1986): ``X(a)`` moves row y by ``a (y - y_c)`` along x (axis -1), ``Y(b)`` column x by
    ``b (x - x_c)`` along y (axis -2).

    Examples
    --------
    >>> [(axis, round(rate, 4)) for axis, rate in rotation_shears(90.0)]
    [(-1, 1.0), (-2, -1.0), (-1, 1.0)]
    """
    theta = math.radians(degrees)
    a, b = math.tan(theta / 2.0), -math.sin(theta)
    return [(-1, a), (-2, b), (-1, a)]


def _shear_plans(rate, n_lines, centre, n, mode, dtype):
    """Per-line plans of a shear: line i displaced by ``rate (i - centre)`` (the G_u shift),
    built for all lines at once (:func:`gfgpu.greens.shift_coefficients_many`; lines
    symmetric about the centre share their coefficients)."""
    d = rate * (np.arange(n_lines) - centre)
    identity = np.abs(d) <= 1e-9
    amounts, where = np.unique(np.where(identity, 1.0, np.abs(d)), return_inverse=True)
    lam, kap, tap = (c[where] for c in greens.shift_coefficients_many(amounts))
    return line_plans(lam, kap, tap, d < 0, n, mode, dtype, identity)


def apply_rotation(job, degrees, center, displace, mode, cval):
    """Rotate ``job``'s image planes by ``degrees`` about ``center = (row, col)`` (default the middle)."""
    height, width = job.shape[-2], job.shape[-1]
    cy, cx = center_point(center, height, width)
    strips.require_whole_image(job, "a rotation (its shears move whole rows and columns)")
    if degrees == 0.0:
        return job.finish(copy_of_input(job))
    shears = rotation_shears(degrees) if displace else \
        rotation_shears(-degrees / 2.0) + rotation_shears(degrees / 2.0)
    be, dtype = job.backend, job.dtype
    batch = int(np.prod(job.shape[:-2], dtype=np.int64))
    cur = be.reshape(job.data, (batch, height, width))
    bufs = [be.empty((batch, height, width), dtype) for _ in range(2)]
    for i, (axis, rate) in enumerate(shears):
        # rows (axis -1): line = row y, about y_c; columns (axis -2): line = column x, about x_c
        lines, n, centre = (height, width, cy) if axis == -1 else (width, height, cx)
        plans = _shear_plans(rate, lines, centre, n, mode, dtype)
        nxt = bufs[i % 2]
        be.recurse_lines(cur, nxt, 2 if axis == -1 else 1, plans, cval)
        cur = nxt
    result = job.result_buffer()
    be.copy(cur, be.reshape(result, (batch, height, width)))
    return job.finish(result)
