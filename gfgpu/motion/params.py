"""Argument parsing shared by the motion operators (velocities, zoom rates, centres, colour axes).

Every pair is in array-axis order, rows then columns: velocities ``(vy, vx)``, zoom rates
``(u1_y, u1_x)``, centres ``(row, col)``.  The kinds of motion and the point-spread functions
that use them are the table of :mod:`gfgpu.motion.kinds`.
"""

from __future__ import annotations

import math

import numpy as np

from .._core.arrays import as_kind, host_array, kind_of
from .._core.validation import finite_scalar, integer

__all__ = ["U1_MIN", "pair", "velocity_pair", "zoom_u1", "zoom_factors", "center_point", "move_channels"]


def pair(value, name):
    """A pair of finite floats from a scalar (used twice) or a length-2 sequence."""
    arr = np.asarray(value, dtype=object)
    if arr.ndim == 0:
        arr = np.array([value, value], dtype=object)
    if arr.shape != (2,):
        raise ValueError(f"{name} must be a number or a pair of numbers, got {value!r}")
    return tuple(finite_scalar(name, v) for v in arr)


def velocity_pair(velocity):
    """``(vy, vx)``: the displacement of a uniform motion, rows (down) then columns (right)."""
    if np.ndim(velocity) == 0:
        raise ValueError(f"velocity must be a pair (vy, vx) in pixels (rows, cols) for kind='uniform', "
                         f"got {velocity!r}")
    return pair(velocity, "velocity")


U1_MIN = 2.0 - 2.0 * math.sqrt(2.0)   # below: beta of eq. 12 is imaginary (no oscillating G_U^(1))


def zoom_u1(name, u1):
    """One zoom rate, checked against the range of a bounded real G_U^(1)."""
    if not U1_MIN < u1 < 2.0:
        raise ValueError(f"{name} must lie in (2 - 2*sqrt(2), 2) ~ (-0.8284, 2) for a bounded G_U^(1) "
                         f"(eq. 12: alpha < 0 for zoom-in u1 > 0, real beta for zoom-out u1 < 0), "
                         f"got {u1!r}")
    return u1


def zoom_factors(velocity):
    """``(u1_y, u1_x)``: the zoom rates along the rows and the columns (one number: both)."""
    u1y, u1x = pair(velocity, "velocity (zoom u1)")
    return zoom_u1("velocity (zoom u1)", u1y), zoom_u1("velocity (zoom u1)", u1x)


def center_point(center, height, width):
    """``(row, col)`` of a fixed point; ``None`` is the image centre ``((H - 1)/2, (W - 1)/2)``."""
    if center is None:
        return (height - 1) / 2.0, (width - 1) / 2.0
    return pair(center, "center (row, col)")


def move_channels(image, channel_axis):
    """Put a colour axis first (numpy input only); returns (array, undo)."""
    if channel_axis is None:
        return image, lambda out: out
    kind = kind_of(image)     # torch in, torch out: the result goes back as the caller's kind
    arr = host_array(image, "image")
    ax = integer("channel_axis", channel_axis)     # not int(): 1.5, True and '-1' are errors
    if not -arr.ndim <= ax < arr.ndim or arr.ndim < 3:
        raise ValueError(f"channel_axis={channel_axis} is out of range for an input of shape {arr.shape} "
                         f"(a colour image needs 3 dimensions)")
    ax %= arr.ndim
    moved = np.ascontiguousarray(np.moveaxis(arr, ax, 0))
    return moved, lambda out: as_kind(np.moveaxis(out, 0, ax), kind, image)
