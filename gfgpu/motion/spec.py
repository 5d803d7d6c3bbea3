"""Executable numpy specifications of the motion-blur fused kernels.

Five kernels, each written here in plain float64 numpy and on every backend as device code
(``_warp.py``, and ``motion.cl`` through ``_opencl.py``, beside this module):

- :func:`box_lines_reference`: the mean of each line's cubic B-spline over a window
  ``[a0 + a1 k, b0 + b1 k]`` at every sample ``k`` (a box exposure; the device kernels slide the
  window with a running sum, O(1) per sample, and start it in closed form, so the cost does not
  depend on the window's length);
- :func:`field_blur_reference`: every pixel gathers the cubic B-spline image along its own
  straight path ``x - t v(x)``, weighted by a point-spread function in ``t``;
- :func:`to_polar_reference` / :func:`from_polar_reference`: cubic B-spline resampling between
  the image plane and a polar grid about a centre (radius in pixels, angle counter-clockwise
  on screen); :func:`add_rows_reference`: a multiple of one array, per row, added to another.

Beyond a line's ends the spline is the one of the line extended by ``mode``: its coefficients
continue as :func:`coef_taps` says (for ``"constant"`` and ``"nearest"`` a geometric approach
to the extension's value, not the end coefficient repeated).

Coordinates are array-axis order: a velocity field is ``(2, H, W)`` = (rows, cols) components,
a centre ``(row, col)``.  Boundary modes are scipy.ndimage's names, as integer codes
(:data:`MODE_CODES`).  These functions know nothing about the applications that use them.

The boundary modes (:data:`MODE_CODES`, :func:`extend_index`) and the cubic B-spline
(:data:`SPLINE_POLE`, :data:`NEAREST_EDGE`, :func:`coef_taps`) are defined once in
:mod:`gfgpu._core.boundary` and :mod:`gfgpu._core.bspline`, and named here as well; the
point-spread functions (:func:`psf_cdf`, :func:`psf_density`) are defined here.
"""

from __future__ import annotations

import math

import numpy as np

from .._core.boundary import MODE_CODES, extend_index, period
from .._core.bspline import (
    NEAREST_EDGE,
    SPLINE_POLE,
    coef_taps,
    pole_series,
    prefix_weights,
    tap_weights,
)

__all__ = ["MODE_CODES", "PSF_CODES", "GREEN_TAIL", "NARROW", "SPLINE_POLE", "NEAREST_EDGE", "GAUSS_NODES",
           "GAUSS_WEIGHTS", "PSF_MIN_CELLS", "extend_index", "coef_taps", "psf_support", "psf_cdf", "psf_density",
           "psf_cells", "spline_sample", "box_lines_reference", "field_blur_reference", "BOX_SPACING", "BOX_NODES",
           "RULE_END", "GREEN_NODE_PX", "GREEN_GRADE", "GREEN_RULE_INTERVALS", "rule_support", "green_spacing",
           "green_index", "green_index_inverse", "rule_limits", "EUCLIDEAN_RULES", "rule_length", "rule_count",
           "gauss_rule", "rule_table", "field_rule_reference", "to_polar_reference",
           "band_pixels", "from_polar_reference", "add_rows_reference"]

#: point-spread functions in ``t`` (fraction of the velocity): box (uniform exposure) and the
#: chapter's G_u; ``+ 2`` for the centred (displace=False) variants
PSF_CODES = {("box", True): 0, ("green", True): 1, ("box", False): 2, ("green", False): 3}

#: G_u's tail beyond ``t = GREEN_TAIL`` velocities carries ``e^-t (sin t + cos t) < 2e-8`` of its
#: mass (below float32 rounding); the last sample takes it, so the gain stays exactly 1
GREEN_TAIL = 18.0

#: windows narrower than this (samples) take the spline's value at their middle
NARROW = 1.0 / 64.0

#: 3-point Gauss-Legendre nodes (fractions of a cell) and weights: exact for polynomials of
#: degree 5, so for the cubic spline along an axis wherever a cell holds no knot
GAUSS_NODES = (0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6))
GAUSS_WEIGHTS = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)

#: fewest cells of a moving pixel's path per PSF code: G_u's shape varies on the scale of one
#: velocity (half of one for the centred one), whatever the path's length in pixels, so its
#: cells span at most 1/2 (1/4) of it; a box has no shape of its own
PSF_MIN_CELLS = (1, int(2 * GREEN_TAIL), 1, int(4 * GREEN_TAIL))


# --------------------------------------------------------------------------------------
# the spline's coefficients beyond a line's ends (coef_taps: gfgpu._core.bspline)
# --------------------------------------------------------------------------------------
def _line_coef(x, i, mode, cval):
    """The coefficients ``i`` (integer array) of the lines ``x[..., n]`` extended by ``mode``."""
    j0, w0, j1, w1 = coef_taps(i, x.shape[-1], mode)
    base = cval if mode == "constant" else 0.0
    return base + w0 * (x[..., j0] - base) + w1 * (x[..., j1] - base)


def _coef_prefix(x, j, mode, cval):
    """``Σ_{0 <= i < j} c[i]`` (``-Σ_{j <= i < 0} c[i]`` for ``j < 0``) of the lines' extended
    coefficients at the integers ``j``, in closed form: O(n) whatever ``|j|``.

    Periodic modes: whole periods times the period's sum.  ``"constant"``/``"nearest"``: ``j e``
    plus the geometric sum of ``z^m (c[0] - e)`` beyond the left end (likewise at the right).
    """
    n = x.shape[-1]
    j = np.asarray(j, np.int64)
    repeat = period(n, mode)
    if repeat is not None:
        one = x[..., extend_index(np.arange(repeat), n, mode)]
        cum = np.concatenate([np.zeros(x.shape[:-1] + (1,)), np.cumsum(one, axis=-1)], axis=-1)
        q, r = np.divmod(j, repeat)
        return q * cum[..., repeat:] + cum[..., r]
    cum = np.concatenate([np.zeros(x.shape[:-1] + (1,)), np.cumsum(x, axis=-1)], axis=-1)
    if mode == "constant":
        left = right = np.full(x.shape[:-1] + (1,), float(cval))
    else:
        a, b = NEAREST_EDGE
        left = a * x[..., :1] + b * x[..., min(1, n - 1)][..., None]
        right = a * x[..., -1:] + b * x[..., max(n - 2, 0)][..., None]
    below, above = np.minimum(j, 0), np.maximum(j - n, 0)
    return (cum[..., np.clip(j, 0, n)] + below * left - (x[..., :1] - left) * pole_series(-below)
            + above * right + (x[..., -1:] - right) * pole_series(above))


# --------------------------------------------------------------------------------------
# box windows along lines
# --------------------------------------------------------------------------------------
def box_lines_reference(src, axis, a0, a1, b0, b1, mode, cval, less=None):
    """Mean of every line's cubic B-spline over the window ``[a0 + a1 k, b0 + b1 k]`` of sample ``k``
    (minus ``less``, if given).

    Parameters
    ----------
    src : ndarray (B, N, M)
        Cubic B-spline coefficients of lines along ``axis`` (1 or 2): the lines prefiltered
        along themselves.
    a0, a1, b0, b1 : float
        The window of sample ``k`` (``a1, b1 >= 0``, ``a0 + a1 k <= b0 + b1 k``), in samples;
        windows may reach any distance beyond the line.
    mode, cval
        Extension of the line beyond its ends (scipy.ndimage names; the coefficients continue
        as :func:`coef_taps` says).
    less : ndarray (B, N, M), optional
        Subtracted from the means (the blur's change from the samples, when ``less`` holds the
        samples; the device kernels allow ``dst`` to be ``less``).

    Returns
    -------
    ndarray
        Same shape and dtype as ``src``: ``(1/(b - a)) ∫_a^b s(x) dx`` with ``s`` the spline;
        where ``b - a < NARROW`` the value ``s((a + b)/2)`` (within ``(b - a)^2 |s''| / 24``: the
        difference of integrals would lose more than that to rounding in float32).  Whole cells
        integrate to ``(c[j-1] + 11 c[j] + 11 c[j+1] + c[j+2]) / 24``, whose sum over ``[A, B)``
        telescopes to ``Σ_{A <= j < B} c[j]`` plus three coefficients at each end (the sum in
        closed form beyond the line, :func:`_coef_prefix`); the ends with the partial cells by
        :func:`gfgpu._core.bspline.prefix_weights`.  O(n) per line whatever the window's length.
    """
    x = np.moveaxis(np.asarray(src, np.float64), axis, -1)
    n = x.shape[-1]
    k = np.arange(n, dtype=np.float64)
    a, b = a0 + a1 * k, b0 + b1 * k

    def integral(p):        # ∫_0^p s up to one constant, and s(p)
        i = np.floor(p).astype(np.int64)
        f = p - i
        near = np.stack([_line_coef(x, i + m - 1, mode, cval) for m in range(4)])     # c[i-1 .. i+2]
        lift = (slice(None),) + (None,) * (x.ndim - 1)      # weights (4, n) against (4, ..., n)
        return (_coef_prefix(x, i, mode, cval) + (prefix_weights(f)[lift] * near).sum(0),
                (tap_weights(f)[lift] * near).sum(0))

    sa, _ = integral(a)
    sb, _ = integral(b)
    _, vm = integral(0.5 * (a + b))
    width = b - a
    out = np.moveaxis(np.where(width >= NARROW, (sb - sa) / np.where(width >= NARROW, width, 1.0), vm), -1, axis)
    if less is not None:
        out = out - np.asarray(less, np.float64)
    return out.astype(src.dtype)


# --------------------------------------------------------------------------------------
# point-spread functions in t and the per-pixel gather
# --------------------------------------------------------------------------------------
def psf_support(code):
    """``(t0, t1)``: the support of the PSF ``code`` in fractions of the velocity."""
    return ((0.0, 1.0), (0.0, GREEN_TAIL), (-0.5, 0.5), (-GREEN_TAIL / 2, GREEN_TAIL / 2))[code]


def psf_cdf(code, t):
    """Cumulative PSF at ``t`` (float64), 0 at the support's start and 1 at its end.

    Box: uniform on the support.  G_u with ``u = 1`` (its mean, one velocity):
    ``1 - e^-t (sin t + cos t)``.  Centred G_u: the autocorrelation of G_{1/2} (an anticausal half
    then a causal half), ``R(t) = e^{-2|t|}(cos 2t + sin 2|t|)``, whose cumulative is
    ``1/2 + sign(t)(1 - e^{-2|t|} cos 2t)/2``.
    """
    t = np.asarray(t, np.float64)
    t0, t1 = psf_support(code)
    if code in (0, 2):
        c = (t - t0) / (t1 - t0)
    elif code == 1:
        s = np.maximum(t, 0.0)
        c = 1.0 - np.exp(-s) * (np.sin(s) + np.cos(s))
    else:
        s = 2.0 * np.abs(t)
        c = 0.5 + np.sign(t) * 0.5 * (1.0 - np.exp(-s) * np.cos(s))
    c = np.where(t <= t0, 0.0, c)
    return np.where(t >= t1, 1.0, c)


def psf_density(code, t):
    """The PSF ``code`` at ``t`` (the derivative of :func:`psf_cdf` inside the support)."""
    t = np.asarray(t, np.float64)
    t0, t1 = psf_support(code)
    if code in (0, 2):
        return np.full(t.shape, 1.0 / (t1 - t0))
    if code == 1:
        return 2.0 * np.exp(-t) * np.sin(t)
    s = 2.0 * np.abs(t)
    return np.exp(-s) * (np.cos(s) + np.sin(s))


def psf_cells(code, length, density, most=0):
    """Cells of a path of ``length`` dominant-axis pixels: ``ceil(length (t1 - t0) density)``, at
    least :data:`PSF_MIN_CELLS` for a moving pixel, 1 for a still one; at most ``most`` where
    ``most > 0`` (a budget per pixel: longer paths get longer cells)."""
    t0, t1 = psf_support(code)
    length = np.asarray(length, np.float64)
    cells = np.maximum(PSF_MIN_CELLS[code], np.ceil(length * (t1 - t0) * density - 1e-9))
    if most > 0:
        cells = np.minimum(cells, most)
    return np.where(length > 0, cells, 1).astype(np.int64)


def spline_sample(coef, py, px, mode, cval, mode_y=None):
    """The cubic B-spline with coefficients ``coef`` (B, H, W) at points ``(py, px)`` (any shape).

    Coefficient indices beyond the image follow ``mode`` (``mode_y`` along the rows, if given),
    as :func:`coef_taps` says, along each axis in turn: the spline of the image extended by
    ``mode`` (``"constant"``: by ``cval``).
    """
    coef = np.asarray(coef, np.float64)
    _, h, w = coef.shape
    mode_y = mode if mode_y is None else mode_y
    py, px = np.asarray(py, np.float64), np.asarray(px, np.float64)
    iy, ix = np.floor(py), np.floor(px)
    wy, wx = tap_weights(py - iy), tap_weights(px - ix)
    iy, ix = iy.astype(np.int64), ix.astype(np.int64)
    base = cval if mode == "constant" else 0.0
    out = np.full((coef.shape[0],) + py.shape, base)
    taps_x = [coef_taps(ix + q - 1, w, mode) for q in range(4)]
    for p in range(4):
        ry0, gy0, ry1, gy1 = coef_taps(iy + p - 1, h, mode_y)
        rows = [(ry0, gy0)] + ([(ry1, gy1)] if mode_y == "nearest" else [])
        for q, (rx0, gx0, rx1, gx1) in enumerate(taps_x):
            cols = [(rx0, gx0)] + ([(rx1, gx1)] if mode == "nearest" else [])
            for ry, gy in rows:
                for rx, gx in cols:
                    out += wy[p] * wx[q] * gy * gx * (coef[:, ry, rx] - base)
    return out


def field_blur_reference(coef, field, psf, density, mode, cval, most=0):
    """Per-pixel motion blur: pixel ``x`` gathers the spline image along ``x - t v(x)``.

    Parameters
    ----------
    coef : ndarray (B, H, W)
        Cubic B-spline coefficients of the images (the prefiltered images).
    field : ndarray (2, H, W)
        Velocity ``(vy, vx)`` of every pixel in pixels per exposure, rows then columns.
    psf : int
        :data:`PSF_CODES` value.
    density : float
        Cells per pixel of the dominant component ``L = max(|vy|, |vx|)`` (:func:`psf_cells`).
    mode, cval
        Extension of the image beyond its border.
    most : int
        Cells of a path at most (0: no bound): the cost per pixel is ``3 most`` samples however
        long its path.

    Returns
    -------
    ndarray (B, H, W), ``coef``'s dtype
        ``Σ_k Σ_i w_ki S(x - t_ki v)``: the support ``[t0, t1]`` cut into ``n = psf_cells`` equal
        cells, each sampled at its three Gauss-Legendre nodes ``t_ki`` (:data:`GAUSS_NODES`).  The
        weights are the node's Gauss weight times the cell's PSF mass (box), or Gauss-Legendre
        quadrature of the density, ``q_ki = Δt g_i psf(t_ki)``, with the cell's exact mass
        restored, ``w_ki = q_ki + g_i (mass_k - Σ_i q_ki)`` (G_u): the weights of a cell sum to
        its mass (``psf_cdf`` differences), so the gain is exactly 1.
    """
    coef = np.asarray(coef)
    b, h, w = coef.shape
    vy, vx = (np.asarray(field[i], np.float64) for i in (0, 1))
    n = psf_cells(psf, np.maximum(np.abs(vy), np.abs(vx)), density, most)
    t0, t1 = psf_support(psf)
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    out = np.zeros((b, h, w))
    for k in range(int(n.max())):
        live = k < n
        ta = t0 + (t1 - t0) * k / n
        tb = t0 + (t1 - t0) * (k + 1) / n
        mass = np.where(live, psf_cdf(psf, tb) - psf_cdf(psf, ta), 0.0)
        nodes = [ta + u * (tb - ta) for u in GAUSS_NODES]
        if psf in (0, 2):
            weights = [g * mass for g in GAUSS_WEIGHTS]
        else:
            quad = [(tb - ta) * g * psf_density(psf, t) for g, t in zip(GAUSS_WEIGHTS, nodes)]
            rest = mass - (quad[0] + quad[1] + quad[2])
            weights = [np.where(live, q + g * rest, 0.0) for q, g in zip(quad, GAUSS_WEIGHTS)]
        for t, wt in zip(nodes, weights):
            out += wt * spline_sample(coef, yy - t * vy, xx - t * vx, mode, cval)
    return out.astype(coef.dtype)


# --------------------------------------------------------------------------------------
# the per-pixel rules of the velocity fields (the default rule, gfgpu.motion.field)
# --------------------------------------------------------------------------------------
#: box: pixels of path per Gauss-Legendre node (the rule has ``ceil(L / BOX_SPACING) + 1`` nodes on
#: the whole support): Gauss-Legendre is spectrally accurate on a band-limited path, and one node
#: per 2 px keeps Gaussian-filtered noise (sigma 2 px) within 0.01 % of the exact integral at L = 30
BOX_SPACING = 2.0

#: most nodes of a box path (at most 126 px at BOX_SPACING; longer paths take the exact cells)
BOX_NODES = 64

#: G_u's rule cuts the support at ``t = RULE_END`` velocities (the tail beyond holds
#: ``e^-6 |sin 6 + cos 6| < 2e-3`` of the mass, given to the end nodes: the gain is 1)
RULE_END = 6.0

#: G_u's rule: pixels of path between nodes where G_u holds its mass (t up to GREEN_GRADE[0]
#: velocities): the nodes' aliases fall at 1 / 2.25 cycles/px along the path, beyond most of what
#: photographs and Gaussian-filtered noise hold there
GREEN_NODE_PX = 2.25

#: ``(t1, alpha, widest)``: beyond ``t1`` velocities the spacing grows as ``e^{alpha (t - t1)}`` (G_u
#: falls as ``e^-t``, and a node's error is its weight times the alias it samples), up to ``widest`` px
GREEN_GRADE = (1.5, 0.5, 5.0)

#: fewest and most intervals of G_u's rule per PSF code 1 (causal) and 3 (centred): at least 12 (24
#: centred, whose shape varies on half a velocity) resolve the PSF's own shape however short the path
#: (6 left 1-2 % at |v| = 3 on a photograph); the most are those of a path whose dominant component is
#: 128 px at 45 degrees (181 px long: the rule counts the Euclidean length, and the tables must cover every
#: path that the dominant component's limit admits, or one diagonal pixel would send a whole field to the
#: exact cells)
GREEN_RULE_INTERVALS = {1: (12, 315), 3: (24, 315)}


def rule_support(code):
    """``(t0, t1)`` of the rule of PSF ``code``: the box's support, G_u's cut at RULE_END."""
    return ((0.0, 1.0), (0.0, RULE_END), (-0.5, 0.5), (-RULE_END / 2, RULE_END / 2))[code]


def green_spacing(tau):
    """Pixels of path per node of G_u's rule at ``tau`` velocities from the start of its decay
    (``tau = t`` causal, ``2 |t|`` centred), per pixel of ``|v|``: :data:`GREEN_NODE_PX` up to
    ``t1``, then growing as ``e^{alpha (tau - t1)}`` up to the widest (:data:`GREEN_GRADE`)."""
    t1, alpha, widest = GREEN_GRADE
    tau = np.asarray(tau, np.float64)
    return np.minimum(widest, GREEN_NODE_PX * np.exp(alpha * np.maximum(tau - t1, 0.0)))


def _green_grade():
    t1, alpha, widest = GREEN_GRADE
    t2 = t1 + math.log(widest / GREEN_NODE_PX) / alpha          # where the spacing stops growing
    p1 = t1 / GREEN_NODE_PX
    p2 = p1 + (1.0 - GREEN_NODE_PX / widest) / (alpha * GREEN_NODE_PX)
    return t1, alpha, widest, t2, p1, p2


def green_index(tau):
    """``∫_0^tau dt / green_spacing(t)`` in closed form: the nodes per pixel of ``|v|`` up to ``tau``."""
    t1, alpha, widest, t2, p1, p2 = _green_grade()
    tau = np.asarray(tau, np.float64)
    grow = (1.0 - np.exp(-alpha * (np.clip(tau, t1, t2) - t1))) / (alpha * GREEN_NODE_PX)
    return np.minimum(tau, t1) / GREEN_NODE_PX + grow + np.maximum(tau - t2, 0.0) / widest


def green_index_inverse(p):
    """The ``tau`` whose :func:`green_index` is ``p`` (0 <= p <= green_index(RULE_END))."""
    t1, alpha, widest, t2, p1, p2 = _green_grade()
    p = np.asarray(p, np.float64)
    grow = t1 - np.log(np.maximum(1.0 - alpha * GREEN_NODE_PX * (np.clip(p, p1, p2) - p1), 1e-300)) / alpha
    return np.where(p <= p1, p * GREEN_NODE_PX, np.where(p <= p2, grow, t2 + (p - p2) * widest))


def rule_limits(code):
    """``(first, most, per_px, extra)``: the rule of a moving pixel of length ``L``
    (:func:`rule_length`) has ``n = max(first, ceil(L per_px - 1e-9) + extra)`` nodes (box) or
    intervals (G_u), at most ``most``."""
    if code in (0, 2):
        return 1, BOX_NODES, 1.0 / BOX_SPACING, 1
    first, most = GREEN_RULE_INTERVALS[code]
    return first, most, float(green_index(RULE_END)), 0


#: PSF codes whose rule is sized by the Euclidean length of the velocity (:func:`rule_length`)
EUCLIDEAN_RULES = (1, 3)


def rule_length(code, vy, vx):
    """The length that sizes a path's rule (float64): the dominant component ``max(|vy|, |vx|)``
    for the box, the Euclidean ``sqrt(vy^2 + vx^2)`` for G_u (its nodes are spaced along the path,
    so a diagonal path is sampled as finely as one along an axis).  ``vy``, ``vx`` as the kernels
    receive them (float32 values square exactly in float64; the sum rounds once, the square root
    is correctly rounded: the same count on every backend)."""
    vy, vx = np.asarray(vy, np.float64), np.asarray(vx, np.float64)
    if code not in EUCLIDEAN_RULES:
        return np.maximum(np.abs(vy), np.abs(vx))
    return np.sqrt(vy * vy + vx * vx)


def rule_count(code, length, most=None):
    """Nodes (box) or intervals (G_u) of the rule of paths of ``length`` px (:func:`rule_length`;
    0 for a still pixel, which takes the spline at the pixel itself), at most ``most`` (default: the
    rule's own limit, :func:`rule_limits`)."""
    first, top, per_px, extra = rule_limits(code)
    most = top if most is None else min(max(int(most), first), top)
    length = np.asarray(length, np.float64)
    n = np.maximum(first, np.ceil(length * per_px - 1e-9) + extra)
    return np.where(length > 0, np.minimum(n, most), 0).astype(np.int64)


def gauss_rule(code, n):
    """``(t, w)`` (float64): the rule of PSF ``code`` and size ``n`` in ``t`` (fraction of the velocity).

    Box: the ``n`` Gauss-Legendre nodes of the support and their weights, normalised to a sum of
    exactly 1 (rounding).  G_u: the trapezoidal rule of ``n`` intervals in the node index ``u``
    (:func:`green_index` of ``tau = t``, causal, or of ``tau = 2|t|``, centred, scaled to [0, 1]):
    nodes spaced :func:`green_spacing` pixels along the path for a path of ``n / per_px`` px,
    ``n + 1`` of them from the support's start to ``RULE_END``; weights the density times
    ``dt/du`` (the end nodes halved).  A smooth weight sampled at uniform steps aliases only at the
    steps' own frequency (where Gauss-Legendre cells of 3 nodes alias at a third of it).  The causal
    density has a kink at ``t = 0`` (``psf'(0) = 2``): the node at ``t = 0`` takes the
    Euler-Maclaurin correction ``(dt/du)^2 psf'(0) / (12 n^2)`` instead of its zero weight.  The
    weights are scaled to the PSF's mass inside the cut, and the mass beyond it (< 2e-3) goes to the
    end node(s) at the cut: the gain is 1.
    """
    t0, t1 = rule_support(code)
    if code in (0, 2):
        x, g = np.polynomial.legendre.leggauss(n)
        return t0 + (t1 - t0) * 0.5 * (x + 1.0), g / g.sum()
    total = float(green_index(RULE_END))
    u = np.arange(n + 1) / n
    if code == 1:
        t = green_index_inverse(u * total)
        t[0], t[-1] = 0.0, RULE_END
        dtdu = total * green_spacing(t)
        w = psf_density(code, t) * dtdu / n
        w[-1] *= 0.5
        w[0] = 2.0 * dtdu[0] ** 2 / (12.0 * n * n)         # psf'(0) = 2
        inner = float(psf_cdf(code, t1))
        w *= inner / w.sum()
        w[-1] += 1.0 - inner
    else:
        half = (2.0 * u - 1.0) * total / 2.0        # signed: each half is the causal index of tau = 2|t|
        t = np.sign(half) * green_index_inverse(2.0 * np.abs(half)) / 2.0
        t[0], t[-1] = t0, t1
        dtdu = total * green_spacing(2.0 * np.abs(t))
        w = psf_density(code, t) * dtdu / n
        w[0] *= 0.5
        w[-1] *= 0.5
        inner = float(psf_cdf(code, t1) - psf_cdf(code, t0))
        w *= inner / w.sum()
        w[0] += (1.0 - inner) / 2
        w[-1] += (1.0 - inner) / 2
    return t, w / w.sum()


def rule_table(code):
    """``(first, offsets, t, w)``: every rule of PSF ``code`` from ``first`` to the most nodes or
    intervals, concatenated (float64); rule ``n``'s nodes are ``t[offsets[n - first]:offsets[n - first + 1]]``,
    ascending.  What the device kernels read (cached per code)."""
    if code not in _RULE_TABLES:
        first, most, _, _ = rule_limits(code)
        rules = [gauss_rule(code, n) for n in range(first, most + 1)]
        offsets = np.concatenate([[0], np.cumsum([len(t) for t, _ in rules])]).astype(np.int32)
        _RULE_TABLES[code] = (first, offsets, np.concatenate([t for t, _ in rules]),
                              np.concatenate([w for _, w in rules]))
    return _RULE_TABLES[code]


_RULE_TABLES = {}


def field_rule_reference(coef, field, psf, mode, cval, most=None):
    """Per-pixel motion blur by a fixed rule per path: the default rule of the fields.

    Parameters
    ----------
    coef : ndarray (B, H, W)
        Cubic B-spline coefficients of the images.
    field : ndarray (2, H, W)
        Velocity ``(vy, vx)`` of every pixel, rows then columns, in pixels per exposure.
    psf : int
        :data:`PSF_CODES` value.
    mode, cval
        Extension of the image beyond its border.
    most : int, optional
        Nodes (box) or intervals (G_u) of a path at most (default and largest: the rule's own,
        :func:`rule_limits`; clipped to its fewest and most); a path that needs more takes the
        ``most`` rule.

    Returns
    -------
    ndarray (B, H, W), ``coef``'s dtype
        ``Σ_k w_k S(x - t_k v)`` with the rule :func:`gauss_rule` of size ``n = rule_count(L)``,
        ``L = rule_length(vy, vx)``; a still pixel (``L = 0``) is ``S(x)``.
    """
    coef = np.asarray(coef)
    b, h, w = coef.shape
    vy, vx = (np.asarray(field[i], np.float64) for i in (0, 1))
    n = rule_count(psf, rule_length(psf, vy, vx), most)
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    out = np.zeros((b, h, w))
    for count in np.unique(n):
        at = n == count
        py, px, sy, sx = yy[at], xx[at], vy[at], vx[at]
        if count == 0:
            out[:, at] = spline_sample(coef, py, px, mode, cval)
            continue
        for t, wt in zip(*gauss_rule(psf, int(count))):
            out[:, at] += wt * spline_sample(coef, py - t * sy, px - t * sx, mode, cval)
    return out.astype(coef.dtype)


# --------------------------------------------------------------------------------------
# polar resampling
# --------------------------------------------------------------------------------------
def to_polar_reference(coef, cy, cx, r0, n_r, n_phi, mode, cval):
    """The spline image at ``r = r0 + i``, ``phi = 2 pi j / n_phi`` about ``(cy, cx)``: ``(B, n_r, n_phi)``.

    Radius on axis 1, angle last (contiguous): the passes along the angle run along the rows.
    Point ``(i, j)`` is the pixel position ``(row, col) = (cy - r sin phi, cx + r cos phi)``: the
    angle turns counter-clockwise on screen (rows point down), so a rotation by ``θ`` about the
    centre moves content from ``phi`` to ``phi + θ``.  ``r0`` (an integer >= 0) is the radius of
    the first ring: a band of rings, whose angles need not be those of another band.
    """
    r = r0 + np.arange(n_r, dtype=np.float64)[:, None]
    phi = 2.0 * np.pi * np.arange(n_phi, dtype=np.float64)[None, :] / n_phi
    out = spline_sample(coef, cy - r * np.sin(phi), cx + r * np.cos(phi), mode, cval)
    return out.astype(np.asarray(coef).dtype)


def band_pixels(shape, cy, cx, r_lo, r_hi):
    """The pixels of an image of ``shape`` (H, W) whose distance from ``(cy, cx)`` lies in ``[r_lo, r_hi)``: what
    :func:`from_polar_reference` changes."""
    yy, xx = np.mgrid[:shape[0], :shape[1]].astype(np.float64)
    r = np.hypot(yy - cy, xx - cx)
    return (r >= r_lo) & (r < r_hi)


def from_polar_reference(pcoef, base, cy, cx, r0, r_lo, r_hi, wcoef=None, outside=None):
    """``base`` (B, H, W), where the pixel's radius ``r`` lies in ``[r_lo, r_hi)`` weighted by the
    radial cubic spline of ``wcoef`` (n_r,) (1 if None) and plus the polar spline ``pcoef``
    (B, n_r, n_phi) of a band whose first ring has radius ``r0``; elsewhere ``outside`` (B, H, W)
    if given (what the output held: the launchers' ``only_band``), else ``base``.

    Pixel ``(y, x)`` reads ``r = hypot(y - cy, x - cx)``, ``phi = atan2(cy - y, x - cx)``, i.e. ring
    ``r - r0``; the radius mirrors at both ends of the band (the callers keep ``[r_lo, r_hi)`` far
    enough inside it that only the centre's mirror matters) and the angle wraps.  The callers
    resample ``blurred - w unblurred`` polar samples (``w`` a weight per ring) and add it to ``w``
    times the image, ``w`` read at the pixel by the same radial spline (``wcoef``: the coefficients
    of the ring weights along the radius, mirrored at both ends), so that an image that the blur
    leaves unchanged (a constant) comes back exactly: where the blur is short (``w`` near 1) what does not move
    is returned as it was, not through two resamplings; bands that split the radii add theirs in
    turn (``base`` the previous band's output).
    """
    base = np.asarray(base)
    n_phi = pcoef.shape[2]
    height, width = base.shape[1:]
    yy, xx = np.mgrid[:height, :width].astype(np.float64)
    r = np.hypot(yy - cy, xx - cx)
    phi = np.mod(np.arctan2(cy - yy, xx - cx), 2.0 * np.pi) * (n_phi / (2.0 * np.pi))
    inside = band_pixels((height, width), cy, cx, r_lo, r_hi)
    out = np.array(base, np.float64)
    if outside is not None:
        out[:, ~inside] = np.asarray(outside, np.float64)[:, ~inside]
    weight = 1.0
    if wcoef is not None:
        wcoef = np.asarray(wcoef, np.float64).reshape(-1)
        ring = r[inside] - r0
        i = np.floor(ring)
        taps = tap_weights(ring - i)
        i = i.astype(np.int64)
        weight = sum(taps[p] * wcoef[extend_index(i + p - 1, len(wcoef), "mirror")] for p in range(4))
    out[:, inside] = (out[:, inside] * weight
                      + spline_sample(pcoef, r[inside] - r0, phi[inside], "wrap", 0.0, mode_y="mirror"))
    return out.astype(base.dtype)


def add_rows_reference(src, dst, scale):
    """``dst + scale[i] src`` at every element ``(b, i, j)`` of the (B, N, M) arrays (``scale`` (N,)):
    a weight per ring of a polar band."""
    out = np.asarray(dst, np.float64) + np.asarray(scale, np.float64)[None, :, None] * np.asarray(src, np.float64)
    return out.astype(np.asarray(dst).dtype)
