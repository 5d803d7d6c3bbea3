"""float64 pairs beyond float32's range: matched as exactly as wide integers, on every backend.

Cast to float32 first, a finite float64 pair above float32's largest value overflowed to inf and
was refused as "NaN or infinite" (a wrong error: it has none), and one below float32's smallest
normal value became an all-zero image (every pixel NaN).  Both are power-of-two copies of an
integer pair here, whose wide-integer copy (int64, shifted by 40 bits) is matched in float64 on
the host: the maps must be that pair's, bit for bit."""

import numpy as np
import pytest

from gfgpu import stereo


def _pair():
    rng = np.random.default_rng(11)
    base = rng.integers(0, 256, (24, 72))
    return base[:, :56], base[:, 7:63]          # the right view moved by 7 px


@pytest.mark.parametrize("scale", [2.0**996, 2.0**-1060, 2.0**-140])
def test_float64_pair_beyond_float32_matches_its_wide_integer_copy(backend, scale):
    left, right = _pair()
    want = stereo.disparity(left.astype(np.int64) << 40, right.astype(np.int64) << 40, 12, backend="numpy",
                            return_confidence=True)
    assert np.isfinite(want[0]).sum() > left.size // 2
    got = stereo.disparity(left * scale, right * scale, 12, backend=backend, return_confidence=True)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w, err_msg=f"scale 2**{np.log2(scale):.0f}")


def test_float64_pair_of_both_signs_near_the_largest_float64(backend):
    # differences from the minimum would overflow float64 itself (2 x 1.6e308)
    left, right = _pair()
    scale = 2.0**1015
    want = stereo.disparity(left.astype(np.int64) << 40, right.astype(np.int64) << 40, 12, backend="numpy")
    got = stereo.disparity((left - 128) * scale, (right - 128) * scale, 12, backend=backend)
    np.testing.assert_array_equal(got, want)


def test_infinite_and_nan_float64_pixels_are_still_refused(backend):
    left, right = _pair()
    for bad in (np.inf, -np.inf, np.nan):
        img = left * 2.0**996
        img[3, 4] = bad
        with pytest.raises(ValueError, match="left contains NaN or infinite values"):
            stereo.disparity(img, right * 2.0**996, 12, backend=backend)


@pytest.mark.parametrize("method", ["uniform", "affine"])
@pytest.mark.parametrize("scale", [2.0**996, 2.0**-1060])
def test_sweeps_take_float64_pairs_beyond_float32(backend, method, scale):
    # the sweeps run in float32: such a pair is moved by its minimum and scaled into float32's
    # range (a power of two, exact: the largest magnitude in [1, 2)), so its map is that of the
    # float32 pair (v - min) / 2**7 on the same backend (the sweeps' float32 rounding depends on
    # the scale, and the backends' sweeps agree to rounding only: docs/stereo.md)
    left, right = _pair()
    low = min(left.min(), right.min())
    top = max(left.max(), right.max()) - low
    assert 128 <= top < 256
    want = stereo.disparity(((left - low) / 2.0**7).astype(np.float32), ((right - low) / 2.0**7).astype(np.float32),
                            12, method=method, backend=backend)
    assert np.isfinite(want).sum() > left.size // 2
    got = stereo.disparity(left * scale, right * scale, 12, method=method, backend=backend)
    np.testing.assert_array_equal(got, want)
