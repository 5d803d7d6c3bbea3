"""Spin and radial zoom blur along their true paths, on a polar grid about the centre.

A rotation about ``c`` moves every point along its circle, a zoom along its ray: in polar
coordinates ``(r, phi)`` about ``c`` both are motions along one array axis.  The image (its
cubic B-spline, :mod:`gfgpu.motion.spline`) is resampled onto ``n_r`` rings ``r = 0, 1, ...``
of ``n_phi`` angles each (:data:`gfgpu.motion.kernels.to_polar`; array ``(planes, n_r, n_phi)``,
angle contiguous, so the passes along the angle run along rows and those along the rays one
vector lane per angle), blurred along the rings or the rays, and what the blur changed (blurred
minus ``w`` times the unblurred samples, ``w`` near 1 where the blur is short, near 0 where it is
long) is resampled back and added to ``w`` times the image
(:data:`gfgpu.motion.kernels.from_polar`, :func:`_run_polar`): what the blur leaves alone comes
back as it was, not through two resamplings.

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
pixel everywhere.  The spin, whose passes run along the rings only, splits the rings into bands
at ``R/2, R/4, ...`` (:func:`polar_bands`), each with the angles its own outer ring needs: about
``4/3 π R²`` samples instead of ``2 π R²``.  The zoom runs along whole rays, on one band.  The
resampling blur of what moves is measured in ``docs/motion.md``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .. import greens
from .._core import strips
from .._core.job import copy_of_input
from .._core.program import run_axis_passes
from .._core.recursion import plan_pass
from .box import box_window
from .kernels import add_rows, box_lines, from_polar, to_polar
from .spline import line_coefficients, spline_coefficients
from .zoom import ray_zoom_pass

__all__ = ["polar_bands", "polar_grid", "polar_samples", "check_polar_cost", "check_center", "apply_spin",
           "apply_radial_zoom", "apply_radial_green_zoom"]

#: rings beyond the farthest pixel (the spline's support reaches two samples outward)
_EXTRA_RINGS = 4

#: rings of a band beyond its radii on each side: the radial prefilter's boundary at a band's
#: end reaches z^16 < 1e-9 into it, the spline two rings more
_SEAM = 18

#: the innermost band of a split grid reaches at least this radius (smaller bands would cost more
#: in seams than they save in angles)
_MIN_BAND = 64

#: blur length (px) at which the image keeps half its weight in the output (:func:`_run_polar`)
_KEEP_LENGTH = 1.0

#: largest ``k`` of the weight ``1/(1 + (k r)^2)``: the polar spline resamples ``w P``, whose 4th
#: radial derivative grows as ``k^4 P`` (the zoom of a coordinate image by u1 = 0.8, k = 0.44, put
#: the pre-image 0.6 px off within 5 px of the fixed point; at k <= 0.15, 0.10 px at most)
_KEEP_SLOPE = 0.15


def _angles(radius):
    """Angles of a ring of ``radius``: at most one pixel apart, a multiple of 16 (the passes along
    the rays run in vector lanes across the angles)."""
    return max(16, 16 * math.ceil(2.0 * math.pi * max(radius, 1.0) / 16.0))


def polar_bands(height, width, cy, cx, reach=1.0, split=False):
    """The polar grid about ``(cy, cx)`` as bands of rings: ``[(r0, n_r, n_phi, r_lo, r_hi), ...]``.

    One band (``split`` false): rings ``0 .. n_r - 1`` out to ``reach`` times the farthest pixel
    (windows that read outward) plus :data:`_EXTRA_RINGS`, ``n_r`` a multiple of 8 (the passes
    along the angle run 8 rings per vector; 16 in a split band that starts beyond ring 8), angles
    at most one pixel apart on the farthest pixel's ring.  ``split``: the radii are cut at half the
    farthest pixel's radius, a quarter, ... (down to :data:`_MIN_BAND`), and each band takes the
    angles its outer radius needs, with :data:`_SEAM` rings beyond its radii ``[r_lo, r_hi)`` on
    either side: ``2 pi R^2`` samples become about ``4/3 pi R^2``, arcs still at most one pixel
    apart.  Bands are listed outermost first.
    """
    radius = max(math.hypot(y - cy, x - cx) for y in (0, height - 1) for x in (0, width - 1))
    cuts = []
    while split and radius / 2 ** (len(cuts) + 1) >= _MIN_BAND:
        cuts.append(radius / 2 ** (len(cuts) + 1))
    edges = [math.inf] + cuts + [0.0]
    bands = []
    for hi, lo in zip(edges[:-1], edges[1:]):
        r0 = max(0, math.floor(lo) - _SEAM)
        end = math.ceil(radius * reach) + _EXTRA_RINGS if hi == math.inf else math.ceil(hi) + _SEAM
        n_r = 8 * math.ceil((end - r0) / 8)
        if split and n_r % 16 and r0 >= 8:
            # a split band takes whole groups of 16 rings (the row passes along the angle run 16 float32
            # rows per vector on a CPU; a partial group runs, and on a first call builds, another
            # kernel), the 8 more inward, where the band has _SEAM rings of margin: its outer rings,
            # and what its pixels read, are the 8-multiple's
            r0, n_r = r0 - 8, n_r + 8
        elif split and n_r % 16 and hi != math.inf:
            n_r += 8        # an inner band from ring 0: the 8 more beyond its outer seam
        bands.append((r0, n_r, _angles(min(hi, radius)), lo, hi))
    return bands


def polar_grid(height, width, cy, cx, reach=1.0):
    """``(n_r, n_phi)`` of the one-band polar grid (:func:`polar_bands`)."""
    return polar_bands(height, width, cy, cx, reach)[0][1:3]


#: a polar grid may hold at most this many samples per pixel of the image, beyond
#: :data:`POLAR_FLOOR` samples (a long thin strip, or a centre far outside, would otherwise cost
#: the square of its long side: a zoom of 3 x 5000 pixels sampled 4e7 points)
POLAR_PER_PIXEL = 64

#: samples per plane that any polar grid may hold, whatever the image's size
POLAR_FLOOR = 1 << 22


def polar_samples(height, width, cy, cx, reach=1.0, split=False):
    """Samples per image plane of the polar grid (:func:`polar_bands`)."""
    return sum(n_r * n_phi for _, n_r, n_phi, _, _ in polar_bands(height, width, cy, cx, reach, split))


def check_polar_cost(height, width, cy, cx, reach, split, what):
    """Refuse, before any work, a polar grid whose size the image's does not account for:
    more than :data:`POLAR_PER_PIXEL` samples per pixel beyond :data:`POLAR_FLOOR`."""
    samples = polar_samples(height, width, cy, cx, reach, split)
    if samples > POLAR_FLOOR + POLAR_PER_PIXEL * height * width:
        raise ValueError(f"{what}: its polar grid about center (row, col) = ({cy:g}, {cx:g}) would hold "
                         f"{samples} samples for {height} x {width} pixels (at most {POLAR_PER_PIXEL} per pixel "
                         f"beyond {POLAR_FLOOR}): the grid grows with the square of the farthest pixel's distance "
                         f"from the center, so an image this elongated, or a center this far off, is refused; "
                         f"crop the image, or blur a downscaled copy")


def check_center(cy, cx, height, width):
    # the grid's size grows with the centre's distance: keep it within a few image sizes
    reach = 2.0 * math.hypot(height, width)
    if math.hypot(cy - (height - 1) / 2.0, cx - (width - 1) / 2.0) > reach:
        raise ValueError(f"center (row, col) = ({cy:g}, {cx:g}) must lie within {reach:.0f} pixels of the "
                         f"image centre (twice the diagonal) for a spin or zoom on the polar grid")


def _run_polar(job, cy, cx, reach, blur, mode, cval, what, rate, split=False):
    """Resample to the polar grid, blur there, and add what the blur changed to the image.

    Resampled twice (to the polar grid and back), the image itself would lose detail, and much
    more where ``'constant'`` or ``'wrap'`` makes the extended image jump at the border (a jump that
    the polar spline, sampled between the pixels, cannot follow: a spin by 1e-6 degree lost 0.24
    of 2.0 on the border of a constant image).  So the output is ``w I + R(B P - w P)``: ``P`` the
    polar samples, ``B P`` the blurred ones, ``R`` the resampling back, and ``w = 1/(1 + (k r)^2)``
    with ``k r`` the blur's length at radius ``r`` (``k = rate``) over :data:`_KEEP_LENGTH`, ``k`` at
    most :data:`_KEEP_SLOPE`; ``w`` is sampled at the rings and read at each pixel by the radial
    spline that ``R`` applies, so that an image the blur leaves alone (a constant) comes back to
    rounding (the closed form at the pixel's radius differed from it by 2.6e-5 at k = 0.15).
    Where the blur is short, the image passes through untouched (a spin or zoom by ~0 is the
    identity in every mode); where it is long, the output is the resampled
    blur, whose smoothing hides the resampling error that the unblurred image would carry
    (``docs/motion.md``).

    ``blur(be, polar, pshape, scratch, extra, weights)`` returns ``B P - w P`` (``weights`` (n_r,):
    ``w`` at each ring) in ``polar``, ``scratch`` or ``extra()`` (one more array of ``pshape``).
    ``split``: the grid runs as bands of rings (:func:`polar_bands`), each blurred on its own
    (``pshape[2]`` is its number of angles) and added at its own radii.
    """
    be, dtype, shape = job.backend, job.dtype, job.shape
    height, width = shape[-2], shape[-1]
    check_center(cy, cx, height, width)
    check_polar_cost(height, width, cy, cx, reach, split, what)
    strips.require_whole_image(job, what)
    cval = job.scaled(cval)     # in job.data's units; after the refusals, which read no pixel
    planes = (math.prod(shape[:-2]), height, width)
    data = be.reshape(job.data, planes)
    bands = polar_bands(height, width, cy, cx, reach, split)
    # every band's polar arrays are the first samples of one workspace (the largest band's size), and so
    # is the image prefilter's scratch: a call takes each new page once (a first call on a new shape
    # pays for every new page it touches: ~5 ms per MB on a shared 2-core VM, as much as the blur)
    most = planes[0] * max(n_r * n_phi for _, n_r, n_phi, _, _ in bands)
    if split:
        # the split grid's two arrays are the halves of one block (work[1], which kernels that take plain
        # pointers read, first): its largest band is about half the one-band grid of the zooms, so the block
        # is of the size class of each zoom array, and a zoom after a spin (or a spin after a zoom) takes
        # its pages from the pool instead of new ones (a first call's main cost; docs/motion.md)
        stride = -(-most // 64) * 64        # the second array on a 256-byte boundary, as the arrays' starts
        block = be.empty((2 * stride,), dtype)
        work = [block[stride:stride + most], block[:most]]
        del block
    else:
        work = [be.empty((most,), dtype), be.empty((most,), dtype)]

    def carve(k, part_shape):
        while k >= len(work):
            work.append(be.empty((most,), dtype))
        return be.reshape(work[k][:math.prod(part_shape)], part_shape)

    size = math.prod(planes)
    fits = size <= most
    tmp = carve(0, planes) if fits else None
    # the image's coefficients are read only by the bands' to_polar, so they take the workspace's second
    # array, which the blur's scratch reuses after them (one image-sized block fewer to allocate: on a new
    # shape each new page costs 0.1-4 ms per MB on the shared 2-core VM): one band (the zooms) from its
    # start; split bands at its end, the outermost band (the largest, whose scratch needs the whole array)
    # run last and the inner ones' scratch before the coefficients
    inner = max((planes[0] * n_r * n_phi for _, n_r, n_phi, _, _ in bands[1:]), default=0)
    tail = (most - size) // 64 * 64         # on a 256-byte boundary, as the arrays' starts
    if fits and len(bands) == 1:
        out = carve(1, planes)
    elif fits and inner <= tail:
        out = be.reshape(work[1][tail:tail + size], planes)
        bands = bands[1:] + bands[:1]
    else:
        out = None
    coef = spline_coefficients(be, data, dtype, planes, (mode, mode), cval, tmp=tmp, out=out)
    del tmp, out
    result = job.result_buffer()
    out = be.reshape(result, planes)
    keep = min(abs(rate) / _KEEP_LENGTH, _KEEP_SLOPE)
    for r0, n_r, n_phi, r_lo, r_hi in bands:
        pshape = (planes[0], n_r, n_phi)        # radius on axis 1, angle on axis 2 (contiguous)
        polar = carve(0, pshape)
        to_polar(be, coef, polar, cy, cx, r0, mode, cval)
        scratch = carve(1, pshape)
        weights = 1.0 / (1.0 + (keep * (r0 + np.arange(n_r))) ** 2)
        # the pixels' own weight: the ring weights' radial spline (mirrored as the polar spline is),
        # what the resampling back gives the subtracted w P, so that w I + R(B P - w P) is I
        # wherever B leaves P alone (a constant image exactly, not to the spline's error in w)
        wcoef = ndimage.spline_filter1d(weights, order=3, mode="mirror") if keep else None
        change = blur(be, polar, pshape, scratch, lambda shape=pshape: carve(2, shape), weights)
        spare = scratch if change is not scratch else polar
        pcoef = spline_coefficients(be, change, dtype, pshape, ("mirror", "wrap"), tmp=spare, out=change)
        del polar, scratch, spare
        # each band writes its own pixels, the radii [r_lo, r_hi): together they cover [0, inf) once (each
        # pixel reads only its own image value, so out may be the image itself)
        from_polar(be, pcoef, data, out, cy, cx, r0, r_lo, r_hi, wcoef, only_band=True)
    return job.finish(result)


def _box_change(be, polar, coef, axis, window, mode, weights):
    """``B P - w P`` in ``polar`` (``P``) for the box window ``(a0, a1, b0, b1)`` along ``axis`` on the
    line coefficients ``coef`` of ``P``: ``P`` scaled by ``w`` in place, then subtracted by the box."""
    add_rows(be, polar, polar, weights - 1.0)
    return box_lines(be, coef, polar, axis, *window, mode, 0.0, polar)


def apply_spin(job, degrees, cy, cx, psf, displace, mode, cval):
    """Spin blur of ``job``'s image planes by ``degrees`` about ``(cy, cx)``, along the arcs."""
    def blur(be, polar, pshape, scratch, extra, weights):
        n_phi = pshape[2]
        d = math.radians(degrees) * n_phi / (2.0 * math.pi)     # samples along every ring
        if psf == "box":
            coef = line_coefficients(be, polar, scratch, job.dtype, pshape, 2, "wrap")
            a0, b0 = box_window(abs(d), displace, d < 0)
            return _box_change(be, polar, coef, 2, (a0, 1.0, b0, 1.0), "wrap", weights)
        if displace:
            out = run_axis_passes(be, polar, scratch, job.dtype, [greens.shift_pass(d)], "wrap", 0.0, 2, pshape)
        else:
            half = run_axis_passes(be, polar, scratch, job.dtype, [greens.shift_pass(-d / 2)], "wrap", 0.0, 2, pshape)
            out = run_axis_passes(be, half, extra(), job.dtype, [greens.shift_pass(d / 2)], "wrap", 0.0, 2, pshape)
        return add_rows(be, polar, out, -weights)

    if degrees == 0.0:
        return job.finish(copy_of_input(job))
    return _run_polar(job, cy, cx, 1.0, blur, mode, cval, "a spin blur (its polar grid holds the whole image)",
                      math.radians(degrees), split=True)


def apply_radial_green_zoom(job, u1, cy, cx, mode, cval):
    """G_U^(1) zoom of ``job``'s image planes at the rate ``u1`` about ``(cy, cx)``, along the rays.

    Each ray of the polar grid is a line from the fixed point: the exact affine recursion of
    :mod:`gfgpu.motion.zoom` (cell-integrated taps, moment correction) runs along it, outward
    for a zoom-in, inward from twice the farthest radius for a zoom-out (whose kernel reads
    beyond the output; the last ring's cell takes the rest of the tail, as the separable
    zoom's border does).
    """
    reach = 1.0 if u1 > 0 else 2.0

    def blur(be, polar, pshape, scratch, extra, weights):
        n_r = pshape[1]
        # the rays are the columns of the polar grid: one pass along axis 1 (adjacent angles in
        # vector lanes), then each ring's own tap and -w in one per-ring multiple
        line_pass, own = ray_zoom_pass(u1, n_r)
        be.recurse(polar, scratch, 1, plan_pass(line_pass, n_r, "constant", job.dtype), 0.0)
        return add_rows(be, polar, scratch, own - weights)

    return _run_polar(job, cy, cx, reach, blur, mode, cval, "a zoom blur (its polar grid holds the whole image)",
                      u1 / (1.0 + u1))


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

    def blur(be, polar, pshape, scratch, extra, weights):
        coef = line_coefficients(be, polar, scratch, job.dtype, pshape, 1, "mirror")
        return _box_change(be, polar, coef, 1, (0.0, a1, 0.0, b1), "mirror", weights)

    return _run_polar(job, cy, cx, b1, blur, mode, cval, "a zoom blur (its polar grid holds the whole image)",
                      u1 / (1.0 + u1))


