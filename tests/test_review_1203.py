"""Review of 1d9d4c4 (OpenCL two-sided steps along rows and columns) and 79c6d45 (stereo: the
left-right check inside the selection, the branch-free right winner, the speckle filter).

Every backend's derivative, projection and gradient against the float64 numpy result on tiny,
odd, long and stacked shapes in every mode; outputs that are views at odd offsets, strided or in
Fortran order; refusals of non-finite inputs on a first step along rows; concurrent calls of
changing shapes (the work-items' counter); the temporaries a step along columns allocates.
Stereo: the band matcher's fused check against left_right_reference (non-dyadic, denormal and
out-of-range tolerances, negative ranges, images narrower than the range, bands), disparity on
every backend against numpy for bool, integer and float images, and the speckle filter against
a per-pixel graph of scipy.sparse.csgraph.
"""

import threading
import warnings

import numpy as np
import pytest
from oracle import max_relerr

import gfgpu
from gfgpu import stereo
from gfgpu.stereo import _opencl, band_plan, kernels, postfilter
from gfgpu.stereo import spec as specs

MODES = ["reflect", "nearest", "mirror", "wrap", "constant"]
TOL = {np.float32: 2e-5, np.float64: 1e-11}


def _close(got, want, dtype, what=""):
    """``got`` within float rounding of ``want`` (relative to the largest magnitude, at least 1)."""
    err = max_relerr(got, want)
    assert err < TOL[dtype], f"{what}: relative error {err:.3g}"


def _host(be, a):
    return be.to_host(a) if not isinstance(a, np.ndarray) else a


# ----------------------------------------------------------------------------------------------
# derivative / projection / gradient: shapes that take the row kernel (>= 8 rows per core's lanes),
# the column kernel, partial vectors, bands and tiles, lines of 1 sample
# ----------------------------------------------------------------------------------------------
SHAPES = [(1, 7), (7, 1), (2, 2), (7, 9), (8, 8), (16, 1), (16, 3), (17, 33), (40, 17), (33, 64),
          (9, 4097), (3, 5, 7), (4, 16, 40)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_derivative_projection_every_mode_and_axis(backend, dtype, shape):
    x = np.random.default_rng(sum(shape)).standard_normal(shape).astype(dtype)
    for mode in MODES:
        for u in (0.7, 3.0, 40.0):
            for axis in range(len(shape)):
                for fn in (gfgpu.derivative, gfgpu.projection):
                    want = fn(x.astype(np.float64), u, axis=axis, mode=mode, cval=0.6, backend="numpy")
                    got = fn(x, u, axis=axis, mode=mode, cval=0.6, backend=backend)
                    _close(_host(backend, got), want, dtype, f"{fn.__name__} {mode} u={u} axis={axis}")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape,channel_axis", [((7, 9), None), ((17, 33), None), ((16, 3), None),
                                                ((20, 30, 3), -1), ((3, 20, 30), 0), ((20, 3, 30), 1),
                                                ((4, 17, 9), None)], ids=str)
def test_gradient_every_mode(backend, dtype, shape, channel_axis):
    x = np.random.default_rng(len(shape)).standard_normal(shape).astype(dtype)
    for mode in MODES:
        want = gfgpu.gradient(x.astype(np.float64), 1.5, channel_axis=channel_axis, mode=mode, cval=-0.8,
                              backend="numpy")
        got = gfgpu.gradient(x, 1.5, channel_axis=channel_axis, mode=mode, cval=-0.8, backend=backend)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            _close(_host(backend, g), w, dtype, f"gradient {mode}")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("u", [0.05, 1e3])
def test_extreme_scales_and_options(backend, dtype, u):
    x = np.random.default_rng(5).standard_normal((20, 33)).astype(dtype)
    for kw in ({}, {"single_scale": True}, {"projection_scale": 0.3}):
        for mode in ("reflect", "wrap", "constant"):
            for axis in (0, 1):
                want = gfgpu.derivative(x.astype(np.float64), u, axis=axis, mode=mode, cval=2.0, backend="numpy",
                                        **kw)
                got = gfgpu.derivative(x, u, axis=axis, mode=mode, cval=2.0, backend=backend, **kw)
                _close(_host(backend, got), want, dtype, f"u={u} {kw} {mode} axis={axis}")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(16, 32768), (16, 32769)], ids=str)
def test_rows_at_the_row_kernel_limit(cpu_opencl, dtype, shape):
    # 32768 samples: the longest rows of the row kernel (MAX_ROW); 32769: the generic pair
    x = np.random.default_rng(2).standard_normal(shape).astype(dtype)
    for axis in (0, 1):
        want = gfgpu.derivative(x.astype(np.float64), 3.0, axis=axis, mode="mirror", backend="numpy")
        _close(gfgpu.derivative(x, 3.0, axis=axis, mode="mirror", backend=cpu_opencl), want, dtype, f"axis {axis}")
    want = gfgpu.gradient(x.astype(np.float64), 3.0, mode="wrap", backend="numpy")
    for g, w in zip(gfgpu.gradient(x, 3.0, mode="wrap", backend=cpu_opencl), want):
        _close(g, w, dtype, "gradient")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(17, 33), (16, 64), (20, 128)], ids=str)
def test_outputs_views_offsets_strides_fortran(backend, dtype, shape):
    x = np.random.default_rng(3).standard_normal(shape).astype(dtype)
    for axis in (0, 1):
        want = gfgpu.derivative(x.astype(np.float64), 2.0, axis=axis, mode="constant", cval=-1.2, backend="numpy")
        for off in (1, 3, 5, 8):
            big = np.full(x.size + off + 16, 7, dtype)
            out = big[off:off + x.size].reshape(shape)
            gfgpu.derivative(x, 2.0, axis=axis, mode="constant", cval=-1.2, backend=backend, output=out)
            _close(out, want, dtype, f"offset {off}")
            assert np.all(big[:off] == 7) and np.all(big[off + x.size:] == 7)
        out = np.zeros(shape, dtype, order="F")
        gfgpu.derivative(x, 2.0, axis=axis, mode="constant", cval=-1.2, backend=backend, output=out)
        _close(out, want, dtype, "Fortran output")
        bigs = np.zeros((shape[0] * 2, shape[1] * 3), dtype)
        gfgpu.derivative(x, 2.0, axis=axis, mode="constant", cval=-1.2, backend=backend, output=bigs[1::2, 2::3])
        _close(bigs[1::2, 2::3], want, dtype, "strided output")
        assert not bigs[0::2].any()
        xs = np.zeros_like(bigs)
        xs[1::2, 2::3] = x
        _close(_host(backend, gfgpu.derivative(xs[1::2, 2::3], 2.0, axis=axis, mode="constant", cval=-1.2,
                                               backend=backend)), want, dtype, "strided input")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_refused_on_a_first_step_along_rows(backend, dtype, bad):
    # a single step along rows (the row kernel's check on OpenCL) and a gradient; the output untouched
    rng = np.random.default_rng(4)
    for shape in [(17, 33), (16, 64), (21, 5), (19, 1), (3, 7, 40)]:
        for _ in range(3):
            x = rng.standard_normal(shape).astype(dtype)
            x[tuple(int(rng.integers(0, s)) for s in shape)] = bad
            out = np.full(shape, 5, dtype)
            with pytest.raises(ValueError, match="NaN or infinite"):
                gfgpu.projection(x, 1.5, axis=-1, output=out, backend=backend)
            assert np.all(out == 5)
            with pytest.raises(ValueError, match="NaN or infinite"):
                gfgpu.derivative(x, 1.5, axes=(len(shape) - 1,), output=out, backend=backend)
            assert np.all(out == 5)
            with pytest.raises(ValueError, match="NaN or infinite"):
                gfgpu.gradient(x, 1.5, backend=backend)


def test_concurrent_calls_of_changing_shapes(cpu_opencl):
    # the work-items take lines from a counter in each call's flag: threads and shapes mixed
    errors = []

    def work(seed):
        rng = np.random.default_rng(seed)
        try:
            for it in range(8):
                shape = (int(rng.integers(1, 60)), int(rng.integers(1, 200)))
                dtype = np.float32 if rng.integers(2) else np.float64
                x = rng.standard_normal(shape).astype(dtype)
                axis = int(rng.integers(2))
                want = gfgpu.derivative(x.astype(np.float64), 1.0 + it, axis=axis, backend="numpy")
                _close(gfgpu.derivative(x, 1.0 + it, axis=axis, backend=cpu_opencl), want, dtype, "derivative")
                for g, w in zip(gfgpu.gradient(x, 1.0 + it, backend=cpu_opencl),
                                gfgpu.gradient(x.astype(np.float64), 1.0 + it, backend="numpy")):
                    _close(g, w, dtype, "gradient")
        except Exception as exc:   # reported by the main thread
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(s,)) for s in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors[0]


@pytest.mark.parametrize("fn", ["derivative", "gradient"])
def test_column_step_temporaries_follow_the_image_width(cpu_opencl, monkeypatch, fn):
    # A step along columns keeps each work-item's anticausal parts in a scratch of N x BAND x NOUT
    # vectors of a cache line (BAND = 4) whatever the width: for (16384, 8) float32 (512 KiB) the
    # derivative allocated 4 MiB (8x), the gradient's shared P/D step 8 MiB (16x); (2e7, 2) float32
    # (160 MB) asked for a 9.5 GiB scratch (the earlier kernel: carries of N / 32 rows, 40 MB).
    be = cpu_opencl
    sizes = []
    empty = be.empty

    def spy(shape, dtype, *args, **kwargs):
        sizes.append(int(np.prod(shape)) * np.dtype(dtype).itemsize)
        return empty(shape, dtype, *args, **kwargs)

    monkeypatch.setattr(be, "empty", spy)
    x = np.random.default_rng(6).standard_normal((16384, 8)).astype(np.float32)
    if fn == "derivative":
        got = [gfgpu.derivative(x, 2.0, axis=0, backend=be)]
        want = [gfgpu.derivative(x.astype(np.float64), 2.0, axis=0, backend="numpy")]
    else:
        got = gfgpu.gradient(x, 2.0, backend=be)
        want = gfgpu.gradient(x.astype(np.float64), 2.0, backend="numpy")
    for g, w in zip(got, want):
        _close(g, w, np.float32, fn)
    assert sizes
    assert max(sizes) <= 4 * x.nbytes, f"a temporary of {max(sizes) / x.nbytes:.0f}x the image's bytes"


# ----------------------------------------------------------------------------------------------
# stereo: the check inside the band matcher's selection
# ----------------------------------------------------------------------------------------------
def _codes(rng, h, w, steps, shift, flip):
    left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def _cpu_band_matcher(require_backend):
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on OpenCL CPU devices")
    return be


# (h, w, samples, steps, first step): negative ranges, images narrower than the range
MATCH_CASES = [(17, 30, 23, 2, -4), (5, 7, 23, 2, -4), (6, 9, 40, 1, -20), (9, 12, 30, 3, -45), (4, 3, 8, 1, 0),
               (8, 40, 17, 4, 8), (3, 5, 12, 2, -30)]


def _match_checked(be, left, right, first, n, steps, paths, tol):
    h, w = left.shape[1:]
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 5, 40, paths, 10, None,
                  left_right=tol)
    return [be.to_host(o) for o in outs]


def _want_checked(left, right, first, n, steps, paths, tol):
    d, dr, m = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, paths, 10)
    with np.errstate(invalid="ignore"):
        wd, wm = specs.left_right_reference(d, dr, m, steps, tol)
    return wd, dr, wm


@pytest.mark.parametrize("plan", ["one band", "bands", "coarse bands"])
@pytest.mark.parametrize("tol", [1.0, 0.75, 0.3, 1 / 3, 2.0**-140, 3.0, 100.0])
def test_fused_left_right_matches_reference(require_backend, monkeypatch, plan, tol):
    be = _cpu_band_matcher(require_backend)
    if plan != "one band":
        monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
        monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w=1, n=1: min(h_, 3))
    if plan == "coarse bands":
        monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    rng = np.random.default_rng(int(tol * 1000) % 97)
    for h, w, n, steps, first in MATCH_CASES:
        for paths in (4, 8):
            left, right = _codes(rng, h, w, steps, 3, 0.35)
            got = _match_checked(be, left, right, first, n, steps, paths, tol)
            for g, r, what in zip(got, _want_checked(left, right, first, n, steps, paths, tol),
                                  ("disp", "disp_right", "margin")):
                np.testing.assert_array_equal(g, r, err_msg=f"{what} {(h, w, n, steps, first, paths)}")


def test_fused_tolerance_beyond_float32_range_is_quiet(require_backend):
    # A tolerance beyond float32's range (1e39) cannot be the selection's float argument: the
    # left_right kernel checks after the matcher.  _fused_tolerance tests that by a float32 cast,
    # which overflows with a RuntimeWarning (an error under -W error, as in many CI setups).
    be = _cpu_band_matcher(require_backend)
    rng = np.random.default_rng(8)
    left, right = _codes(rng, 9, 20, 2, 3, 0.35)
    want = _want_checked(left, right, -4, 23, 2, 4, 1e39)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _opencl._fused_tolerance(be, 1e39) is None
        got = _match_checked(be, left, right, -4, 23, 2, 4, 1e39)
    for g, r in zip(got, want):
        np.testing.assert_array_equal(g, r)


def _pair(rng, h, w, shift, kind):
    base = rng.random((h, w + abs(shift) + 2))
    left, right = base[:, :w], np.roll(base, -shift, axis=1)[:, :w]
    if kind == "bool":
        return left > 0.5, right > 0.5
    if kind == "uint16":
        return (left * 65535).astype(np.uint16), (right * 65535).astype(np.uint16)
    return left.astype(kind), right.astype(kind)


@pytest.mark.parametrize("kind", ["float32", "float64", "uint16", "bool"])
def test_disparity_with_left_right_equals_numpy(backend, kind):
    rng = np.random.default_rng(9)
    for h, w, mx, mn, shift in [(20, 30, 8, 0, 3), (12, 6, 12, 0, 2), (15, 25, 4, -6, -3), (9, 10, 20, -5, 1),
                                (2, 40, 8, 0, 3), (16, 17, 3, -3, 0)]:
        left, right = _pair(rng, h, w, shift, kind)
        want = stereo.disparity(left, right, mx, min_disparity=mn, backend="numpy", return_confidence=True)
        got = stereo.disparity(left, right, mx, min_disparity=mn, backend=backend, return_confidence=True)
        for g, r in zip(got, want):
            np.testing.assert_array_equal(_host(backend, g), r, err_msg=f"{(h, w, mx, mn)}")


# ----------------------------------------------------------------------------------------------
# stereo: the speckle filter against a graph of every pixel
# ----------------------------------------------------------------------------------------------
def pixel_graph_small_regions(disp, max_size, max_diff):
    """Reference: the 4-neighbour joins (float64 differences) of every pixel as one sparse graph,
    its connected components; valid pixels of components of at most ``max_size`` pixels."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    d = np.asarray(disp, np.float64)
    h, w = d.shape
    idx = np.arange(h * w).reshape(h, w)
    with np.errstate(invalid="ignore"):
        right = np.abs(d[:, 1:] - d[:, :-1]) <= max_diff
        down = np.abs(d[1:] - d[:-1]) <= max_diff
    src = np.concatenate([idx[:, :-1][right], idx[:-1][down]])
    dst = np.concatenate([idx[:, 1:][right], idx[1:][down]])
    graph = coo_matrix((np.ones(src.size), (src, dst)), shape=(h * w, h * w))
    _, label = connected_components(graph, directed=False)
    return (np.bincount(label)[label] <= max_size).reshape(h, w) & np.isfinite(d)


def _speckle_map(rng, kind, h, w):
    if kind == 0:
        d = rng.integers(0, 4, (h, w)).astype(np.float32)                  # ties everywhere
    elif kind == 1:
        d = (rng.random((h, w)) * 5).astype(np.float32)
    elif kind == 2:
        d = np.round(rng.random((h, w)) * 8) / 4                              # steps at the tolerance
    elif kind == 3:
        d = rng.integers(0, 3, (h, w)).astype(np.float64)
        d[:, rng.integers(0, w)] = 9                                          # a vertical run
    elif kind == 4:
        d = rng.integers(0, 3, (h, w)).astype(np.float32) * np.float32(0.1)  # float32 steps near 0.1
    else:
        d = np.full((h, w), 5.0, np.float32)
        d[rng.random((h, w)) < 0.2] = rng.integers(0, 10)                     # single pixels
    d[rng.random((h, w)) < 0.15] = np.nan
    if rng.random() < 0.1:
        d[rng.random((h, w)) < 0.1] = np.inf
    if rng.random() < 0.3:
        d = np.asfortranarray(d)
    if rng.random() < 0.2:
        d = d[:, ::-1]
    return d


def test_small_regions_match_a_pixel_graph():
    rng = np.random.default_rng(11)
    for it in range(1500):
        h, w = int(rng.integers(1, 14)), int(rng.integers(1, 14))
        d = _speckle_map(rng, it % 6, h, w)
        size = int(rng.integers(0, 12))
        diff = float(rng.choice([0.0, 0.1, 0.25, 0.5, 1.0, 1.5, float(np.float32(0.1))]))
        np.testing.assert_array_equal(postfilter.small_regions(d, size, diff), pixel_graph_small_regions(d, size, diff),
                                      err_msg=f"case {it}: {d.dtype} {d.shape} size {size} diff {diff}")
        if size > 0:
            out = postfilter.filter_speckles(d, size, diff)
            assert out.dtype == d.dtype
            want = np.array(d, copy=True)
            want[pixel_graph_small_regions(d, size, diff)] = np.nan
            np.testing.assert_array_equal(out, want)


@pytest.mark.parametrize("dtype", [bool, np.uint8, np.uint16, np.int32, np.float16, ">f4", ">f8"])
def test_small_regions_of_other_dtypes(dtype):
    rng = np.random.default_rng(12)
    for _ in range(50):
        d = rng.integers(0, 3, (7, 9)).astype(dtype)
        np.testing.assert_array_equal(postfilter.small_regions(d, 3, 1.0),
                                      pixel_graph_small_regions(np.asarray(d, np.float64), 3, 1.0))
