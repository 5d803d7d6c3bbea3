"""The CPU band matcher of the OpenCL launcher (``_opencl.launch_match``): every variant of its
kernels (the Hamming distances with and without AVX512-VPOPCNTDQ) and every band plan (one band,
bands with the byte costs kept, recomputed, or kept for the top rows only) gives the numpy
specification's maps bit for bit."""

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import _opencl, band_plan, kernels
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, slanted


def _codes(rng, h, w, steps, shift, flip):
    left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def _match(be, left, right, first, n, steps, block, paths, budget=None):
    h, w = left.shape[1:]
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, block, 5, 40, paths, 10, budget)
    return [be.to_host(o) for o in outs]


def _cpu_opencl(require_backend):
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on OpenCL CPU devices")
    return be


# (h, w, samples, steps, first step, block): the Hamming kernel's 16-sample vectors whole, cut by
# the image's left edge (a scalar tail) and by the range's end, one and many vectors
HAMMING_CASES = [(9, 45, 15, 1, 0, 3), (8, 70, 33, 2, -10, 3), (6, 90, 63, 3, 3, 5), (7, 60, 129, 2, 0, 1)]


@pytest.mark.parametrize("popcount", ["host", "portable"])
def test_hamming_variants_match_the_specification(require_backend, monkeypatch, popcount):
    # "host": the build options the launcher takes from this CPU (AVX512-VPOPCNTDQ where it has
    # it); "portable": none, the AVX2 nibble-table or scalar popcount every x86 CPU runs
    be = _cpu_opencl(require_backend)
    if popcount == "portable":
        monkeypatch.setattr(_opencl, "_host_cpu_defines", lambda be: {})
    rng = np.random.default_rng(3)
    for h, w, n, steps, first, block in HAMMING_CASES:
        left, right = _codes(rng, h, w, steps, 3, 0.2)
        got = _match(be, left, right, first * steps, n, steps, block, 4)
        want = specs.semi_global_match_reference(left[0], right, first * steps, n, steps, block, 5, 40, 4, 10)
        for g, r in zip(got, want):
            np.testing.assert_array_equal(g, r, err_msg=f"{popcount}: n={n} steps={steps} first={first}")


def test_host_cpu_defines_follow_the_cpu_flags(require_backend, monkeypatch):
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(_opencl, "_CPU_FLAGS", frozenset({"avx2", "avx512f", "avx512_vpopcntdq"}))
    assert _opencl._host_cpu_defines(be) == {"VPOPCNTQ": 1}
    monkeypatch.setattr(_opencl, "_CPU_FLAGS", frozenset({"avx2", "avx512f"}))
    assert _opencl._host_cpu_defines(be) == {}


def test_camera_size_plan_recomputes_costs_in_coarse_bands():
    # 1000 x 1500 with max_disparity 191 and half-pixel samples (383): the whole image's byte
    # costs (576 MB) exceed KEEP_BYTES, so the plan recomputes them per coarse band: a multiple
    # of the band rows, fewer rows than the image, and the matcher's own memory a fraction of
    # the costs it no longer keeps
    plan = band_plan.match_plan(1000, 1500, 383, 4)
    assert not plan.keep and plan.rows < plan.coarse < 1000 and plan.coarse % plan.rows == 0
    assert plan.nbytes == band_plan.match_memory(1000, 1500, 383, 4, False)
    assert plan.nbytes < 0.25 * 1000 * 1500 * 384
    # a smaller image whose costs fit KEEP_BYTES keeps them; a budget below that recomputes
    small = band_plan.match_plan(400, 1500, 191, 4)
    assert small.keep and small.coarse == 400 and small.rows < 400
    tight = band_plan.match_plan(400, 1500, 191, 4, budget=small.nbytes - 1)
    assert not tight.keep and tight.nbytes < small.nbytes


@pytest.mark.parametrize("h,k,paths", [(23, 2, 4), (30, 3, 8), (17, 4, 4), (9, 2, 4)])
def test_coarse_bands_match_the_specification(require_backend, monkeypatch, h, k, paths):
    # costs recomputed per coarse band: coarse bands of several fine bands, a last coarse band
    # shorter than the others (down to one row), the fine checkpoints of each; against the spec
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w=1, n=1: min(h_, k))
    w, n, steps, first = 26, 21, 2, -4
    plan = band_plan.match_plan(h, w, n, paths)
    assert not plan.keep and plan.rows == k and plan.coarse < h
    left, right = _codes(np.random.default_rng(h), h, w, steps, 2, 0.25)
    got = _match(be, left, right, first, n, steps, 3, paths)
    want = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, paths, 10)
    for g, r in zip(got, want):
        np.testing.assert_array_equal(g, r)


@pytest.mark.parametrize("keep,paths", [(True, 4), (True, 8), (False, 4), (False, 8)])
def test_band_sweeps_run_in_their_checkpoints(require_backend, monkeypatch, keep, paths):
    # the up sweep reads a band's first predecessors from one checkpoint slot and writes the next
    # (or runs in its own slot): no device copy of a state, with the costs kept or recomputed, and
    # the maps still the specification's; the slots' guard lanes matter (not written: wrong maps)
    from gfgpu.backends.opencl import launch as ocl
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w=1, n=1: min(h_, 3))
    if not keep:
        monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)

    def no_copy(*args, **kwargs):
        raise AssertionError("the band matcher copied a device buffer")
    monkeypatch.setattr(ocl, "copy_bytes", no_copy)
    h, w, n, steps, first = 20, 30, 21, 2, -4
    assert band_plan.match_plan(h, w, n, paths).keep == keep
    left, right = _codes(np.random.default_rng(5), h, w, steps, 2, 0.25)
    want = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, paths, 10)
    for g, r in zip(_match(be, left, right, first, n, steps, 3, paths), want):
        np.testing.assert_array_equal(g, r)
    real_launch = ocl.launch

    def launch_without_guards(be_, knl, *args):
        return None if knl.function_name == "sgm_guards" else real_launch(be_, knl, *args)
    monkeypatch.setattr(ocl, "launch", launch_without_guards)
    # fresh buffers that hold no guard lanes: zeros (a reused buffer would keep the last call's)
    real_empty = be.empty

    def zeroed(shape, dtype):
        a = real_empty(shape, dtype)
        a.fill(0)
        return a
    monkeypatch.setattr(be, "empty", zeroed)
    got = _match(be, left, right, first, n, steps, 3, paths)
    assert any(not np.array_equal(g, r, equal_nan=True) for g, r in zip(got, want))


@pytest.mark.parametrize("paths", [4, 8])
def test_stream_in_coarse_bands_equals_disparity(require_backend, monkeypatch, paths):
    # StereoMatcher keeps the coarse bands' buffers (costs, interleaved codes of one coarse band,
    # coarse and fine checkpoints) across frames: every frame equals a one-shot disparity() and
    # the numpy specification's map
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w=1, n=1: min(h_, 3))
    shape = (29, 48)
    assert not band_plan.match_plan(*shape, 27, paths).keep
    matcher = stereo.StereoMatcher(shape, 13, min_disparity=-1, paths=paths, backend=be)
    for k in range(3):
        left, right, _ = random_dot_pair(lambda yy, xx, k=k: slanted(yy, xx) + 0.4 * k, shape=shape, seed=k)
        got = matcher.compute(left, right)
        want = stereo.disparity(left, right, 13, min_disparity=-1, paths=paths, backend=be)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(got, stereo.disparity(left, right, 13, min_disparity=-1, paths=paths,
                                                            backend="numpy"))


@pytest.mark.parametrize("plan", ["one band", "bands", "coarse bands"])
@pytest.mark.parametrize("tol", [1.0, 0.5, 0.1])
def test_selection_checks_left_right_as_the_specification(require_backend, monkeypatch, plan, tol):
    # match(left_right=tol): the selection checks each row left against right as it finishes it
    # (a tolerance a float32 holds exactly, on a device with fp64), else the left_right kernel
    # after the matcher (0.1); either way the maps of left_right_reference after the matcher's,
    # on noisy codes whose two views disagree in places
    be = _cpu_opencl(require_backend)
    if plan != "one band":
        monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
        monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w=1, n=1: min(h_, 3))
    if plan == "coarse bands":
        monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    h, w, n, steps, first = 17, 30, 23, 2, -4
    left, right = _codes(np.random.default_rng(int(10 * tol)), h, w, steps, 3, 0.35)
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 5, 40, 4, 10, None,
                  left_right=tol)
    disp, disp_right, margin = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, 4, 10)
    want_disp, want_margin = specs.left_right_reference(disp, disp_right, margin, steps, tol)
    assert np.isnan(want_disp).sum() > np.isnan(disp).sum()          # the check rejects something
    assert np.isfinite(want_disp).any()
    np.testing.assert_array_equal(be.to_host(outs[0]), want_disp)
    np.testing.assert_array_equal(be.to_host(outs[1]), disp_right)
    np.testing.assert_array_equal(be.to_host(outs[2]), want_margin)
    assert _opencl._fused_tolerance(be, tol) == (tol if tol != 0.1 and be.supports_float64 else None)
