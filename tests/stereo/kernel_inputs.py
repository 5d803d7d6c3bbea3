"""Input builders of the stereo fused kernels (``stereo.*``, gfgpu/stereo/kernels.py): each runs the
kernel and its numpy specification on random inputs and compares them. tests/backends/test_fused.py
runs every builder on every backend and fails for a registered kernel without one."""
import math

import numpy as np
from backends.builders import builds, compare

from gfgpu.stereo import spec as specs


@builds("stereo.census")
def _census(be, kernel, rng):
    for radius in (1, 2, 3):
        h, w = 11, 19 + radius
        image = rng.integers(0, 4, (h, w)).astype(np.float32)     # small integers: equal neighbours
        sentinel = np.full((3, h, w), 0xDEADBEEF, np.uint64)
        out = be.asarray(sentinel.copy())       # (the numpy backend's asarray does not copy)
        kernel(be, be.asarray(image), out, 1, radius)
        ref = sentinel
        ref[1] = kernel.spec(image, radius)
        compare(be.to_host(out), ref, f"census radius {radius}")      # the other planes untouched


@builds("stereo.planes")
def _planes(be, kernel, rng):
    # the right view's sub-pixel planes: float64 recursions per row, bit for bit on every backend
    # (tests/stereo/test_views.py: edge cases of the values)
    for (h, w), steps in (((5, 1), 2), ((7, 23), 2), ((4, 40), 3), ((6, 17), 4), ((3, 9), 1)):
        right = (rng.random((h, w)) * 1.9).astype(np.float32)
        right[:, w // 2:] = 0.0
        out = be.empty((steps, h, w), np.float32)
        kernel(be, be.asarray(right), out, steps)
        got, want = np.asarray(be.to_host(out)), kernel.spec(right, steps)
        compare(got.view(np.uint32), want.view(np.uint32), f"planes {h}x{w} steps {steps}")


# (h, w, disparity samples, steps, first step, block, census radius): one and several 16-lane
# vectors per pixel, partial last vectors, negative and positive disparity ranges
COST_CASES = [(7, 11, 5, 1, 0, 1, 1), (13, 29, 16, 2, -3, 3, 2), (9, 40, 17, 3, 4, 5, 3), (6, 50, 33, 2, -20, 3, 3),
              (5, 9, 40, 2, -6, 3, 1)]     # (the last: wider range than the image, both bands)


@builds("stereo.cost")
def _cost(be, kernel, rng):
    for h, w, n, steps, first, block, radius in COST_CASES:
        bits = (2 * radius + 1) ** 2 - 1
        left = rng.integers(0, 2**bits, (1, h, w), dtype=np.uint64)
        right = rng.integers(0, 2**bits, (steps, h, w), dtype=np.uint64)
        out = be.empty((h, w, n), np.int16)
        kernel(be, be.asarray(left), be.asarray(right), out, first, steps, block)
        compare(be.to_host(out), kernel.spec(left[0], right, first, n, steps, block),
                 f"cost {h}x{w}x{n} steps {steps} first {first} block {block}")


def _with_views(cost, rng):
    """``cost`` with samples out of view (-1): contiguous runs of k per column, as the cost
    kernel writes them (some columns with nothing in view)."""
    h, w, n = cost.shape
    lo = rng.integers(-2, n, w)
    hi = lo + rng.integers(-1, n + 2, w)
    k = np.arange(n)[None]
    out = cost.copy()
    out[:, (k < lo[:, None]) | (k > hi[:, None])] = -1
    return out


@builds("stereo.sgm")
def _sgm(be, kernel, rng):
    for (h, w, n), paths in (((9, 13, 5), 8), ((8, 21, 17), 4), ((5, 7, 33), 8), ((1, 12, 3), 8)):
        cost = _with_views(rng.integers(0, 49, (h, w, n)).astype(np.int16), rng)
        for p1, p2 in ((10, 100), (0, 0), (7, 7)):
            out = be.empty((h, w, n), np.int16)
            kernel(be, be.asarray(cost), out, p1, p2, paths)
            compare(be.to_host(out), kernel.spec(cost, p1, p2, paths), f"sgm {h}x{w}x{n} {paths} paths p={p1},{p2}")


@builds("stereo.select")
def _select(be, kernel, rng):
    for (h, w, n, steps, d_min, uniqueness), top in (((6, 37, 5, 1, 0, 10), 12), ((6, 37, 17, 2, -3, 5), 12),
                                                     ((5, 23, 40, 4, -1, 0), 3000), ((4, 19, 48, 2, 9, 15), 40)):
        agg = rng.integers(0, top, (h, w, n)).astype(np.int16)      # few values: many ties
        agg = _with_views(agg, rng)
        disp, right = be.empty((h, w), np.float32), be.empty((h, w), np.int32)
        margin = be.empty((h, w), np.float32)
        kernel(be, be.asarray(agg), disp, right, margin, d_min, steps, uniqueness)
        ref_disp, ref_right, ref_margin = kernel.spec(agg, d_min, steps, uniqueness)
        what = f"select {h}x{w}x{n} steps {steps} d_min {d_min}"
        compare(be.to_host(disp), ref_disp, what)
        compare(be.to_host(right), ref_right, what)
        compare(be.to_host(margin), ref_margin, what)


@builds("stereo.match")
def _match(be, kernel, rng):
    # images taller than a band (the CPU OpenCL launcher's 16 rows): several bands and checkpoints
    for (h, w, n, steps, first, paths), shift in (((40, 31, 13, 2, 0, 4), 3), ((35, 26, 11, 1, -4, 8), -2),
                                                  ((17, 20, 25, 2, -6, 8), 1), ((3, 12, 9, 1, 2, 4), 4)):
        left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
        right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
        right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < 0.05).astype(np.uint64)
        outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
        kernel(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 54, 576, paths, 10)
        for got, ref in zip(outs, kernel.spec(left[0], right, first, n, steps, 3, 54, 576, paths, 10)):
            compare(be.to_host(got), ref, f"match {h}x{w}x{n} steps {steps} first {first} {paths} paths")


@builds("stereo.left_right")
def _left_right(be, kernel, rng):
    # disparities on the sample grid (ties of rint(x - d) at .5, |d - d_R| = tol exactly) and off
    # it, NaN, right winners missing or beyond the row, both signs
    for (h, w), steps, tol in (((5, 23), 1, 1.0), ((6, 31), 2, 1.0), ((4, 17), 3, 0.5), ((3, 9), 4, 2.0)):
        k = rng.integers(-3 * steps, 12 * steps, (h, w))
        disp = (k / steps + np.where(rng.random((h, w)) < 0.5, 0, rng.uniform(-0.5, 0.5, (h, w))))
        disp = disp.astype(np.float32)
        disp[rng.random((h, w)) < 0.15] = np.nan
        right = (k + rng.integers(-2 * steps, 2 * steps + 1, (h, w))).astype(np.int32)
        right[rng.random((h, w)) < 0.15] = specs.NO_MATCH
        margin = rng.random((h, w)).astype(np.float32)
        dev = [be.asarray(a.copy()) for a in (disp, right, margin)]
        kernel(be, dev[0], dev[1], dev[2], steps, tol)
        ref_disp, ref_margin = kernel.spec(disp, right, margin, steps, tol)
        what = f"left_right {h}x{w} steps {steps} tol {tol}"
        np.testing.assert_array_equal(be.to_host(dev[0]), ref_disp, err_msg=what)    # NaN where rejected
        np.testing.assert_array_equal(be.to_host(dev[2]), ref_margin, err_msg=what)
        assert 0 < np.isnan(ref_disp).mean() < 1, what
    # x - d not representable in float32 (x ~ 1000, d just below 10.5): rint of the exact
    # difference picks x - 10, of the float32 one the even neighbour; the right view matches at
    # even columns only
    w = 1100
    disp = np.full((1, w), np.nextafter(np.float32(10.5), np.float32(0)), np.float32)
    right = np.where(np.arange(w) % 2 == 0, 21, specs.NO_MATCH).astype(np.int32)[None]
    margin = np.ones((1, w), np.float32)
    dev = [be.asarray(a.copy()) for a in (disp, right, margin)]
    kernel(be, dev[0], dev[1], dev[2], 2, 1.0)
    ref_disp, ref_margin = kernel.spec(disp, right, margin, 2, 1.0)
    np.testing.assert_array_equal(be.to_host(dev[0]), ref_disp, err_msg="left_right ties of x - d")
    np.testing.assert_array_equal(be.to_host(dev[2]), ref_margin, err_msg="left_right ties of x - d")


@builds("stereo.sweep")
def _sweep(be, kernel, rng):
    for (h, w), radius, d_min in (((9, 17), 1, -1.0), ((12, 10), 2, 2.5)):
        host = np.full((9, h, w), np.nan, np.float32)
        host[[0, 5, 6, 7]] = np.inf
        state = be.asarray(host.copy())
        for k in range(6):
            d = d_min + 0.5 * k
            offset = math.floor(d)
            left, right = (rng.random((h, w)).astype(np.float32) for _ in range(2))
            gain_l, gain_r = (rng.uniform(0.8, 1.2, w).astype(np.float32) for _ in range(2))
            kernel(be, state, be.asarray(left), be.asarray(right), be.asarray(gain_l), be.asarray(gain_r),
                   offset, d, radius)
            host = kernel.spec(host, left, right, gain_l, gain_r, offset, d, radius)
            compare(be.to_host(state), host, f"sweep {h}x{w} radius {radius} step d={d}")
