"""The matcher's stage kernels (census, cost, SGM aggregation, selection) against the numpy
specification (gfgpu.stereo.spec), bit for bit, for every layout of the disparity axis."""


import numpy as np
import pytest

from gfgpu.stereo import kernels as stereo_kernels
from gfgpu.stereo import spec as specs


def test_kernels_match_reference(backend):
    rng = np.random.default_rng(1)
    h, w, n = 23, 37, 9
    img_l, img_r = (rng.random((h, w)).astype(np.float32) for _ in range(2))
    cl, cr = backend.empty((1, h, w), np.uint64), backend.empty((2, h, w), np.uint64)
    stereo_kernels.census(backend, backend.asarray(img_l), cl, 0, 2)
    stereo_kernels.census(backend, backend.asarray(img_r), cr, 0, 2)
    stereo_kernels.census(backend, backend.asarray(img_r[::-1].copy()), cr, 1, 2)
    ref_l = specs.census_transform_reference(img_l, 2)
    np.testing.assert_array_equal(backend.to_host(cl)[0], ref_l)
    cost = backend.empty((h, w, n), np.int16)
    stereo_kernels.cost(backend, cl, cr, cost, -3, 2, 3)
    ref_cost = specs.census_cost_reference(ref_l, backend.to_host(cr), -3, n, 2, 3)
    np.testing.assert_array_equal(backend.to_host(cost), ref_cost)
    agg = backend.empty((h, w, n), np.int16)
    stereo_kernels.sgm(backend, cost, agg, 20, 150, 8)
    ref_agg = specs.sgm_aggregate_reference(ref_cost, 20, 150, 8)
    np.testing.assert_array_equal(backend.to_host(agg), ref_agg)
    disp, right = backend.empty((h, w), np.float32), backend.empty((h, w), np.int32)
    margin = backend.empty((h, w), np.float32)
    stereo_kernels.select(backend, agg, disp, right, margin, -2, 2, 5)
    ref_d, ref_r, ref_m = specs.select_disparity_reference(ref_agg, -2, 2, 5)
    np.testing.assert_allclose(backend.to_host(disp), ref_d, atol=1e-5)
    np.testing.assert_array_equal(backend.to_host(right), ref_r)
    np.testing.assert_allclose(backend.to_host(margin), ref_m, atol=1e-6)


# (h, w, disparity samples, steps, first step, block, census radius, paths): one and several
# 16-lane vectors per pixel, full and partial last vectors, negative and positive ranges
KERNEL_CASES = [
    (7, 11, 5, 1, 0, 1, 1, 8),
    (13, 29, 16, 2, -3, 3, 2, 8),
    (9, 40, 17, 3, 4, 5, 3, 4),
    (20, 31, 33, 4, -9, 3, 3, 8),
    (5, 64, 127, 2, 0, 3, 3, 8),
    (6, 50, 48, 1, -20, 1, 1, 4),
    (17, 19, 31, 2, -40, 3, 3, 8),
]


def _census_pair(backend, h, w, steps, radius, seed):
    rng = np.random.default_rng(seed)
    img_l = rng.random((h, w)).astype(np.float32)
    img_r = [rng.random((h, w)).astype(np.float32) for _ in range(steps)]
    cl, cr = backend.empty((1, h, w), np.uint64), backend.empty((steps, h, w), np.uint64)
    stereo_kernels.census(backend, backend.asarray(img_l), cl, 0, radius)
    for f in range(steps):
        stereo_kernels.census(backend, backend.asarray(img_r[f]), cr, f, radius)
    ref_l = specs.census_transform_reference(img_l, radius)
    ref_r = np.stack([specs.census_transform_reference(im, radius) for im in img_r])
    return cl, cr, ref_l, ref_r


@pytest.mark.parametrize("case", KERNEL_CASES, ids=lambda c: "x".join(map(str, c[:3])))
def test_cost_and_aggregation_match_reference(backend, case):
    # the vectorised kernels (16 disparities per vector, tails, two-sweep SGM on CPUs) are
    # bit-identical to the specification for every layout of the disparity axis
    h, w, n, steps, first, block, radius, paths = case
    cl, cr, ref_l, ref_r = _census_pair(backend, h, w, steps, radius, seed=n)
    np.testing.assert_array_equal(backend.to_host(cl)[0], ref_l)
    np.testing.assert_array_equal(backend.to_host(cr), ref_r)
    cost = backend.empty((h, w, n), np.int16)
    stereo_kernels.cost(backend, cl, cr, cost, first, steps, block)
    ref_cost = specs.census_cost_reference(ref_l, ref_r, first, n, steps, block)
    np.testing.assert_array_equal(backend.to_host(cost), ref_cost)
    for p1, p2 in ((10, 100), (0, 0), (7, 7)):
        agg = backend.empty((h, w, n), np.int16)
        stereo_kernels.sgm(backend, cost, agg, p1, p2, paths)
        np.testing.assert_array_equal(backend.to_host(agg),
                                      specs.sgm_aggregate_reference(ref_cost, p1, p2, paths))


@pytest.mark.parametrize("n,steps,d_min", [(5, 1, 0), (17, 2, -3), (33, 3, 2), (40, 4, -1), (48, 2, 9)])
def test_select_matches_reference_with_ties(backend, n, steps, d_min):
    # small integer costs: many ties, which both views must break towards the first k
    h, w = 6, 37
    agg = np.random.default_rng(n).integers(0, 12, (h, w, n)).astype(np.int16)
    # out of view as the cost kernel leaves it: a left band (positive d) and a right band
    view = specs.in_view_reference(w, d_min * steps, n, steps, 1)
    agg[:, ~view] = specs.OUT_OF_VIEW
    disp, right = backend.empty((h, w), np.float32), backend.empty((h, w), np.int32)
    margin = backend.empty((h, w), np.float32)
    stereo_kernels.select(backend, backend.asarray(agg), disp, right, margin, d_min, steps, 5)
    ref_d, ref_r, ref_m = specs.select_disparity_reference(agg, d_min, steps, 5)
    np.testing.assert_allclose(backend.to_host(disp), ref_d, atol=1e-5)
    np.testing.assert_array_equal(backend.to_host(right), ref_r)
    np.testing.assert_allclose(backend.to_host(margin), ref_m, atol=1e-6)


def test_opencl_line_aggregation_matches_reference(monkeypatch, require_backend):
    # GPUs aggregate one image line per work-item (sgm_line_pair), CPUs in two sweeps: run the
    # GPU variant on whatever OpenCL device there is
    be = require_backend("opencl")
    monkeypatch.setattr(be, "kind", "gpu")
    for h, w, n, steps, first, block, _, paths in KERNEL_CASES[2:5]:
        cost = np.random.default_rng(n).integers(0, 60, (h, w, n)).astype(np.int16)
        cost[:, ~specs.in_view_reference(w, first, n, steps, block // 2)] = specs.OUT_OF_VIEW
        agg = be.empty((h, w, n), np.int16)
        stereo_kernels.sgm(be, be.asarray(cost), agg, 9, 70, paths)
        np.testing.assert_array_equal(be.to_host(agg), specs.sgm_aggregate_reference(cost, 9, 70, paths))


def test_sgm_reference_single_path():
    # one horizontal path by hand: L = C + min(prev, prev±1 + P1, min + P2) - min
    cost = np.array([[[0, 5, 5], [5, 0, 5], [5, 5, 0]]], np.int16)
    total = specs.sgm_aggregate_reference(cost, 1, 3, paths=1)
    np.testing.assert_array_equal(total[0, 0], [0, 5, 5])
    np.testing.assert_array_equal(total[0, 1], [5 + 0, 0 + 1, 5 + 3])
    np.testing.assert_array_equal(total[0, 2], [5 + 2 - 1, 5 + 1 - 1, 0 + 2 - 1])
