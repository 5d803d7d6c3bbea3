"""Uniform motion with the box point-spread function: a uniform exposure along the path.

Content at every time of the shutter interval is weighted equally: the output at ``x`` is the
mean of the image over the segment from ``x - v`` to ``x`` (``displace=True``, trailing: content
moves from its position by ``v``) or from ``x - v/2`` to ``x + v/2`` (centred).  Along the
lines of the direction (an array axis, or the sheared layout of :mod:`gfgpu._core.oblique`,
which follows the continuous direction) the window's mean is a difference of running sums of
the line's cubic B-spline (its coefficients along the line are two recursions,
:mod:`gfgpu.motion.spline`): the fused kernel :data:`gfgpu.motion.kernels.box_lines`
slides the window with one running sum, so fractional lengths are exact, and starts it in
closed form (beyond the line whole periods of the extension, or its geometric approach to the
edge value), so the cost per pixel does not depend on the length.  Beyond the image the spline
is the one of the image extended by ``mode`` (for ``"nearest"`` the edge pixel's value, not the
edge coefficient's: :func:`gfgpu.motion.spec.coef_taps`).
"""

from __future__ import annotations

import math

from .._core.lines import axis_view_shape, direction
from .._core.oblique import run_oblique_lines
from .kernels import box_lines
from .spline import line_coefficients

__all__ = ["box_window", "apply_uniform_box"]


def box_window(length, displace, reverse):
    """``(a0, b0)``: the window ``[k + a0, k + b0]`` of sample ``k`` along lines on which content
    moves by ``length`` samples toward higher indices (toward lower ones if ``reverse``)."""
    if not displace:
        return -length / 2.0, length / 2.0
    return (0.0, length) if reverse else (-length, 0.0)


def apply_uniform_box(job, vy, vx, displace, mode, cval):
    """Box blur of ``job``'s image planes along ``(vy, vx)``; returns the finished result."""
    be, dtype, shape = job.backend, job.dtype, job.shape
    length = max(abs(vy), abs(vx))      # samples along the lines: steps of the dominant axis
    steep, reverse, gamma = direction(math.atan2(vy, vx))
    a0, b0 = box_window(length, displace, reverse)
    result = job.result_buffer()
    if abs(gamma) < 1e-12:
        view, line_axis = axis_view_shape(shape, len(shape) - (2 if steep else 1))
        coef = line_coefficients(be, be.reshape(job.data, view), be.empty(view, dtype), dtype, view, line_axis,
                                 mode, cval)
        box_lines(be, coef, be.reshape(result, view), line_axis, a0, 1.0, b0, 1.0, mode, cval)
        return job.finish(result)

    def along(be, rows_in, rows_out, axis, rev):
        line_coefficients(be, rows_in, rows_out, dtype, tuple(rows_in.shape), axis, mode, cval)
        box_lines(be, rows_out, rows_in, axis, a0, 1.0, b0, 1.0, mode, cval)
        return rows_in

    batch = math.prod(shape[:-2])
    planes = (batch,) + tuple(shape[-2:])
    run_oblique_lines(be, be.reshape(job.data, planes), be.reshape(result, planes), dtype, along, mode, cval,
                      math.atan2(vy, vx), (1, 2))
    return job.finish(result)
