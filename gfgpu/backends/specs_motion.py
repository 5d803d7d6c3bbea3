"""Executable numpy specifications of the motion-blur fused kernels.

Four kernels, each written here in plain float64 numpy and on every backend as device code
(``backends/warp/motion.py``, ``backends/opencl/motion.cl``):

- :func:`box_lines_reference`: the mean of the piecewise-linear line over a window
  ``[a0 + a1 k, b0 + b1 k]`` at every sample ``k`` (a box exposure; the device kernels slide the
  window with a running sum, O(1) per sample);
- :func:`field_blur_reference`: every pixel gathers the cubic B-spline image along its own
  straight path ``x - t v(x)``, weighted by a point-spread function in ``t``;
- :func:`to_polar_reference` / :func:`from_polar_reference`: cubic B-spline resampling between
  the image plane and a polar grid about a centre (radius in pixels, angle counter-clockwise
  on screen).

Coordinates are array-axis order: a velocity field is ``(2, H, W)`` = (rows, cols) components,
a centre ``(row, col)``.  Boundary modes are scipy.ndimage's names, as integer codes
(:data:`MODE_CODES`).  These functions know nothing about the applications that use them.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["MODE_CODES", "PSF_CODES", "GREEN_TAIL", "NARROW", "SPLINE_POLE", "extend_index", "psf_support", "psf_cdf",
           "psf_samples", "spline_sample", "box_lines_reference", "field_blur_reference",
           "to_polar_reference", "from_polar_reference"]

#: boundary modes as the device kernels number them
MODE_CODES = {"constant": 0, "nearest": 1, "wrap": 2, "reflect": 3, "mirror": 4}

#: point-spread functions in ``t`` (fraction of the velocity): box (uniform exposure) and the
#: chapter's G_u; ``+ 2`` for the centred (displace=False) variants
PSF_CODES = {("box", True): 0, ("green", True): 1, ("box", False): 2, ("green", False): 3}

#: G_u's tail beyond ``t = GREEN_TAIL`` velocities carries ``e^-t (sin t + cos t) < 2e-8`` of its
#: mass (below float32 rounding); the last sample takes it, so the gain stays exactly 1
GREEN_TAIL = 18.0

#: windows narrower than this (samples) take the spline's value at their middle
NARROW = 1.0 / 64.0

#: pole of the cubic B-spline interpolation prefilter
SPLINE_POLE = math.sqrt(3.0) - 2.0


def extend_index(i, n, mode):
    """Index into ``[0, n)`` of the sample ``i`` of a line extended by ``mode`` (-1: cval)."""
    i = np.asarray(i, np.int64)
    if mode == "constant":
        return np.where((i >= 0) & (i < n), i, -1)
    if mode == "nearest":
        return np.clip(i, 0, n - 1)
    if mode == "wrap":
        return np.mod(i, n)
    if mode == "reflect":                       # d c b a | a b c d | d c b a
        q = np.mod(i, 2 * n)
        return np.where(q < n, q, 2 * n - 1 - q)
    if n == 1:                                  # mirror: d c b | a b c d | c b a
        return np.zeros_like(i)
    q = np.mod(i, 2 * n - 2)
    return np.where(q < n, q, 2 * n - 2 - q)


# --------------------------------------------------------------------------------------
# box windows along lines
# --------------------------------------------------------------------------------------
def box_lines_reference(src, axis, a0, a1, b0, b1, mode, cval):
    """Mean of every line's cubic B-spline over the window ``[a0 + a1 k, b0 + b1 k]`` of sample ``k``.

    Parameters
    ----------
    src : ndarray (B, N, M)
        Cubic B-spline coefficients of lines along ``axis`` (1 or 2): the lines prefiltered
        along themselves.
    a0, a1, b0, b1 : float
        The window of sample ``k`` (``a1, b1 >= 0``, ``a0 + a1 k <= b0 + b1 k``), in samples.
    mode, cval
        Extension of the line beyond its ends (scipy.ndimage names; ``"constant"`` as in
        :func:`spline_sample`).

    Returns
    -------
    ndarray
        Same shape and dtype as ``src``: ``(1/(b - a)) ∫_a^b s(x) dx`` with ``s`` the spline;
        where ``b - a < NARROW`` the value ``s((a + b)/2)`` (within ``(b - a)^2 |s''| / 24``: the
        difference of integrals would lose more than that to rounding in float32).  Whole cells integrate to
        ``(c[j-1] + 11 c[j] + 11 c[j+1] + c[j+2]) / 24``; partial cells by :func:`_bspline_integrals`.
    """
    x = np.moveaxis(np.asarray(src, np.float64), axis, -1)
    n = x.shape[-1]
    k = np.arange(n, dtype=np.float64)
    a, b = a0 + a1 * k, b0 + b1 * k
    lo = int(math.floor(min(a.min(), b.min()))) - 2
    hi = int(math.floor(max(a.max(), b.max()))) + 3
    j = np.arange(lo, hi + 1)
    idx, factor = _spline_index(j, n, mode)
    base = cval if mode == "constant" else 0.0
    ext = base + factor * (x[..., idx] - base)                        # coefficients lo .. hi
    cells = (ext[..., :-3] + 11.0 * ext[..., 1:-2] + 11.0 * ext[..., 2:-1] + ext[..., 3:]) / 24.0
    prefix = np.concatenate([np.zeros(x.shape[:-1] + (1,)), np.cumsum(cells, axis=-1)], axis=-1)

    def integral(p):        # ∫_{lo + 1}^p s, and s(p)
        i = np.floor(p).astype(np.int64)
        f = p - i
        q = i - lo          # coefficient i sits at ext[..., q]
        near = np.stack([ext[..., q - 1 + m] for m in range(4)])
        lift = (slice(None),) + (None,) * (x.ndim - 1)      # weights (4, n) against (4, ..., n)
        return (prefix[..., q - 1] + (_bspline_integrals(f)[lift] * near).sum(0),
                (_bspline_weights(f)[lift] * near).sum(0))

    sa, _ = integral(a)
    sb, _ = integral(b)
    _, vm = integral(0.5 * (a + b))
    width = b - a
    out = np.where(width >= NARROW, (sb - sa) / np.where(width >= NARROW, width, 1.0), vm)
    return np.moveaxis(out, -1, axis).astype(src.dtype)


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


def psf_samples(code, length, density):
    """Samples of a path of ``length`` dominant-axis pixels: ``ceil(length (t1 - t0) density)``, >= 1."""
    t0, t1 = psf_support(code)
    return np.maximum(1, np.ceil(np.asarray(length, np.float64) * (t1 - t0) * density - 1e-9)).astype(np.int64)


def _bspline_weights(f):
    """Cubic B-spline weights of offsets -1, 0, 1, 2 for the fraction ``f``."""
    g = 1.0 - f
    return np.stack([g**3 / 6.0, (3.0 * f**3 - 6.0 * f * f + 4.0) / 6.0,
                     (3.0 * g**3 - 6.0 * g * g + 4.0) / 6.0, f**3 / 6.0])


def _bspline_integrals(f):
    """``∫_0^f`` of the cubic B-spline weights of offsets -1, 0, 1, 2 (each 1/24, 11/24, 11/24,
    1/24 at ``f = 1``)."""
    f2 = f * f
    f4 = f2 * f2
    return np.stack([(1.0 - (1.0 - f) ** 4) / 24.0, (0.75 * f4 - 2.0 * f2 * f + 4.0 * f) / 6.0,
                     (-0.75 * f4 + f2 * f + 1.5 * f2 + f) / 6.0, f4 / 24.0])


def _spline_index(i, n, mode):
    """``(index, factor)`` of the coefficient ``i`` of a line of ``n`` beyond its ends.

    For ``mode="constant"`` the spline interpolates the line extended by ``cval``; the
    coefficients of ``I - cval`` (zero beyond the ends) continue geometrically, ``z^m`` times the
    end coefficient ``m`` samples out (``z`` the prefilter's pole), so the index is clamped and
    the factor is ``z^m``.  Other modes extend the coefficients as the samples (factor 1).
    """
    if mode != "constant":
        return extend_index(i, n, mode), np.ones(np.shape(i))
    j = np.clip(i, 0, n - 1)
    return j, SPLINE_POLE ** np.abs(i - j).astype(np.float64)


def spline_sample(coef, py, px, mode, cval, mode_y=None):
    """The cubic B-spline with coefficients ``coef`` (B, H, W) at points ``(py, px)`` (any shape).

    Coefficient indices beyond the image follow ``mode`` (``mode_y`` along the rows, if given;
    ``"constant"``: the spline of the image extended by ``cval``, see :func:`_spline_index`).
    """
    coef = np.asarray(coef, np.float64)
    _, h, w = coef.shape
    py, px = np.asarray(py, np.float64), np.asarray(px, np.float64)
    iy, ix = np.floor(py), np.floor(px)
    wy, wx = _bspline_weights(py - iy), _bspline_weights(px - ix)
    iy, ix = iy.astype(np.int64), ix.astype(np.int64)
    base = cval if mode == "constant" else 0.0
    out = np.full((coef.shape[0],) + py.shape, base)
    for p in range(4):
        ry, fy = _spline_index(iy + p - 1, h, mode if mode_y is None else mode_y)
        for q in range(4):
            rx, fx = _spline_index(ix + q - 1, w, mode)
            out += wy[p] * wx[q] * fy * fx * (coef[:, ry, rx] - base)
    return out


def field_blur_reference(coef, field, psf, density, mode, cval):
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
        Samples per pixel of the dominant component ``L = max(|vy|, |vx|)``.
    mode, cval
        Extension of the image beyond its border.

    Returns
    -------
    ndarray (B, H, W), ``coef``'s dtype
        ``Σ_k w_k S(x - t_k v)``: the support ``[t0, t1]`` cut into ``n = psf_samples`` equal
        cells, ``t_k`` their midpoints and ``w_k`` their PSF masses (``psf_cdf`` differences:
        they sum to 1 exactly).
    """
    coef = np.asarray(coef)
    b, h, w = coef.shape
    vy, vx = (np.asarray(field[i], np.float64) for i in (0, 1))
    n = psf_samples(psf, np.maximum(np.abs(vy), np.abs(vx)), density)
    t0, t1 = psf_support(psf)
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    out = np.zeros((b, h, w))
    for k in range(int(n.max())):
        live = k < n
        ta = t0 + (t1 - t0) * k / n
        tb = t0 + (t1 - t0) * (k + 1) / n
        weight = np.where(live, psf_cdf(psf, tb) - psf_cdf(psf, ta), 0.0)
        tm = 0.5 * (ta + tb)
        out += weight * spline_sample(coef, yy - tm * vy, xx - tm * vx, mode, cval)
    return out.astype(coef.dtype)


# --------------------------------------------------------------------------------------
# polar resampling
# --------------------------------------------------------------------------------------
def to_polar_reference(coef, cy, cx, n_phi, n_r, mode, cval):
    """The spline image at ``phi = 2 pi j / n_phi``, ``r = i`` about ``(cy, cx)``: ``(B, n_phi, n_r)``.

    Angle first, radius last (contiguous): the passes along the angle then run along axis 1,
    one vector lane per ring.  Point ``(j, i)`` is the pixel position
    ``(row, col) = (cy - r sin phi, cx + r cos phi)``: the angle turns counter-clockwise on
    screen (rows point down), so a rotation by ``θ`` about the centre moves content from
    ``phi`` to ``phi + θ``.
    """
    r = np.arange(n_r, dtype=np.float64)[None, :]
    phi = 2.0 * np.pi * np.arange(n_phi, dtype=np.float64)[:, None] / n_phi
    out = spline_sample(coef, cy - r * np.sin(phi), cx + r * np.cos(phi), mode, cval)
    return out.astype(np.asarray(coef).dtype)


def from_polar_reference(pcoef, cy, cx, height, width):
    """The polar spline ``pcoef`` (B, n_phi, n_r) back on the ``(height, width)`` pixel grid.

    Pixel ``(y, x)`` reads ``r = hypot(y - cy, x - cx)``, ``phi = atan2(cy - y, x - cx)``; the
    angle wraps and the radius mirrors at both ends (the grid holds rings beyond the farthest
    pixel, so only the centre's mirror matters).
    """
    n_phi = pcoef.shape[1]
    yy, xx = np.mgrid[:height, :width].astype(np.float64)
    r = np.hypot(yy - cy, xx - cx)
    phi = np.mod(np.arctan2(cy - yy, xx - cx), 2.0 * np.pi) * (n_phi / (2.0 * np.pi))
    out = spline_sample(pcoef, phi, r, "mirror", 0.0, mode_y="wrap")
    return out.astype(np.asarray(pcoef).dtype)
