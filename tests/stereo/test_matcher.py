"""The fused matcher (``stereo.match``) against ``semi_global_match_reference``, bit for bit: awkward
shapes, saturated costs and extreme penalties, the GPU code path; and the plan of the CPU band
matcher (bands of rows, checkpoints, column tiles, byte costs kept or recomputed per band)."""


import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import kernels, matching
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, slanted


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


def test_opencl_match_refuses_steps_beyond_its_builds(require_backend):
    # the selection kernel is built for 1..4 sub-pixel steps: more is refused before any work,
    # naming the argument (disparity() limits subpixel_steps to the same range)
    be = require_backend("opencl")
    rng = np.random.default_rng(4)
    left, right = _codes(rng, 4, 9, 5, 1, 0.3)
    outs = be.empty((4, 9), np.float32), be.empty((4, 9), np.int32), be.empty((4, 9), np.float32)
    with pytest.raises(ValueError, match="steps must be 1..4"):
        kernels.match(be, be.asarray(left), be.asarray(right), *outs, 0, 21, 5, 3, 6, 90, 4, 10)


def test_gpu_code_path_of_the_matcher_runs_on_the_cpu_device(require_backend, monkeypatch):
    # the OpenCL matcher's GPU branch (whole int16 volumes: Hamming distances per pixel, block
    # sums, one work-item per path line, selection) has no GPU here: run it on the CPU device
    be = require_backend("opencl")
    monkeypatch.setattr(be, "kind", "gpu")
    rng = np.random.default_rng(7)
    for (h, w, n, steps, first, paths) in ((23, 31, 13, 2, -4, 8), (9, 40, 17, 1, 3, 4)):
        left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
        right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
        right[0] = np.roll(left[0], -2, axis=1) ^ (rng.random((h, w)) < 0.05).astype(np.uint64)
        outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
        kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 54, 576,
                             paths, 10, None)
        ref = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 54, 576, paths, 10)
        for got, want in zip(outs, ref):
            np.testing.assert_array_equal(be.to_host(got), want)


# --------------------------------------------------------------------------------------
# the CPU band matcher: bands, checkpoints, column tiles
# --------------------------------------------------------------------------------------
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


def test_band_matcher_keeps_or_recomputes_costs_with_the_same_result(require_backend, monkeypatch):
    # issue 14, item 2: the CPU OpenCL matcher streams bands of rows; with a working set too
    # small for the byte cost volume it recomputes each band's costs (bit-identical maps), and
    # a working set too small even for the bands is refused before any work
    import gfgpu
    from gfgpu.stereo.band_plan import band_rows
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on OpenCL CPU devices")
    left, right, _ = random_dot_pair(slanted, shape=(90, 72), seed=5)
    monkeypatch.setattr("gfgpu.stereo.band_plan.BAND_BYTES", 1)   # bands of the fewest rows
    monkeypatch.setattr("gfgpu.stereo.band_plan.WHOLE_BYTES", 0)  # (not one band)
    assert band_rows(90, 4, 72, 16) < 90                # several bands, checkpoints
    keep = stereo.disparity(left, right, 12, min_disparity=-3, backend=be)
    full = stereo.disparity_memory(left.shape, 12, min_disparity=-3, backend=be)
    with gfgpu.working_set(full - 90 * 72 * 8):        # no room for the (H, W, D) byte costs
        again = stereo.disparity(left, right, 12, min_disparity=-3, backend=be)
        assert stereo.disparity_memory(left.shape, 12, min_disparity=-3, backend=be) < full
    np.testing.assert_array_equal(again, keep)
    ref = stereo.disparity(left, right, 12, min_disparity=-3, backend="numpy")
    np.testing.assert_allclose(keep, ref, atol=1e-5)
    with gfgpu.working_set("64K"), pytest.raises(ValueError, match="working set"):
        stereo.disparity(left, right, 12, min_disparity=-3, backend=be)
