"""Per-pixel velocity fields: every pixel blurred along its own path (the post-process model).

The pixel at ``x`` gathers the image along the straight path ``x - t v(x)``, ``t`` over the
shutter, weighted by the point-spread function in ``t`` (:data:`gfgpu.motion.spec.PSF_CODES`):
the box (uniform exposure, ``t`` in ``[0, 1]``, or ``[-1/2, 1/2]`` centred) or the chapter's
G_u along the path (``u = |v|``: mean exactly one velocity; centred: the autocorrelation of
G_{|v|/2}).  The image is the cubic B-spline through its samples (:mod:`gfgpu.motion.spline`).
Two rules integrate the path (``motion_blur(..., quadrature=...)`` selects; ``docs/motion.md`` has the
measurements):

``"gauss"`` (the default; :func:`gfgpu.motion.spec.field_rule_reference`): a rule whose size depends
only on the pixel's velocity, read from tables computed once in float64 (:func:`gfgpu.motion.spec.rule_table`).
Box: ``ceil(L / 2) + 1`` Gauss-Legendre nodes over the whole support, ``L`` the dominant component
``max(|vy|, |vx|)`` (spectral accuracy on band-limited content: one node per 2 px of path).  G_u: its
support cut at ``t = 6`` velocities (the tail, < 2e-3 of the mass, given to the last node) and sampled
by the trapezoidal rule in a graded variable (:func:`gfgpu.motion.spec.gauss_rule`): nodes 2.25 px
apart along the path where G_u holds its mass (``t <= 1.5``), the spacing growing as ``e^{t/2}`` to at
most 5 px in its tail, ``max(12, ceil(1.736 |v|))`` intervals for the Euclidean length ``|v|`` (24 at
least centred), plus the pixel itself with the correction for G_u's kink at ``t = 0``.  A smooth weight
at uniform steps aliases only at the steps' own frequency, so this rule is more accurate than 3-node
Gauss-Legendre cells of 2 px per node (which alias at a third of the cell's frequency) with a third
fewer samples.  Cost per pixel: ``ceil(L / 2) + 1`` samples (box) or ``max(12, ceil(1.736 |v|)) + 1``
(G_u: 54 at |v| = 30) of 16 coefficients, 1 for a still pixel, at most 64 and 316 (the tables: paths
up to 126 px box by the dominant component, 181 px G_u by the length; every path of at most 128 px
along each axis fits).  Against a rendering of 512 exactly warped copies at |v| <= 30
(``docs/motion.md``): 0.02-0.23 % (box) and 0.4-0.6 % (G_u) on Gaussian-filtered noise (sigma 2 px)
under smooth, split, rotation, zoom, shear and random fields; on six photographs 0.7-8.7 % (box) and
0.6-8.1 % (G_u), grass 7-18 %, where sharp edges and fine texture put detail at 0.25-0.5 cycles/px
that the node spacing aliases; up to 5.5 % (G_u) on noise band-limited at 0.25 cycles/px.  Those
inputs want ``"exact"``, within its budget (below): G_u at |v| = 30 fits it only on images of about
50 x 50 px; larger ones are refused before any work.

``"exact"`` (:func:`gfgpu.motion.spec.field_blur_reference`): the support cut into ``n`` equal
cells of at most one pixel of ``L``, each integrated by 3-point Gauss-Legendre quadrature (exact
for the spline along an axis wherever a cell holds no knot) with the cell's exact PSF mass.  A
uniform field gives the uniform box to 2e-4 on white noise.  Cost per pixel: ``3 ceil(L)``
samples for the box (3 at least), ``3 max(ceil(18 L), 36)`` for G_u (whose tail runs to 18
velocities before its mass falls below float32 rounding; 72 cells at least centred), never more
than :data:`FIELD_CELLS` cells (the budget) for the paths that fit in it.  Beyond the budget the
cells would grow longer than a pixel and alias (a 4096-px box field of noise came out 0.45 off),
so a field whose paths need more cells runs with its exact cells when their total is within the
budget on average or within :data:`FIELD_TOTAL` samples, and is refused before any work
otherwise (:func:`field_cells`).  A field whose longest path exceeds the Gauss rule's tables also
runs the exact cells (one rule per call).  The prefilter is two recursions per axis.

On OpenCL the Gauss rule samples from the coefficients' rows side by side in pairs with a margin of
the image extended by the mode around them, as wide as the field's farthest node (:func:`reach`
sizes it; ``gfgpu.motion.field_kernels._opencl.margin``), so a path that leaves the image samples as
one inside it (no boundary test per node); results equal the unpadded kernel's within float32
rounding.
"""

from __future__ import annotations

import math

import numpy as np

from .kernels import field_blur
from .kernels import field_rule as rule_kernel
from .spline import spline_coefficients

__all__ = ["FIELD_MAX", "FIELD_DENSITY", "FIELD_CELLS", "FIELD_TOTAL", "FIELD_RULES", "is_field", "check_field",
           "field_cells", "check_quadrature", "reach", "rule_fits", "apply_field"]

#: the rules a field is blurred with: ``"gauss"`` (the default: a Gauss rule of a few nodes per path,
#: :func:`gfgpu.motion.spec.field_rule_reference`) and ``"exact"`` (cells of at most one pixel,
#: :func:`gfgpu.motion.spec.field_blur_reference`)
FIELD_RULES = ("gauss", "exact")


#: largest velocity component of a field, in pixels (the cost per pixel grows with it)
FIELD_MAX = 4096.0

#: quadrature cells per pixel of the dominant component along each path
FIELD_DENSITY = 1.0

#: most cells of one pixel's path, per PSF code (box, G_u, centred box, centred G_u): the
#: per-pixel budget, 3 samples of 16 coefficients each (at least the PSF's fewest cells)
FIELD_CELLS = (32, 144, 32, 144)

#: spline samples a field may cost in all when a path needs more cells than :data:`FIELD_CELLS`
#: (its exact cells are then used, never longer ones)
FIELD_TOTAL = 4_000_000


def is_field(velocity):
    """True when ``velocity`` is an array of 3 dimensions (a per-pixel field)."""
    return np.ndim(velocity) == 3


def check_field(field, shape):
    """``field`` as a ``(2, H, W)`` array matching the image plane of ``shape``: a copy in its own
    precision (float32 or float64; integers as float64), so that a float32 field, the usual one, goes
    to the device as it is (a float64 copy of a 2048^2 field and its way back to float32 cost more
    than a third of the box kernel's time)."""
    arr = np.asarray(field)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.float16:
        raise TypeError(f"velocity field must be a real float or integer array, got dtype {arr.dtype}")
    if arr.shape != (2,) + tuple(shape[-2:]):
        raise ValueError(f"velocity field must have shape (2, H, W) = (2, {shape[-2]}, {shape[-1]}) "
                         f"(rows, cols components, like skimage's optical flow), got {arr.shape}")
    arr = arr.astype(arr.dtype if arr.dtype in (np.float32, np.float64) else np.float64)
    # no temporary: the largest |component| is NaN or inf exactly where a component is (min and max propagate NaN)
    peak = float(max(-arr.min(), arr.max()))
    if not math.isfinite(peak):
        raise ValueError("velocity field must be finite")
    if peak > FIELD_MAX:
        raise ValueError(f"velocity field components must lie within ±{FIELD_MAX:g} pixels, got {peak:g}")
    return arr


def field_cells(field, code, planes=1):
    """The cells per pixel that ``field`` is run with: each path's own ``psf_cells`` where none
    exceeds :data:`FIELD_CELLS` (the budget, exact within it), otherwise the same unbounded cells
    when their total stays within the budget on average or within :data:`FIELD_TOTAL` samples.

    Returns the ``most`` argument of the field kernel (the budget, or 0: unbounded).

    Raises
    ------
    ValueError
        A field whose paths are too long for both (before any work): past the budget, cells
        longer than a pixel sample the spline too sparsely (0.45 off a 4096-px box blur of noise),
        and their exact count would cost more than the limit.
    """
    from .spec import psf_cells
    length = np.max(np.abs(field), axis=0)
    cells = psf_cells(code, length, FIELD_DENSITY)
    most = FIELD_CELLS[code]
    if int(cells.max()) <= most:
        return most
    samples = 3 * int(cells.sum()) * planes
    if samples <= max(FIELD_TOTAL, 3 * most * length.size * planes):
        return 0
    raise ValueError(f"velocity field too long for its cost budget: its paths (up to {float(length.max()):g} px) "
                     f"need {samples:,} spline samples, beyond {3 * most} per pixel and {FIELD_TOTAL:,} in all; "
                     f"blur a downscaled image, or use a uniform velocity (a tuple), whose cost does not grow "
                     f"with the length")


def check_quadrature(quadrature):
    """``quadrature`` checked against :data:`FIELD_RULES` (``ValueError`` naming them)."""
    if not isinstance(quadrature, str) or quadrature not in FIELD_RULES:
        raise ValueError(f"quadrature must be one of {', '.join(map(repr, FIELD_RULES))}, got {quadrature!r}")
    return quadrature


def reach(field):
    """The largest ``|component|`` of ``field`` in px (0 for an empty field)."""
    return float(max(-np.min(field), np.max(field))) if np.size(field) else 0.0


def rule_fits(field, code, dominant=None):
    """Whether every path of ``field`` fits in the Gauss rule's tables (its most nodes or cells):
    a field with a longer path runs the exact cells (all of it: one rule per call).  ``dominant``:
    :func:`reach` of ``field`` where the caller has it."""
    from .spec import rule_length, rule_limits
    first, most, per_px, extra = rule_limits(code)
    if not np.size(field):
        return True
    dominant = reach(field) if dominant is None else dominant
    fits = lambda length: max(first, math.ceil(length * per_px - 1e-9) + extra) <= most
    if fits(dominant * math.sqrt(2.0) * (1 + 1e-15)):     # no length exceeds it: no float64 pass over the field
        return True
    return fits(float(np.max(rule_length(code, field[0], field[1]))))


def apply_field(job, field, code, mode, cval, quadrature="gauss"):
    """Blur ``job``'s image planes along the per-pixel velocities ``field`` (checked) with the
    rule ``quadrature`` (:data:`FIELD_RULES`; the exact cells where a path outgrows the Gauss
    rule's tables).  The Gauss rule's kernel gets the field's :func:`reach` (its OpenCL launcher
    sizes the paired coefficients' margin by it)."""
    be, dtype, shape = job.backend, job.dtype, job.shape
    planes = (math.prod(shape[:-2]),) + tuple(shape[-2:])
    dominant = reach(field) if quadrature == "gauss" else None
    gauss = quadrature == "gauss" and rule_fits(field, code, dominant)
    most = None if gauss else field_cells(field, code, planes[0])     # refusals before any work
    coef = spline_coefficients(be, be.reshape(job.data, planes), dtype, planes, (mode, mode), cval)
    dev_field = be.host_view(np.ascontiguousarray(field, dtype=dtype))     # read in place where the device can
    result = job.result_buffer()
    if gauss:
        rule_kernel(be, coef, dev_field, be.reshape(result, planes), code, mode, cval, reach=dominant)
    else:
        field_blur(be, coef, dev_field, be.reshape(result, planes), code, FIELD_DENSITY, mode, cval, most)
    return job.finish(result)
