"""What makes repeated ``disparity`` calls cheap (issue 28, time): the buffers a one-shot call
keeps for the next call of its size, the results that are the caller's own, the right view's
planes four rows per work-item, the row-looping OpenCL kernels (interleave, left-right check) and
the speckle filter's run graph -- each against a reference that does not share its path."""

import threading

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import kernels, matching, postfilter

from .scenes import random_dot_pair, shifted_pair, slanted, square
from .test_postfilter import flood_fill_speckles


def _pairs(shape, count):
    return [random_dot_pair(square if i % 2 else slanted, shape=shape, seed=i)[:2] for i in range(count)]


def test_one_shot_calls_reuse_buffers_not_results(backend):
    # three pairs of one size and range, then another range and another size: each map equals the
    # numpy specification's, and a returned map is never written by a later call
    pairs = _pairs((40, 72), 3)
    spec = [stereo.disparity(lft, rgt, 15, backend="numpy") for lft, rgt in pairs]
    first = stereo.disparity(*pairs[0], 15, backend=backend)
    kept = first.copy()
    for (lft, rgt), want in zip(pairs, spec):
        np.testing.assert_array_equal(stereo.disparity(lft, rgt, 15, backend=backend), want)
    np.testing.assert_array_equal(first, kept)
    np.testing.assert_array_equal(stereo.disparity(*pairs[1], 11, backend=backend),
                                  stereo.disparity(*pairs[1], 11, backend="numpy"))
    small = [p[:, :50] for p in pairs[2]]
    np.testing.assert_array_equal(stereo.disparity(*small, 15, backend=backend),
                                  stereo.disparity(*small, 15, backend="numpy"))
    # with the confidence too, and without the post-filters (the matcher's own arrays returned):
    # both results the caller's own
    for post in ({}, {"speckle_size": 0}):
        d1, c1 = stereo.disparity(*pairs[0], 15, return_confidence=True, backend=backend, **post)
        copies = d1.copy(), c1.copy()
        stereo.disparity(*pairs[1], 15, return_confidence=True, backend=backend, **post)
        np.testing.assert_array_equal(d1, copies[0])
        np.testing.assert_array_equal(c1, copies[1])


def test_kept_buffers_are_small_and_taken_by_one_call(backend, monkeypatch):
    be = stereo.matching.resolve_backend(backend, None)
    pairs = _pairs((40, 72), 1)
    stereo.disparity(*pairs[0], 15, backend=be)
    key, bufs = matching._KEPT[be]
    assert key[:2] == (40, 72) and sum(matching._nbytes(b) for b in bufs.values()) <= matching._KEPT_BYTES
    assert matching._kept_buffers(be, key) is bufs and be not in matching._KEPT    # taken
    assert matching._kept_buffers(be, key) == {}                                   # a second caller: new ones
    # above the limit nothing is kept
    monkeypatch.setattr(matching, "_KEPT_BYTES", 0)
    stereo.disparity(*pairs[0], 15, backend=be)
    assert be not in matching._KEPT


def test_concurrent_one_shot_calls(backend):
    # calls from several threads at once on one backend: none takes another's buffers
    pairs = _pairs((36, 64), 4)
    want = [stereo.disparity(lft, rgt, 12, backend="numpy") for lft, rgt in pairs]
    got = [None] * len(pairs)
    errors = []

    def run(i):
        try:
            for _ in range(3):
                got[i] = stereo.disparity(*pairs[i], 12, backend=backend)
                np.testing.assert_array_equal(got[i], want[i])
        except Exception as exc:      # reported in the main thread
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(pairs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[0]


@pytest.mark.parametrize("h", [1, 2, 3, 4, 5, 7, 9])
@pytest.mark.parametrize("steps", [1, 2, 3, 4])
def test_device_planes_every_row_count(require_backend, h, steps):
    # shift_planes runs four rows per work-item: row counts that leave 0..3 rows in the last one
    be = require_backend("opencl")
    if not be.supports_float64:
        pytest.skip("no cl_khr_fp64: the planes are computed on the host")
    rng = np.random.default_rng(h * 10 + steps)
    img = rng.random((h, 29)).astype(np.float32) * 1.9
    img[rng.random(img.shape) < 0.2] = 0.0
    out = be.empty((steps, h, 29), np.float32)
    kernels.planes(be, be.asarray(img), out, steps)
    want = matching.subpixel_planes(img, steps)
    np.testing.assert_array_equal(be.to_host(out).view(np.uint32), want.view(np.uint32))


@pytest.mark.parametrize("width", [37, 741])
def test_row_kernels_odd_widths(backend, width):
    # census_interleave and left_right loop over a row's columns (a work-item per row on CPUs):
    # odd widths against the numpy specification's map and confidence
    lft, rgt = shifted_pair(6, shape=(21, width), seed=width)
    want = stereo.disparity(lft, rgt, 15, return_confidence=True, backend="numpy")
    got = stereo.disparity(lft, rgt, 15, return_confidence=True, backend=backend)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])


def _striped_map(seed, shape=(30, 90)):
    # short runs (of 1..6 pixels) under and over long ones: a short run joins its neighbour rows
    # at many places, the joins of one pair of runs next to each other
    rng = np.random.default_rng(seed)
    d = np.zeros(shape)
    for y in range(shape[0]):
        if y % 3 == 1:
            x = 0
            while x < shape[1]:
                n = int(rng.integers(1, 7))
                d[y, x:x + n] = rng.choice([0.0, 0.3, 5.0, 9.0])
                x += n
        else:
            d[y] = rng.choice([0.0, 0.2, 9.0])
    d[rng.random(shape) < 0.05] = np.nan
    return d.astype(np.float32)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("max_size,max_diff", [(3, 0.5), (6, 0.25), (25, 0.5), (60, 1.0)])
def test_speckles_of_runs_joined_many_times(seed, max_size, max_diff):
    d = _striped_map(seed)
    np.testing.assert_array_equal(postfilter.filter_speckles(d, max_size, max_diff),
                                  flood_fill_speckles(d, max_size, max_diff))


@pytest.mark.parametrize("shape", [(1, 40), (40, 1), (2, 2), (1, 1)])
def test_speckles_thin_maps(shape):
    rng = np.random.default_rng(sum(shape))
    d = rng.integers(0, 3, shape).astype(np.float32)
    d[rng.random(shape) < 0.2] = np.nan
    for max_size in (1, 2, 5):
        np.testing.assert_array_equal(postfilter.filter_speckles(d, max_size, 0.5),
                                      flood_fill_speckles(d, max_size, 0.5))


def test_scaled_views_start_on_a_page():
    # the views a CPU device reads in place (host_view) must start on its alignment boundary
    rng = np.random.default_rng(0)
    for shape in [(3, 5), (288, 384), (17, 1)]:
        left, right = (rng.random(shape).astype(np.float32) * 300 for _ in range(2))
        for view, src in zip(matching._scaled_views(left, right), (left, right)):
            assert view.ctypes.data % matching._PAGE == 0 and view.flags.c_contiguous
            exp = matching._scale_exponent(left, right)
            np.testing.assert_array_equal(view, np.ldexp(src, exp).astype(np.float32))
