"""Scene tests that fix GSFS's per-line constants: flat background, quiet border, noise level."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .params import checked_image, checked_mask

__all__ = ["noise_sigma", "flat_background", "has_background", "border_band", "quiet_sides",
           "border_side_masks"]

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
#: ... or when at least this fraction of the border band is flat background (an object that the
#: image border cuts: a bust, an object on a table edge; see :func:`has_background`)
BORDER_FLAT = 0.25



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
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> yy, xx = np.mgrid[:128, :128] / 128.0
    >>> round(noise_sigma(xx * yy + 0.02 * rng.standard_normal((128, 128))), 3)
    0.02
    """
    img = checked_image(image).astype(np.float64)
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
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> z = 8 * np.exp(-(xx**2 + yy**2) / 50)
    >>> flat = flat_background(lambertian_shading(z, (1, 0, 1)))
    >>> bool(flat[0, 0]), bool(flat[32, 28])
    (True, False)
    """
    img = checked_image(image).astype(np.float64)
    m = checked_mask(mask, img.shape)
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


def border_band(shape):
    h, w = shape
    b = max(2, int(round(BORDER_WIDTH * min(h, w))))
    band = np.ones(shape, bool)
    band[b:h - b, b:w - b] = False
    return band


def border_side_masks(shape):
    """The border band split into its four sides: ``(top, bottom, left, right)`` bool arrays."""
    h, w = shape
    b = max(2, int(round(BORDER_WIDTH * min(h, w))))
    sides = [np.zeros(shape, bool) for _ in range(4)]
    sides[0][:b] = True
    sides[1][h - b:] = True
    sides[2][:, :b] = True
    sides[3][:, w - b:] = True
    return sides


def quiet_sides(image, mask=None):
    """Which sides of the image border, ``(top, bottom, left, right)``, carry no shading.

    A side is quiet when the intensity standard deviation over its band (width
    :data:`BORDER_WIDTH` of the smaller image side, at least 2 pixels) is below
    :data:`BORDER_QUIET` times that of the whole image, the test of :func:`has_background`
    applied to one side: the surface there is the reference plane, so the depth at the ends of
    the lines that leave the image through it is 0.  A busy side is where an object (a bust,
    a relief) is cut by the frame.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading
    >>> yy, xx = np.mgrid[:64, :64] + 0.5
    >>> z = np.sqrt(np.clip(20.0**2 - xx**2 - (yy - 32)**2, 0, None))   # a sphere cut by the left side
    >>> [bool(v) for v in quiet_sides(lambertian_shading(z, (1, 0, 1)))]
    [True, True, False, True]
    """
    img = checked_image(image).astype(np.float64)
    m = checked_mask(mask, img.shape)
    total = float(img[m].std())
    out = []
    for side in border_side_masks(img.shape):
        sel = side & m
        out.append(bool(total > 0 and sel.sum() >= 4 and float(img[sel].std()) < BORDER_QUIET * total))
    return tuple(out)


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
        :data:`BORDER_QUIET` times the standard deviation over the whole image, or when at
        least :data:`BORDER_FLAT` of the band is :func:`flat_background` (an object that the
        border cuts: a bust, a relief at a table edge).

    Notes
    -----
    The depth at the two ends of every line along γ is unobservable by a linear SFS method;
    it lies on one plane exactly when the surface at the image border is that plane, i.e.
    when the border carries (almost) no shading.  On the synthetic set (docs/shading.md) the
    ratio is 0 to 0.36 for objects on a plane, noise 0.02 included, and 0.95 to 1.15 for
    textured surfaces that fill the frame; 0.5 lies between.  Objects cut by the border make
    the band busy (ratio above 0.5) but leave most of it flat: 0.42 to 0.78 of the band on the
    bordered scenes of the benchmark (noise included), against 0 on every textured surface;
    0.25 lies between.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> has_background(lambertian_shading(8 * np.exp(-(xx**2 + yy**2) / 100), (1, 0, 1)))
    True
    >>> has_background(lambertian_shading(3 * np.sin(xx / 5) * np.cos(yy / 7), (1, 0, 1)))
    False
    """
    img = checked_image(image).astype(np.float64)
    m = checked_mask(mask, img.shape)
    band = border_band(img.shape) & m
    total = float(img[m].std())
    if band.sum() < 16 or not total > 0:
        return False
    if float(img[band].std()) < BORDER_QUIET * total:
        return True
    return float(flat_background(img, m)[band].mean()) >= BORDER_FLAT
