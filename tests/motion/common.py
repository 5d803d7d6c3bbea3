"""Helpers shared by the motion tests."""
import numpy as np


def float_dtype(be):
    return np.float64 if be.supports_float64 else np.float32


def centroid(img, y, x, r=None):
    """(row, col) centroid of ``img`` (optionally in a window of radius r about (y, x))."""
    yy, xx = np.mgrid[: img.shape[0], : img.shape[1]]
    w = img.astype(np.float64)
    if r is not None:
        w = np.where((np.abs(yy - y) <= r) & (np.abs(xx - x) <= r), w, 0.0)
    return float((w * yy).sum() / w.sum()), float((w * xx).sum() / w.sum())
