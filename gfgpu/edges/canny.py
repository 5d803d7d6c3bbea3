"""Edge detection with a one-signed variant of the chapter's differentiator D(x).

``canny`` = the gradient of :mod:`gfgpu.edges.operator` (D across, P = ∫D along; exact
recursions on the backend)
→ magnitude, interpolated non-maximum suppression and its classes against the thresholds (a
kernel on the backend) → hysteresis (seeds grown through the candidates, on the host).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from .._core import strips
from .._core.boundary import filter_mode
from .._core.job import NONFINITE, Job
from .._core.validation import finite_cval, finite_scalar, flag
from ..backends import resolve_backend
from ..filters import make_job
from ..greens import EDGE_A, EDGE_ETA
from . import kernels, operator
from .spec import class_thresholds

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

    Parameters
    ----------
    suppressed : (H, W) array_like
        Suppressed gradient magnitude (0 off the crests).
    low : float
        Lower threshold: the pixels that may be edges.
    high : float or sequence of float
        Upper threshold(s): a component is kept when it holds a pixel at or above it.

    Returns
    -------
    edges : (H, W) bool ndarray, or a list of them when ``high`` is a sequence
    """
    suppressed = np.asarray(suppressed)
    if suppressed.ndim != 2:
        raise ValueError(f"suppressed must be 2-D (H, W), got shape {suppressed.shape}")
    weak = suppressed >= low
    weak &= suppressed > 0
    index = np.flatnonzero(weak)
    values = suppressed.reshape(-1)[index]
    label, count = _components(weak, index)
    maps = [_kept(index, label, count, values >= h, weak.shape) for h in np.atleast_1d(high)]
    return maps if np.ndim(high) else maps[0]


#: above this fraction of candidate pixels ``scipy.ndimage.label`` (which visits every pixel)
#: is faster than linking runs (whose cost grows with the runs): the two cross near 7 % at
#: 512² and 2048² on noise and on the camera image with low thresholds
_DENSE_FRACTION = 1 / 16


def _components(weak, index):
    """8-connected components of the 2-D bool ``weak``, whose set pixels are at the flat ``index``.

    Returns the component of each pixel of ``index`` and an upper bound on the labels.  Sparse
    masks (edge candidates, typically 1-5 % of the pixels) are linked as runs along the rows
    (:func:`_link_runs`); dense ones by ``scipy.ndimage.label``.  Both give the same components.
    """
    if index.size > _DENSE_FRACTION * weak.size:
        labels, count = ndimage.label(weak, np.ones((3, 3), bool))
        return labels.reshape(-1)[index], count + 1
    run, component = _link_runs(index, weak.shape[1])
    return component[run], component.size


def _link_runs(index, width):
    """8-connected components of the pixels at the sorted flat ``index`` of a (H, ``width``) image.

    The pixels form runs along the rows; a run touches a run of the row above when their column
    ranges, widened by one, overlap (8-connectivity), and those runs are found by a binary
    search, so the cost is that of the candidate pixels, not of the image (``ndimage.label``
    visits every pixel and writes an int32 label image).

    Returns
    -------
    run : int ndarray
        The run of each pixel of ``index``.
    component : int ndarray
        The component of each run.
    """
    count = index.size
    if count == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    row, col = np.divmod(index, width)
    first = np.empty(count, bool)          # the first pixel of each run
    first[0] = True
    np.not_equal(np.diff(index), 1, out=first[1:])
    first[1:] |= col[1:] == 0               # a run never wraps onto the next row
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:], count) - 1
    # keys row * (width + 2) + column: a search widened by one column stays within its row
    stride = width + 2
    base = row[starts] * stride
    start_key = base + col[starts]
    end_key = base + col[ends]
    above = base - stride
    lo = np.searchsorted(end_key, above + col[starts] - 1, "left")
    hi = np.searchsorted(start_key, above + col[ends] + 1, "right")
    links = np.maximum(hi - lo, 0)
    total = int(links.sum())
    run = np.cumsum(first) - 1
    if total == 0:
        return run, np.arange(starts.size)
    source = np.repeat(np.arange(starts.size), links)
    target = np.arange(total) - np.repeat(np.cumsum(links) - links - lo, links)
    graph = sparse.csr_matrix((np.ones(total, np.int8), (source, target)), shape=(starts.size, starts.size))
    return run, csgraph.connected_components(graph, directed=False)[1]


def _grow(between, strong):
    """Hysteresis from its seeds ``strong`` and the other candidates ``between`` (2-D bool,
    disjoint, both False on the image's border): the pixels of the 8-connected components of
    ``between | strong`` that hold a seed.

    Every seed is an edge; a candidate below the upper threshold is one when its component among
    such candidates alone touches a seed (8-neighbours): the path from it to a seed runs through
    those candidates up to the first seed.  Only the candidates between the two thresholds are
    linked, typically far fewer than all of them (none for noise, where every crest clears both).
    The edges are written into ``strong`` (returned).
    """
    index = np.flatnonzero(between)
    edges = strong
    if index.size == 0:
        return edges
    label, count = _components(between, index)
    # a seed among the 8 neighbours; no candidate is on the border, so no offset leaves the
    # image or wraps onto the next row
    width = between.shape[1]
    seeds = strong.reshape(-1)
    touch = np.zeros(index.size, bool)
    for offset in (-width - 1, -width, -width + 1, -1, 1, width - 1, width, width + 1):
        touch |= seeds[index + offset]
    keep = np.zeros(count, bool)    # (every seed read above, before the first edge is added)
    keep[label[touch]] = True
    edges.reshape(-1)[index[keep[label]]] = True
    return edges


def _kept(index, label, count, strong, shape):
    """Edge map: the pixels at ``index`` whose component (``label`` < ``count``) holds a pixel
    where ``strong`` (both per pixel of ``index``)."""
    keep = np.zeros(count, bool)
    keep[label[strong]] = True
    edges = np.zeros(shape, bool)
    edges.reshape(-1)[index[keep[label]]] = True
    return edges


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
    """The image as a host array of the work dtype (not checked to be finite); integers scaled to [0, 1]
    by their dtype's maximum (as skimage), in float64 before the cast so no integer is rounded
    before its division."""
    be = job.backend
    if not job.host_input:
        return be.to_host(job.data)
    raw = np.asarray(job.source)
    if raw.dtype.kind in "iu":
        return (raw.astype(np.float64) / np.iinfo(raw.dtype).max).astype(job.dtype)
    return np.asarray(raw, dtype=job.dtype)     # never written: the scaling below makes a new array


def _scale_pow2(img, exponent, dtype):
    """``img * 2**exponent`` in ``dtype``, as ``np.ldexp``: a product with a power of two is exact,
    or rounded once where it is subnormal, as ldexp rounds; a multiplication streams at memory
    speed where ldexp calls libm per element (20 ms at 2048²).  Factors outside the dtype's
    normal range (images of subnormal or near-overflowing peak) take ldexp."""
    info = np.finfo(dtype)
    if info.minexp <= exponent < info.maxexp:
        return np.multiply(img, np.dtype(dtype).type(2.0 ** exponent), dtype=dtype)
    return np.ldexp(img, exponent).astype(dtype, copy=False)


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
    (as skimage's bilinear variant does) and runs on the backend, which also compares the
    suppressed magnitude with the thresholds (one byte a pixel comes back to the host);
    hysteresis keeps the 8-connected components of ``magnitude >= low`` (after suppression)
    that contain a pixel ``>= high``.  It is computed on the host as: every seed (``>= high``)
    is an edge, and a candidate below ``high`` is one when its component among those
    candidates alone touches a seed (the path to a seed runs through them up to the first
    seed), so only the candidates between the thresholds are linked: their runs along the
    rows, linked to the touching runs of the row above by a binary search, and the components
    of that graph (``scipy.sparse.csgraph``), which costs those few candidates rather than the
    image (candidates denser than 1/16 of the pixels take ``scipy.ndimage.label``, the same
    components).  Magnitudes within 64 ulps of the image's largest value are rounding noise
    and never edges.

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
    # the finite check is the image's extremes below, which also give its peak (one read)
    job = Job(image, None, resolve_backend(backend, device, image), min_ndim=2, finite=True)
    if job.ndim != 2:
        raise ValueError(f"image must be 2-D (H, W), got shape {job.shape}")
    if mask is not None:
        mask = _check_mask(mask, job.shape)
    strips.require_whole_image(job, "canny (hysteresis links edges across the image)")
    be = job.backend
    img = _host_image(job, image)
    hi, lo = float(img.max()), float(img.min())      # no |img| temporary
    if not (math.isfinite(hi) and math.isfinite(lo)):
        raise ValueError(NONFINITE)
    peak = max(hi, -lo)
    if mask is not None:
        if not mask.any():
            return _nothing(job, return_gradient)
        img = _fill_outside(img, mask)
        peak = max(float(img.max()), -float(img.min()))
    if "constant" in mode:       # the constant extension is part of the image
        peak = max(peak, abs(cval))
    if peak == 0:
        return _nothing(job, return_gradient)
    # a power of two: exact, and it brings the image to [0.5, 1) so that no pass, square or
    # sum can overflow or underflow (|g| <= sqrt(2) max|image| for this one-signed D)
    exponent = int(np.frexp(peak)[1])
    if exponent:
        img = _scale_pow2(img, -exponent, job.dtype)
    cval = float(np.ldexp(cval, -exponent))
    # read in place by a CPU device (a copy elsewhere); img is never written: a scaled or converted
    # image is a new array, and the caller's own array is only read
    dev = be.host_view(np.ascontiguousarray(img))
    gy, gx = operator.gradient(Job(dev, None, be, finite=True), u, mode, cval, a, eta, single_scale,
                               projection_scale)
    # a gradient within the recursions' rounding of the image's values is zero: without this
    # floor a flat image has "edges" made of rounding noise that differ by backend and dtype
    floor = _NOISE_ULPS * float(np.finfo(job.dtype).eps) * float(np.ldexp(peak, -exponent))
    if return_gradient or low_q or high_q:
        hy, hx = be.to_host(gy), be.to_host(gx)
        magnitude = np.hypot(hy, hx)
    # thresholds in the normalised image's units; quantiles partition one scratch copy in place
    # (the second partition starts from the first's order), one scalar q at a time: a q array
    # would interpolate in float64, not in the magnitude's dtype
    if low_q or high_q:     # a copy: the magnitude itself classifies below
        scratch = magnitude.ravel().copy()
    low = float(np.percentile(scratch, 100.0 * low, overwrite_input=True)) if low_q else float(np.ldexp(low, -exponent))
    high = (float(np.percentile(scratch, 100.0 * high, overwrite_input=True)) if high_q
            else float(np.ldexp(high, -exponent)))
    if high < low:     # only where one threshold is a quantile and the other the absolute default
        raise ValueError(f"low_threshold ({low_threshold!r}: {np.ldexp(low, exponent):.6g} per pixel) must not "
                         f"exceed high_threshold ({high_threshold!r}: {np.ldexp(high, exponent):.6g} per pixel)")
    # candidates: above the floor and >= low, in one comparison (either bound implies the other;
    # decided on the bounds as the comparisons round them, to the dtype); seeds: candidates
    # >= high.  The device classifies the suppressed magnitude (one byte a pixel read back)
    low_t, floor_t = class_thresholds(job.dtype, low, floor)
    bound, strict = (floor_t, True) if low_t <= floor_t else (low_t, False)
    classes = be.empty(job.shape, np.uint8)
    # a quantile is a value of the host's magnitude (quantile 1: its maximum): compared with the
    # device's own magnitude, which may round differently, a pixel at the threshold could fall on
    # either side. Then the device keeps the crests only and the host compares its magnitude
    on_host = low_q or high_q
    kernels.nms_classes(be, gy, gx, classes, floor_t if on_host else bound, np.inf if on_host else high,
                        True if on_host else strict)
    cls = np.asarray(be.to_host(classes))
    if on_host:
        high_t = class_thresholds(job.dtype, high, high)[0]
        weak = (cls != 0) & (magnitude > floor_t) & (magnitude >= low_t)
        cls = weak.view(np.uint8) | ((weak & (magnitude >= high_t)).view(np.uint8) << 1)
    if mask is not None:        # candidates inside the eroded mask only
        cls = cls * ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=0)
    # the suppressed magnitude is 0 on the border: clearing it again keeps _grow's neighbours inside
    cls[[0, -1], :] = cls[:, [0, -1]] = 0
    edges = _grow(cls == 1, cls == 3)
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
