"""Depth from one shading image: Green's-function shape from shading and photometric motion.

Two of the chapter's applications (§3 and §4), built on the line filters of
:mod:`gfgpu.filters`:

* :func:`shape_from_shading` (GSFS, eq. 30-33): the matching image ``I2 = G_u * I1`` of a
  virtual light displacement along the light's image-plane direction γ, and the depth
  ``Z = u·Ī2/k1`` with ``Ī2 = ½(G_u + H_u) * I1`` (science.md §2.2: eq. 32 with
  ``(a, b, c) = (½, -1, ½)``), one exact O(N) recursion per line;
* :func:`photometric_motion` (GPM, eq. 39-40): the rotated-view pair ``I2 = G_U * I1`` from
  the approximate affine Green's function G_U^(2) (eq. 14), and the depth of eq. 39.

Helpers: :func:`estimate_illuminant` (Zheng & Chellappa 1991), :func:`lambertian_shading`
(the re-rendering used to fix the depth scale), :func:`parse_light`, and the scene tests that
fix GSFS's per-line constants: :func:`flat_background`, :func:`has_background` and
:func:`noise_sigma` (Immerkær 1996).

Conventions (docs/shading.md): ``x`` is the column, ``y`` the row (downward), ``Z`` the height
toward the viewer in pixel units, ``p = ∂Z/∂x``, ``q = ∂Z/∂y``; the unit normal is
``(-p, -q, 1)/sqrt(1 + p² + q²)`` and the light ``(l1, l2, l3)`` points from the surface toward
the source, ``l1`` toward +x (right), ``l2`` toward +y (down), ``l3 > 0`` toward the viewer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from . import greens
from .filters import green_filter
from .lines import direction as _line_direction

__all__ = [
    "shape_from_shading", "photometric_motion", "estimate_illuminant", "lambertian_shading",
    "parse_light", "fit_depth_scale", "flat_background", "has_background", "noise_sigma", "ShadingGreen", "MIN_SLANT",
]

#: Lights whose slant (angle from the viewing direction, radians) is below this have no usable
#: image-plane direction: the linear term of the reflectance map, which GSFS integrates, vanishes.
MIN_SLANT = math.radians(1.0)

#: GSFS matching constant u as a fraction of the path length of one digital line across the image
#: (the operator is then an integrator over the whole line; Notes of :func:`shape_from_shading`)
GSFS_U_FRACTION = 1.0

#: shading-free ("flat background") pixels: smoothing scale (pixels) of the gradient test, the
#: gradient floor relative to the image's strong (99th-percentile) shading gradient, the erosion
#: radius that drops isolated critical points of the shading, and the smallest fraction of the
#: analysed pixels for the image to count as an object on a background (see :func:`flat_background`)
FLAT_SMOOTHING = 2.0
FLAT_RELATIVE_GRADIENT = 0.02
FLAT_EROSION = 3
FLAT_MIN_FRACTION = 0.02

#: the image border counts as background (GSFS ``boundary='auto'``) when the intensity standard
#: deviation over a band of this fraction of the image size is below BORDER_QUIET times that of
#: the whole image (see :func:`has_background`)
BORDER_WIDTH = 0.05
BORDER_QUIET = 0.5

#: largest number of pixels used by the scale fits (a regular subsample beyond this)
_FIT_PIXELS = 65536


# --------------------------------------------------------------------------------------
# the fused GSFS kernel ½(G_u + H_u)
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShadingGreen(greens.GreenKernel):
    """½(G_u + H_u) (eq. 9 and 33): the GSFS operator ``Ī2 = ½(G_u + H_u) * I1`` as ONE recursion.

    .. math:: c(x) = \\frac{1}{u} (\\sin(x/u) + \\cos(x/u))\\, e^{-x/u} \\quad (x > 0)

    Both kernels share the poles ``exp((-1 ± i)/u)``, so their half sum is one complex section
    ``lam = exp((-1+i)/u)``, ``kap = (1 - i) lam / u`` plus H_u's direct tap halved, ``1/(2u)``.
    Its transfer function is ``(1 + ε/2)/(1 + ε + ε²/2)``, ``ε = iuω``: about 1 for ``uω ≪ 1``
    and about ``1/(iuω)`` (an integrator, times 1/u) for ``uω ≫ 1``.
    """

    u: float

    def __post_init__(self):
        object.__setattr__(self, "u", greens._positive("u", self.u))

    shift_invariant = True

    @property
    def tap(self):
        return 0.5 / self.u

    def __call__(self, x, x0):
        d = np.asarray(x, np.float64) - np.asarray(x0, np.float64)
        return 0.5 * (greens.g_uniform(d, self.u) + greens.h_homogeneous(d, self.u))

    def _section(self):
        lam = np.exp(complex(-1.0, 1.0) / self.u)
        return greens.Section(lam=lam, kap=(1.0 - 1.0j) * lam / self.u)


# --------------------------------------------------------------------------------------
# argument handling
# --------------------------------------------------------------------------------------
def _image(image, name="image"):
    arr = np.asarray(image)
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grey-level image, got shape {arr.shape}")
    if min(arr.shape) < 4:
        raise ValueError(f"{name} must be at least 4 x 4 pixels, got shape {arr.shape}")
    dtype = arr.dtype if arr.dtype in (np.float32, np.float64) else np.dtype(np.float32)
    arr = arr.astype(dtype, copy=False)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _mask(mask, shape):
    if mask is None:
        return np.ones(shape, bool)
    m = np.asarray(mask)
    if m.shape != shape:
        raise ValueError(f"mask must have the image's shape {shape}, got {m.shape}")
    m = m.astype(bool)
    if m.sum() < 16:
        raise ValueError(f"mask must select at least 16 pixels, got {int(m.sum())}")
    return m


def _check_contrast(image, mask, name="image"):
    vals = image[mask].astype(np.float64)
    spread = float(vals.max() - vals.min())
    if not spread > 1e-6 * max(1.0, float(np.abs(vals).max())):
        raise ValueError(f"{name} is constant (range {spread:g}) over the analysed pixels: "
                         f"shading carries no shape")


def parse_light(light):
    """Unit light vector ``(l1, l2, l3)`` from a 3-vector or a ``(tilt, slant)`` pair.

    Parameters
    ----------
    light : sequence of 3 or 2 floats
        ``(l1, l2, l3)`` (any positive length; normalised), or ``(tilt, slant)`` in radians,
        ``tilt`` from +x toward +y (down the rows) and ``0 <= slant < pi/2`` from the viewer.

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    ValueError
        Wrong length, non-finite values, zero vector, or a light that does not face the viewer
        (``l3 <= 0`` or ``slant`` outside ``[0, pi/2)``): it would not light the visible surface.

    Examples
    --------
    >>> parse_light((1, 0, 1)).round(4).tolist()
    [0.7071, 0.0, 0.7071]
    """
    try:
        vals = [float(v) for v in light]
    except (TypeError, ValueError):
        raise TypeError(f"light must be a 3-vector (l1, l2, l3) or a pair (tilt, slant) of real "
                        f"numbers, got {light!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"light must be finite, got {light!r}")
    if len(vals) == 2:
        tilt, slant = vals
        if not 0.0 <= slant < math.pi / 2:
            raise ValueError(f"light slant must lie in [0, pi/2) radians (a light facing the "
                             f"viewer), got {slant!r}")
        return np.array([math.cos(tilt) * math.sin(slant), math.sin(tilt) * math.sin(slant),
                         math.cos(slant)])
    if len(vals) != 3:
        raise ValueError(f"light must have 3 components (l1, l2, l3) or 2 (tilt, slant), got {len(vals)}")
    v = np.array(vals)
    norm = float(np.linalg.norm(v))
    if norm == 0:
        raise ValueError("light must be a non-zero vector")
    v = v / norm
    if not v[2] > 0:
        raise ValueError(f"light {tuple(vals)} points away from the viewer (l3 <= 0): it cannot "
                         f"light the visible surface; l3 must be > 0")
    return v


def _tilt_slant(light):
    return math.atan2(light[1], light[0]), math.acos(min(1.0, float(light[2])))


# --------------------------------------------------------------------------------------
# reflectance: rendering and illuminant estimation
# --------------------------------------------------------------------------------------
def _surface_gradient(depth):
    q, p = np.gradient(np.asarray(depth, np.float64))
    return p, q


def _render_pq(p, q, light, albedo=1.0):
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
    >>> z = np.zeros((8, 8))
    >>> float(lambertian_shading(z, (1, 0, 1))[4, 4].round(4))
    0.7071
    """
    p, q = _surface_gradient(depth)
    return _render_pq(p, q, parse_light(light), float(albedo))


def noise_sigma(image):
    """Standard deviation of additive white noise in an image (Immerkær 1996).

    Parameters
    ----------
    image : (H, W) array_like
        At least 4 x 4 pixels.

    Returns
    -------
    float
        ``sqrt(π/2) · mean|N * I| / 6`` over the interior, ``N`` the 3 x 3 difference of two
        Laplacians (``[[1, -2, 1], [-2, 4, -2], [1, -2, 1]]``), which cancels every quadratic
        intensity profile: smooth shading contributes only through its third derivatives.

    References
    ----------
    .. [1] J. Immerkær, "Fast noise variance estimation", Computer Vision and Image
       Understanding 64(2):300-302, 1996.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> yy, xx = np.mgrid[:128, :128] / 128.0
    >>> round(noise_sigma(xx * yy + 0.02 * rng.standard_normal((128, 128))), 3)
    0.02
    """
    img = _image(image).astype(np.float64)
    kernel = np.array([[1.0, -2.0, 1.0], [-2.0, 4.0, -2.0], [1.0, -2.0, 1.0]])
    resp = ndimage.correlate(img, kernel, mode="nearest")[1:-1, 1:-1]
    return math.sqrt(math.pi / 2) * float(np.abs(resp).mean()) / 6.0


def flat_background(image, mask=None):
    """Shading-free pixels: the flat background that an object stands on, if there is one.

    Parameters
    ----------
    image : (H, W) array_like
    mask : (H, W) bool array_like, optional
        Pixels to consider (default all).

    Returns
    -------
    ndarray of bool, (H, W)
        True where the image is flat; all False when fewer than :data:`FLAT_MIN_FRACTION` of the
        considered pixels are flat (no background: a textured surface filling the frame).

    Notes
    -----
    A pixel is flat when the gradient magnitude of the image smoothed by a Gaussian of
    :data:`FLAT_SMOOTHING` pixels is at most ``max(3 σ_g, r · g99)``: ``σ_g = σ_n/(√(8π) s²)`` is
    the standard deviation of one gradient component of smoothed white noise of the level
    ``σ_n`` given by :func:`noise_sigma`, and ``r = FLAT_RELATIVE_GRADIENT`` of the 99th
    percentile ``g99`` of the gradient magnitude sets a floor for noise-free images (shading
    50 times weaker than the image's strong shading).  The flat set is then eroded by a
    square of radius :data:`FLAT_EROSION` pixels, which removes the isolated points where
    the shading of a curved surface happens to be stationary; what remains are extended
    regions of constant intensity, i.e. planes.  Under a single distant light a Lambertian
    plane has constant intensity, and the one that fills large parts of an image around an
    object is its background.  The thresholds are documented choices (docs/shading.md), not
    fitted per image.

    Examples
    --------
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> z = 8 * np.exp(-(xx**2 + yy**2) / 50)
    >>> flat = flat_background(lambertian_shading(z, (1, 0, 1)))
    >>> bool(flat[0, 0]), bool(flat[32, 28])
    (True, False)
    """
    img = _image(image).astype(np.float64)
    m = _mask(mask, img.shape)
    s = FLAT_SMOOTHING
    smooth = ndimage.gaussian_filter(img, s, mode="nearest")
    gy, gx = np.gradient(smooth)
    mag = np.hypot(gx, gy)
    sigma_g = noise_sigma(img) / (math.sqrt(8 * math.pi) * s * s)
    tau = max(3.0 * sigma_g, FLAT_RELATIVE_GRADIENT * float(np.percentile(mag[m], 99)))
    r = FLAT_EROSION
    flat = ndimage.binary_erosion(mag <= tau, np.ones((2 * r + 1, 2 * r + 1), bool), border_value=1) & m
    if flat.sum() < FLAT_MIN_FRACTION * m.sum():
        flat[:] = False
    return flat


def _border_band(shape):
    h, w = shape
    b = max(2, int(round(BORDER_WIDTH * min(h, w))))
    band = np.ones(shape, bool)
    band[b:h - b, b:w - b] = False
    return band


def has_background(image, mask=None):
    """Whether the image shows an object on a background: a quiet image border.

    Parameters
    ----------
    image : (H, W) array_like
    mask : (H, W) bool array_like, optional
        Pixels to consider (default all).

    Returns
    -------
    bool
        True when the intensity standard deviation over the border band (width
        :data:`BORDER_WIDTH` of the smaller image side, at least 2 pixels) is below
        :data:`BORDER_QUIET` times the standard deviation over the whole image.

    Notes
    -----
    The depth at the two ends of every line along γ is unobservable by a linear SFS method;
    it lies on one plane exactly when the surface at the image border is that plane, i.e.
    when the border carries (almost) no shading.  On the synthetic set (docs/shading.md) the
    ratio is 0 to 0.36 for objects on a plane, noise 0.02 included, and 0.95 to 1.15 for
    textured surfaces that fill the frame; 0.5 lies between.

    Examples
    --------
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> has_background(lambertian_shading(8 * np.exp(-(xx**2 + yy**2) / 100), (1, 0, 1)))
    True
    >>> has_background(lambertian_shading(3 * np.sin(xx / 5) * np.cos(yy / 7), (1, 0, 1)))
    False
    """
    img = _image(image).astype(np.float64)
    m = _mask(mask, img.shape)
    band = _border_band(img.shape) & m
    total = float(img[m].std())
    if band.sum() < 16 or not total > 0:
        return False
    return float(img[band].std()) < BORDER_QUIET * total


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
    >>> yy, xx = np.mgrid[-40:41, -40:41] / 40.0
    >>> z = 40 * np.sqrt(np.clip(1.2 - xx**2 - yy**2, 0, None))
    >>> light, albedo = estimate_illuminant(lambertian_shading(z, (1, 0, 1)))
    >>> bool(light[0] > 0.3 and abs(light[1]) < 0.05)
    True
    """
    img = _image(image).astype(np.float64)
    m = _mask(mask, img.shape)
    _check_contrast(img, m)
    if exclude_background:
        fg = m & ~flat_background(img, m)
        if fg.sum() >= 16:
            m = fg
            _check_contrast(img, m)
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
def _fit_subsample(shape):
    step = max(1, int(math.ceil(math.sqrt(shape[0] * shape[1] / _FIT_PIXELS))))
    return (slice(None, None, step), slice(None, None, step)), step


def _render_residual(scale, p, q, image, light):
    """min over albedo of Σ (I − ρ R(scale·p, scale·q))², and that albedo."""
    r = _render_pq(scale * p, scale * q, light)
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
    p, q = _surface_gradient(z)
    sub, step = _fit_subsample(img.shape)
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


# --------------------------------------------------------------------------------------
# GSFS
# --------------------------------------------------------------------------------------
def _step_length(angle):
    """Euclidean length (pixels) of one step of a digital line at ``angle`` (DESIGN: lines.py)."""
    return 1.0 / max(abs(math.cos(angle)), abs(math.sin(angle)))


def _line_extent(shape, angle):
    """Pixels of path covered by one digital line at ``angle`` across the image."""
    steep, _, _ = _line_direction(angle)
    steps = shape[0] if steep else shape[1]
    return steps * _step_length(angle)


def _resolve_light(image, light, mask):
    if light is None:
        est, _ = estimate_illuminant(image, mask)
        return est, True
    return parse_light(light), False


def _integration_angle(light, direction, estimated):
    tilt, slant = _tilt_slant(light)
    if direction is not None:
        return greens._finite_scalar("direction", direction)   # radians
    if slant < MIN_SLANT:
        src = "the estimated light" if estimated else "light"
        raise ValueError(
            f"{src} ({light[0]:.4g}, {light[1]:.4g}, {light[2]:.4g}) is frontal (slant {math.degrees(slant):.2f} deg < "
            f"{math.degrees(MIN_SLANT):.0f} deg): its image-plane direction γ is undefined and the "
            f"linear reflectance term that GSFS integrates vanishes. Pass direction= (radians) to "
            f"choose the virtual light displacement, or use photometric_motion")
    return tilt


def _line_coordinates(shape, angle):
    """Digital line index (0-based) and step position of every pixel at ``angle`` (lines.py)."""
    steep, _, gamma = _line_direction(angle)
    h, w = shape
    yy, xx = np.mgrid[:h, :w]
    t, minor = (yy, xx) if steep else (xx, yy)
    r = np.floor(gamma * np.arange(h if steep else w) + 0.5).astype(np.int64)
    line = minor - r[t]
    return line - line.min(), t.astype(np.float64)


def _fix_line_solutions(z, line, t, weights, anchors):
    """Add ``c + a·t`` to every line: the homogeneous solutions of the line integration.

    ``anchors`` None: ``a = 0`` and ``c`` gives each line zero weighted mean (minimum norm).
    Otherwise ``(c, a)`` per line are the least-squares fit of ``Z + c + a·t = 0`` on its anchor
    pixels (weighted); a line with anchors at one position only gets ``a = 0``.
    """
    n = int(line.max()) + 1
    lab = line.ravel()

    def per_line(w, v):
        return np.bincount(lab, (w * v).ravel(), minlength=n)

    if anchors is None:
        cnt = per_line(weights, 1.0)
        c = -np.divide(per_line(weights, z), cnt, out=np.zeros(n), where=cnt > 0)
        return z + c[line]
    w = weights * anchors
    s0, s1, s2 = per_line(w, 1.0), per_line(w, t), per_line(w, t * t)
    sz, stz = per_line(w, z), per_line(w, t * z)
    det = s0 * s2 - s1 * s1
    ok = det > 1e-9 * np.maximum(s0 * s2, 1e-300)
    a = np.zeros(n)
    a[ok] = -(s0[ok] * stz[ok] - s1[ok] * sz[ok]) / det[ok]
    c = -np.divide(sz + a * s1, s0, out=np.zeros(n), where=s0 > 0)
    return z + c[line] + a[line] * t


def _line_ends(line, t, weights):
    """Pixels at the first and the last weighted position of every line."""
    n = int(line.max()) + 1
    idx = np.arange(n)
    lo = ndimage.minimum(np.where(weights > 0, t, np.inf), line, idx)
    hi = ndimage.maximum(np.where(weights > 0, t, -np.inf), line, idx)
    return (weights > 0) & ((t == lo[line]) | (t == hi[line]))


def shape_from_shading(image, *, light=None, u=None, k1="render", mask=None, direction=None,
                       boundary="auto", backend=None, device=None):
    """Depth from one shading image by Green's-function shape from shading (GSFS).

    Parameters
    ----------
    image : (H, W) array_like
        Shading image (Lambertian surface, one distant light).  float32/float64 kept,
        integers -> float32.  The image is used as is: no clipping, no normalisation.
    light : sequence, optional
        Light as ``(l1, l2, l3)`` or ``(tilt, slant)`` (radians; see :func:`parse_light`).
        Default: estimated from the image by :func:`estimate_illuminant` (Zheng & Chellappa).
    u : float, optional
        Matching constant (virtual disparity, eq. 7), in pixels of path along γ, > 0.
        Default: :data:`GSFS_U_FRACTION` (1) times the path length of one digital line
        across the image (Notes).
    k1 : {'render', 'linear'} or float, optional
        Depth scale of eq. 31.  ``'render'`` (default): the value whose Lambertian re-rendering
        best matches the image in least squares (:func:`fit_depth_scale`).  ``'linear'``:
        ``k1 = -ρ sin σ`` from the linearised reflectance map, with the albedo ρ of
        :func:`estimate_illuminant`.  A float is used as given (non-zero).
    mask : (H, W) bool array_like, optional
        Pixels that enter the light estimate, k0, the line constants and the k1 fit (default
        all).  The filtering itself runs over the whole image.
    direction : float, optional
        Matching direction γ as an angle in radians from +x toward +y; default the light's
        tilt.  Required when the light is frontal (slant below :data:`MIN_SLANT`).
    boundary : {'auto', 'background', 'free'}, optional
        How the two constants that the integration leaves free on every line are fixed
        (Notes).  ``'background'``: the flat background and the ends of every line lie on
        one reference plane.  ``'free'``: one global k0 and zero-mean lines.  ``'auto'``
        (default): ``'background'`` when :func:`has_background` (a quiet image border),
        else ``'free'``.
    backend, device : str, optional
        Where the line filtering runs (:func:`gfgpu.green_filter`).

    Returns
    -------
    ndarray, (H, W)
        Height toward the viewer, in pixel units, float32 (float64 for float64 input), with
        zero mean over ``mask``.

    Raises
    ------
    ValueError
        Non-2-D, empty, constant or non-finite image; a light pointing away from the viewer;
        a frontal light without ``direction``; ``u <= 0``; ``k1 == 0``; bad ``boundary``/``mask``.
    TypeError
        Non-numeric image or parameters.

    Notes
    -----
    *Operator.*  Eq. 30 of DBPS with the second-order matching equation (7) integrated once
    along γ gives (science.md §2.2) ``Z = u Ī2 / k1 − k0 (x + γy)/(k1 (1+γ²))`` (eq. 30-31)
    with ``Ī2 = I2 + (u/2)∂_γ I2`` and, in terms of the input, exactly
    ``Ī2 = ½(G_u + H_u) * I1``, i.e. eq. 32 with ``(a, b, c) = (½, -1, ½)``.  The k0 ramp of
    eq. 30 is the integral of the constant k0, so it is removed by filtering ``I1 − k0``.
    ``½(G_u + H_u)`` is one first-order complex recursion per line (:class:`ShadingGreen`),
    run causally along the digital lines at angle γ by :func:`gfgpu.green_filter` on the chosen
    backend, with ``I1 − k0 = 0`` beyond the image (``mode='constant'``: the surface continues
    as the reference plane).  Along an oblique line one step covers ``1/max(|cos γ|, |sin γ|)``
    pixels, so ``u`` in pixels is divided by that length to get the kernel's ``u`` in steps.
    The transfer function ``(1 + ε/2)/(1 + ε + ε²/2)``, ``ε = iuω``, times ``u`` tends to the
    integrator ``1/(iω)`` for ``uω ≫ 1``; with ``u`` = one line length that holds for every
    frequency a line can carry, so ``u Ī2`` is the path integral of ``I1 − k0`` along γ and,
    with the linearised Lambertian map ``I ≈ k0 − ρ sin σ ∂_γ Z``, the depth for
    ``k1 = −ρ sin σ``.

    *The two free constants of every line.*  Integrating along γ determines the depth on each
    line up to the homogeneous solutions of the integrated equation: a constant and, through
    the unknown k0, a ramp along the line (the integrator limit of eq. 34's solutions).  Depth
    variation across γ is unobservable from the linear term, so these constants must come
    from a prior, and the right prior depends on the scene:

    * an object on a flat background (``boundary='background'``): k0 is the background's
      intensity (median over the :func:`flat_background` pixels, or over the border band when
      there are none; a frontal plane gives exactly ``ρ l3``), and on
      every line ``(c, a)`` are fitted in least squares so that the flat pixels and the two
      ends of the line lie on the reference plane ``Z = 0`` (Dirichlet conditions, which also
      cancel each line's shading bias from the non-linear terms: shadows, ``1/|n|``);
    * a textured surface filling the frame (``boundary='free'``): one global k0, the mean
      intensity (the surface has no mean slope along γ), which keeps each line's own
      end-to-end depth difference, and ``c`` gives every line zero mean depth (the minimum
      norm solution, also the least cross-line gradient energy).

    ``'auto'`` chooses by :func:`has_background`.  Pentland's FFT method instead discards
    each line's mean intensity and wraps it periodically, which is neither.

    *Frontal light.*  For a light along the viewing direction γ is undefined and the linear
    term vanishes; GSFS refuses such a light unless ``direction`` is given, in which case the
    method runs as stated along that direction (its result is then not supported by the
    linearisation; docs/shading.md reports it).

    References
    ----------
    .. [1] J. R. A. Torreão, "A Green's function approach to shape from shading", Pattern
       Recognition 34:2367-2382, 2001.
    .. [2] Torreão, Victer and Fernandes, "Green's Functions of Matching Equations", 2007,
       §3, eqs. 29-34.
    .. [3] A. Pentland, "Linear shape from shading", IJCV 4:153-162, 1990.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading, photometric_motion, shape_from_shading
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> z = 8 * np.exp(-(xx**2 + yy**2) / 200)
    >>> img = lambertian_shading(z, (1, 0, 1))
    >>> est = shape_from_shading(img, light=(1, 0, 1), backend="numpy")
    >>> bool(np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.9)
    True
    """
    img = _image(image)
    m = _mask(mask, img.shape)
    _check_contrast(img, m)
    if boundary not in ("auto", "background", "free"):
        raise ValueError(f"boundary must be 'auto', 'background' or 'free', got {boundary!r}")
    L, estimated = _resolve_light(img, light, m)
    angle = _integration_angle(L, direction, estimated)
    step = _step_length(angle)
    if u is None:
        u_px = GSFS_U_FRACTION * _line_extent(img.shape, angle)
    else:
        u_px = greens._positive("u", u)
    if boundary == "auto":
        boundary = "background" if has_background(img, m) else "free"
    flat = flat_background(img, m) if boundary == "background" else None
    if boundary == "background":
        # the background's intensity: the flat pixels, else the border band
        ref = flat if flat.any() else (_border_band(img.shape) & m)
        k0 = float(np.median(img[ref]))
    else:
        k0 = float(img[m].astype(np.float64).mean())
    centred = (img - np.asarray(k0, img.dtype)).astype(img.dtype, copy=False)
    bar = green_filter(centred, ShadingGreen(u_px / step), angle=angle, mode="constant", cval=0.0,
                       backend=backend, device=device)
    z_unit = u_px * np.asarray(bar, np.float64)      # eq. 31 with k1 = 1, k0 ramp removed
    line, t = _line_coordinates(img.shape, angle)
    weights = m.astype(np.float64)
    if boundary == "background":
        anchors = (flat | _line_ends(line, t, weights)).astype(np.float64)
        z_unit = _fix_line_solutions(z_unit, line, t, weights, anchors)
    else:
        z_unit = _fix_line_solutions(z_unit, line, t, weights, None)
    z_unit -= z_unit[m].mean()
    if isinstance(k1, str):
        if k1 == "render":
            scale, _, _ = fit_depth_scale(z_unit, img, L, m)
        elif k1 == "linear":
            _, slant = _tilt_slant(L)
            _, albedo = estimate_illuminant(img, m)
            if math.sin(slant) * albedo == 0:
                raise ValueError("k1='linear' needs an oblique light (k1 = -ρ sin σ is 0 for a "
                                 "frontal one); use k1='render'")
            scale = -1.0 / (albedo * math.sin(slant))
        else:
            raise ValueError(f"k1 must be 'render', 'linear' or a non-zero number, got {k1!r}")
    else:
        k = greens._finite_scalar("k1", k1)
        if k == 0:
            raise ValueError("k1 must be non-zero (Z = u Ī2 / k1)")
        scale = 1.0 / k
    return (scale * z_unit).astype(img.dtype)


# --------------------------------------------------------------------------------------
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
    img = _image(image)
    m = _mask(mask, img.shape)
    _check_contrast(img, m)
    L, _ = _resolve_light(img, light, m)
    tilt, slant = _tilt_slant(L)
    if direction is None:
        angle = tilt if slant >= MIN_SLANT else 0.0
    else:
        angle = greens._finite_scalar("direction", direction)
    # the rotation's sense only flips the sign of Z (absorbed by the fitted scale): take the
    # direction modulo π so that lines are traversed forward and x_U lies before their start
    if _line_direction(angle)[1]:
        angle -= math.pi
    u0 = greens._positive("shift", shift)
    t, n = _line_positions(img.shape, angle)
    if fixed_point is None:
        x_U = -100.0 * n
    else:
        x_U = greens._finite_scalar("fixed_point", fixed_point)
        if not x_U < 0:
            raise ValueError(f"fixed_point must be < 0 (the affine flow's fixed point before each "
                             f"line's first sample, outside the domain of eq. 14), got {fixed_point!r}")
    sigma = math.sqrt(u0 * abs(x_U))
    kappa = greens._finite_scalar("kappa", kappa)
    i2 = np.asarray(green_filter(img, greens.AffineGreenApprox(sigma, x_U), angle=angle, mode=mode,
                                 backend=backend, device=device), np.float64)
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
        z = depth_unit(greens._finite_scalar("k0", k0))
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
