"""Rotation angles of the spin blur, and Paeth's three-shear factorisation of a rotation.

The spin blur itself runs along the arcs on a polar grid (:mod:`gfgpu.motion.polar`).  The
shears (each line shifted by its own amount with the Green shift) are kept as a building block
for comparisons (``benchmarks/oblique.py``): their blur runs along three straight strokes,
not along the arc.
"""

from __future__ import annotations

import math

import numpy as np

from .. import greens
from .._core.recursion import line_plans
from .._core.validation import finite_scalar

__all__ = ["ROTATION_MAX_DEGREES", "rotation_angle", "rotation_shears"]

ROTATION_MAX_DEGREES = 360.0   # one turn: beyond it, every ring's window wraps over itself


def rotation_angle(velocity):
    theta = finite_scalar("velocity (rotation angle in degrees)", velocity)
    if abs(theta) > ROTATION_MAX_DEGREES:
        raise ValueError(f"velocity (rotation angle) must lie in [-{ROTATION_MAX_DEGREES:g}, "
                         f"{ROTATION_MAX_DEGREES:g}] degrees (one turn), got {theta!r}")
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
