"""Sample-count buckets of the CPU band matcher (issue 28, item 3): a new ``max_disparity`` within
a bucket that is already built costs no build, and every count of a bucket gives the map of the
numpy specification."""

import numpy as np
import pytest

from gfgpu.stereo import band_plan, disparity, kernels, matching
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, square_subpixel


def test_buckets_cover_every_count_with_little_padding():
    nmax = 4 * matching.MAX_RANGE + 1               # 4 sub-pixel steps over the widest range
    counts = np.arange(1, nmax + 1)
    sizes = np.array([band_plan.sample_bucket(n)[0] for n in counts])
    full = np.array([band_plan.sample_bucket(n)[1] for n in counts])
    assert (sizes >= counts).all() and (sizes % 16 == 0).all()
    assert (16 * full < counts).all()               # the vectors below NV_FULL hold samples only
    assert (full < sizes // 16).all()
    wide = counts > 16 * 12                         # below 13 vectors every count is a bucket
    assert (sizes[wide] / (16 * np.ceil(counts[wide] / 16)) <= 1.125).all()
    assert len(set(sizes[counts <= 1024])) <= 30
    for num_disp in list(range(16, 257, 16)) + list(range(288, 513, 32)):     # OpenCV-style ranges
        n = 2 * num_disp - 1                        # half-pixel samples of 0 .. num_disp - 1
        assert band_plan.sample_bucket(n)[0] == 16 * -(-n // 16)
    with pytest.raises(ValueError, match="largest bucket"):
        band_plan.sample_bucket(16 * band_plan.BUCKET_VECTORS[-1] + 1)


def _codes(rng, h, w, steps, shift, flip):
    left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def test_every_count_of_a_bucket_matches_the_specification(require_backend):
    # counts of one bucket (49..64: 4 vectors, NV_FULL 3) and of a wider one (417..448, 28
    # vectors, NV_FULL 26), with ranges inside, straddling and beyond the image (masked paths
    # and entering samples), 4 and 8 paths, 1..4 sub-pixel steps
    be = require_backend("opencl")
    rng = np.random.default_rng(5)
    assert band_plan.sample_bucket(49) == band_plan.sample_bucket(64) == (64, 3)
    assert band_plan.sample_bucket(417) == band_plan.sample_bucket(431) == (448, 26)
    cases = [(49, 1, 0, 4), (50, 2, -10, 8), (57, 3, 3, 4), (64, 4, -32, 8), (417, 1, -400, 4), (431, 2, 0, 4)]
    for n, steps, first, paths in cases:
        h, w = 7, 40
        left, right = _codes(rng, h, w, steps, 2, 0.1)
        outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
        first *= steps
        kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 5, 40, paths, 10,
                      None)
        ref = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, paths, 10)
        for got, want in zip(outs, ref):
            np.testing.assert_array_equal(be.to_host(got), want, err_msg=f"n={n} steps={steps} first={first}")


def test_new_range_in_a_built_bucket_builds_nothing(require_backend, monkeypatch):
    # max_disparity 20 and 23 (41 and 47 half-pixel samples) share the bucket of 3 vectors: the
    # second call builds no program (counted at the launch toolkit's builds, pyopencl's
    # Program.build) and both maps are the numpy specification's
    be = require_backend("opencl")
    import pyopencl as cl
    builds = []
    build = cl.Program.build

    def counting(self, *args, **kwargs):
        builds.append(kwargs.get("options", args[0] if args else None))
        return build(self, *args, **kwargs)

    monkeypatch.setattr(cl.Program, "build", counting)
    left, right, _ = random_dot_pair(square_subpixel, shape=(40, 90), seed=3)
    assert band_plan.sample_bucket(2 * 20 + 1) == band_plan.sample_bucket(2 * 23 + 1)
    maps = {}
    for d_max in (20, 23):
        before = len(builds)
        maps[d_max] = disparity(left, right, d_max, backend=be)
        if d_max == 23:
            assert builds[before:] == []
        np.testing.assert_array_equal(maps[d_max], disparity(left, right, d_max, backend="numpy"))
    assert np.isfinite(maps[23]).mean() > 0.5
