"""Edge detection with the chapter's Green's-function differentiator D(x).

``canny`` = :func:`gfgpu.gradient` (D across, P = ∫D along; exact recursions on the backend)
→ magnitude and interpolated non-maximum suppression (a kernel on the backend) → hysteresis
(connected components on the host).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .._core import strips
from .._core.validation import flag
from ..filters import gradient, make_job
from ..greens import EDGE_A, EDGE_ETA
from . import kernels

__all__ = ["canny", "hysteresis", "DEFAULT_LOW", "DEFAULT_HIGH"]

#: default thresholds, in gradient-magnitude units (slope per pixel of the image scaled to
#: [0, 1] for integer types): skimage's defaults 0.1 / 0.2 apply to an unnormalised Sobel
#: magnitude, which is 8 x the slope, so these select the same edges.
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
        keep[np.unique(labels[candidates & (suppressed >= h)])] = True
        keep[0] = False
        maps.append(keep[labels])
    return maps if np.ndim(high) else maps[0]


def _threshold(value, name, use_quantiles, default):
    if value is None:
        return default, False
    v = float(value)
    if not np.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if use_quantiles and v > 1:
        raise ValueError(f"{name} must lie in [0, 1] when use_quantiles=True, got {value!r}")
    return v, use_quantiles


def canny(image, u=1.0, low_threshold=None, high_threshold=None, *, mask=None, use_quantiles=False,
          mode="reflect", cval=0.0, a=EDGE_A, eta=EDGE_ETA, single_scale=False, projection_scale=1.0,
          return_gradient=False, backend=None, device=None):
    """Edge map by the Green's-function differentiator (chapter §2) and Canny's steps.

    Parameters
    ----------
    image : (H, W) array_like or device array
        Grey image.  Integer images are scaled to [0, 1] by their dtype's maximum (as in
        skimage); float images are used as they are.
    u : float
        Scale of D(x) (pixels, > 0); the chapter's Fig. 3 uses 0.05 and 1.0.
    low_threshold, high_threshold : float, optional
        Hysteresis thresholds on the gradient magnitude (slope per pixel, see
        ``DEFAULT_LOW``/``DEFAULT_HIGH`` for the defaults, equivalent to skimage's), or
        quantiles of the magnitude in [0, 1] with ``use_quantiles=True``.
    mask : (H, W) bool array, optional
        Edges are reported only inside ``mask`` eroded by one pixel (as in skimage).
    use_quantiles : bool
        Treat the thresholds as quantiles of the gradient magnitude.
    mode, cval : str, float
        Boundary handling of the gradient (see :func:`gfgpu.green_filter`).  The image's
        outermost pixels are never edges.
    a, eta, single_scale, projection_scale
        Parameters of D(x) and of the projection P along edges, see :func:`gfgpu.derivative`.
    return_gradient : bool
        Also return the gradient magnitude and orientation (``arctan2(gy, gx)``: radians from +x,
        along the columns, toward +y, down the rows).
    backend, device
        Where the gradient and non-maximum suppression run.

    Returns
    -------
    edges : (H, W) bool ndarray
    magnitude, orientation : (H, W) ndarrays, only with ``return_gradient=True``

    Notes
    -----
    Non-maximum suppression interpolates the magnitude linearly along the gradient direction
    (as skimage's bilinear variant does) and runs on the backend; hysteresis keeps the
    8-connected components of ``magnitude >= low`` (after suppression) that contain a pixel
    ``>= high``, computed on the host with ``scipy.ndimage.label`` (one pass; faster end to
    end than an iterative device flood fill for the image sizes measured in
    ``benchmarks/edges_fom.py``).

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
    """
    use_quantiles = flag("use_quantiles", use_quantiles)
    return_gradient = flag("return_gradient", return_gradient)
    low, low_q = _threshold(low_threshold, "low_threshold", use_quantiles, DEFAULT_LOW)
    high, high_q = _threshold(high_threshold, "high_threshold", use_quantiles, DEFAULT_HIGH)
    job = make_job(image, None, backend, device, min_ndim=2)
    if job.ndim != 2:
        raise ValueError(f"image must be 2-D (H, W), got shape {job.shape}")
    strips.require_whole_image(job, "canny (hysteresis links edges across the image)")
    be = job.backend
    data = job.data
    if job.host_input:
        raw = np.asarray(image)
        if raw.dtype.kind in "iu":
            data = be.asarray(np.ascontiguousarray(raw, dtype=job.dtype) / np.iinfo(raw.dtype).max)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != job.shape:
            raise ValueError(f"mask must have the image's shape {job.shape}, got {mask.shape}")
        mask = mask.astype(bool)
    # data lives on the backend, so the gradient stays there for the suppression kernel
    gy, gx = gradient(data, u, mode=mode, cval=cval, a=a, eta=eta, single_scale=single_scale,
                      projection_scale=projection_scale, backend=be)
    suppressed = be.empty(job.shape, job.dtype)
    kernels.nms(be, gy, gx, suppressed)
    nms = be.to_host(suppressed)
    # a gradient within the recursions' rounding of the image's values is zero: without this
    # floor a flat image has "edges" made of rounding noise that differ by backend and dtype
    scale = float(np.abs(be.to_host(data)).max())
    floor = _NOISE_ULPS * float(np.finfo(job.dtype).eps) * scale
    nms[nms <= floor] = 0
    need_mag = return_gradient or low_q or high_q
    if need_mag:
        hy, hx = be.to_host(gy), be.to_host(gx)
        magnitude = np.hypot(hy, hx)
    if low_q or high_q:
        pick = magnitude if mask is None else magnitude[mask]
        if pick.size == 0:      # an empty mask: no edges (as skimage)
            low, high = np.inf, np.inf
        else:
            if low_q:
                low = float(np.percentile(pick, 100.0 * low))
            if high_q:
                high = float(np.percentile(pick, 100.0 * high))
    if high < low:
        raise ValueError(f"low_threshold ({low}) must not exceed high_threshold ({high})")
    if mask is not None:
        nms = np.where(ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=0), nms, 0)
    edges = hysteresis(nms, max(low, floor), max(high, floor)) if np.isfinite(high) else np.zeros(job.shape, bool)
    if return_gradient:
        return edges, magnitude, np.arctan2(hy, hx)
    return edges
