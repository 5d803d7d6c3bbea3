"""Every backend against the numpy specification of everything it runs.

The generic primitives of the :class:`~gfgpu.backends.base.Backend` contract (``recurse``,
``recurse_lines``, ``gather``) against :func:`gfgpu._core.recursion.run_reference`,
:func:`~gfgpu._core.recursion.run_reference_lines` and numpy indexing; and every fused kernel
registered with :mod:`gfgpu.backends.fused` against its ``.spec``, on random inputs: integer
outputs bit for bit, float outputs to 1e-5 (float32) or 1e-12 (float64) relative.  A kernel
registered without an input builder here fails :func:`test_every_registered_kernel_is_tested`.
"""
import importlib
import math
import pkgutil

import numpy as np
import pytest
from oracle import relerr

import gfgpu
from gfgpu import greens
from gfgpu._core.recursion import MODES, plan_lines, plan_pass, run_reference, run_reference_lines
from gfgpu.backends import BACKENDS, fused
from gfgpu.stereo import spec as specs


def _import_every_application():
    """Applications register their kernels when imported: import every gfgpu module (but the
    device code of the backends, which registers nothing and needs its device library)."""
    for info in pkgutil.walk_packages(gfgpu.__path__, "gfgpu."):
        if info.name == "gfgpu.__main__" or info.name.startswith(("gfgpu.backends.warp.",
                                                                   "gfgpu.backends.opencl.")):
            continue
        importlib.import_module(info.name)


_import_every_application()
REGISTERED = sorted(fused.registered())
TOL = {np.dtype(np.float32): 1e-5, np.dtype(np.float64): 1e-12}


def _need_dtype(be, dtype):
    if np.dtype(dtype) == np.float64 and not be.supports_float64:
        pytest.skip(f"{be} has no float64")


def _compare(got, ref, what):
    got, ref = np.asarray(got), np.asarray(ref)
    assert got.shape == ref.shape and got.dtype == ref.dtype, (what, got.shape, got.dtype, ref.shape, ref.dtype)
    if np.issubdtype(ref.dtype, np.integer):
        np.testing.assert_array_equal(got, ref, err_msg=what)
    else:
        tol = TOL[ref.dtype]
        scale = float(np.nanmax(np.abs(np.where(np.isfinite(ref), ref, 0)), initial=0.0))
        np.testing.assert_allclose(got, ref, rtol=tol, atol=tol * scale, equal_nan=True, err_msg=what)


# --------------------------------------------------------------------------------------
# input builders: one per registered kernel name; each runs the kernel and its spec
# --------------------------------------------------------------------------------------
BUILDERS = {}


def builds(name):
    def register(fn):
        BUILDERS[name] = fn
        return fn
    return register


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
        _compare(be.to_host(out), ref, f"census radius {radius}")      # the other planes untouched


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
        _compare(be.to_host(out), kernel.spec(left[0], right, first, n, steps, block),
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
            _compare(be.to_host(out), kernel.spec(cost, p1, p2, paths), f"sgm {h}x{w}x{n} {paths} paths p={p1},{p2}")


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
        _compare(be.to_host(disp), ref_disp, what)
        _compare(be.to_host(right), ref_right, what)
        _compare(be.to_host(margin), ref_margin, what)


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
            _compare(be.to_host(got), ref, f"match {h}x{w}x{n} steps {steps} first {first} {paths} paths")


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
            _compare(be.to_host(state), host, f"sweep {h}x{w} radius {radius} step d={d}")


@builds("edges.nms")
def _nms(be, kernel, rng):
    for dtype in (np.float32, np.float64):
        if np.dtype(dtype) == np.float64 and not be.supports_float64:
            continue
        gy, gx = rng.standard_normal((2, 37, 53)).astype(dtype)
        gy[5, :] = 0                                    # exact zeros and axis-aligned gradients
        gx[:, 7] = 0
        for case, (a, b) in {"normal": (gy, gx), "ties": (np.round(2 * gy), np.round(2 * gx)),
                             "small": (gy[:2, :5], gx[:2, :5])}.items():
            a, b = np.ascontiguousarray(a, dtype), np.ascontiguousarray(b, dtype)
            out = be.empty(a.shape, dtype)
            kernel(be, be.asarray(a), be.asarray(b), out)
            _compare(be.to_host(out), kernel.spec(a, b), f"nms {np.dtype(dtype).name} {case}")


def _close(be, got, ref, dtype, what):
    got = be.to_host(got).reshape(ref.shape)
    tol = 1e-11 if np.dtype(dtype) == np.float64 else 2e-5
    assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max()), what


def _motion_dtypes(be):
    return (np.float32, np.float64) if be.supports_float64 else (np.float32,)


@builds("motion.box_lines")
def _box_lines(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        src = rng.standard_normal((2, 7, 33)).astype(dtype)
        for axis, window, mode in ((1, (-5.3, 1.0, 0.0, 1.0), "reflect"), (2, (0.0, 1.0, 7.25, 1.0), "wrap"),
                                   (2, (-40.5, 1.0, 0.0, 1.0), "constant"), (1, (0.0, 0.8, 0.0, 1.3), "nearest")):
            dst = be.empty(src.shape, dtype)
            kernel(be, be.asarray(src), dst, axis, *window, mode, 0.7)
            _close(be, dst, kernel.spec(src, axis, *window, mode, 0.7), dtype, f"box_lines {axis} {window} {mode}")
        # minus less, also in place (dst is less), on the scalar and the vector kernels (8 | 2 * 8 rows)
        for shape, axis, window in (((2, 7, 33), 1, (-2.5, 1.0, 2.5, 1.0)), ((2, 8, 33), 2, (-3.25, 1.0, 0.0, 1.0)),
                                    ((2, 8, 33), 2, (0.0, 0.9, 0.0, 1.2))):
            src, less = (rng.standard_normal(shape).astype(dtype) for _ in range(2))
            ref = kernel.spec(src, axis, *window, "nearest", 0.7, less)
            dst = be.empty(shape, dtype)
            kernel(be, be.asarray(src), dst, axis, *window, "nearest", 0.7, be.asarray(less))
            _close(be, dst, ref, dtype, f"box_lines less {shape} {window}")
            same = be.asarray(less.copy())
            kernel(be, be.asarray(src), same, axis, *window, "nearest", 0.7, same)
            _close(be, same, ref, dtype, f"box_lines less in place {shape} {window}")


@builds("motion.field_blur")
def _field_blur(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        field = (rng.standard_normal((2, 20, 24)) * 4).astype(dtype)
        for psf, mode in ((0, "reflect"), (1, "wrap"), (2, "constant"), (3, "mirror")):
            out = be.empty(coef.shape, dtype)
            kernel(be, be.asarray(coef), be.asarray(field), out, psf, 2.0, mode, 0.3)
            _close(be, out, kernel.spec(coef, field, psf, 2.0, mode, 0.3), dtype, f"field_blur {psf} {mode}")


@builds("motion.to_polar")
def _to_polar(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        for mode, r0 in (("reflect", 0), ("constant", 0), ("nearest", 3)):
            polar = be.empty((2, 18, 64), dtype)
            kernel(be, be.asarray(coef), polar, 9.5, 11.2, r0, mode, 0.3)
            _close(be, polar, kernel.spec(coef, 9.5, 11.2, r0, 18, 64, mode, 0.3), dtype, f"to_polar {mode} {r0}")


@builds("motion.from_polar")
def _from_polar(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        pcoef = rng.standard_normal((2, 18, 64)).astype(dtype)
        base = rng.standard_normal((2, 20, 24)).astype(dtype)
        for r0, r_lo, r_hi, keep in ((0, 0.0, math.inf, 0.0), (2, 4.5, 9.0, 0.3)):
            ref = kernel.spec(pcoef, base, 9.5, 11.2, r0, r_lo, r_hi, keep)
            back = be.empty((2, 20, 24), dtype)
            kernel(be, be.asarray(pcoef), be.asarray(base), back, 9.5, 11.2, r0, r_lo, r_hi, keep)
            _close(be, back, ref, dtype, f"from_polar {r0}")
            same = be.asarray(base.copy())      # in place: a band adds its change to the previous bands'
            kernel(be, be.asarray(pcoef), same, same, 9.5, 11.2, r0, r_lo, r_hi, keep)
            _close(be, same, ref, dtype, f"from_polar in place {r0}")


@builds("motion.add_rows")
def _add_rows(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        src, dst = (rng.standard_normal((2, 9, 17)).astype(dtype) for _ in range(2))
        scale = rng.standard_normal(9)
        ref, ref_same = kernel.spec(src, dst, scale), kernel.spec(src, src, scale)
        out = be.asarray(dst.copy())
        kernel(be, be.asarray(src), out, scale)
        _close(be, out, ref, dtype, "add_rows")
        same = be.asarray(src.copy())       # dst is src: a scale per row in place
        kernel(be, same, same, scale)
        _close(be, same, ref_same, dtype, "add_rows in place")


def test_every_registered_kernel_is_tested():
    assert REGISTERED, "no fused kernel registered: the applications did not import"
    assert {"stereo.census", "stereo.cost", "stereo.sgm", "stereo.select", "stereo.match", "stereo.sweep",
            "edges.nms"} <= set(REGISTERED)
    missing = sorted(set(REGISTERED) - set(BUILDERS))
    stale = sorted(set(BUILDERS) - set(REGISTERED))
    assert not missing, f"registered fused kernels without an input builder in {__file__}: {missing}"
    assert not stale, f"input builders for kernels nobody registers: {stale}"
    for name, kernel in fused.registered().items():
        assert set(kernel.launchers) == set(BACKENDS), f"{name} runs on {sorted(kernel.launchers)} only"
        # the numpy specification: the spec module of the feature that registers the kernel
        feature = name.partition(".")[0]
        assert callable(kernel.spec) and kernel.spec.__module__ == f"gfgpu.{feature}.spec", name


@pytest.mark.parametrize("name", REGISTERED)
def test_fused_kernel_matches_its_spec(backend, name):
    kernel = fused.registered()[name]
    if name not in BUILDERS:
        pytest.fail(f"fused kernel {name!r} has no input builder in {__file__}")
    if backend.name not in kernel.launchers:
        pytest.fail(f"fused kernel {name!r} has no launcher on the {backend.name} backend")
    BUILDERS[name](backend, kernel, np.random.default_rng(sum(map(ord, name))))


# --------------------------------------------------------------------------------------
# the generic primitives
# --------------------------------------------------------------------------------------
PASSES = {
    "G_u": greens.UniformGreen(2.3).line_pass(),
    "H_u anticausal": greens.HomogeneousGreen(1.7).line_pass(reverse=True),
    "shift -3.6": greens.shift_pass(-3.6),
    "D (two sections)": greens.derivative_passes(1.5)[0],
    "G_U1": greens.AffineGreen(0.6, -3.5).line_pass(),
    "G_U2 anticausal": greens.AffineGreenApprox(6.0, 80.0).line_pass(reverse=True),
}
# (B, N, M) and the axis of the lines: columns (1) and rows (2), one line, lines of one sample
LAYOUTS = [((2, 17, 5), 1), ((3, 4, 23), 2), ((1, 1, 40), 2), ((2, 33, 1), 1), ((1, 3, 1), 2)]


def _reference_pass(src, axis, line_pass, mode, cval):
    """run_reference (float64) on every line of a (B, N, M) array."""
    b, n, m = src.shape
    x = src.astype(np.float64)
    if axis == 1:
        plan = plan_pass(line_pass, n, mode, np.float64)
        return np.stack([run_reference(x[i], plan, cval) for i in range(b)])
    plan = plan_pass(line_pass, m, mode, np.float64)
    return run_reference(x.reshape(b * n, m).T, plan, cval).T.reshape(b, n, m)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", list(PASSES))
def test_recurse_matches_run_reference(backend, name, dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(7)
    for shape, axis in LAYOUTS:
        n = shape[axis]
        if name.startswith("G_U2") and n <= 1:
            continue
        for mode in MODES:
            src = (1.0 + rng.standard_normal(shape)).astype(dtype)
            plan = plan_pass(PASSES[name], n, mode, dtype)
            ref = _reference_pass(src, axis, PASSES[name], mode, 0.25)
            what = f"{name} {shape} axis {axis} {mode}"
            out = backend.empty(shape, dtype)
            backend.recurse(backend.asarray(src), out, axis, plan, cval=0.25)
            got = backend.to_host(out)
            assert got.dtype == dtype and relerr(got, ref) <= TOL[np.dtype(dtype)], what
            base = rng.standard_normal(shape).astype(dtype)
            acc = backend.asarray(base.copy())
            backend.recurse(backend.asarray(src), acc, axis, plan, cval=0.25, accumulate=True)
            assert relerr(backend.to_host(acc), ref + base) <= TOL[np.dtype(dtype)], f"{what} accumulate"
            same = backend.asarray(src.copy())
            backend.recurse(same, same, axis, plan, cval=0.25)          # dst may be src
            assert relerr(backend.to_host(same), ref) <= TOL[np.dtype(dtype)], f"{what} in place"


LINE_PASSES = [greens.UniformGreen(1.3).line_pass(), None, greens.shift_pass(-2.7), greens.shift_pass(0.35),
               greens.HomogeneousGreen(2.0).line_pass(reverse=True), greens.shift_pass(9.5), None]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_recurse_lines_matches_run_reference_lines(backend, dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(8)
    lines = len(LINE_PASSES)
    for shape, axis in (((2, 19, lines), 1), ((3, lines, 26), 2), ((1, lines, 1), 2)):
        n = shape[axis]
        for mode in MODES:
            src = (1.0 + rng.standard_normal(shape)).astype(dtype)
            plans = plan_lines(LINE_PASSES, n, mode, dtype)
            plans64 = plan_lines(LINE_PASSES, n, mode, np.float64)
            x = src.astype(np.float64)
            ref = np.stack([run_reference_lines(x[i] if axis == 1 else x[i].T, plans64, -0.5)
                            for i in range(shape[0])])
            ref = ref if axis == 1 else ref.transpose(0, 2, 1)
            out = backend.empty(shape, dtype)
            backend.recurse_lines(backend.asarray(src), out, axis, plans, cval=-0.5)
            what = f"{shape} axis {axis} {mode}"
            assert relerr(backend.to_host(out), ref) <= TOL[np.dtype(dtype)], what
            same = backend.asarray(src.copy())
            backend.recurse_lines(same, same, axis, plans, cval=-0.5)
            assert relerr(backend.to_host(same), ref) <= TOL[np.dtype(dtype)], f"{what} in place"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("index_dtype", [np.int32, np.int64])
def test_gather_matches_numpy_indexing(backend, dtype, index_dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(9)
    src = rng.standard_normal((2, 9, 13)).astype(dtype)
    for out_shape in ((5, 7), (2, 13, 9), (1,)):
        size = int(np.prod(out_shape))
        index = rng.integers(-3, src.size, size).astype(index_dtype)
        index[:1] = src.size - 1
        out = backend.empty(out_shape, dtype)
        backend.gather(backend.asarray(src), index, 2.5, out)
        ref = np.where(index < 0, dtype(2.5), src.reshape(-1)[np.maximum(index, 0)]).reshape(out_shape)
        np.testing.assert_array_equal(backend.to_host(out), ref, err_msg=f"gather into {out_shape}")
