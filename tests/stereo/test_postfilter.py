"""The post-filters of ``disparity`` (issue 28, item 4): the speckle filter against a plain flood
fill and against OpenCV, the confidence threshold, their argument checks, and identical maps on
every backend with the filters on."""

from collections import deque

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import postfilter

from .scenes import random_dot_pair, square


def flood_fill_speckles(disp, max_size, max_diff):
    """Brute-force reference: a breadth-first flood fill from every unvisited valid pixel over
    4-neighbours at most ``max_diff`` apart; regions of at most ``max_size`` pixels -> NaN."""
    d = np.asarray(disp, np.float64)
    h, w = d.shape
    seen = np.zeros((h, w), bool)
    out = np.array(disp, copy=True)
    for y0 in range(h):
        for x0 in range(w):
            if seen[y0, x0] or not np.isfinite(d[y0, x0]):
                continue
            region, queue = [], deque([(y0, x0)])
            seen[y0, x0] = True
            while queue:
                y, x = queue.popleft()
                region.append((y, x))
                for ny, nx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                    if (0 <= ny < h and 0 <= nx < w and not seen[ny, nx] and np.isfinite(d[ny, nx])
                            and abs(d[ny, nx] - d[y, x]) <= max_diff):
                        seen[ny, nx] = True
                        queue.append((ny, nx))
            if len(region) <= max_size:
                for y, x in region:
                    out[y, x] = np.nan
    return out


def random_map(seed, shape=(23, 31), levels=6, holes=0.15, dtype=np.float32):
    rng = np.random.default_rng(seed)
    # blocky regions of a few levels plus sub-pixel jitter and isolated outliers
    d = np.kron(rng.integers(0, levels, (shape[0] // 3 + 1, shape[1] // 3 + 1)), np.ones((3, 3)))
    d = d[:shape[0], :shape[1]] * 2.0 + rng.uniform(-0.4, 0.4, shape)
    d[rng.random(shape) < 0.03] = rng.uniform(20, 40)
    d[rng.random(shape) < holes] = np.nan
    return d.astype(dtype)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_size,max_diff", [(1, 0.5), (4, 1.0), (12, 1.0), (30, 2.5), (0, 1.0)])
def test_speckles_equal_flood_fill(seed, max_size, max_diff):
    d = random_map(seed, dtype=np.float32 if seed % 2 else np.float64)
    out = postfilter.filter_speckles(d, max_size, max_diff)
    ref = flood_fill_speckles(d, max_size, max_diff)
    assert out.dtype == d.dtype and out is not d
    np.testing.assert_array_equal(out, ref)
    if max_size:
        assert np.isnan(out).sum() > np.isnan(d).sum()        # the cases do remove something


def ramp_map(seed, shape=(19, 27)):
    # slopes that cross a bin of floor(d / max_diff) every few pixels while every step stays
    # within max_diff: regions that no single run of equal bins covers
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:shape[0], :shape[1]]
    d = 0.3 * xx + 0.2 * yy + rng.uniform(-0.05, 0.05, shape)
    d[:, shape[1] // 2] = np.nan                    # a cut: two regions
    d[rng.random(shape) < 0.05] = 50.0              # single-pixel outliers (joined where adjacent)
    return d.astype(np.float32)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("max_size,max_diff", [(1, 0.5), (3, 0.5), (200, 0.5), (250, 0.4), (5, 0.0)])
def test_speckles_on_ramps_equal_flood_fill(seed, max_size, max_diff):
    d = ramp_map(seed)
    np.testing.assert_array_equal(postfilter.filter_speckles(d, max_size, max_diff),
                                  flood_fill_speckles(d, max_size, max_diff))


def test_small_regions_by_hand():
    d = np.array([[1.0, 1.2, np.nan, 5.0],
                  [1.1, np.nan, 5.5, 5.0],
                  [9.0, 9.0, np.nan, 0.0]])
    # regions: {1.0, 1.2, 1.1} (3), {5.0, 5.5, 5.0} (3), {9, 9} (2), {0} (1)
    np.testing.assert_array_equal(postfilter.small_regions(d, 2, 0.5),
                                  [[0, 0, 0, 0], [0, 0, 0, 0], [1, 1, 0, 1]])
    np.testing.assert_array_equal(postfilter.small_regions(d, 1, 0.5), [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]])
    assert postfilter.small_regions(d, 3, 0.5).sum() == 9
    assert postfilter.small_regions(d, 3, 0.4).sum() == 9      # 5.0 - 5.5 cut: {5.0, 5.0} and {5.5}


def test_speckles_match_opencv():
    cv2 = pytest.importorskip("cv2")
    for seed in range(4):
        d = random_map(seed, (60, 80), levels=4)
        d = np.where(np.isnan(d), np.nan, np.round(d * 16) / 16).astype(np.float32)   # SGBM's 1/16 px
        out = postfilter.filter_speckles(d, 15, 1.0)
        fixed = np.where(np.isnan(d), -32, d * 16).astype(np.int16)
        cv2.filterSpeckles(fixed, -32, 15, 16)
        np.testing.assert_array_equal(np.isnan(out), fixed == -32)


def test_confidence_threshold():
    rng = np.random.default_rng(1)
    d = rng.uniform(0, 9, (7, 8)).astype(np.float32)
    d[0, :3] = np.nan
    conf = rng.random((7, 8)).astype(np.float32)
    out = postfilter.invalidate_low_confidence(d, conf, 0.4)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(d) | (conf < 0.4))
    np.testing.assert_array_equal(out[np.isfinite(out)], d[np.isfinite(out)])
    np.testing.assert_array_equal(postfilter.invalidate_low_confidence(d, conf, 0.0), d)
    with pytest.raises(ValueError, match="confidence"):
        postfilter.invalidate_low_confidence(d, conf[:3], 0.4)


def test_postfilter_without_confidence():
    """``disparity`` passes no confidence where it returns none: the same map, None back, and a
    threshold that needs the confidence refused."""
    d = random_map(3)
    conf = np.random.default_rng(3).random(d.shape).astype(np.float32)
    with_conf, filtered = postfilter.apply_postfilter(d, conf, 4, 1.0, 0.0)
    without, none = postfilter.apply_postfilter(d, None, 4, 1.0, 0.0)
    assert none is None
    np.testing.assert_array_equal(without, with_conf)
    np.testing.assert_array_equal(without, flood_fill_speckles(d, 4, 1.0))
    np.testing.assert_array_equal(filtered, np.where(np.isfinite(with_conf), conf, 0))
    with pytest.raises(ValueError, match="min_confidence"):
        postfilter.apply_postfilter(d, None, 4, 1.0, 0.2)


@pytest.mark.parametrize("kwargs,error,match", [
    ({"speckle_size": -1}, ValueError, "speckle_size"),
    ({"speckle_size": 10.0}, TypeError, "speckle_size"),
    ({"speckle_size": True}, TypeError, "speckle_size"),
    ({"speckle_range": -0.5}, ValueError, "speckle_range"),
    ({"speckle_range": float("nan")}, ValueError, "speckle_range"),
    ({"speckle_range": "1"}, TypeError, "speckle_range"),
    ({"min_confidence": 1.5}, ValueError, "min_confidence"),
    ({"min_confidence": -0.1}, ValueError, "min_confidence"),
    ({"min_confidence": float("inf")}, ValueError, "min_confidence"),
])
def test_bad_options_are_named(kwargs, error, match):
    left, right, _ = random_dot_pair(square, shape=(24, 40))
    for method in ("sgm", "uniform"):
        with pytest.raises(error, match=match):
            stereo.disparity(left, right, 12, method=method, backend="numpy", **kwargs)
    with pytest.raises(error, match=match):
        stereo.StereoMatcher((24, 40), 12, backend="numpy", **kwargs)
    d = np.zeros((3, 3), np.float32)
    if "min_confidence" in kwargs:
        with pytest.raises(error, match=match):
            postfilter.invalidate_low_confidence(d, d, kwargs["min_confidence"])
    else:
        size = kwargs.get("speckle_size", 4)
        with pytest.raises(error, match=match):
            postfilter.filter_speckles(d, size, kwargs.get("speckle_range", 1.0))


def test_bad_maps():
    with pytest.raises(TypeError, match="float"):
        postfilter.filter_speckles(np.zeros((3, 3), np.int32), 4)
    with pytest.raises(ValueError, match="2-D"):
        postfilter.filter_speckles(np.zeros((2, 3, 3), np.float32), 4)


def noisy_pair():
    # a random-dot square with noise on both views: the matcher leaves wrong islands
    left, right, truth = random_dot_pair(square, shape=(64, 112), seed=3)
    rng = np.random.default_rng(4)
    left = left + rng.normal(0, 40, left.shape).astype(np.float32)
    right = right + rng.normal(0, 40, right.shape).astype(np.float32)
    return left, right, truth


OPTIONS = {"speckle_size": 40, "speckle_range": 1.0, "min_confidence": 0.1}


@pytest.mark.parametrize("method", ["sgm", "uniform"])
def test_filters_on_every_backend(backend, method):
    left, right, _ = noisy_pair()
    plain, conf = stereo.disparity(left, right, 16, method=method, return_confidence=True, backend=backend,
                                   speckle_size=0)
    out, out_conf = stereo.disparity(left, right, 16, method=method, return_confidence=True, backend=backend,
                                     **OPTIONS)
    # the filters compose as documented: threshold, then speckles on what is left
    ref = postfilter.filter_speckles(postfilter.invalidate_low_confidence(plain, conf, 0.1), 40, 1.0)
    np.testing.assert_array_equal(out, ref)
    np.testing.assert_array_equal(out_conf, np.where(np.isfinite(ref), conf, 0))
    assert np.isnan(out).sum() > np.isnan(plain).sum()
    if method == "sgm":
        # identical maps on every backend with the filters on, as without (the sweeps' maps are
        # not bit-identical across backends: their Green shifts run on the device in float32)
        numpy_map = stereo.disparity(left, right, 16, method=method, backend="numpy", **OPTIONS)
        np.testing.assert_array_equal(out, numpy_map)


def test_matcher_applies_the_filters(backend):
    left, right, _ = noisy_pair()
    matcher = stereo.StereoMatcher(left.shape, 16, backend=backend, **OPTIONS)
    for _ in range(2):
        d, conf = matcher.compute(left, right, return_confidence=True)
        ref, ref_conf = stereo.disparity(left, right, 16, return_confidence=True, backend=backend, **OPTIONS)
        np.testing.assert_array_equal(d, ref)
        np.testing.assert_array_equal(conf, ref_conf)


def test_speckle_filter_removes_wrong_islands():
    # on the noisy square the islands the filter removes are mostly wrong: the error of what it
    # keeps is lower than the error of what it removes
    left, right, truth = noisy_pair()
    d = stereo.disparity(left, right, 16, backend="numpy", speckle_size=0)
    out = postfilter.filter_speckles(d, 40, 1.0)
    removed = np.isfinite(d) & np.isnan(out)
    kept = np.isfinite(out)
    assert removed.sum() >= 20
    err = np.abs(d - truth)
    assert np.mean(err[removed] > 2) > 3 * np.mean(err[kept] > 2)


def test_defaults(backend):
    # "sgm" runs the speckle filter by default (SPECKLE_SIZE, SPECKLE_RANGE), the sweeps do not;
    # StereoMatcher has disparity's defaults
    left, right, _ = noisy_pair()
    raw, conf = stereo.disparity(left, right, 16, speckle_size=0, return_confidence=True, backend=backend)
    ref = postfilter.filter_speckles(raw, postfilter.SPECKLE_SIZE, postfilter.SPECKLE_RANGE)
    assert np.isnan(ref).sum() > np.isnan(raw).sum()
    d, c = stereo.disparity(left, right, 16, return_confidence=True, backend=backend)
    np.testing.assert_array_equal(d, ref)
    np.testing.assert_array_equal(c, np.where(np.isfinite(ref), conf, 0))
    np.testing.assert_array_equal(stereo.StereoMatcher(left.shape, 16, backend=backend).compute(left, right), ref)
    sweep = stereo.disparity(left, right, 16, method="uniform", backend=backend)
    np.testing.assert_array_equal(sweep, stereo.disparity(left, right, 16, method="uniform", speckle_size=0,
                                                          backend=backend))
