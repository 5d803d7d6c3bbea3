"""Lambertian reflectance: light directions, rendering, illuminant estimation and the depth scale.

Conventions (docs/shading.md): ``x`` is the column, ``y`` the row (downward), ``Z`` the height
toward the viewer in pixel units, ``p = ∂Z/∂x``, ``q = ∂Z/∂y``; the unit normal is
``(-p, -q, 1)/sqrt(1 + p² + q²)`` and the light ``(l1, l2, l3)`` points from the surface toward
the source, ``l1`` toward +x (right), ``l2`` toward +y (down), ``l3 > 0`` toward the viewer.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from .params import check_contrast, checked_image, checked_mask, parse_light
from .scene import flat_background

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



def estimate_illuminant(image, mask=None, *, exclude_background=True):
    """Light direction and albedo of a Lambertian image (Zheng & Chellappa 1991).

    Parameters
    ----------
    image : (H, W) array_like
    mask : (H, W) bool array_like, optional
        Pixels to use (default all).
    exclude_background : bool, optional
        Leave out the flat background found by :func:`flat_background` (default True; Notes).

    Returns
    -------
    light : ndarray, shape (3,)
        Unit light vector (convention of :mod:`gfgpu.shading`).
    albedo : float

    Raises
    ------
    ValueError
        Non-2-D, constant or non-finite image; moments inconsistent with a Lambertian image
        (``6π²E[I²] <= 48 E[I]²``).

    Notes
    -----
    Under the assumption that surface normals are uniformly distributed over the visible
    hemisphere, ``E[I] = π ρ cos σ / 4`` and ``E[I²] = ρ²(1 + 3cos²σ)/6``, hence

    .. math:: \\rho = \\sqrt{6\\pi^2 E[I^2] - 48 E[I]^2}/\\pi, \\qquad \\cos\\sigma = 4E[I]/(\\pi\\rho)

    (``cos σ`` clipped to [0, 1]).  The tilt is the direction of the mean of the unit image
    gradients, ``τ = atan2(E[I_y/|∇I|], E[I_x/|∇I|])`` (gradients by central differences, pixels
    with ``|∇I|`` below 1e-6 of the largest ignored): shading brightens toward the light.

    The uniform-normal assumption fails on an object on a flat background: every background
    pixel has the same normal, which drags the moments toward a frontal light (slant near 0).
    With ``exclude_background`` those pixels (:func:`flat_background`) are left out, so the
    statistics are those of the object's surface.  A linear shading image is unchanged when the
    light's image-plane direction and the surface are both reversed (the convex/concave
    ambiguity), so on surfaces whose bumps and dips are equally likely the tilt is only
    determined modulo 180° (docs/shading.md reports both errors).

    References
    ----------
    .. [1] Q. Zheng and R. Chellappa, "Estimation of illuminant direction, albedo, and shape
       from shading", IEEE Trans. PAMI 13(7):680-702, 1991.
    .. [2] R. Zhang, P.-S. Tsai, J. E. Cryer and M. Shah, "Shape from shading: a survey",
       IEEE Trans. PAMI 21(8):690-706, 1999 (the same estimator, used to feed every method).

    Examples
    --------
    >>> import numpy as np
    >>> yy, xx = np.mgrid[-40:41, -40:41] / 40.0
    >>> z = 40 * np.sqrt(np.clip(1.2 - xx**2 - yy**2, 0, None))
    >>> light, albedo = estimate_illuminant(lambertian_shading(z, (1, 0, 1)))
    >>> bool(light[0] > 0.3 and abs(light[1]) < 0.05)
    True
    """
    img = checked_image(image).astype(np.float64)
    m = checked_mask(mask, img.shape)
    check_contrast(img, m)
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
