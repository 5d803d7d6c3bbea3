"""Lambertian reflectance: light directions, rendering, illuminant estimation and the depth scale.

Conventions (docs/shading.md): ``x`` is the column, ``y`` the row (downward), ``Z`` the height
toward the viewer in pixel units, ``p = ∂Z/∂x``, ``q = ∂Z/∂y``; the unit normal is
``(-p, -q, 1)/sqrt(1 + p² + q²)`` and the light ``(l1, l2, l3)`` points from the surface toward
the source, ``l1`` toward +x (right), ``l2`` toward +y (down), ``l3 > 0`` toward the viewer.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage, optimize

from .params import check_contrast, checked_image, checked_mask, parse_light
from .scene import flat_background, noise_sigma

__all__ = ["lambertian_shading", "estimate_illuminant", "fit_depth_scale", "surface_gradient", "render_pq",
           "fit_subsample"]

#: largest number of pixels used by the scale fits (a regular subsample beyond this)
FIT_PIXELS = 65536


# --------------------------------------------------------------------------------------
# reflectance: rendering and illuminant estimation
# --------------------------------------------------------------------------------------
def surface_gradient(depth):
    q, p = np.gradient(np.asarray(depth, np.float64))
    return p, q


def render_pq(p, q, light, albedo=1.0):
    return albedo * np.maximum(0.0, (light[2] - light[0] * p - light[1] * q) / np.sqrt(1.0 + p * p + q * q))


def lambertian_shading(depth, light, albedo=1.0):
    """Lambertian image of a height map: ``albedo · max(0, n·L)``.

    Parameters
    ----------
    depth : (H, W) array_like
        Height toward the viewer, in pixel units.
    light : sequence
        As in :func:`parse_light`.
    albedo : float
        Reflectance factor ρ.

    Returns
    -------
    ndarray, float64
        The image; surface gradients by central differences (``numpy.gradient``).

    Examples
    --------
    >>> import numpy as np
    >>> z = np.zeros((8, 8))
    >>> float(lambertian_shading(z, (1, 0, 1))[4, 4].round(4))
    0.7071
    """
    p, q = surface_gradient(depth)
    return render_pq(p, q, parse_light(light), float(albedo))



#: the light estimate's peak fit: half-width (pixels) of the window of the quadratic fit at the
#: object's brightest point, and the smoothing (pixels) that locates that point
PEAK_HALF_WIDTH = 4
PEAK_SMOOTHING = 2.0
#: a slant is told from a frontal light only when the peak exceeds the background by this many
#: standard errors of the two levels
FRONTAL_SIGMAS = 3.0
#: ... and by at least this fraction of the background level (1 - cos 2.6°): below it the
#: slant is within 2.6° of frontal, under the sampling error of a peak on a pixel grid
FRONTAL_RELATIVE = 1e-3
#: without an interior peak: the largest smoothed object pixel counts as level with the plane
#: within this many noise sigmas of the smoothed image (the largest of ~10⁴ samples of white
#: noise lies about 4 sigmas above their mean)
FRONTAL_NOISE_MAX = 5.0


def estimate_illuminant(image, mask=None, *, method="background", exclude_background=True):
    """Light direction and albedo of a Lambertian image.

    Parameters
    ----------
    image : (H, W) array_like
    mask : (H, W) bool array_like, optional
        ``method='background'``: the object (its complement holds the reference plane);
        default found from the image (:func:`flat_background`).  ``'zheng-chellappa'``:
        the pixels to use (default all).
    method : {'background', 'zheng-chellappa'}, optional
        ``'background'`` (default): an object on a frontal reference plane (Notes); refuses
        images without such a plane.  ``'zheng-chellappa'``: Zheng & Chellappa's moments
        (1991), which assume uniformly distributed surface normals.
    exclude_background : bool, optional
        ``'zheng-chellappa'`` only: leave out the flat background (default True).

    Returns
    -------
    light : ndarray, shape (3,)
        Unit light vector (convention of :mod:`gfgpu.shading`); exactly ``(0, 0, 1)`` when
        the image cannot tell the light from a frontal one.
    albedo : float

    Raises
    ------
    ValueError
        Non-2-D, constant or non-finite image; unknown ``method``.  ``'background'``: no flat
        background (or, with a mask, no pixels outside it); an object whose brightest point
        is not inside it or is darker than the background beyond the noise (no visible
        surface faces the light, so the slant is not determined).  ``'zheng-chellappa'``:
        moments inconsistent with a Lambertian image (``6π²E[I²] <= 48 E[I]²``).

    Notes
    -----
    *'background'.*  A Lambertian plane facing the viewer (the reference plane an object
    stands on) has intensity ``b = ρ l3``, and a smooth object whose normals include the
    light's direction has its brightest point, of intensity ``ρ``, where the normal equals
    ``L``.  So ``cos σ = b/ρ`` with ``b`` the median background intensity and ``ρ`` the
    peak of a least-squares quadratic fitted over a window of :data:`PEAK_HALF_WIDTH` pixels
    (or twice, or half that, where the first has no interior maximum) around the object's
    brightest point (located after a Gaussian smoothing of :data:`PEAK_SMOOTHING`
    pixels): no assumption on how the normals are distributed.  When ``ρ − b`` is within
    :data:`FRONTAL_SIGMAS` standard errors of the two levels (from the fit's residual and the
    background's spread) the light is reported as frontal, ``(0, 0, 1)``: ``σ`` from
    ``b/ρ ≈ 1`` is ill-conditioned (``σ ≈ sqrt(2(1 − b/ρ))``), and the noise alone would
    otherwise invent a slant and a tilt.  The object must have a normal along ``L`` (any
    smooth object whose outline is an occluding contour all round has every visible normal);
    where its brightest point lies on its outline instead (a low dome cut by the plane) the
    estimate is refused, but a shallow relief whose steepest slope faces the light has an
    interior maximum darker than ``ρ``, and its slant is then underestimated.

    The tilt's axis is the direction ``γ`` whose lines see zero integrated shading
    ``∫ (I − b) dt``: with the linearised map ``I − b ≈ −ρ sin σ ∂_γ Z`` that integral is the
    difference of ``Z`` at the line's ends, 0 where the line meets the plane on both sides of
    the object; the angle minimising the sum of their squares over all lines is taken (0.25°
    steps).  Its sense makes the first moment about the object's centroid,
    ``Σ (x cos γ + y sin γ)(I − b)``, positive: the object stands *above* its plane
    (the moment is ``ρ sin σ ∫ Z`` under the same linearisation), so an object that is mostly
    a dent gets the opposite tilt.  The non-linear terms (``1/|n|``, attached shadows) and
    lines that do not end on the plane (an object that the image frame cuts, like the
    survey's vase at its top and bottom) bias the axis, up to a wrong tilt; docs/shading.md
    gives the errors measured.

    *'zheng-chellappa'.*  Under the assumption that surface normals are uniformly
    distributed over the visible hemisphere, ``E[I] = π ρ cos σ / 4`` and
    ``E[I²] = ρ²(1 + 3cos²σ)/6``, hence

    .. math:: \\rho = \\sqrt{6\\pi^2 E[I^2] - 48 E[I]^2}/\\pi, \\qquad \\cos\\sigma = 4E[I]/(\\pi\\rho)

    (``cos σ`` clipped to [0, 1]); the tilt is the direction of the mean of the unit image
    gradients (pixels with ``|∇I|`` below 1e-6 of the largest ignored).  An image samples
    normals by projected area, not uniformly, so a frontally lit sphere reads about 22°
    off; the tilt is only determined modulo 180° on surfaces whose bumps and dips are
    equally likely (the convex/concave ambiguity).

    References
    ----------
    .. [1] Q. Zheng and R. Chellappa, "Estimation of illuminant direction, albedo, and shape
       from shading", IEEE Trans. PAMI 13(7):680-702, 1991.
    .. [2] R. Zhang, P.-S. Tsai, J. E. Cryer and M. Shah, "Shape from shading: a survey",
       IEEE Trans. PAMI 21(8):690-706, 1999.

    Examples
    --------
    >>> import numpy as np
    >>> yy, xx = np.mgrid[-40:41, -40:41].astype(float)
    >>> z = np.sqrt(np.clip(30.0**2 - xx**2 - yy**2, 0, None))
    >>> light, albedo = estimate_illuminant(lambertian_shading(z, (0, 0, 1)))
    >>> light.tolist(), round(albedo, 3)
    ([0.0, 0.0, 1.0], 1.0)
    """
    img = checked_image(image).astype(np.float64)
    if method not in ("background", "zheng-chellappa"):
        raise ValueError(f"method must be 'background' or 'zheng-chellappa', got {method!r}")
    m = checked_mask(mask, img.shape)
    check_contrast(img, m)
    if method == "background":
        return _from_background(img, None if m.all() else m)
    if exclude_background:
        fg = m & ~flat_background(img, m)
        if fg.sum() >= 16:
            m = fg
            check_contrast(img, m)
    vals = img[m]
    mu1, mu2 = float(vals.mean()), float((vals * vals).mean())
    disc = 6 * math.pi**2 * mu2 - 48 * mu1**2
    if not disc > 0:
        raise ValueError("image moments are inconsistent with a Lambertian image under the "
                         "uniform-normal assumption (6π²E[I²] <= 48E[I]²); pass light= explicitly")
    albedo = math.sqrt(disc) / math.pi
    cos_s = min(1.0, max(0.0, 4 * mu1 / (math.pi * albedo)))
    gy, gx = np.gradient(img)
    mag = np.hypot(gx, gy)
    ok = m & (mag > 1e-6 * mag.max())
    ex, ey = (gx[ok] / mag[ok]).mean(), (gy[ok] / mag[ok]).mean()
    tilt = math.atan2(ey, ex)
    sin_s = math.sqrt(max(0.0, 1 - cos_s * cos_s))
    return np.array([math.cos(tilt) * sin_s, math.sin(tilt) * sin_s, cos_s]), albedo


def _from_background(img, obj):
    """The 'background' light estimate: (light, albedo); obj the user's object or None."""
    if obj is None:
        flat = flat_background(img)
        if not flat.any():
            raise ValueError("the light cannot be estimated from this image: it shows no flat "
                             "background (a frontal reference plane, whose intensity ρ·l3 fixes "
                             "the slant), so the slant is not determined by the shading; pass "
                             "light= explicitly, or mask= the object on its background")
        level = float(np.median(img[flat]))
        # a stationary point of the shading (the brightest one, where n = L) can look flat:
        # holes in the object are object
        obj = ndimage.binary_fill_holes(~flat)
        ref = flat & ~obj
        if ref.sum() < 16:
            ref = flat
    else:
        flat = flat_background(img) & ~obj
        ref = flat if flat.sum() >= 16 else ~obj
        if ref.sum() < 16:
            raise ValueError("the light cannot be estimated: the mask leaves fewer than 16 "
                             "background pixels, whose intensity ρ·l3 fixes the slant; pass light=")
    level = float(np.median(img[ref]))
    se_level = 1.2533 * float(img[ref].std()) / math.sqrt(ref.sum())     # s.e. of a median
    frontal = np.array([0.0, 0.0, 1.0])
    try:
        peak, se_peak = _peak(img, obj)
        tol = max(FRONTAL_SIGMAS * math.hypot(se_peak, se_level), FRONTAL_RELATIVE * level)
        if peak - level <= -tol:
            raise _NoPeak(f"the object's brightest point ({peak:.4g}) is darker than its background "
                          f"({level:.4g})")
    except _NoPeak as exc:
        # frontal when nothing on the object outshines the plane beyond the noise of the
        # smoothed image (a frontal light makes every top and the plane equal)
        sm = ndimage.gaussian_filter(img, PEAK_SMOOTHING, mode="nearest")
        noise = noise_sigma(img) / (2 * math.sqrt(math.pi) * PEAK_SMOOTHING)
        if float(sm[obj].max()) - level <= max(FRONTAL_NOISE_MAX * noise, FRONTAL_RELATIVE * level):
            return frontal, level
        raise ValueError(f"the light cannot be estimated: {exc}, so no visible surface faces the "
                         f"light and the slant is not determined; pass light=") from None
    if peak - level <= tol:
        return frontal, max(peak, level)
    cos_s = level / peak
    sin_s = math.sqrt(1.0 - cos_s * cos_s)
    tilt = _tilt_axis(img - level, obj)
    yy, xx = np.mgrid[: img.shape[0], : img.shape[1]].astype(np.float64)
    d = (img - level)[obj]
    x, y = xx[obj] - xx[obj].mean(), yy[obj] - yy[obj].mean()     # about the object's centroid
    moment = float(((x * math.cos(tilt) + y * math.sin(tilt)) * d).sum())
    if moment < 0:      # the object stands above its plane
        tilt += math.pi
    return np.array([math.cos(tilt) * sin_s, math.sin(tilt) * sin_s, cos_s]), peak


class _NoPeak(Exception):
    """The object has no interior intensity maximum to fit."""


def _peak(img, obj):
    """Peak value of a quadratic fitted at the object's brightest point, and its standard error.

    Windows of PEAK_HALF_WIDTH, twice it (noise can hide a broad peak's curvature) and half it
    (a peak near the outline) are tried in turn.
    """
    sm = ndimage.gaussian_filter(img, PEAK_SMOOTHING, mode="nearest")
    first = None
    for r in (PEAK_HALF_WIDTH, 2 * PEAK_HALF_WIDTH, max(1, PEAK_HALF_WIDTH // 2)):
        try:
            return _peak_fit(img, sm, obj, r)
        except _NoPeak as exc:
            first = first or exc
    raise first


def _peak_fit(img, sm, obj, r):
    inner = ndimage.binary_erosion(obj, np.ones((2 * r + 1, 2 * r + 1), bool), border_value=0)
    if not inner.any():
        raise _NoPeak(f"the object holds no {2 * r + 1} x {2 * r + 1} window to fit its brightest point")
    i, j = np.unravel_index(int(np.argmax(np.where(inner, sm, -np.inf))), img.shape)
    dy, dx = (a.ravel().astype(np.float64) for a in np.mgrid[-r:r + 1, -r:r + 1])
    v = img[i - r:i + r + 1, j - r:j + r + 1].ravel()
    A = np.stack([np.ones_like(dx), dx, dy, dx * dx, dx * dy, dy * dy], axis=1)
    coef, *_ = np.linalg.lstsq(A, v, rcond=None)
    hess = np.array([[2 * coef[3], coef[4]], [coef[4], 2 * coef[5]]])
    grad = coef[1:3]
    ev = np.linalg.eigvalsh(hess)
    res = v - A @ coef
    var = float(res @ res) / max(len(v) - 6, 1)
    cov = var * np.linalg.inv(A.T @ A)
    # a plateau (curvature at rounding level) is not a peak
    at = None
    if ev.max() < -1e-9 * float(np.abs(v).max()):
        at = -np.linalg.solve(hess, grad)
    if at is None or np.abs(at).max() > r:
        raise _NoPeak("the object's intensity has no maximum inside it (its brightest point lies "
                      "on its outline)")
    row = np.array([1.0, at[0], at[1], at[0] ** 2, at[0] * at[1], at[1] ** 2])
    return float(row @ coef), math.sqrt(max(float(row @ cov @ row), 0.0))


def _tilt_axis(centred, obj):
    """Angle (mod π) of the lines along which the integrated shading is smallest (least squares)."""
    sub, _ = fit_subsample(centred.shape)
    yy, xx = np.mgrid[: centred.shape[0], : centred.shape[1]].astype(np.float64)
    sel = obj[sub]
    x, y, d = xx[sub][sel], yy[sub][sel], centred[sub][sel]
    step = sub[0].step or 1

    def cost(angle):
        s = (y * math.cos(angle) - x * math.sin(angle)) / step
        k = np.floor(s).astype(np.int64)
        sums = np.bincount(k - k.min(), d)
        return float(sums @ sums)

    coarse = np.radians(np.arange(0.0, 180.0, 2.0))
    best = coarse[int(np.argmin([cost(a) for a in coarse]))]
    fine = best + np.radians(np.arange(-2.0, 2.0 + 1e-9, 0.25))
    return float(fine[int(np.argmin([cost(a) for a in fine]))])


# --------------------------------------------------------------------------------------
# the depth scale: least-squares fit of the Lambertian re-rendering
# --------------------------------------------------------------------------------------
def fit_subsample(shape):
    step = max(1, int(math.ceil(math.sqrt(shape[0] * shape[1] / FIT_PIXELS))))
    return (slice(None, None, step), slice(None, None, step)), step


def _render_residual(scale, p, q, image, light):
    """min over albedo of Σ (I − ρ R(scale·p, scale·q))², and that albedo."""
    r = render_pq(scale * p, scale * q, light)
    rr = float((r * r).sum())
    if rr == 0:
        return float((image * image).sum()), 0.0
    rho = float((image * r).sum()) / rr
    rho = max(rho, 0.0)
    res = image - rho * r
    return float((res * res).sum()), rho


def fit_depth_scale(shape_estimate, image, light, mask=None):
    """Scale ``s`` (either sign) whose Lambertian rendering of ``s·Z̃`` best matches ``image``.

    Minimises ``Σ_mask (I − ρ·R(s∇Z̃))²`` over ``s`` and the albedo ``ρ >= 0`` (closed form for
    each ``s``): a log-spaced grid of 25 values per sign spanning 6 decades around the scale
    that gives unit RMS slope, then a bounded Brent refinement between the grid neighbours of
    the best point.  Ties between ``s`` and ``-s`` (exact for a frontal light: the convex/concave
    ambiguity) go to ``s > 0``.  Gradients by central differences; at most 65536 pixels
    (regular subsample) enter the fit.

    Returns
    -------
    scale, albedo, relative_rms_residual : float
    """
    z = np.asarray(shape_estimate, np.float64)
    img = np.asarray(image, np.float64)
    m = np.ones(img.shape, bool) if mask is None else mask
    p, q = surface_gradient(z)
    sub, step = fit_subsample(img.shape)
    p, q, img_s, m_s = p[sub], q[sub], img[sub], m[sub]
    p, q, img_s = p[m_s], q[m_s], img_s[m_s]
    rms = math.sqrt(float((p * p + q * q).mean()))
    if not rms > 0:
        raise ValueError("the shape estimate is flat: no depth scale can be fitted")
    s_unit = 1.0 / rms
    grid = s_unit * np.logspace(-3, 3, 25)
    best = (math.inf, 0.0)
    for sign in (1.0, -1.0):
        errs = [_render_residual(sign * s, p, q, img_s, light)[0] for s in grid]
        k = int(np.argmin(errs))
        lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
        def cost(log_s, sign=sign):
            return _render_residual(sign * math.exp(log_s), p, q, img_s, light)[0]
        res = optimize.minimize_scalar(cost, bounds=(math.log(lo), math.log(hi)), method="bounded",
                                       options={"xatol": 1e-4})
        cand = (float(res.fun), sign * math.exp(float(res.x)))
        if errs[k] < cand[0]:
            cand = (errs[k], sign * grid[k])
        if cand[0] < best[0] * (1 - 1e-9):
            best = cand
    err, scale = best
    _, rho = _render_residual(scale, p, q, img_s, light)
    return scale, rho, math.sqrt(err / max(float((img_s * img_s).sum()), 1e-300))
