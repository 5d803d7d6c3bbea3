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


def _joins(d, max_diff):
    """Which 4-neighbours are joined: ``(right, down)`` booleans of shapes (H, W-1), (H-1, W).
    NaN - x is NaN and NaN <= m is False, so a join needs both pixels valid."""
    with np.errstate(invalid="ignore"):
        return (np.abs(d[:, 1:] - d[:, :-1]) <= max_diff), (np.abs(d[1:, :] - d[:-1, :]) <= max_diff)


def _small_regions_whole(valid, right, down, max_size):
    """:func:`small_regions` on the whole grid graph at once (when most pixels lie in short runs
    of equal bins: noisy maps): a CSR matrix of each pixel's joins to its right and lower
    neighbours, built directly, and its components."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    h, w = valid.shape
    join = np.zeros((h, w, 2), bool)
    join[:, :-1, 0] = right
    join[:-1, :, 1] = down
    idx = np.arange(h * w, dtype=np.int64).reshape(h, w)
    indices = np.stack([idx + 1, idx + w], axis=-1)[join]
    indptr = np.zeros(h * w + 1, np.int64)
    np.cumsum(join.reshape(h * w, 2).sum(axis=1), out=indptr[1:])
    graph = csr_matrix((np.ones(indices.size, np.int8), indices, indptr), shape=(h * w, h * w))
    _, comp = connected_components(graph, directed=False)
    comp = comp.reshape(h, w)
    size = np.bincount(comp[valid], minlength=comp.max() + 1)
    return valid & (size[comp] <= max_size)


def small_regions(disp, max_size, max_diff):
    """Mask of the valid pixels whose region of similar disparity has at most ``max_size`` pixels.

    A region is a 4-connected component of the valid (finite) pixels, neighbours joined when
    their disparities differ by at most ``max_diff`` (a similarity rule that
    :func:`scipy.ndimage.label`, which joins equal binary values, cannot express).

    Two steps, both exact.  (1) Pixels of one bin ``floor(d / max_diff)`` differ by less than
    ``max_diff``, so a 4-connected run of equal bins (:func:`skimage.measure.label`) lies inside
    one region; a run of more than ``max_size`` pixels makes its region large, and so does a
    join to such a run.  (2) The regions of the remaining pixels (few, in speckled areas) are
    found by :func:`scipy.sparse.csgraph.connected_components` on their joins, the large runs
    merged into one extra node: a region without that node is counted in full.  Where most
    pixels remain (noisy maps), the components of the whole grid graph are taken instead.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    d = np.asarray(disp, np.float64)     # float32 differences round; float64 ones of float32 values do not
    h, w = d.shape
    valid = np.isfinite(d)
    right, down = _joins(d, max_diff)
    anchored = np.zeros((h, w), bool)
    if max_diff > 0:
        from skimage.measure import label
        # |d| <= ~2e4 px: floor(d / m) is exact enough that one bin never holds values more
        # than m apart (float64 quotient error ~1e-12 against float32 steps ~1e-7)
        # (bins counted from the smallest, int32: |d| / m stays far below 2**31 for m >= 1e-5)
        low = np.floor(np.min(d[valid]) / max_diff) - 1 if valid.any() else 0.0
        bins = np.floor(d / max_diff) - low
        if np.all(bins[valid] < 2**31 - 1):
            bins = np.where(valid, bins, 0).astype(np.int32)
            runs = label(bins, background=0, connectivity=1)
            run_size = np.bincount(runs.ravel())
            run_size[0] = 0
            anchored = np.take(run_size > max_size, runs)
    rest = valid & ~anchored
    n = int(rest.sum())
    small = np.zeros((h, w), bool)
    if n == 0:
        return small
    if 2 * n > h * w:
        return _small_regions_whole(valid, right, down, max_size)
    node = np.full((h, w), n, np.int64)        # node n: every large run at once
    node[rest] = np.arange(n)
    src, dst = [], []
    for join, a, b in ((right, (slice(None), slice(None, -1)), (slice(None), slice(1, None))),
                       (down, (slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        keep = join & (rest[a] | rest[b])      # joins between two anchored pixels change nothing
        src.append(node[a][keep])
        dst.append(node[b][keep])
    src, dst = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(src.size, np.int8), (src, dst)), shape=(n + 1, n + 1))
    _, comp = connected_components(graph, directed=False)
    size = np.bincount(comp[:n], minlength=comp.max() + 1)
    small[rest] = (comp[:n] != comp[n]) & (size[comp[:n]] <= max_size)
    return small


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
    confidence)`` as float32 copies, the confidence 0 wherever the map is NaN."""
    out = np.asarray(disp, np.float32)
    conf = np.asarray(confidence, np.float32)
    if min_confidence > 0:
        out = invalidate_low_confidence(out, conf, min_confidence)
    if speckle_size > 0:
        out = filter_speckles(out, speckle_size, speckle_range)
    return out, np.where(np.isfinite(out), conf, np.float32(0)).astype(np.float32)
