"""Stereo pairs with known disparities, shared by the stereo tests: random-dot stereograms of a
disparity function and exact-shift pairs cut from one texture."""

import numpy as np
from scipy import ndimage

from gfgpu import stereo


def random_dot_pair(disp_fn, shape=(64, 112), seed=0):
    """(left, right, true disparity) for a disparity given as a function of (y, x)."""
    yy, xx = np.mgrid[: shape[0], : shape[1]].astype(np.float64)
    d = disp_fn(yy, xx)
    left, right = stereo.random_dot_stereogram(d, seed)
    return left, right, d


def square(yy, xx):
    # fronto-parallel background and a raised square (piecewise constant, integer)
    return np.where((abs(yy - 32) < 14) & (abs(xx - 64) < 18), 9.0, 4.0)


def square_subpixel(yy, xx):
    return np.where((abs(yy - 32) < 14) & (abs(xx - 64) < 18), 8.4, 3.7)


def slanted(yy, xx):
    return 3.0 + 0.05 * xx + 0.02 * yy


def shifted_pair(shift, shape=(48, 96), seed=0):
    """An exact-shift pair, ``left[y, x] = right[y, x - shift]``, cut from one smooth random
    texture (so the band where ``x - shift`` leaves the right view has no match at all)."""
    h, w = shape
    rng = np.random.default_rng(seed)
    big = ndimage.gaussian_filter(rng.random((h, w + 40)), 1.0)
    big = (big - big.min()) / np.ptp(big) * 255
    right = big[:, 20:20 + w]
    left = big[:, 20 - shift:20 - shift + w]
    return left.astype(np.float32), right.astype(np.float32)


def bandlimited_pair(disp, sigma=1.0, seed=0):
    """(left, right) with ``left[y, x] = T_y(x - disp[y, x])`` and ``right[y, x] = T_y(x)`` for a
    band-limited random texture ``T_y`` of each row (a Fourier series, Gaussian spectrum of
    width ``1 / (2π sigma)`` cycles per px), evaluated exactly at any real position: exact
    sub-pixel shifts with no interpolation error.  Scaled to [0, 255], float32."""
    d = np.asarray(disp, np.float64)
    h, w = d.shape
    rng = np.random.default_rng(seed)
    k = np.fft.rfftfreq(w + 64)[1:]
    amp = np.exp(-0.5 * (2 * np.pi * k * sigma) ** 2)
    xs = np.arange(w) + 32.0
    left, right = np.empty((h, w)), np.empty((h, w))
    for y in range(h):
        c = (rng.standard_normal(k.size) + 1j * rng.standard_normal(k.size)) * amp
        right[y] = (np.exp(2j * np.pi * np.outer(xs, k)) @ c).real
        left[y] = (np.exp(2j * np.pi * np.outer(xs - d[y], k)) @ c).real
    lo, hi = right.min(), right.max()
    return (((left - lo) / (hi - lo) * 255).astype(np.float32),
            ((right - lo) / (hi - lo) * 255).astype(np.float32))
