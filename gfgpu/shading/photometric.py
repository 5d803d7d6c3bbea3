"""Photometric motion (GPM, chapter §4, eqs. 39-40): the rotated-view pair from G_U^(2) (eq. 14)."""

from __future__ import annotations

import math

import numpy as np

from .. import greens
from .._core.lines import direction as _line_direction
from .._core.validation import finite_scalar, positive
from ..backends import resolve_backend
from ..filters import green_filter
from .gsfs import resolve_light
from .light import fit_depth_scale
from .params import MIN_SLANT, check_contrast, checked_image, checked_mask, tilt_slant

__all__ = ["photometric_motion"]


# photometric motion
# --------------------------------------------------------------------------------------
def _line_positions(shape, angle):
    """Step index of every pixel along its digital line at ``angle`` (0 at the line's start)."""
    steep, reverse, _ = _line_direction(angle)
    h, w = shape
    yy, xx = np.mgrid[:h, :w]
    t = yy if steep else xx
    n = h if steep else w
    return (n - 1 - t) if reverse else t, n


def photometric_motion(image, *, light=None, direction=None, shift=1.0, fixed_point=None,
                       k0=None, kappa=0.0, mask=None, mode="nearest", backend=None, device=None):
    """Depth from one shading image by Green's-function photometric motion (GPM, eq. 39-40).

    Parameters
    ----------
    image : (H, W) array_like
        Shading image.  float32/float64 kept, integers -> float32.
    light : sequence, optional
        As in :func:`shape_from_shading`; only used for the default direction and for the
        re-rendering that fixes the depth scale and ``k0``.  Default: estimated
        (:func:`estimate_illuminant`).
    direction : float, optional
        Motion direction γ (radians from +x toward +y), taken modulo π (the rotation's sense
        only flips the sign of Z, which the fitted scale absorbs); default the light's tilt, or
        +x when the light is frontal (slant below :data:`MIN_SLANT`).
    shift : float, optional
        Displacement ``u0 = σ²/|x_U|`` of the rotated view at the fixed point's side, in steps
        along γ (> 0), default 1.
    fixed_point : float, optional
        ``x_U`` (< 0, in steps before each line's first sample): the affine flow's fixed point
        (the rotation axis).  Default ``-100 n`` for lines of ``n`` steps, so that ``|x_U| ≫ x``
        as eq. 14 requires: G_U's gain ramp and eq. 39's factor ``x − x_U`` then vary by about
        1 % across the image (at ``-4 n`` the 25 % ramp dominated the depth on the benchmark).
    k0 : float, optional
        Intensity offset of the linear reflectance map in eq. 39.  Must lie outside the range
        of ``I2`` (eq. 39 has a pole where ``I2 = k0``).  Default: fitted (Notes).
    kappa : float, optional
        The arbitrary constant κ of eq. 39, default 0.  The coordinate ``x + γy`` of its term
        is measured from the fixed point (always ``> 0`` inside the image).
    mask, mode, backend, device
        As in :func:`shape_from_shading`.

    Returns
    -------
    ndarray, (H, W)
        Height toward the viewer (zero mean over ``mask``), float32 (float64 for float64 input),
        scaled by the re-rendering fit.

    Raises
    ------
    ValueError
        Bad image (as in :func:`shape_from_shading`), ``shift <= 0``, ``fixed_point >= 0``,
        or ``k0``/``kappa`` that put a pole of eq. 39 inside the image (the denominator
        ``(I2 − k0) + κ/(x − x_U)`` changes sign or vanishes).

    Notes
    -----
    ``I2 = G_U * I1`` with G_U^(2) (eq. 14), ``σ = sqrt(u0 |x_U|)``, run causally along the
    digital lines at angle γ (exact recursion; the domain ``(x_U, ∞)`` contains every line).
    With the affine flow ``U = u1 (x − x_U)`` (eq. 13; ``u1 = u0/|x_U|``), eq. 39 reads

    .. math:: Z = -\\frac{k_1 (1+\\gamma^2)\\, u_1 (x - x_U)}{(I_2 - k_0) u_1 + \\kappa/(x - x_U)}

    ``k1 (1 + γ²) u1`` is one global scale.  It and ``k0`` are chosen together by the
    re-rendering rule of :func:`fit_depth_scale`: for each ``k0`` on a grid of 26 values at
    ``max(I2) + t·range(I2)`` and ``min(I2) − t·range(I2)``, ``t`` 13 values log-spaced in [0.01, 100],
    the scale (either sign) and albedo that best re-render the image are fitted, and the
    ``k0`` with the smallest residual is kept.  Large ``t`` makes ``Z`` an affine function of
    ``I2``; small ``t`` a strongly non-linear one.

    References
    ----------
    .. [1] J. R. A. Torreão and J. L. Fernandes, "Green's function photometric motion",
       Pattern Analysis and Applications (doi 10.1007/s10044-009-0156-z).
    .. [2] Torreão, Victer and Fernandes, "Green's Functions of Matching Equations", 2007,
       §4, eqs. 35-40 and 14.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading, photometric_motion, shape_from_shading
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> z = np.sqrt(48.0**2 - xx**2 - yy**2)      # a spherical cap filling the frame
    >>> img = lambertian_shading(z, (0, 0, 1))
    >>> est = photometric_motion(img, light=(0, 0, 1), backend="numpy")
    >>> bool(np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.9)
    True
    """
    img = checked_image(image)
    m = checked_mask(mask, img.shape)
    check_contrast(img, m)
    be = resolve_backend(backend, device)      # an unknown backend or device: refused before work
    L, _ = resolve_light(img, light, m)
    tilt, slant = tilt_slant(L)
    if direction is None:
        angle = tilt if slant >= MIN_SLANT else 0.0
    else:
        angle = finite_scalar("direction", direction)
    # the rotation's sense only flips the sign of Z (absorbed by the fitted scale): take the
    # direction modulo π so that lines are traversed forward and x_U lies before their start
    if _line_direction(angle)[1]:
        angle -= math.pi
    u0 = positive("shift", shift)
    t, n = _line_positions(img.shape, angle)
    if fixed_point is None:
        x_U = -100.0 * n
    else:
        x_U = finite_scalar("fixed_point", fixed_point)
        if not x_U < 0:
            raise ValueError(f"fixed_point must be < 0 (the affine flow's fixed point before each "
                             f"line's first sample, outside the domain of eq. 14), got {fixed_point!r}")
    sigma = math.sqrt(u0 * abs(x_U))
    kappa = finite_scalar("kappa", kappa)
    i2 = np.asarray(green_filter(img, greens.AffineGreenApprox(sigma, x_U), angle=angle, mode=mode,
                                 backend=be), np.float64)
    s = t - x_U                                    # distance from the fixed point, > 0

    def depth_unit(k):
        den = (i2 - k) + kappa / s
        lo, hi = float(den.min()), float(den.max())
        if lo * hi <= 0 or min(abs(lo), abs(hi)) <= 1e-9 * max(abs(lo), abs(hi)):
            raise ValueError(f"k0 = {k:g} with kappa = {kappa:g} puts a pole of eq. 39 inside the "
                             f"image: (I2 - k0) + kappa/(x - x_U) spans [{lo:g}, {hi:g}]; k0 must lie "
                             f"outside the range of I2 = [{float(i2.min()):g}, {float(i2.max()):g}]")
        z = -s / den
        return z - z[m].mean()

    if k0 is not None:
        z = depth_unit(finite_scalar("k0", k0))
        scale, _, _ = fit_depth_scale(z, img, L, m)
        return (scale * z).astype(img.dtype)
    lo, hi = float(i2[m].min()), float(i2[m].max())
    span = max(hi - lo, 1e-12)
    best = (math.inf, None)
    for tt in np.logspace(-2, 2, 13):
        for k in (hi + tt * span, lo - tt * span):
            try:
                z = depth_unit(k)
            except ValueError:      # κ ≠ 0 can still make a pole for this k0: skip it
                continue
            scale, _, err = fit_depth_scale(z, img, L, m)
            if err < best[0]:
                best = (err, scale * z)
    if best[1] is None:
        raise ValueError(f"no k0 outside the range of I2 avoids a pole of eq. 39 with kappa = {kappa:g}")
    return best[1].astype(img.dtype)
