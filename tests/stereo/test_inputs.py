"""Every documented input of ``disparity(method="sgm")`` runs with the defaults and gives one map on
every backend: windows 1..15 with the default penalties, and boolean, integer, float and subnormal
pairs matched bit for bit as the numpy specification matches them."""

import functools

import numpy as np
import pytest
from scipy import ndimage

from gfgpu import stereo
from gfgpu.stereo import matching
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, shifted_pair


def _same(got, want, what):
    # NaN where the specification has NaN, the same float32 bits elsewhere
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=what)
    np.testing.assert_array_equal(got[np.isfinite(want)], want[np.isfinite(want)], err_msg=what)


def test_default_penalties_fit_int16_for_every_window():
    for paths in (4, 8):
        for window in range(1, 16, 2):
            p1, p2 = matching.default_penalties(window, paths)
            scale = 2 ** specs.cost_shift(window)
            largest = min((48 * window**2) >> specs.cost_shift(window), specs.COST_MAX)
            assert paths * (largest + p2) < matching._INT16_MAX, (window, paths)
            assert (p1, p2) == (6 * window**2 // scale, 64 * window**2 // scale)   # scaled with the costs
    assert matching.default_penalties(3) == (54, 576)                               # the default unchanged
    assert [specs.cost_shift(w) for w in range(1, 16, 2)] == [0, 0, 1, 2, 3, 4, 4, 5]


def test_block_sums_shifted_before_they_saturate():
    # 7x7 and larger blocks saturated on correct matches too (the minima tied): their sums are
    # shifted right by cost_shift bits first, in the specification as on every device
    rng = np.random.default_rng(1)
    left = rng.integers(0, 2**48, (12, 20), dtype=np.uint64)
    right = left[None] ^ (rng.random((1, 12, 20)) < 0.02).astype(np.uint64)
    for block in (3, 7, 15):
        cost = specs.census_cost_reference(left, right, 0, 3, 1, block)
        ham = np.bitwise_count(left ^ right[0]).astype(np.int64)
        r = block // 2
        pad = np.pad(ham, r, mode="edge")
        window = sum(pad[v:v + 12, u:u + 20] for v in range(block) for u in range(block))
        inside = cost[:, r:20 - r, 0]
        np.testing.assert_array_equal(inside, np.minimum(window >> specs.cost_shift(block), 254)[:, r:20 - r])


@pytest.mark.parametrize("paths", [4, 8])
def test_every_documented_window_runs_with_default_penalties(backend, paths):
    # window=13 and 15 raised "p2 = 10816 is too large" with the defaults (9..15 with 8 paths)
    left, right = shifted_pair(6, shape=(40, 80), seed=1)
    for window in range(1, 16, 2):
        d = stereo.disparity(left, right, 12, window=window, paths=paths, backend=backend)
        inner = d[:, 6 + 8:]
        assert np.isfinite(inner).mean() > 0.5, window
        assert np.nanmedian(np.abs(inner - 6)) < 0.1, window


def test_too_large_p2_names_the_bound():
    img = np.random.default_rng(0).random((20, 40)).astype(np.float32)
    top = matching._largest_p2(3, 3, 4)
    stereo.disparity(img, img, 5, p2=top, backend="numpy")
    with pytest.raises(ValueError, match=f"p2 <= {top}"):
        stereo.disparity(img, img, 5, p2=top + 1, backend="numpy")


def _pairs():
    rng = np.random.default_rng(5)
    tex = ndimage.gaussian_filter(rng.random((60, 120)), 2) > 0.5
    yield "bool", tex, np.roll(tex, -6, axis=1)
    left, right, _ = random_dot_pair(lambda yy, xx: 6 + 4 * np.sin(xx / 40.0) + yy / 100, shape=(300, 401), seed=1)
    yield "random-dot 401x300", left, right
    yield "uint8", np.rint(left).astype(np.uint8), np.rint(right).astype(np.uint8)
    yield "uint16 x 257", (np.rint(left) * 257).astype(np.uint16), (np.rint(right) * 257).astype(np.uint16)
    yield "int32 negative", np.rint(left).astype(np.int32) - 300, np.rint(right).astype(np.int32) - 300
    yield "float64", left.astype(np.float64) / 255, right.astype(np.float64) / 255
    tiny = np.float32(1e-41)      # float32 subnormals: devices flush them
    yield "subnormal", (left[:80, :160] * tiny).astype(np.float32), (right[:80, :160] * tiny).astype(np.float32)
    yield "huge", (left[:80, :160] * np.float32(1e36)).astype(np.float32), \
        (right[:80, :160] * np.float32(1e36)).astype(np.float32)


@functools.cache
def _reference(index, steps):
    what, left, right = list(_pairs())[index]
    return stereo.disparity(left, right, 15, subpixel_steps=steps, return_confidence=True, backend="numpy")


@pytest.mark.parametrize("name", ["warp", "opencl"])
def test_maps_identical_on_every_backend_for_every_dtype(name, require_backend):
    # the right view's Green shifts rounded differently on each backend (float32 recursions) and
    # the devices flushed subnormals: a boolean pair differed in thousands of pixels, a
    # subnormal-scaled pair in ~160
    be = require_backend(name)
    for index, (what, left, right) in enumerate(_pairs()):
        for steps in ((2,) if left.size > 10**5 else (1, 2, 3)):
            want, conf_want = _reference(index, steps)
            got, conf = stereo.disparity(left, right, 15, subpixel_steps=steps, return_confidence=True,
                                         backend=be)
            _same(got, want, f"{name} {what} steps={steps}")
            np.testing.assert_array_equal(conf, conf_want, err_msg=f"{name} {what} steps={steps}")


def test_subnormal_pair_matches_as_its_normal_copy():
    # scaling both views by a power of two is exact and census compares are scale-free
    left, right = shifted_pair(5, shape=(40, 80), seed=2)
    ref = stereo.disparity(left, right, 10, backend="numpy")
    tiny = np.float32(2.0**-140)
    _same(stereo.disparity(left * tiny, right * tiny, 10, backend="numpy"), ref, "subnormal")


def test_matching_views_are_normal_and_exactly_scaled():
    rng = np.random.default_rng(3)
    left = (rng.random((16, 40)) * 1e-40).astype(np.float32)
    right = np.roll(left, 3, axis=1)
    lft, planes = matching.matching_views(left, right, 2)
    assert 1 <= np.abs(np.concatenate([lft.ravel(), planes[0].ravel()])).max() < 2
    np.testing.assert_array_equal(lft, np.ldexp(left, 1 - np.frexp(np.abs(np.stack([left, right])).max())[1]))
    for plane in (lft, *planes):
        small = plane[plane != 0]
        assert (np.abs(small) >= np.finfo(np.float32).tiny).all()


@pytest.mark.parametrize("method", ["sgm", "uniform", "affine"])
@pytest.mark.parametrize("bad, match", [
    (dict(sigma="a"), "sigma"), (dict(sigma=-1.0), "sigma"), (dict(sweep_step="a"), "sweep_step"),
    (dict(sweep_step=2.0), "sweep_step"), (dict(p1="a"), "p1"), (dict(p2=1.5), "p2"),
    (dict(census_radius="a"), "census_radius"), (dict(census_radius=0), "census_radius"),
    (dict(paths=5), "paths"), (dict(uniqueness=101), "uniqueness"), (dict(subpixel_steps=9), "subpixel_steps")])
def test_every_option_is_checked_whatever_the_method(method, bad, match):
    """An option of another method is refused by name, not ignored (sigma='a' ran under 'sgm')."""
    left, right = random_dot_pair(lambda y, x: 3.0 + 0 * x, (24, 40), seed=2)[:2]
    with pytest.raises((TypeError, ValueError), match=match):
        stereo.disparity(left, right, 8, method=method, backend="numpy", **bad)
