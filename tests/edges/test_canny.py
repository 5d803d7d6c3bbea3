"""The edge detector: NMS kernels vs the numpy rule, geometry, thresholds and mask semantics."""
import numpy as np
import pytest

import gfgpu
from gfgpu.edges import kernels as edge_kernels
from gfgpu.edges.spec import suppress_nonmaxima_reference


def _disc(size=96, radius=30.3, noise=0.0, seed=0):
    yy, xx = np.mgrid[:size, :size]
    c = (size - 1) / 2
    img = ((yy - c) ** 2 + (xx - c) ** 2 < radius**2).astype(np.float64)
    if noise:
        img += noise * np.random.default_rng(seed).standard_normal(img.shape)
    return img, c


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_nonmaximum_suppression_kernel_matches_the_rule(backend, rng, dtype):
    gy, gx = rng.standard_normal((2, 37, 53)).astype(dtype)
    gy[5, :] = 0            # exact zeros and axis-aligned gradients
    gx[:, 7] = 0
    out = backend.empty(gy.shape, dtype)
    edge_kernels.nms(backend, backend.asarray(gy), backend.asarray(gx), out)
    np.testing.assert_allclose(backend.to_host(out), suppress_nonmaxima_reference(gy, gx),
                               rtol=1e-6 if dtype == np.float32 else 1e-14, atol=0)


@pytest.mark.parametrize("u", [0.5, 1.0, 2.0])
def test_canny_finds_a_disc_within_one_pixel(backend, u):
    img, c = _disc()
    edges = gfgpu.canny(img, u, backend=backend)
    yy, xx = np.nonzero(edges)
    r = np.hypot(yy - c, xx - c)
    assert len(r) > 150                           # the whole circle ...
    assert np.all(np.abs(r - 30.3) <= 1.0)        # ... within 1 px of the true boundary
    angles = np.arctan2(yy - c, xx - c)
    assert np.histogram(angles, bins=16, range=(-np.pi, np.pi))[0].min() > 0


def test_thresholds_and_quantiles(backend):
    img, _ = _disc(noise=0.05)
    loose = gfgpu.canny(img, 1.0, 0.01, 0.02, backend=backend)
    strict = gfgpu.canny(img, 1.0, 0.05, 0.2, backend=backend)
    assert strict.sum() < loose.sum()
    assert not np.any(strict & ~loose)            # higher thresholds only remove edges
    edges, mag, ori = gfgpu.canny(img, 1.0, 0.8, 0.95, use_quantiles=True, return_gradient=True,
                                  backend=backend)
    lo, hi = np.percentile(mag, [80, 95])
    assert np.all(mag[edges] >= lo - 1e-12)
    assert mag.shape == ori.shape == img.shape
    # every kept component holds a pixel above the high threshold (hysteresis)
    from scipy import ndimage
    labels, count = ndimage.label(edges, np.ones((3, 3)))
    for k in range(1, count + 1):
        assert mag[labels == k].max() >= hi - 1e-12


def test_mask_semantics(backend):
    img, c = _disc()
    mask = np.zeros(img.shape, bool)
    mask[:, : int(c)] = True                       # left half only
    edges = gfgpu.canny(img, 1.0, mask=mask, backend=backend)
    assert edges.any()
    assert not edges[:, int(c) - 1:].any()         # nothing outside the eroded mask


def test_integer_images_are_scaled_like_skimage(backend):
    img, _ = _disc()
    as_uint8 = (img * 200).astype(np.uint8)
    as_float = as_uint8 / 255.0
    np.testing.assert_array_equal(gfgpu.canny(as_uint8, 1.0, backend=backend),
                                  gfgpu.canny(as_float, 1.0, backend=backend))


@pytest.mark.parametrize("kwargs,exc,match", [
    (dict(low_threshold=0.3, high_threshold=0.1), ValueError, "must not exceed"),
    (dict(low_threshold=1.5, use_quantiles=True), ValueError, r"\[0, 1\]"),
    (dict(low_threshold=-1.0), ValueError, ">= 0"),
    (dict(u=0.0), ValueError, "u must be > 0"),
    (dict(mask=np.ones((3, 3), bool)), ValueError, "mask must have"),
])
def test_canny_bad_inputs(kwargs, exc, match):
    img, _ = _disc(32, 10)
    with pytest.raises(exc, match=match):
        gfgpu.canny(img, **{"u": 1.0, **kwargs}, backend="numpy")
    with pytest.raises(ValueError, match="2-D"):
        gfgpu.canny(np.ones((3, 4, 5)), 1.0, backend="numpy")


def test_step_edge_is_marked_once_on_the_bright_side(backend):
    img = np.zeros((40, 48))
    img[:, 20:] = 1.0
    edges = gfgpu.canny(img, 1.0, backend=backend)
    cols = np.unique(np.nonzero(edges)[1])
    assert cols.tolist() == [20]
    assert edges[1:-1, 20].all()
