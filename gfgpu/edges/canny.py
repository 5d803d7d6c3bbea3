"""Edge detection with a one-signed variant of the chapter's differentiator D(x).

``canny`` = the gradient of :mod:`gfgpu.edges.operator` (D across, P = ∫D along; exact
recursions on the backend)
→ magnitude and interpolated non-maximum suppression (a kernel on the backend) → hysteresis
(connected components on the host).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import ndimage

from .._core import strips
from .._core.boundary import filter_mode
from .._core.job import Job
from .._core.validation import finite_cval, finite_scalar, flag
from ..filters import make_job
from ..greens import EDGE_A, EDGE_ETA
from . import kernels, operator

__all__ = ["canny", "edge_gradient", "check_arguments", "hysteresis", "DEFAULT_LOW", "DEFAULT_HIGH"]

#: default thresholds, in gradient-magnitude units (slope per pixel of the image scaled to
#: [0, 1] for integer types): skimage's defaults 0.1 / 0.2 apply to an unnormalised Sobel
#: magnitude, which is 8 x the slope, so these are the same thresholds on the slope (the
#: operators differ, so the edges do too: README, "Edge detection").
DEFAULT_LOW, DEFAULT_HIGH = 0.1 / 8, 0.2 / 8

#: gradient magnitudes below this many ulps of the image's largest value are rounding noise
_NOISE_ULPS = 64

def hysteresis(suppressed, low, high):
    """Hysteresis thresholding of a suppressed gradient magnitude (host, one labelling pass).

    Keeps the 8-connected components of ``suppressed >= low`` (and ``> 0``) that hold a pixel
    ``>= high``.  ``high`` may be a sequence: the labelling is shared and one edge map is
    returned per value (used to scan thresholds cheaply).

    Returns
    -------
    edges : bool ndarray, or a list of them when ``high`` is a sequence
    """
    candidates = suppressed >= low
    candidates &= suppressed > 0
    labels, count = ndimage.label(candidates, np.ones((3, 3), bool))
    highs = np.atleast_1d(high)
    maps = []
    for h in highs:
        if count == 0:
            maps.append(candidates.copy())
            continue
        keep = np.zeros(count + 1, bool)
        keep[labels[candidates & (suppressed >= h)]] = True      # (repeated labels: no sort needed)
        keep[0] = False
        maps.append(keep[labels])
    return maps if np.ndim(high) else maps[0]


def _threshold(value, name, use_quantiles, default):
    if value is None:
        return default, False
    allowed = "a quantile in [0, 1] (use_quantiles=True)" if use_quantiles else \
        "a finite number >= 0 (gradient-magnitude units)"
    try:
        v = finite_scalar(name, value)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{name} must be {allowed}, got {value!r}") from None
    if v < 0 or (use_quantiles and v > 1):
        raise ValueError(f"{name} must be {allowed}, got {value!r}")
    return v, use_quantiles


def _check_mask(mask, shape):
    mask = np.asarray(mask)
    if mask.shape != shape:
        raise ValueError(f"mask must have the image's shape {shape} (rows, cols), got {mask.shape}")
    if mask.dtype != bool:
        # 0/1 masks (uint8 from an image file) are taken as they are; any other value is an error
        if mask.dtype.kind not in "iuf" or not np.all((mask == 0) | (mask == 1)):
            raise TypeError(f"mask must be a boolean array (or hold only 0 and 1), got dtype {mask.dtype}"
                            + (" with other values" if mask.dtype.kind in "iuf" else ""))
        mask = mask != 0
    return mask


def _host_image(job, image):
    """The image as a host array of the work dtype, finite (checked); integers scaled to [0, 1]
    by their dtype's maximum (as skimage), in float64 before the cast so no integer is rounded
    before its division."""
    be = job.backend
    if not job.host_input:
        return be.to_host(job.data)
    raw = np.asarray(job.source)
    if raw.dtype.kind in "iu":
        return (raw.astype(np.float64) / np.iinfo(raw.dtype).max).astype(job.dtype)
    return np.asarray(raw, dtype=job.dtype)     # never written: the scaling below makes a new array


def _fill_outside(img, mask):
    """Pixels outside ``mask`` replaced by their nearest pixel inside (taxicab distance): the
    gradient then depends on the pixels inside only, and has no step at the mask's boundary.
    (The chamfer transform is 3.5x faster than the Euclidean one, 0.4 s against 1.3 s at 2048²;
    across a straight boundary both pick the pixel straight across.)"""
    if mask.all():
        return img
    idx = ndimage.distance_transform_cdt(~mask, metric="taxicab", return_distances=False, return_indices=True)
    return img[tuple(idx)]


class Arguments(NamedTuple):
    """canny's parameters, checked (:func:`check_arguments`)."""
    low: float
    low_q: bool
    high: float
    high_q: bool
    cval: float
    single_scale: bool
    return_gradient: bool


def check_arguments(u=1.0, low_threshold=None, high_threshold=None, *, mask=None, shape=None, use_quantiles=False,
                    mode="reflect", cval=0.0, a=EDGE_A, eta=EDGE_ETA, single_scale=False, projection_scale=1.0,
                    return_gradient=False):
    """Check :func:`canny`'s parameters without an image (callers that run it later, such as
    :func:`gfgpu.dask.canny`, check before any work); ``mask`` against ``shape`` (H, W) when
    both are given.  Raises as :func:`canny`; returns an :class:`Arguments`."""
    use_quantiles = flag("use_quantiles", use_quantiles)
    return_gradient = flag("return_gradient", return_gradient)
    single_scale = flag("single_scale", single_scale)
    low, low_q = _threshold(low_threshold, "low_threshold", use_quantiles, DEFAULT_LOW)
    high, high_q = _threshold(high_threshold, "high_threshold", use_quantiles, DEFAULT_HIGH)
    if low_q == high_q and low > high:   # quantiles are monotone: the same order holds after
        raise ValueError(f"low_threshold ({low}) must not exceed high_threshold ({high})")
    filter_mode(mode)       # scipy's names; canny takes the filter meaning (grid-* as their twins)
    cval = finite_cval(cval)
    operator.gradient_programs(u, a, eta, single_scale, projection_scale)   # checks u, a, eta, the ratio
    if mask is not None and shape is not None:
        _check_mask(mask, tuple(shape))
    return Arguments(low, low_q, high, high_q, cval, single_scale, return_gradient)


def canny(image, u=1.0, low_threshold=None, high_threshold=None, *, mask=None, use_quantiles=False,
          mode="reflect", cval=0.0, a=EDGE_A, eta=EDGE_ETA, single_scale=False, projection_scale=1.0,
          return_gradient=False, backend=None, device=None):
    """Edge map by a one-signed two-scale Green's-function differentiator and Canny's steps.

    Parameters
    ----------
    image : (H, W) array_like or device array
        Grey image, rows then columns.  Integer images are scaled to [0, 1] by their dtype's
        maximum (as in skimage); float images are used as they are.  The edges do not depend
        on the image's scale: ``canny(c * x, u, c * lo, c * hi)`` equals ``canny(x, u, lo, hi)``
        exactly for a power of two ``c`` and up to the rounding of ``c * x`` otherwise (tested
        for float32 images from 1e-25 to 1e38): the image is normalised by a power of two
        before the passes, so no intermediate overflows or underflows.
    u : float
        Scale of the differentiator, pixels, in [0.002, 1e9] (``eta * u`` too).
    low_threshold, high_threshold : float, optional
        Hysteresis thresholds on the gradient magnitude, >= 0, in the image's units per pixel
        (slope; defaults ``DEFAULT_LOW``/``DEFAULT_HIGH`` = 0.0125/0.025, skimage's 0.1/0.2
        divided by the Sobel gain 8), or quantiles in [0, 1] with ``use_quantiles=True``:
        then the thresholds are ``numpy.percentile(magnitude, 100 * q)`` (linear
        interpolation) of the gradient magnitude over the whole image, before non-maximum
        suppression, as skimage takes them (also with a ``mask``).
    mask : (H, W) bool array, optional
        Region of interest.  Pixels outside it do not influence the result: they are replaced
        by their nearest pixel inside (taxicab distance) before the gradient, and edges are reported
        only inside ``mask`` eroded by one pixel (3×3, as in skimage).  skimage instead
        smooths the zero-filled image and divides by the smoothed mask; both make the edges a
        function of the pixels inside the mask only.  An all-False mask gives no edges.
    use_quantiles : bool
        Treat the thresholds as quantiles (see above).
    mode, cval : str, float
        Boundary handling of the gradient (see :func:`gfgpu.green_filter`).  The image's
        outermost pixels are never edges.
    a, eta : float
        Weight (> 0) of the fine scale u and ratio (> 0) of the coarse scale ``eta * u``
        (defaults 1.1 and 3.5, the chapter's).
    single_scale : bool
        Use the fine scale only.
    projection_scale : float
        Scale (> 0) of the smoothing along edges, relative to ``u``.
    return_gradient : bool
        Also return the gradient magnitude (image units per pixel, the image's dtype) and
        orientation (``arctan2(gy, gx)``: radians from +x, along the columns, toward +y, down
        the rows).
    backend, device
        Where the gradient and non-maximum suppression run.

    Returns
    -------
    edges : (H, W) bool ndarray
    magnitude, orientation : (H, W) ndarrays, only with ``return_gradient=True``

    Raises
    ------
    TypeError
        A threshold, ``u``, ``a``, ``eta``, ``projection_scale`` or ``cval`` that is not a real
        number; a flag that is not a bool; a mask that is not boolean (or 0/1).
    ValueError
        Any parameter out of its range above, ``low_threshold`` above ``high_threshold``, a
        mask of another shape, an image that is not 2-D, empty or holds NaN/infinity.

    Notes
    -----
    **The differentiator.**  The chapter's D(x) (eq. 25-26, :func:`gfgpu.derivative`) is a
    sum of damped sines; its step response oscillates, with extrema every π·η·u pixels (11 px
    at u = 1) of 1 % of the edge's height, which non-maximum suppression reports as parallel
    ghost edges at any contrast or low threshold that lets them through.  ``canny`` therefore
    uses the one-signed variant of :mod:`gfgpu.edges.operator`: each ``e^{-t} sin t`` is
    replaced by ``e^{-t}(1 - e^{-t})`` (same value, slope and decay at the origin), which keeps
    the two scales, the weights, the unit ramp response and the exact O(N) recursions, and whose
    step response has a single extremum, at the edge.  ``return_gradient`` returns its gradient.

    Non-maximum suppression interpolates the magnitude linearly along the gradient direction
    (as skimage's bilinear variant does) and runs on the backend; hysteresis keeps the
    8-connected components of ``magnitude >= low`` (after suppression) that contain a pixel
    ``>= high``, computed on the host with ``scipy.ndimage.label`` (one pass; faster end to
    end than an iterative device flood fill for the image sizes measured in
    ``benchmarks/edges_fom.py``).  Magnitudes within 64 ulps of the image's largest value are
    rounding noise and never edges.

    References
    ----------
    .. [1] J. Canny, "A computational approach to edge detection", IEEE PAMI 8(6), 1986.
    .. [2] J. R. A. Torreão, M. S. Amaral, Pattern Recognition Letters 23 (2002) 1755-1759.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> yy, xx = np.mgrid[:64, :64]
    >>> disc = ((yy - 32) ** 2 + (xx - 32) ** 2 < 15 ** 2).astype(float)
    >>> edges = gfgpu.canny(disc, 1.0, backend="numpy")
    >>> bool(edges[32, 17] or edges[32, 18]), bool(edges[32, 32])
    (True, False)
    >>> step = (xx >= 32) * 255.0          # one edge at every contrast: no side lobes
    >>> np.unique(np.nonzero(gfgpu.canny(step, 1.0, backend="numpy"))[1]).tolist()
    [32]
    """
    args = check_arguments(u, low_threshold, high_threshold, use_quantiles=use_quantiles, mode=mode, cval=cval,
                           a=a, eta=eta, single_scale=single_scale, projection_scale=projection_scale,
                           return_gradient=return_gradient)
    low, low_q, high, high_q, cval = args.low, args.low_q, args.high, args.high_q, args.cval
    single_scale, return_gradient = args.single_scale, args.return_gradient
    mode = filter_mode(mode)
    job = make_job(image, None, backend, device, min_ndim=2)
    if job.ndim != 2:
        raise ValueError(f"image must be 2-D (H, W), got shape {job.shape}")
    if mask is not None:
        mask = _check_mask(mask, job.shape)
    strips.require_whole_image(job, "canny (hysteresis links edges across the image)")
    be = job.backend
    img = _host_image(job, image)
    if mask is not None:
        if not mask.any():
            return _nothing(job, return_gradient)
        img = _fill_outside(img, mask)
    peak = max(float(img.max()), -float(img.min()))     # no |img| temporary
    if "constant" in mode:       # the constant extension is part of the image
        peak = max(peak, abs(cval))
    if peak == 0:
        return _nothing(job, return_gradient)
    # a power of two: exact, and it brings the image to [0.5, 1) so that no pass, square or
    # sum can overflow or underflow (|g| <= sqrt(2) max|image| for this one-signed D)
    exponent = int(np.frexp(peak)[1])
    if exponent:
        img = np.ldexp(img, -exponent).astype(job.dtype, copy=False)
    cval = float(np.ldexp(cval, -exponent))
    # read in place by a CPU device (a copy elsewhere); img is never written: a scaled or converted
    # image is a new array, and the caller's own array is only read
    dev = be.host_view(np.ascontiguousarray(img))
    gy, gx = operator.gradient(Job(dev, None, be, finite=True), u, mode, cval, a, eta, single_scale,
                               projection_scale)
    suppressed = be.empty(job.shape, job.dtype)
    kernels.nms(be, gy, gx, suppressed)
    nms = be.to_host(suppressed)
    # a gradient within the recursions' rounding of the image's values is zero: without this
    # floor a flat image has "edges" made of rounding noise that differ by backend and dtype
    floor = _NOISE_ULPS * float(np.finfo(job.dtype).eps) * float(np.ldexp(peak, -exponent))
    nms[nms <= floor] = 0
    if return_gradient or low_q or high_q:
        hy, hx = be.to_host(gy), be.to_host(gx)
        magnitude = np.hypot(hy, hx)
    # thresholds in the normalised image's units
    low = float(np.ldexp(low, -exponent)) if not low_q else float(np.percentile(magnitude, 100.0 * low))
    high = float(np.ldexp(high, -exponent)) if not high_q else float(np.percentile(magnitude, 100.0 * high))
    if high < low:     # only where one threshold is a quantile and the other the absolute default
        raise ValueError(f"low_threshold ({low_threshold!r}: {np.ldexp(low, exponent):.6g} per pixel) must not "
                         f"exceed high_threshold ({high_threshold!r}: {np.ldexp(high, exponent):.6g} per pixel)")
    if mask is not None:
        nms = np.where(ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=0), nms, 0)
    edges = hysteresis(nms, max(low, floor), max(high, floor))
    if return_gradient:
        with np.errstate(over="ignore"):    # only a magnitude beyond the dtype's range: inf
            mag = np.ldexp(magnitude, exponent).astype(job.dtype, copy=False)
        return job.deliver((edges, mag, np.arctan2(hy, hx)))
    return job.deliver(edges)


def edge_gradient(image, u=1.0, *, mode="reflect", cval=0.0, a=EDGE_A, eta=EDGE_ETA, single_scale=False,
                  projection_scale=1.0, backend=None, device=None):
    """The gradient :func:`canny` differentiates with: the one-signed D across, P = ∫D along.

    Parameters
    ----------
    image : (H, W) array_like or device array
        Grey image (float32/float64 kept; bools and integers of up to 16 bits in float32,
        wider integers in float64, unscaled).
    u, mode, cval, a, eta, single_scale, projection_scale, backend, device
        As in :func:`canny`.

    Returns
    -------
    (gy, gx) : tuple of (H, W) arrays
        d/dy (down the rows) and d/dx (along the columns), unit response to a unit ramp; numpy
        in, numpy out; a device array stays on its device.

    Raises
    ------
    TypeError, ValueError
        As :func:`canny` for these parameters; an image that is not 2-D, empty or not finite.

    Notes
    -----
    Unlike :func:`canny` the image is not normalised first: values whose squares overflow the
    dtype give an overflowing gradient magnitude, not an overflowing gradient.
    """
    single_scale = flag("single_scale", single_scale)
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    operator.gradient_programs(u, a, eta, single_scale, projection_scale)    # checks u, a, eta, the ratio
    job = make_job(image, None, backend, device, min_ndim=2)
    if job.ndim != 2:
        raise ValueError(f"image must be 2-D (H, W), got shape {job.shape}")
    return operator.gradient(job, u, mode, cval, a, eta, single_scale, projection_scale)


def _nothing(job, return_gradient):
    edges = np.zeros(job.shape, bool)
    if return_gradient:
        return job.deliver((edges, np.zeros(job.shape, job.dtype), np.zeros(job.shape, job.dtype)))
    return job.deliver(edges)
