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
What they change on real scenes, and why they are off by default, is measured in
``docs/stereo.md`` ("Low texture: post-filters", ``benchmarks/stereo_lowtexture.py``).
"""

from __future__ import annotations

import numpy as np

from .._core.validation import finite_scalar, integer

__all__ = ["filter_speckles", "invalidate_low_confidence", "check_postfilter", "apply_postfilter"]


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


def speckle_labels(disp, max_diff):
    """Labels of the 4-connected regions of similar disparity of ``disp`` and their sizes.

    Two valid (finite) 4-neighbours are joined when their disparities differ by at most
    ``max_diff``; NaN pixels belong to no region (label -1).  The components are found by
    :func:`scipy.sparse.csgraph.connected_components` on that grid graph (a similarity rule
    that :func:`scipy.ndimage.label`, which joins equal binary values, cannot express).

    Returns
    -------
    labels : (H, W) int64 ndarray
        Region index per pixel, -1 where invalid.
    sizes : (n,) int64 ndarray
        Valid pixels per label (0 for the labels of invalid pixels, which ``labels`` never uses).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    d = np.asarray(disp, np.float64)
    h, w = d.shape
    valid = np.isfinite(d)
    idx = np.arange(h * w).reshape(h, w)
    with np.errstate(invalid="ignore"):
        # NaN - x is NaN and NaN <= m is False: a join needs both pixels valid
        right = np.abs(d[:, 1:] - d[:, :-1]) <= max_diff
        down = np.abs(d[1:, :] - d[:-1, :]) <= max_diff
    src = np.concatenate([idx[:, :-1][right], idx[:-1, :][down]])
    dst = np.concatenate([idx[:, 1:][right], idx[1:, :][down]])
    graph = coo_matrix((np.ones(src.size, np.int8), (src, dst)), shape=(h * w, h * w))
    n, comp = connected_components(graph, directed=False)
    labels = np.where(valid, comp.reshape(h, w), -1).astype(np.int64)
    # each invalid pixel is a component of its own: counted over the valid pixels only, size 0
    return labels, np.bincount(labels[valid], minlength=n).astype(np.int64)


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
    labels, sizes = speckle_labels(arr, rng)
    small = np.zeros(labels.shape, bool)
    valid = labels >= 0
    small[valid] = sizes[labels[valid]] <= size
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
