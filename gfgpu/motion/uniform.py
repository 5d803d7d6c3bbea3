"""Uniform linear motion: the discrete G_u shift along a direction (chapter eq. 9)."""

from __future__ import annotations

import math

from .. import greens
from .._core.program import Program, direction_steps
from .._core.validation import SCALE_RANGE
from .params import velocity_pair

__all__ = ["uniform_motion_program"]


def uniform_motion_program(ndim, velocity, displace=True):
    """The :class:`~gfgpu._core.program.Program` of a uniform motion on ``(..., H, W)`` arrays.

    Parameters
    ----------
    ndim : int
        Number of dimensions of the array (>= 2; the image plane is the last two axes).
    velocity : pair of float
        ``(vy, vx)``: the displacement in pixels during the exposure, rows (down) then columns
        (right), array-axis order.
    displace : bool, optional
        True: content moves by ``velocity``; False: blurred in place (see
        :func:`gfgpu.motion.motion_blur`).

    Returns
    -------
    Program

    Raises
    ------
    ValueError
        ``ndim < 2``, or a ``velocity`` that is not a pair of finite numbers.

    Examples
    --------
    >>> len(uniform_motion_program(2, (0.0, 12.5)).steps), len(uniform_motion_program(2, (0, 0)).steps)
    (1, 0)
    """
    if ndim < 2:
        raise ValueError(f"motion blur needs an image (at least 2 dimensions), got {ndim}")
    vy, vx = velocity_pair(velocity)
    length = max(abs(vx), abs(vy))   # steps of the dominant axis (gfgpu._core.lines convention)
    if length == 0.0:
        return Program([])
    if length > SCALE_RANGE[1]:
        raise ValueError(f"velocity must be at most {SCALE_RANGE[1]:g} pixels along each axis, got {velocity!r} "
                         f"(float64 cannot resolve the decay of a longer blur)")
    angle = math.atan2(vy, vx)       # radians from +x (columns) toward +y (rows)
    if displace:
        parts = [greens.shift_pass(length)]
    else:
        # anticausal half then causal half: the PSF is the autocorrelation of one half-shift
        # kernel (symmetric, single-peaked); both halves have mean exactly -L/2 and +L/2.
        parts = [greens.shift_pass(-length / 2), greens.shift_pass(length / 2)]
    steps, plane = [], None
    for lp in parts:
        s, plane = direction_steps(ndim, [lp], angle, (-2, -1))
        steps += s
    return Program(steps, plane)
