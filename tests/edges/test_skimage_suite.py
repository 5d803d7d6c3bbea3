"""scikit-image's own canny tests (skimage/feature/tests/test_canny.py), run against gfgpu.canny.

Adapter: skimage's ``canny(image, sigma, low, high, mask)`` is ``gfgpu.canny(image, u, low / 8,
high / 8, mask=mask)`` with ``u = sigma / 2`` (gfgpu's thresholds are slopes, skimage's Sobel
magnitudes, 8 x the slope).  The scale: gfgpu's smoothing has the variance of a Gaussian of
sigma = 4 u, but it is peaked and suppresses noise less; at u = sigma / 4 the noisy circle keeps
2,173 noise edge pixels, at u >= 1.5 (sigma / 2.7) none.
Differences kept on purpose (README, "Edge detection"): ``test_use_quantiles`` compares with an
11 x 11 map hand-made from skimage's Gaussian + Sobel (another operator marks other pixels), and
``test_preserve_range`` tests an argument gfgpu does not have (integers are always scaled to
[0, 1] by their dtype's maximum).
"""
import numpy as np
import pytest
from scipy.ndimage import binary_dilation, binary_erosion

import gfgpu


def canny(image, sigma=1.0, low_threshold=None, high_threshold=None, mask=None, use_quantiles=False,
          backend="numpy"):
    scale = 1.0 if use_quantiles else 1 / 8
    low = None if low_threshold is None else low_threshold * scale
    high = None if high_threshold is None else high_threshold * scale
    return gfgpu.canny(image, sigma / 2, low, high, mask=mask, use_quantiles=use_quantiles, backend=backend)


def _ring():
    i, j = np.mgrid[-200:200, -200:200].astype(float) / 200
    return np.abs(np.sqrt(i * i + j * j) - 0.5) < 0.02


def test_00_00_zeros(backend):
    assert not canny(np.zeros((20, 20)), 4, 0, 0, np.ones((20, 20), bool), backend=backend).any()


def test_00_01_zeros_mask(backend):
    img = np.random.default_rng(0).uniform(size=(20, 20))
    assert not canny(img, 4, 0, 0, np.zeros((20, 20), bool), backend=backend).any()


def test_01_01_circle(backend):
    c = _ring()
    result = canny(c.astype(float), 4, 0, 0, np.ones(c.shape, bool), backend=backend)
    cde = binary_dilation(c, iterations=3) & ~binary_erosion(c, iterations=3)
    assert np.all(cde[result])
    assert 1200 < result.sum() < 1600


def test_01_02_circle_with_noise(backend):
    c = _ring()
    rng = np.random.RandomState(0)
    cf = c.astype(float) * 0.5 + rng.uniform(size=c.shape) * 0.5
    result = canny(cf, 4, 0.1, 0.2, np.ones(c.shape, bool), backend=backend)
    cde = binary_dilation(c, iterations=4) & ~binary_erosion(c, iterations=4)
    assert np.all(cde[result])
    assert 1200 < result.sum() < 1600


def test_image_shape():
    with pytest.raises(ValueError):
        canny(np.zeros((20, 20, 20)), 4, 0, 0)


def test_mask_none():
    result1 = canny(np.zeros((20, 20)), 4, 0, 0, np.ones((20, 20), bool))
    result2 = canny(np.zeros((20, 20)), 4, 0, 0)
    assert np.all(result1 == result2)


def test_full_mask_matches_no_mask():
    from skimage import data
    img = data.camera()[::4, ::4]
    np.testing.assert_array_equal(canny(img, 2, mask=np.ones(img.shape, bool)), canny(img, 2))


@pytest.mark.parametrize("low,high", [(0.5, 3.6), (-5, 0.5), (99, 0.9), (0.5, -100), (50, 150)])
def test_invalid_use_quantiles(low, high):
    from skimage import data, img_as_float
    image = img_as_float(data.camera()[::50, ::50])
    with pytest.raises(ValueError):
        canny(image, use_quantiles=True, low_threshold=low, high_threshold=high)


def test_dtype():
    from skimage import data, img_as_float
    image_uint8 = data.camera()
    np.testing.assert_array_equal(canny(image_uint8), canny(img_as_float(image_uint8)))
