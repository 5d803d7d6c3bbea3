"""Invalidation filters applied to a finished disparity map on the host (O(H·W)).

Two filters of the kind OpenCV's StereoSGBM runs after its matcher, for the far-off wrong
pixels that large uniform surfaces produce (issue 28, item 4):

:func:`filter_speckles`
    OpenCV's ``filterSpeckles``: 4-connected regions of similar disparity (neighbours at most
    ``max_diff`` px apart) of at most ``max_size`` pixels are set to NaN.  Wrong matches in a
    uniform area tend to come as small islands at a disparity unrelated to their surroundings.
:func:`invalidate_low_confidence`
    NaN where the confidence (:func:`gfgpu.stereo.disparity` with ``return_confidence=True``:
    uniqueness margin times left-right agreement) is below a threshold.

Both take and return host arrays; :func:`gfgpu.stereo.disparity` applies them (its
``speckle_size``, ``speckle_range`` and ``min_confidence`` options) after the matcher, so every
backend's map goes through the same numpy code and the maps stay identical across backends.
``"sgm"`` runs the speckle filter by default (:data:`SPECKLE_SIZE` px, :data:`SPECKLE_RANGE`
px), the confidence threshold is off; what each changes on held-out scenes is measured in
``docs/stereo.md`` ("Low texture", ``benchmarks/stereo_lowtexture.py``).
"""

from __future__ import annotations

import numpy as np

from .._core.validation import finite_scalar, integer

#: the speckle filter of ``"sgm"`` by default (``speckle_size``, ``speckle_range``): picked on the
#: training scenes (tsukuba, venus; the setting with the lowest mean absolute error among those
#: better on every training pair) and kept because it lowered the error on held-out scenes
#: (teddy, cones, motorcycle: 9 of 9 pairs, and 5 of 6 fresh ones; docs/stereo.md, "Low texture")
SPECKLE_SIZE = 25
SPECKLE_RANGE = 0.5

__all__ = ["SPECKLE_SIZE", "SPECKLE_RANGE", "filter_speckles", "invalidate_low_confidence", "small_regions",
           "check_postfilter", "apply_postfilter"]


def _disparity_map(disp, name="disp"):
    arr = np.asarray(disp)
    if arr.dtype == object or arr.dtype.kind != "f":
        raise TypeError(f"{name} must be a float array (NaN = invalid), got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D (H, W), got shape {arr.shape}")
    return arr


def check_postfilter(speckle_size, speckle_range, min_confidence):
    """The post-filter options of :func:`gfgpu.stereo.disparity` checked (an error naming each),
    as ``(speckle_size, speckle_range, min_confidence)`` of int, float, float."""
    size = integer("speckle_size", speckle_size)
    if size < 0:
        raise ValueError(f"speckle_size must be >= 0 pixels (0 disables), got {size}")
    rng = finite_scalar("speckle_range", speckle_range)
    if rng < 0:
        raise ValueError(f"speckle_range must be >= 0 px, got {speckle_range!r}")
    conf = finite_scalar("min_confidence", min_confidence)
    if not 0 <= conf <= 1:
        raise ValueError(f"min_confidence must lie in [0, 1] (0 disables), got {min_confidence!r}")
    return size, rng, conf


def _joined(a, b, max_diff):
    """Whether ``|a - b| <= max_diff`` elementwise, the difference taken in float64 (float32
    differences round; float64 ones of float32 values do not), in one temporary: the float32
    operands are widened as the subtraction reads them (a float64 copy of the whole map and three
    whole-image temporaries before: 77 ms at 1000 x 1500 under load, mostly fresh pages).
    NaN - x is NaN and NaN <= m is False, so a join needs both pixels valid."""
    with np.errstate(invalid="ignore"):
        t = np.subtract(a, b, dtype=np.float64)
        np.abs(t, out=t)
        return np.less_equal(t, max_diff)


def small_regions(disp, max_size, max_diff):
    """Mask of the valid pixels whose region of similar disparity has at most ``max_size`` pixels.

    A region is a 4-connected component of the valid (finite) pixels, neighbours joined when
    their disparities differ by at most ``max_diff`` (a similarity rule that
    :func:`scipy.ndimage.label`, which joins equal binary values, cannot express).

    Exact, on runs: the joins to the right neighbour cut each row into runs (raster order;
    an invalid pixel is a run of its own), each inside one region.  A run of more than
    ``max_size`` pixels makes its region large.  The regions of the remaining short valid runs
    (few, in speckled areas) are the components of the graph of their vertical joins
    (:func:`scipy.sparse.csgraph.connected_components`), every long run merged into one extra
    node: a component without that node is a whole region, its size the sum of its runs'
    lengths.  O(H W) numpy passes and a graph of the short runs only; the vertical joins are
    tested only where a short run lies above or below (the default map of 1000 x 1500: 12 ms,
    where a labelling of equal disparity bins and a graph of the remaining pixels took 71 ms).
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    d = np.asarray(disp)
    if d.dtype != np.float32 and d.dtype != np.float64:
        d = d.astype(np.float64)
    h, w = d.shape
    if d.size == 0:
        return np.zeros((h, w), bool)
    start = np.ones((h, w), bool)
    # a run starts where the pixel is not joined to its left
    np.logical_not(_joined(d[:, 1:], d[:, :-1], max_diff), out=start[:, 1:])
    starts = np.flatnonzero(start)
    length = np.diff(starts, append=h * w)
    flat = d.ravel()
    # short runs of valid pixels are the graph's nodes 0 .. m - 1, every long run node m (a run
    # of more than one pixel is valid throughout: NaN joins nothing)
    short = np.isfinite(flat[starts]) & (length <= max_size)
    m = int(np.count_nonzero(short))
    if m == 0:
        return np.zeros((h, w), bool)
    node = np.full(starts.size, m, np.int32 if m < 2**31 - 1 else np.int64)
    node[short] = np.arange(m, dtype=node.dtype)
    # each pixel's node, read at the joins' two ends (was a binary search of the run starts per
    # join: 2.2 of 6.7 ms on the 741 x 500 motorcycle map)
    pix = np.repeat(node, length)
    rest = (pix < m).reshape(h, w)
    # vertical joins with a short run at either end (joins between two long runs change nothing),
    # tested there only (a whole-image test of the vertical joins: 3 ms of 15 at 1000 x 1500)
    near = np.flatnonzero(rest[:-1] | rest[1:])
    at = near[_joined(flat[near], flat[near + w], max_diff)]
    src, dst = pix[at], pix[at + w]
    # the joins of one pair of runs lie next to each other along the row: one edge for them
    # (a short run joins its neighbour row at up to max_size places)
    if src.size > 1:
        new_pair = np.empty(src.size, bool)
        new_pair[0] = True
        np.not_equal(src[1:], src[:-1], out=new_pair[1:])
        new_pair[1:] |= dst[1:] != dst[:-1]
        src, dst = src[new_pair], dst[new_pair]
    # the graph as CSR rows (the joins ordered by their first run): connected_components took
    # a COO matrix through two conversions and their checks (0.1 of 1.6 ms on tsukuba's map)
    order = np.argsort(src, kind="stable")
    indptr = np.zeros(m + 2, np.int64 if max(m + 1, src.size) >= 2**31 - 1 else np.int32)
    np.cumsum(np.bincount(src, minlength=m + 1), out=indptr[1:])
    graph = csr_matrix((np.ones(src.size, np.float64), dst[order].astype(indptr.dtype), indptr),
                       shape=(m + 1, m + 1))
    # the weak components of the directed graph are the undirected graph's, without the
    # symmetrised copy that directed=False builds
    _, comp = connected_components(graph, directed=True, connection="weak")
    size = np.bincount(comp[:m], weights=length[short], minlength=comp.max() + 1)
    small_run = np.zeros(starts.size, bool)
    small_run[short] = (comp[:m] != comp[m]) & (size[comp[:m]] <= max_size)
    return np.repeat(small_run, length).reshape(h, w)


def filter_speckles(disp, max_size, max_diff=1.0):
    """Set to NaN the small regions of similar disparity (OpenCV's ``filterSpeckles``).

    A region is a 4-connected set of valid pixels whose neighbours differ by at most
    ``max_diff`` px; every region of at most ``max_size`` pixels is invalidated.  OpenCV's
    ``speckleWindowSize`` is ``max_size``; its ``speckleRange`` (in 1/16 px for SGBM's fixed
    point maps) is ``max_diff`` in px.

    Parameters
    ----------
    disp : (H, W) float ndarray
        Disparities (px), NaN where invalid.
    max_size : int
        Largest region size (pixels) that is removed, >= 0 (0 returns a copy).
    max_diff : float, optional
        Largest disparity step (px) between 4-neighbours of one region, >= 0.

    Returns
    -------
    (H, W) ndarray of ``disp``'s dtype
        A copy with the speckles set to NaN.

    Raises
    ------
    ValueError
        ``disp`` not 2-D, ``max_size`` < 0 or ``max_diff`` < 0 or not finite.
    TypeError
        ``disp`` not a float array, ``max_size`` not an integer.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.full((4, 6), 5.0, np.float32)
    >>> d[1, 2] = 40.0                        # a 1-pixel island far off its surroundings
    >>> out = filter_speckles(d, 2, 1.0)
    >>> bool(np.isnan(out[1, 2])), int(np.isnan(out).sum())
    (True, 1)
    """
    arr = _disparity_map(disp)
    size, rng, _ = check_postfilter(max_size, max_diff, 0.0)
    out = np.array(arr, copy=True)
    if size == 0 or not np.isfinite(arr).any():
        return out
    small = small_regions(arr, size, rng)
    out[small] = np.nan
    return out


def invalidate_low_confidence(disp, confidence, threshold):
    """``disp`` with NaN where ``confidence < threshold``.

    Parameters
    ----------
    disp : (H, W) float ndarray
        Disparities, NaN where invalid.
    confidence : (H, W) array_like
        Confidence in [0, 1] (:func:`gfgpu.stereo.disparity`'s).
    threshold : float
        In [0, 1]; 0 returns a copy.

    Returns
    -------
    (H, W) ndarray, a copy

    Examples
    --------
    >>> import numpy as np
    >>> invalidate_low_confidence(np.array([[1.0, 2.0]]), np.array([[0.5, 0.1]]), 0.2)
    array([[ 1., nan]])
    """
    arr = _disparity_map(disp)
    conf = np.asarray(confidence)
    if conf.shape != arr.shape:
        raise ValueError(f"confidence must have disp's shape {arr.shape}, got {conf.shape}")
    _, _, thr = check_postfilter(0, 0.0, threshold)
    out = np.array(arr, copy=True)
    if thr > 0:
        out[conf < thr] = np.nan
    return out


def apply_postfilter(disp, confidence, speckle_size, speckle_range, min_confidence):
    """The checked post-filters of :func:`gfgpu.stereo.disparity` in its order: the confidence
    threshold, then the speckle filter (on what the threshold left).  Returns ``(disp,
    confidence)`` as float32 copies, the confidence 0 wherever the map is NaN; ``confidence``
    None (only where ``min_confidence`` is 0: a caller that does not return it) gives None."""
    out = np.asarray(disp, np.float32)
    if confidence is None and min_confidence > 0:
        raise ValueError(f"min_confidence = {min_confidence} needs the confidence, got None")
    if min_confidence > 0:
        out = invalidate_low_confidence(out, np.asarray(confidence, np.float32), min_confidence)
    if speckle_size > 0:
        out = filter_speckles(out, speckle_size, speckle_range)
    if confidence is None:
        return out, None
    conf = np.asarray(confidence, np.float32)
    return out, np.where(np.isfinite(out), conf, np.float32(0)).astype(np.float32, copy=False)
