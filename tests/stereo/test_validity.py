"""Which pixels get a disparity: a match outside the other view or a cost without a unique minimum
is NaN (every backend, every method), the left-right check, and the confidence beside the map."""


import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, shifted_pair, square

VALIDITY_CASES = [(m, dt) for m in stereo.METHODS for dt in ("float32", "uint8")]


@pytest.mark.parametrize("method,dtype", VALIDITY_CASES, ids=lambda v: str(v))
def test_no_match_is_nan(backend, method, dtype):
    # issue 14, item 1: a pixel whose match lies outside the other view, or whose cost has no
    # unique minimum, is NaN -- left band for positive disparities, right band for negative
    # ones, images narrower than the range, flat pairs -- on every backend, for every method
    left, right = (np.rint(a).astype(dtype) for a in shifted_pair(9))
    d, conf = stereo.disparity(left, right, 16, method=method, return_confidence=True, backend=backend)
    assert np.isnan(d[:, :9]).all()                       # x - 9 < 0: no right pixel
    ok = np.isfinite(d)
    # (whole-pixel cost samples: the parabola through the aggregated costs is off by < 0.3 px)
    assert np.abs(d[ok] - 9).max() <= 0.3
    assert ok[:, 16:].mean() >= 0.97                      # away from the band
    assert ((conf > 0) == ok).all() and conf.max() <= 1
    # the mirror: true d = -9 in [-16, 4]; the right band x >= W - 9 has no match
    d = stereo.disparity(right, left, 4, min_disparity=-16, method=method, backend=backend)
    ok = np.isfinite(d)
    assert np.isnan(d[:, -9:]).all()
    assert np.abs(d[ok] + 9).max() <= 0.3
    assert ok[:, :-16].mean() >= 0.97
    # a flat pair has no unique minimum anywhere
    flat = np.full((24, 40), 7, dtype)
    assert np.isnan(stereo.disparity(flat, flat, 8, method=method, backend=backend)).all()
    # narrow: the range reaches beyond the width; no candidate left of x = 9, and none at all
    # for a range that starts beyond it
    left, right = (np.rint(a).astype(dtype) for a in shifted_pair(9, (24, 24)))
    d = stereo.disparity(left, right, 30, method=method, backend=backend)
    assert np.isnan(d[:, :9]).all() and np.nanmax(np.abs(d - 9)) <= 0.35 and np.isfinite(d).any()
    assert np.isnan(stereo.disparity(left, right, 40, min_disparity=25, method=method,
                                     backend=backend)).all()


def test_no_match_same_maps_on_every_backend(backend):
    # the integer stages are bit-identical (tests/stereo/kernel_inputs.py, run by
    # tests/backends/test_fused.py); the final maps too
    for shift, lo, hi in ((9, 0, 16), (-9, -16, 4)):
        left, right = shifted_pair(abs(shift))
        if shift < 0:
            left, right = right, left
        ref = stereo.disparity(left, right, hi, min_disparity=lo, backend="numpy")
        out = stereo.disparity(left, right, hi, min_disparity=lo, backend=backend)
        np.testing.assert_array_equal(np.isnan(out), np.isnan(ref))
        np.testing.assert_allclose(out, ref, atol=1e-5, equal_nan=True)


def test_lr_check_and_colour():
    left, right, truth = random_dot_pair(square)
    rgb_l = np.repeat(left[..., None], 3, axis=2).astype(np.uint8)
    rgb_r = np.repeat(right[..., None], 3, axis=2).astype(np.uint8)
    d = stereo.disparity(rgb_l, rgb_r, 16, backend="numpy")
    plain = stereo.disparity(rgb_l[..., 0], rgb_r[..., 0], 16, backend="numpy")
    np.testing.assert_array_equal(d, plain)                # colour: its luminance (grey stays grey)
    assert 0 < np.isnan(d).mean() < 0.2
    filled = stereo.fill_holes(d)
    assert np.isfinite(filled).all()
    no_check = stereo.disparity(left, right, 16, lr_check=False, uniqueness=0, backend="numpy")
    assert np.isfinite(no_check[:, 17:]).mean() > 0.99     # only exact ties rejected there


def test_lr_check_rule():
    # left pixel x with d = 2 points at right pixel x - 2, whose own winner must be within 1 px
    disp = np.full((1, 6), 2.0, np.float32)
    right = np.array([[2, 2, 2, 5, 2, specs.NO_MATCH]], np.int32)
    out = stereo.matching.left_right_check(disp, right, 1, 1.0)
    np.testing.assert_array_equal(np.isnan(out[0]), [True, True, False, False, False, True])


def test_confidence_every_method(backend):
    left, right, truth = random_dot_pair(square)
    for method in stereo.METHODS:
        d, conf = stereo.disparity(left, right, 16, method=method, return_confidence=True, backend=backend)
        assert conf.dtype == np.float32 and conf.shape == d.shape
        assert ((conf > 0) == np.isfinite(d)).all() and conf.min() >= 0 and conf.max() <= 1
        plain = stereo.disparity(left, right, 16, method=method, backend=backend)
        np.testing.assert_array_equal(plain, d)
