"""The speckle filter on an OpenCL CPU device (``_opencl.launch_speckles``, stereo.cl's union-find
``speckle_label`` / ``speckle_seam`` / ``speckle_mark``) against the host's
:func:`gfgpu.stereo.postfilter.filter_speckles` and a plain flood fill, bit for bit: random maps
with many small regions, and shapes that stress the two halves and their seam at row ``h // 2``
(one row, one column, odd heights, regions that cross the seam)."""

import numpy as np
import pytest

from gfgpu.stereo import postfilter

from .test_postfilter import flood_fill_speckles, random_map


def _device(be, d, max_size, max_diff, conf=None):
    """(map, confidence) after launch_speckles on copies of ``d`` and ``conf`` (default ones)."""
    from gfgpu.stereo import _opencl
    h, w = d.shape
    disp = be.asarray(np.ascontiguousarray(d, np.float32))
    margin = be.asarray(np.ones((h, w), np.float32) if conf is None else np.ascontiguousarray(conf, np.float32))
    parent = be.asarray(np.full((h, w), 12345, np.int32))       # a used scratch: overwritten first
    _opencl.launch_speckles(be, disp, margin, parent, max_size, max_diff)
    return np.array(be.to_host(disp)), np.array(be.to_host(margin))


def _check(be, d, max_size, max_diff):
    conf = np.random.default_rng(d.size).random(d.shape).astype(np.float32)
    got, got_conf = _device(be, d, max_size, max_diff, conf)
    want, want_conf = postfilter.apply_postfilter(d, conf, max_size, max_diff, 0.0)
    # bit for bit: NaN's payload too (numpy's NaN)
    np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))
    np.testing.assert_array_equal(got_conf.view(np.uint32), want_conf.view(np.uint32))
    return got


def _skip_without_fp64(be):
    if not be.supports_float64:
        pytest.skip("launch_speckles needs cl_khr_fp64")


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("shape", [(23, 31), (64, 97), (7, 5), (2, 40), (41, 2)])
@pytest.mark.parametrize("max_size,max_diff", [(0, 1.0), (1, 0.5), (4, 1.0), (25, 0.5), (60, 2.5), (10**9, 1.0)])
def test_device_speckles_equal_host(cpu_opencl, seed, shape, max_size, max_diff):
    _skip_without_fp64(cpu_opencl)
    d = random_map(seed, shape)
    got = _check(cpu_opencl, d, max_size, max_diff)
    if d.size <= 800:
        np.testing.assert_array_equal(got, flood_fill_speckles(d, max_size, max_diff))


def _adversarial():
    rng = np.random.default_rng(11)
    maps = {}
    maps["one row"] = random_map(1, (1, 57))
    maps["one column"] = random_map(2, (57, 1))
    maps["one pixel"] = np.array([[3.0]], np.float32)
    maps["1x2 NaN"] = np.array([[np.nan, 1.0]], np.float32)
    maps["h odd"] = random_map(3, (9, 13))
    maps["h 3"] = random_map(4, (3, 40))
    # a U whose two arms lie in the two halves and join below the seam only, and one whose arms
    # join above it: each one region (size 2 h - 1 + w - 2), the halves' labels merged at the seam
    u = np.full((11, 9), np.nan, np.float32)
    u[:, 0] = 5.0
    u[:, 8] = 5.25
    u[10, :] = np.linspace(5.0, 5.25, 9)
    maps["U across the seam"] = u
    maps["cap across the seam"] = u[::-1].copy()
    # a comb: teeth in the upper half joined by a spine in the lower one (one region through many
    # seam joins) beside single-pixel columns that the seam cuts in two
    comb = np.full((10, 21), np.nan, np.float32)
    comb[:, ::2] = 7.0
    comb[7, :] = 7.0
    comb[:, 1::4] = rng.uniform(20, 30, (10, 5)).astype(np.float32)
    maps["comb"] = comb
    # stripes of alternating disparity: many regions, each crossing the seam
    maps["stripes"] = np.tile(np.float32([1, 4]), (12, 15))
    maps["checkerboard"] = (np.indices((15, 16)).sum(0) % 2 * 3.0).astype(np.float32)
    maps["all NaN"] = np.full((6, 7), np.nan, np.float32)
    # infinite pixels (no matcher makes them): not valid for the host's filter, never removed
    inf = random_map(6, (8, 9))
    inf[::3, 1::2] = np.inf
    inf[4, 4] = -np.inf
    maps["infinities"] = inf
    maps["constant"] = np.full((6, 7), 2.0, np.float32)
    # the range's edge: differences at exactly max_diff join (float64 of float32 values)
    ramp = (np.arange(30, dtype=np.float32) * np.float32(0.5))[None].repeat(5, 0)
    ramp[2, 7] = np.float32(0.1) + ramp[2, 7]
    maps["ramp"] = ramp
    return maps


ADVERSARIAL = _adversarial()


@pytest.mark.parametrize("name", sorted(ADVERSARIAL))
@pytest.mark.parametrize("max_size,max_diff", [(1, 0.0), (2, 0.5), (10, 0.5), (30, 0.25), (200, 3.0)])
def test_device_speckles_adversarial(cpu_opencl, name, max_size, max_diff):
    _skip_without_fp64(cpu_opencl)
    d = ADVERSARIAL[name]
    got = _check(cpu_opencl, d, max_size, max_diff)
    np.testing.assert_array_equal(got, flood_fill_speckles(d, max_size, max_diff))


def test_device_speckles_seam_region(cpu_opencl):
    """The U's two arms are one region only through the seam: it survives a size below its own
    and goes at its size (the halves alone are smaller)."""
    _skip_without_fp64(cpu_opencl)
    u = ADVERSARIAL["U across the seam"]
    size = int(np.isfinite(u).sum())
    assert np.isfinite(_device(cpu_opencl, u, size - 1, 0.5)[0]).sum() == size
    assert np.isnan(_device(cpu_opencl, u, size, 0.5)[0]).all()


def test_device_speckles_checks(cpu_opencl):
    _skip_without_fp64(cpu_opencl)
    from gfgpu.stereo import _opencl
    be = cpu_opencl
    d = be.asarray(np.zeros((4, 5), np.float32))
    with pytest.raises(ValueError, match="margin and parent"):
        _opencl.launch_speckles(be, d, be.asarray(np.zeros((4, 5), np.float32)),
                                be.asarray(np.zeros((5, 4), np.int32)), 3, 1.0)
    with pytest.raises((TypeError, ValueError), match="parent"):
        _opencl.launch_speckles(be, d, be.asarray(np.zeros((4, 5), np.float32)),
                                be.asarray(np.zeros((4, 5), np.float32)), 3, 1.0)


@pytest.mark.parametrize("max_size,max_diff", [(-1, 1.0), (2.5, 1.0), (2, -0.5), (2, float("nan"))])
def test_device_speckles_refuses_bad_options(cpu_opencl, max_size, max_diff):
    _skip_without_fp64(cpu_opencl)
    from gfgpu.stereo import _opencl
    be = cpu_opencl
    arrays = (be.asarray(np.zeros((4, 5), np.float32)), be.asarray(np.zeros((4, 5), np.float32)),
              be.asarray(np.zeros((4, 5), np.int32)))
    with pytest.raises(ValueError, match="max_size" if max_size != 2 else "max_diff"):
        _opencl.launch_speckles(be, *arrays, max_size, max_diff)


def test_disparity_filters_on_the_device(cpu_opencl, monkeypatch):
    """``disparity`` on an OpenCL CPU device filters on the device (no host filter call) and
    returns numpy's map and confidence bit for bit."""
    _skip_without_fp64(cpu_opencl)
    from gfgpu import stereo
    from gfgpu.stereo import postfilter as post
    rng = np.random.default_rng(4)
    right = rng.random((37, 61)).astype(np.float32)
    left = np.roll(right, 4, axis=1)
    left[8:20, 15:40] = rng.random((12, 25))          # a patch of noise: speckles in the map
    want = stereo.disparity(left, right, 12, backend="numpy", return_confidence=True, speckle_size=8)
    unfiltered = stereo.disparity(left, right, 12, backend="numpy", speckle_size=0)
    assert np.isnan(want[0]).sum() > np.isnan(unfiltered).sum()       # the filter removes some
    calls = []
    real = post.apply_postfilter
    monkeypatch.setattr(post, "apply_postfilter", lambda *a: calls.append(a) or real(*a))
    got = stereo.disparity(left, right, 12, backend=cpu_opencl, return_confidence=True, speckle_size=8)
    assert not calls
    for g, w in zip(got, want):
        np.testing.assert_array_equal(np.asarray(g).view(np.uint32), w.view(np.uint32))
