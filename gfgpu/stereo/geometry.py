"""From disparities to geometry: depth, OpenCV-style reprojection matrix, point clouds.

Conventions as in :func:`gfgpu.stereo.disparity`: a left pixel at column ``x`` matches the right
pixel at column ``x - d``; rows and columns in array-axis order ``(row, col)``.  The camera
frame is OpenCV's: X to the right (columns), Y down (rows), Z forward along the optical axis,
in the units of the baseline.
"""

from __future__ import annotations

import numpy as np

from .._core.validation import finite_scalar, positive

__all__ = ["disparity_to_depth", "stereo_q", "reproject_to_3d"]


def _disparity_map(disparity):
    d = np.asarray(disparity)
    if d.dtype == object or d.dtype.kind not in "iuf":
        raise TypeError(f"disparity must be a real numeric array, got dtype {d.dtype}")
    if d.ndim != 2 or d.size == 0:
        raise ValueError(f"disparity must be a non-empty (H, W) array, got shape {d.shape}")
    return d.astype(np.float64)


def disparity_to_depth(disparity, focal_px, baseline, *, doffs=0.0):
    """Depth ``Z = focal_px * baseline / (d + doffs)`` of every pixel of a disparity map.

    Parameters
    ----------
    disparity : (H, W) array_like
        Disparities in px (NaN = no match), as returned by :func:`gfgpu.stereo.disparity`;
        ``+inf``/``-inf`` also mean no match (Middlebury's PFM ground truth marks unknown
        pixels with ``+inf``).
    focal_px : float
        Focal length in px (> 0), of the rectified pair.
    baseline : float
        Distance between the camera centres (> 0), in the unit wanted for the depth.
    doffs : float, optional
        Difference of the principal points' columns, ``cx_right - cx_left`` in px
        (Middlebury's ``doffs``; 0 for rectified pairs with a common principal point).

    Returns
    -------
    (H, W) float32 ndarray
        Depth in the units of ``baseline``; NaN where the disparity is NaN or infinite (no
        match: not a point at the camera, as ``f b / inf = 0`` would say; the same pixels are
        NaN in :func:`reproject_to_3d`) or where ``d + doffs <= 0`` (a point at or beyond
        infinity); ``+inf`` where the depth exceeds float32's range (``d + doffs`` below about
        ``f b / 3.4e38``).

    Raises
    ------
    ValueError
        ``focal_px`` or ``baseline`` not finite and positive, ``doffs`` not finite, or
        ``disparity`` not a non-empty 2-D array.
    TypeError
        Non-numeric arguments (strings and bools included), each named.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.array([[10.0, np.nan], [0.0, 40.0]])
    >>> disparity_to_depth(d, focal_px=800, baseline=0.1)      # metres
    array([[ 8., nan],
           [nan,  2.]], dtype=float32)
    >>> disparity_to_depth(np.array([[np.inf, 40.0]]), 800, 0.1)   # +inf: unknown (Middlebury PFM)
    array([[nan,  2.]], dtype=float32)
    """
    d = _disparity_map(disparity)
    f = positive("focal_px", focal_px)
    b = positive("baseline", baseline)
    off = finite_scalar("doffs", doffs)
    den = d + off
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = np.where(np.isfinite(d) & (den > 0), f * b / den, np.nan)
        return z.astype(np.float32)       # a depth beyond float32's range is +inf (documented)


def stereo_q(focal_px, baseline, center, *, cx_right=None):
    """The 4x4 reprojection matrix ``Q`` of a rectified pair, as OpenCV's ``stereoRectify`` gives.

    ``[X, Y, Z, W]^T = Q [x, y, d, 1]^T`` and the point is ``(X/W, Y/W, Z/W)``:
    ``Z = focal_px * baseline / (d - (cx - cx_right))``.

    Parameters
    ----------
    focal_px : float
        Focal length in px (> 0).
    baseline : float
        Distance between the camera centres (> 0); the points come out in its unit.
    center : (row, col) pair of float
        Principal point of the left view ``(cy, cx)`` in px, array-axis order.
    cx_right : float, optional
        Principal point column of the right view (default ``cx``).

    Returns
    -------
    (4, 4) float64 ndarray

    Raises
    ------
    ValueError
        ``focal_px``/``baseline`` not finite and positive, ``center`` not two finite numbers.
    TypeError
        Non-numeric arguments (strings and bools included), each named.

    Examples
    --------
    >>> stereo_q(800, 0.1, (240, 320))
    array([[   1.,    0.,    0., -320.],
           [   0.,    1.,    0., -240.],
           [   0.,    0.,    0.,  800.],
           [   0.,    0.,   10.,   -0.]])
    """
    f = positive("focal_px", focal_px)
    b = positive("baseline", baseline)
    if isinstance(center, (str, bytes)) or np.ndim(center) != 1 or len(center) != 2:
        raise ValueError(f"center must be (row, col), two finite numbers; got {center!r}")
    cy, cx = (finite_scalar("center", v) for v in center)
    cxr = cx if cx_right is None else finite_scalar("cx_right", cx_right)
    return np.array([[1.0, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, f], [0, 0, 1 / b, -(cx - cxr) / b]])


def reproject_to_3d(disparity, q):
    """3-D point of every pixel: ``[X, Y, Z, W]^T = Q [x, y, d, 1]^T``, as OpenCV's
    ``reprojectImageTo3D``.

    Parameters
    ----------
    disparity : (H, W) array_like
        Disparities in px (NaN = no match).
    q : (4, 4) array_like
        Reprojection matrix (:func:`stereo_q`, or OpenCV's ``stereoRectify``).

    Returns
    -------
    (H, W, 3) float32 ndarray
        ``(X, Y, Z)`` per pixel (X along the columns, Y along the rows, Z forward), in the
        units of the baseline folded into ``q``; NaN where the disparity is NaN or infinite
        (no match, as in :func:`disparity_to_depth`) or ``W = 0``.
        (OpenCV puts a large Z there instead, with ``handleMissingValues``.)

    Raises
    ------
    ValueError
        ``q`` not a finite 4x4 matrix, ``disparity`` not a non-empty 2-D array.
    TypeError
        Non-numeric arguments.

    Examples
    --------
    >>> import numpy as np
    >>> q = stereo_q(800, 0.1, (1.0, 1.0))
    >>> pts = reproject_to_3d(np.full((3, 3), 40.0), q)
    >>> pts[1, 1].tolist(), pts[2, 2].tolist()
    ([0.0, 0.0, 2.0], [0.0024999999441206455, 0.0024999999441206455, 2.0])
    """
    d = _disparity_map(disparity)
    qm = np.asarray(q)
    if qm.dtype == object or qm.dtype.kind not in "iuf":
        raise TypeError(f"q must be a real 4x4 matrix, got dtype {qm.dtype}")
    qm = qm.astype(np.float64)
    if qm.shape != (4, 4) or not np.isfinite(qm).all():
        raise ValueError(f"q must be a finite 4x4 matrix, got shape {qm.shape}")
    h, w = d.shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    known = np.isfinite(d)
    hom = np.stack([xx, yy, np.where(known, d, 0.0), np.ones_like(d)], axis=-1) @ qm.T
    with np.errstate(divide="ignore", invalid="ignore"):
        pts = hom[..., :3] / hom[..., 3:]
    pts[~(np.isfinite(pts).all(axis=-1) & known)] = np.nan
    return pts.astype(np.float32)
