"""Review of the fused stereo matcher (``stereo.match``, commits 9baac4b, df31f92): bit-exactness of
every backend against ``semi_global_match_reference`` on awkward shapes, many bands, the
recompute path, saturated costs and extreme penalties; the working-set refusal; and the
memory estimate of the numpy specification (a failing reproducer, see the review report)."""

import tracemalloc

import numpy as np
import pytest

import gfgpu
from gfgpu.stereo import disparity, disparity_memory, kernels, matching, random_dot_stereogram
from gfgpu.stereo import spec as specs


def _codes(rng, h, w, steps, shift, flip, bits=48):
    left = rng.integers(0, 2**bits, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**bits, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def _check(be, left, right, first, n, steps, block, p1, p2, paths, uniq, budget=None):
    h, w = left.shape[1:]
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, block, p1, p2, paths,
                  uniq, budget)
    ref = specs.semi_global_match_reference(left[0], right, first, n, steps, block, p1, p2, paths, uniq)
    what = f"{be.name} {h}x{w} n={n} steps={steps} first={first} block={block} p=({p1},{p2}) " \
           f"paths={paths} uniq={uniq} budget={budget}"
    for got, want in zip(outs, ref):
        np.testing.assert_array_equal(be.to_host(got), want, err_msg=what)


@pytest.mark.parametrize("name", ["warp", "opencl"])
def test_match_bit_exact_on_awkward_shapes(name, require_backend):
    # 1..3 rows, 1..5 columns, vector tails (n = 1, 16, 17, 33; 15 and 31 below), ranges below, above,
    # straddling and wider than the image, 1..4 sub-pixel steps, 4 and 8 paths
    be = require_backend(name)
    rng = np.random.default_rng(0)
    cases = [(h, w, n) for h in (1, 2, 3) for w, n in ((1, 16), (2, 1), (3, 17), (4, 33), (5, 17), (5, 1))]
    for i, (h, w, n) in enumerate(cases):
        steps, paths = 1 + i % 4, (4, 8)[i % 2]
        first = (-2 * n, -n // 2, 0, 3)[i % 4]
        left, right = _codes(rng, h, w, steps, 2, 0.05)
        _check(be, left, right, first, n, steps, 3, 5, 40, paths, 10)


def test_opencl_match_many_bands_keep_and_recompute(monkeypatch, require_backend):
    # bands of 2..3 rows (h not a multiple), checkpoints of both path counts, byte costs kept
    # for the image (budget None) or recomputed per band (budget 1); saturating block sums
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on CPU devices only")
    from gfgpu.stereo import band_plan as ocl
    monkeypatch.setattr(ocl, "BAND_BYTES", 1)
    monkeypatch.setattr(ocl, "WHOLE_BYTES", 0)
    rng = np.random.default_rng(1)
    for rows, (h, w, n, steps, paths, block, p1, p2, uniq, first) in zip(
            (2, 3, 2, 3), ((11, 9, 17, 1, 4, 3, 5, 40, 10, -3), (13, 13, 33, 2, 8, 5, 0, 0, 0, -10),
                           (7, 6, 16, 3, 8, 15, 3, 300, 100, 0), (10, 20, 31, 1, 4, 9, 54, 576, 15, 2))):
        monkeypatch.setattr(ocl, "MIN_BAND_ROWS", rows)
        assert ocl.band_rows(h, paths, w, n) < h
        left, right = _codes(rng, h, w, steps, 3, 0.3)
        for budget in (None, 1):
            _check(be, left, right, first, n, steps, block, p1, p2, paths, uniq, budget)


@pytest.mark.parametrize("name", ["warp", "opencl"])
def test_match_saturated_64bit_codes_and_largest_penalties(name, require_backend):
    # full 64-bit codes and 15x15 blocks (sums up to 14400, saturated at 254), and the largest
    # p2 that matching._sgm's int16 guard admits, for 4 and 8 paths
    be = require_backend(name)
    rng = np.random.default_rng(2)
    for paths in (4, 8):
        p2 = (matching._INT16_MAX - 1) // paths - specs.COST_MAX
        for p1 in (0, p2):
            left, right = _codes(rng, 9, 21, 1, 3, 0.5, bits=64)
            _check(be, left, right, -2, 33, 1, 15, p1, p2, paths, 0)
            _check(be, left, right, -2, 33, 1, 15, p1, p2, paths, 0, budget=1)


def test_opencl_working_set_boundary(require_backend):
    # refused one byte below the least memory the request runs in, run (and equal to the
    # numpy specification) at it
    be = require_backend("opencl")
    left, right = random_dot_stereogram(np.full((30, 50), 6.0), seed=1)
    need = matching._sgm_memory(be, left.shape, 16, 1, 4, None, keep=False)
    with gfgpu.working_set(need - 1), pytest.raises(ValueError, match="more than the working set"):
        disparity(left, right, 15, subpixel_steps=1, backend=be)
    with gfgpu.working_set(need):
        got = disparity(left, right, 15, subpixel_steps=1, backend=be)
    np.testing.assert_array_equal(got, disparity(left, right, 15, subpixel_steps=1, backend="numpy"))


def test_numpy_disparity_memory_is_an_upper_estimate():
    # REPRODUCER (fails): disparity_memory promises the peak "within ~10 %" and disparity refuses
    # requests above the working set with it, but the numpy specification's temporaries
    # ((H, W, block, D) int32 window sums, int64 copies in the selection) take ~40 bytes per
    # sample, not the 16 of matching._SGM_BYTES: measured 2.4x the estimate
    left, right = random_dot_stereogram(np.full((60, 120), 8.0), seed=0)
    disparity(left[:8, :40], right[:8, :40], 31, backend="numpy")
    tracemalloc.start()
    try:
        disparity(left, right, 31, backend="numpy")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    estimate = disparity_memory(left.shape, 31, backend="numpy")
    assert peak <= 1.1 * estimate, f"numpy peak {peak / 2**20:.1f} MiB, estimate {estimate / 2**20:.1f} MiB"


@pytest.mark.parametrize("tile_bytes", [1, 700, 3000])
def test_band_sweeps_in_column_tiles(tile_bytes, monkeypatch, require_backend):
    # the CPU band sweeps take the columns in tiles (4 paths; the horizontal path goes on across
    # a tile's edge): tiles of 1, a few and many columns, one band and several, both sweeps'
    # directions, ranges entering the view at both edges; 8 paths ignore the tiles
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on CPU devices only")
    from gfgpu.stereo import band_plan as ocl
    monkeypatch.setattr(ocl, "TILE_BYTES", tile_bytes)
    whole_bytes, band_bytes = ocl.WHOLE_BYTES, ocl.BAND_BYTES
    rng = np.random.default_rng(3)
    for whole, (h, w, n, steps, paths, first) in zip(
            (True, False, True, False), ((9, 23, 17, 1, 4, -3), (12, 31, 33, 2, 4, -8), (5, 40, 49, 3, 4, 0),
                                         (7, 19, 16, 1, 8, -2))):
        monkeypatch.setattr(ocl, "WHOLE_BYTES", whole_bytes if whole else 0)
        monkeypatch.setattr(ocl, "BAND_BYTES", band_bytes if whole else 1)
        monkeypatch.setattr(ocl, "MIN_BAND_ROWS", 16 if whole else 3)
        rows = ocl.match_plan(h, w, n, paths, 3)[0]
        assert (rows == h) if whole else (rows < h), (whole, rows, h)
        left, right = _codes(rng, h, w, steps, 3, 0.3)
        _check(be, left, right, first, n, steps, 3, 6, 90, paths, 10)


def test_opencl_match_refuses_steps_beyond_its_builds(require_backend):
    # the selection kernel is built for 1..4 sub-pixel steps: more is refused before any work,
    # naming the argument (disparity() limits subpixel_steps to the same range)
    be = require_backend("opencl")
    rng = np.random.default_rng(4)
    left, right = _codes(rng, 4, 9, 5, 1, 0.3)
    outs = be.empty((4, 9), np.float32), be.empty((4, 9), np.int32), be.empty((4, 9), np.float32)
    with pytest.raises(ValueError, match="steps must be 1..4"):
        kernels.match(be, be.asarray(left), be.asarray(right), *outs, 0, 21, 5, 3, 6, 90, 4, 10)
