"""Wide integer views (int32/uint32/int64) lose no value (issue 31): ``disparity`` and
``StereoMatcher`` match them exactly, not as float32 roundings."""

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import StereoMatcher, disparity, matching

from .scenes import random_dot_pair, square


def _quantised_pair():
    left, right, _ = random_dot_pair(square, shape=(40, 96), seed=4)
    q = [np.rint(v / 255 * 200).astype(np.int64) for v in (left, right)]
    q[0][0, 0] = 0                  # the pair's minimum is 0: 3 q is its exact offset copy
    return q


@pytest.mark.parametrize("dtype", [np.int32, np.uint32, np.int64])
def test_values_near_2e9_that_differ_by_3_are_matched_exactly(backend, dtype):
    # 2e9 + 3 q: float32 holds only multiples of 128 there (every pixel of a view would read
    # alike); the map must be that of the exact offset pair 3 q
    q = _quantised_pair()
    base = 2_000_000_000
    wide = [(base + 3 * v).astype(dtype) for v in q]
    assert np.float32(base + 3) == np.float32(base)
    got = disparity(*wide, 14, backend=backend)
    want = disparity(*[(3 * v).astype(np.float32) for v in q], 14, backend=backend)
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(got).mean() > 0.6
    rounded = disparity(*[v.astype(np.float32) for v in wide], 14, backend=backend)
    assert not np.array_equal(np.isfinite(rounded), np.isfinite(got))     # what was lost before
    matcher = StereoMatcher(wide[0].shape, 14, backend=backend)
    np.testing.assert_array_equal(matcher.compute(*wide), got)


@pytest.mark.parametrize("dtype, base", [(np.int64, 2**62), (np.int64, -2**62), (np.uint64, 2**63 + 5)])
def test_values_beyond_float64_integers_that_differ_by_3(dtype, base):
    # near 2**62 float64 holds only multiples of 1024: the offset is taken in integer arithmetic
    q = _quantised_pair()
    wide = [(np.array(base, dtype) + (3 * v).astype(dtype)) for v in q]
    got = disparity(*wide, 14, backend="numpy")
    want = disparity(*[(3 * v).astype(np.float32) for v in q], 14, backend="numpy")
    np.testing.assert_array_equal(got, want)


def test_wide_range_is_matched_in_float64_identically_on_every_backend(backend):
    # an int64 range beyond 2**24 after the offset: no float32 holds it; the census runs on the
    # float64 views, the same codes for every backend
    q = _quantised_pair()
    wide = [(2**40 + 100_003 * v).astype(np.int64) for v in q]
    lft, rgt = matching._exact_views(*(matching.grey_image(v, n) for v, n in zip(wide, ("l", "r"))))
    assert lft.dtype == np.float64 and float(max(lft.max(), rgt.max())) >= 2**24
    assert matching.grey_image(wide[0], "l").dtype == np.int64
    got = disparity(*wide, 14, backend=backend)
    np.testing.assert_array_equal(got, disparity(*wide, 14, backend="numpy"))
    d = got[np.isfinite(got)]
    assert d.size > 0.6 * got.size
    assert abs(np.median(d) - 4.0) < 0.1
    colour = [np.repeat(v[..., None], 3, axis=-1) for v in wide]      # grey as colour: the same map
    np.testing.assert_array_equal(disparity(*colour, 14, backend=backend), got)


def test_narrow_integers_keep_the_float32_path():
    # int32 values within float32's exact integers are matched as before (no offset)
    q = _quantised_pair()
    img = matching.grey_image(q[0].astype(np.int32), "left")
    assert img.dtype == np.float32
    assert matching.grey_image((q[0] + 2**24).astype(np.int32), "left").dtype == np.int64
    assert stereo.disparity is disparity
