"""Spin and radial zoom blur along their true paths, on a polar grid about the centre.

A rotation about ``c`` moves every point along its circle, a zoom along its ray: in polar
coordinates ``(r, phi)`` about ``c`` both are motions along one array axis.  The image (its
cubic B-spline, :mod:`gfgpu.motion.spline`) is resampled onto ``n_r`` rings ``r = 0, 1, ...``
of ``n_phi`` angles each (:data:`gfgpu.motion.kernels.to_polar`; array ``(planes, n_phi, n_r)``,
radius contiguous, so the passes along the angle run one vector lane per ring), blurred along the rings or
the rays, and resampled back (:data:`gfgpu.motion.kernels.from_polar`).

- **Spin** by ``θ``: content at ``phi`` moves to ``phi + θ``, i.e. ``D = θ n_phi / 2π`` samples
  along every ring, the same on every ring: one shift-invariant pass along the rows of the
  polar grid with periodic boundaries (``mode="wrap"`` is exact there).  The box is the
  running-sum window of :mod:`gfgpu.motion.box`; G_u is the chapter's recursion
  (:func:`gfgpu.greens.shift_pass`, mean exactly ``D``).  A point at radius ``r`` is blurred
  along its arc of length ``r θ``.
- **Green zoom** (``u1_y = u1_x``): the exact affine G_U^(1) recursion of
  :mod:`gfgpu.motion.zoom` along every ray, a line from the fixed point
  (:func:`gfgpu.motion.zoom.ray_zoom_pass`).
- **Zoom** (box, ``u1_y = u1_x``): pixel ``x`` gathers uniformly along the segment from ``x`` to
  its pre-image ``c + (x - c)/(1 + u1)`` (a camera moving toward the scene at constant speed:
  the pre-image moves linearly in time), i.e. the radii ``[r/(1 + u1), r]``, a window whose ends
  grow linearly along the ray: the same running-sum kernel with slopes ``(1/(1+u1), 1)``.

Both are O(1) per pixel whatever the angle or the rate: two spline prefilters (recursions),
two resamplings of 16 coefficients per sample and one running sum or recursion per sample.
``n_phi = ceil(2π R)`` angles on the outermost ring ``R`` keep the arc spacing at most one
pixel everywhere.  The resampling blur (a spin by 0 through the grid) is measured in
``docs/motion.md``.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .. import greens
from .._core import strips
from .._core.job import copy_of_input
from .._core.program import run_axis_passes
from .._core.recursion import plan_pass
from .box import box_window
from .kernels import box_lines, from_polar, to_polar
from .spline import line_coefficients, spline_coefficients
from .zoom import ray_zoom_pass

__all__ = ["polar_grid", "apply_spin", "apply_radial_zoom", "apply_radial_green_zoom"]

#: rings beyond the farthest pixel (the spline's support reaches two samples outward)
_EXTRA_RINGS = 4


def polar_grid(height, width, cy, cx, reach=1.0):
    """``(n_r, n_phi)`` of the polar grid about ``(cy, cx)``: rings out to ``reach`` times the
    farthest pixel (windows that read outward), a multiple of 8 (the vector lanes of the passes
    along the angle, which run across the rings); angles spaced at most one pixel on the
    outermost image ring."""
    radius = max(math.hypot(y - cy, x - cx) for y in (0, height - 1) for x in (0, width - 1))
    n_r = 8 * math.ceil((math.ceil(radius * reach) + _EXTRA_RINGS) / 8)
    n_phi = max(16, 16 * math.ceil(2.0 * math.pi * max(radius, 1.0) / 16.0))
    return n_r, n_phi


def _check_center(cy, cx, height, width):
    # the grid's size grows with the centre's distance: keep it within a few image sizes
    reach = 2.0 * math.hypot(height, width)
    if math.hypot(cy - (height - 1) / 2.0, cx - (width - 1) / 2.0) > reach:
        raise ValueError(f"center (row, col) = ({cy:g}, {cx:g}) must lie within {reach:.0f} pixels of the "
                         f"image centre (twice the diagonal) for a spin or zoom on the polar grid")


def _run_polar(job, cy, cx, reach, blur, mode, cval, what):
    """Resample to the polar grid, ``blur(be, polar, shape, scratch)`` -> blurred polar array
    (``polar`` or ``scratch``, both of ``shape``), resample back."""
    be, dtype, shape = job.backend, job.dtype, job.shape
    height, width = shape[-2], shape[-1]
    _check_center(cy, cx, height, width)
    strips.require_whole_image(job, what)
    planes = (math.prod(shape[:-2]), height, width)
    n_r, n_phi = polar_grid(height, width, cy, cx, reach)
    pshape = (planes[0], n_phi, n_r)        # angle on axis 1, radius on axis 2 (contiguous)
    coef = spline_coefficients(be, be.reshape(job.data, planes), dtype, planes, (mode, mode), cval)
    polar = be.empty(pshape, dtype)
    to_polar(be, coef, polar, cy, cx, mode, cval)
    del coef
    scratch = be.empty(pshape, dtype)       # one buffer of the grid's size reused by every step
    blurred = blur(be, polar, pshape, scratch)
    spare = scratch if blurred is polar else polar
    pcoef = spline_coefficients(be, blurred, dtype, pshape, ("wrap", "mirror"), tmp=spare, out=blurred)
    result = job.result_buffer()
    from_polar(be, pcoef, be.reshape(result, planes), cy, cx)
    return job.finish(result)


def apply_spin(job, degrees, cy, cx, psf, displace, mode, cval):
    """Spin blur of ``job``'s image planes by ``degrees`` about ``(cy, cx)``, along the arcs."""
    def blur(be, polar, pshape, scratch):
        n_phi = pshape[1]
        d = math.radians(degrees) * n_phi / (2.0 * math.pi)     # samples along every ring
        if psf == "box":
            coef = line_coefficients(be, polar, scratch, job.dtype, pshape, 1, "wrap")
            a0, b0 = box_window(abs(d), displace, d < 0)
            box_lines(be, coef, polar, 1, a0, 1.0, b0, 1.0, "wrap", 0.0)
            return polar
        steps = [[greens.shift_pass(d)]] if displace else [[greens.shift_pass(-d / 2)], [greens.shift_pass(d / 2)]]
        cur, nxt = polar, scratch
        for passes in steps:
            run_axis_passes(be, cur, nxt, job.dtype, passes, "wrap", 0.0, 1, pshape)
            cur, nxt = nxt, cur
        return cur

    if degrees == 0.0:
        return job.finish(copy_of_input(job))
    return _run_polar(job, cy, cx, 1.0, blur, mode, cval, "a spin blur (its polar grid holds the whole image)")


@lru_cache(maxsize=4)
def _ray_maps(planes, n_phi, n_r, inward):
    """Gather maps polar grid -> duplicated ray layout ``(planes, n_phi, 2 n_r)`` and back
    (:func:`gfgpu.motion.zoom.ray_zoom_pass`); read-only (backends cache their upload)."""
    k = np.arange(n_r)
    sample = (n_r - 1 - k) if inward else k                  # the sample at positions 2k, 2k + 1
    line = np.arange(planes * n_phi)[:, None]
    itype = np.int32 if planes * n_phi * 2 * n_r < 2**31 else np.int64
    spread = (line * n_r + np.repeat(sample, 2)[None, :]).astype(itype).reshape(-1)
    read = 2 * ((n_r - 1 - k) if inward else k) + 1           # where sample k's output is
    collect = (line * (2 * n_r) + read[None, :]).astype(itype).reshape(-1)
    for arr in (spread, collect):
        arr.setflags(write=False)
    return spread, collect


def apply_radial_green_zoom(job, u1, cy, cx, mode, cval):
    """G_U^(1) zoom of ``job``'s image planes at the rate ``u1`` about ``(cy, cx)``, along the rays.

    Each ray of the polar grid is a line from the fixed point: the exact affine recursion of
    :mod:`gfgpu.motion.zoom` (cell-integrated taps, moment correction) runs along it, outward
    for a zoom-in, inward from twice the farthest radius for a zoom-out (whose kernel reads
    beyond the output; the last ring's cell takes the rest of the tail, as the separable
    zoom's border does).
    """
    reach = 1.0 if u1 > 0 else 2.0

    def blur(be, polar, pshape, scratch):
        planes, n_phi, n_r = pshape
        spread, collect = _ray_maps(planes, n_phi, n_r, u1 < 0)
        rows_in = be.empty((planes, n_phi, 2 * n_r), job.dtype)
        rows_out = be.empty((planes, n_phi, 2 * n_r), job.dtype)
        be.gather(be.reshape(polar, (-1,)), spread, 0.0, be.reshape(rows_in, (-1,)))
        be.recurse(rows_in, rows_out, 2, plan_pass(ray_zoom_pass(u1, n_r), 2 * n_r, "constant", job.dtype), 0.0)
        be.gather(be.reshape(rows_out, (-1,)), collect, 0.0, be.reshape(polar, (-1,)))
        return polar

    return _run_polar(job, cy, cx, reach, blur, mode, cval, "a zoom blur (its polar grid holds the whole image)")


def zoom_window(u1, displace):
    """``(a1, b1)``: the radii ``[a1 r, b1 r]`` that the output at radius ``r`` averages."""
    pre = 1.0 / (1.0 + u1)          # the pre-image's radius, per unit radius
    if displace:
        return min(pre, 1.0), max(pre, 1.0)
    half = abs(1.0 - pre) / 2.0      # centred: the path's middle at r
    return 1.0 - half, 1.0 + half


def apply_radial_zoom(job, u1, cy, cx, displace, mode, cval):
    """Box zoom blur of ``job``'s image planes at the rate ``u1`` about ``(cy, cx)``, along the rays."""
    a1, b1 = zoom_window(u1, displace)

    def blur(be, polar, pshape, scratch):
        coef = line_coefficients(be, polar, scratch, job.dtype, pshape, 2, "mirror")
        box_lines(be, coef, polar, 2, 0.0, a1, 0.0, b1, "mirror", 0.0)
        return polar

    return _run_polar(job, cy, cx, b1, blur, mode, cval, "a zoom blur (its polar grid holds the whole image)")


