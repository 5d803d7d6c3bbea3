"""Per-pixel velocity fields: every pixel blurred along its own path (the post-process model).

The pixel at ``x`` gathers the image along the straight path ``x - t v(x)``, ``t`` over the
shutter, weighted by the point-spread function in ``t`` (:data:`gfgpu.motion.spec.PSF_CODES`):
the box (uniform exposure, ``t`` in ``[0, 1]``, or ``[-1/2, 1/2]`` centred) or the chapter's
G_u along the path (``u = |v|``: mean exactly one velocity; centred: the autocorrelation of
G_{|v|/2}).  The image is the cubic B-spline through its samples (:mod:`gfgpu.motion.spline`);
the support is cut into ``n`` equal cells, each integrated by 3-point Gauss-Legendre quadrature
(exact for the spline along an axis wherever a cell holds no knot) with the cell's exact PSF
mass (the masses telescope: the gain is exactly 1).  A uniform field gives the uniform box to
2e-4 on white noise (one midpoint sample per half pixel gave 2.4e-2 at L = 0.5).

Cost per pixel: ``3 n`` samples of 16 coefficients, ``n = ceil(L (t1 - t0))`` cells of at most
one pixel along the path, ``L`` the dominant component of the pixel's own velocity: ``3 ceil(L)``
samples for the box (3 at least), ``3 max(ceil(18 L), 36)`` for G_u (whose tail runs to 18
velocities before its mass falls below float32 rounding, and whose shape needs cells of half
a velocity however short the path; 72 cells at least for the centred G_u), 3 for a still
pixel; and never more than :data:`FIELD_CELLS` cells (the budget): ``3 x 32 = 96`` samples for
the box, ``3 x 144 = 432`` for G_u, however long the path (a 4096-px field once ran 64 s on
64 x 64 pixels).  Beyond the budget the cells grow longer than a pixel, and their three nodes
sample the spline more sparsely than its detail: the error against the unbounded quadrature
(``most=0``, the float64 reference of the tests), rel. L2 on band-limited noise (cut 0.25
cycles/px, 48², wrap, velocity (0.6, 0.8) L), measured::

    box, 32 cells:   L = 10: 0.0 %   L = 30: 0.0 %    (16 cells: 0.01 % at 30; 8: 0.18 %)
    G_u, 144 cells:  L = 10: 0.0 %   L = 30: 0.19 %   (72 cells: 4.7 % at 30; 36: > 100 %)

Longer cells would alias (a 4096-px box field of noise came out 0.45 off), so the budget is
never stretched: a field whose paths need more cells runs with its exact cells when their total
is within the budget on average or within :data:`FIELD_TOTAL` samples, and is refused before
any work otherwise (:func:`field_cells`).  The prefilter is two recursions per axis.
"""

from __future__ import annotations

import math

import numpy as np

from .kernels import field_blur
from .spline import spline_coefficients

__all__ = ["FIELD_MAX", "FIELD_DENSITY", "FIELD_CELLS", "FIELD_TOTAL", "is_field", "check_field", "field_cells",
           "apply_field"]

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
    """``field`` as a float64 ``(2, H, W)`` array matching the image plane of ``shape``."""
    arr = np.asarray(field)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.float16:
        raise TypeError(f"velocity field must be a real float or integer array, got dtype {arr.dtype}")
    if arr.shape != (2,) + tuple(shape[-2:]):
        raise ValueError(f"velocity field must have shape (2, H, W) = (2, {shape[-2]}, {shape[-1]}) "
                         f"(rows, cols components, like skimage's optical flow), got {arr.shape}")
    arr = arr.astype(np.float64)
    if not np.isfinite(arr).all():
        raise ValueError("velocity field must be finite")
    peak = float(np.abs(arr).max())
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


def apply_field(job, field, code, mode, cval):
    """Blur ``job``'s image planes along the per-pixel velocities ``field`` (checked)."""
    be, dtype, shape = job.backend, job.dtype, job.shape
    planes = (math.prod(shape[:-2]),) + tuple(shape[-2:])
    most = field_cells(field, code, planes[0])
    coef = spline_coefficients(be, be.reshape(job.data, planes), dtype, planes, (mode, mode), cval)
    dev_field = be.asarray(np.ascontiguousarray(field, dtype=dtype))
    result = job.result_buffer()
    field_blur(be, coef, dev_field, be.reshape(result, planes), code, FIELD_DENSITY, mode, cval, most)
    return job.finish(result)
