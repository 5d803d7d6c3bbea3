"""Uniform linear motion: the discrete G_u shift along a direction (chapter eq. 9)."""

from __future__ import annotations

import math

from .. import greens
from .._core.program import Program, direction_steps
from .params import velocity_pair

__all__ = ["uniform_motion_program"]


def uniform_motion_program(ndim, velocity, displace=True):
    """The :class:`~gfgpu.filters.Program` of a uniform motion by ``velocity = (dx, dy)``."""
    if ndim < 2:
        raise ValueError(f"motion blur needs an image (at least 2 dimensions), got {ndim}")
    dx, dy = velocity_pair(velocity)
    length = max(abs(dx), abs(dy))   # steps of the dominant axis (gfgpu.lines convention)
    if length == 0.0:
        return Program([])
    angle = math.atan2(dy, dx)
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
