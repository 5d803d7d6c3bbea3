"""Review of 2026-12-03 (b): attacks on today's caches and kept state.

* 064f8db, plans at a new image size: windows cached by ``lam^period`` (recursion), two-sided unit
  windows keyed by identity (twosided), per-direction column tables (oblique).  Every result after a
  sequence of calls at other sizes, modes and dtypes must have the bits of the same call with every
  cache cleared, and be close to an independent float64 reference (the line padded by ``np.pad``
  in the mode and filtered with ``constant``, which needs no window).
* 7e5cf12, stereo: the device speckle filter and the kept 256 MiB buffers: every map bit for bit
  the numpy backend's, whatever came before.
* a5b6839, spin and zoom: only_band writes, content-keyed small uploads: close to numpy's float64.
* 84d795d, the OpenCL probe: an unusable verdict cache never breaks the backend.
"""

import functools
import os
import threading
from collections import OrderedDict

import numpy as np
import pytest

import gfgpu
from gfgpu import greens
from gfgpu._core import lines, oblique, program, recursion, twosided

# ---------------------------------------------------------------------------------------------
# helpers


def _forget_everything():
    """Clear every lru_cache and every OrderedDict cache of the planning modules (more than
    tests/backends/test_first_call.py's list: whatever the modules hold)."""
    for mod in (recursion, twosided, oblique, lines, program):
        for name in dir(mod):
            obj = getattr(mod, name)
            if isinstance(obj, functools._lru_cache_wrapper) and getattr(obj, "__module__", None) == mod.__name__:
                obj.cache_clear()
            elif isinstance(obj, OrderedDict):
                obj.clear()


def _bits_equal(got, want):
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape and got.dtype == want.dtype, (got.shape, got.dtype, want.shape, want.dtype)
    u = {4: np.uint32, 8: np.uint64}[got.dtype.itemsize]
    bad = np.nonzero(got.view(u) != want.view(u))
    assert bad[0].size == 0, (f"{bad[0].size} values differ, first at {tuple(int(b[0]) for b in bad)}: "
                              f"{got[tuple(b[0] for b in bad)]!r} vs {want[tuple(b[0] for b in bad)]!r}")


def _skip64(be, dtype):
    if np.dtype(dtype) == np.float64 and not be.supports_float64:
        pytest.skip(f"{be!r} has no float64")


def _in_threads(funcs):
    """Run each callable in its own thread, all released at once; their results in order (the
    first exception raised again)."""
    results, errors = [None] * len(funcs), []
    barrier = threading.Barrier(len(funcs))

    def run(k):
        try:
            barrier.wait()
            results[k] = funcs[k]()
        except BaseException as exc:     # raised again below
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(len(funcs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise errors[0]
    return results


_NP_PAD = {"reflect": "symmetric", "mirror": "reflect", "wrap": "wrap", "nearest": "edge", "constant": "constant",
           "grid-wrap": "wrap", "grid-mirror": "symmetric", "grid-constant": "constant"}


def _padded_reference(x, g, axis, mode, cval=0.0):
    """green_filter of float64 ``x`` along ``axis`` with ``mode``, computed on the line padded by
    np.pad far beyond the kernel's decay and filtered with mode 'constant' (no window)."""
    lam = max(abs(complex(s.lam)) for s in g.line_pass().sections)
    pad = int(np.ceil(np.log(1e-18) / np.log(lam))) + 8
    widths = [(0, 0)] * x.ndim
    widths[axis] = (pad, pad)
    kw = {"constant_values": cval} if mode.endswith("constant") else {}
    big = np.pad(np.asarray(x, np.float64), widths, mode=_NP_PAD[mode], **kw)
    out = gfgpu.green_filter(big, g, axis=axis, mode="constant", cval=cval, backend="numpy")
    sl = [slice(None)] * x.ndim
    sl[axis] = slice(pad, pad + x.shape[axis])
    return out[tuple(sl)]


def _reach(g, dtype):
    return max(int(recursion._reach(complex(s.lam), recursion.TOL[np.dtype(dtype)])) for s in g.line_pass().sections)


# ---------------------------------------------------------------------------------------------
# 064f8db: plans at a new image size


@pytest.mark.parametrize("u", [3.0, 20.0])
@pytest.mark.parametrize("mode", ["wrap", "mirror", "reflect", "nearest", "constant", "grid-wrap", "grid-mirror",
                                  "grid-constant"])
def test_line_lengths_around_the_reach_alternating_have_fresh_bits(backend, u, mode):
    """Lines just within and just beyond a section's reach (computed in full vs a cached row),
    1-3 samples, both dtypes sharing the caches, rows and columns, in an order that alternates:
    each result has the bits of the same call after every cache is cleared, and is close to the
    padded float64 reference."""
    g = greens.UniformGreen(u)
    dtypes = [np.float32] + ([np.float64] if backend.supports_float64 else [])
    rng = np.random.default_rng(7)
    cases = []
    for dtype in dtypes:
        r = _reach(g, dtype)
        for n in (2 * r + 5, r + 1, 3, r, 1, r + 2, 2, r - 1, r + 3, 2 * r + 6):
            for axis in (1, 0):
                shape = (3, n) if axis == 1 else (n, 2)
                cases.append((dtype, n, axis, rng.standard_normal(shape)))
    rng.shuffle(cases)
    _forget_everything()
    seq = [gfgpu.green_filter(x.astype(dt), g, axis=ax, mode=mode, cval=0.25, backend=backend)
           for dt, n, ax, x in cases]
    for (dt, n, ax, x), got in zip(cases, seq):
        _forget_everything()
        fresh = gfgpu.green_filter(x.astype(dt), g, axis=ax, mode=mode, cval=0.25, backend=backend)
        _bits_equal(got, fresh)
        ref = _padded_reference(x, g, ax, mode, cval=0.25)
        tol = 1e-9 if dt == np.float64 else 2e-5
        err = np.abs(np.asarray(got, np.float64) - ref).max() / max(np.abs(ref).max(), 1e-30)
        assert err <= tol, (dt, n, ax, mode, err)


@pytest.mark.parametrize("amount", [1e-9, 0.999999999, -0.0, 1.0 - 2**-40, 2**-30])
def test_shifts_near_whole_pixels_after_other_sizes_have_fresh_bits(backend, amount):
    """Shifts by fractions near 0 or 1 (poles near 0 or 1) and by -0.0, after the same shift at
    other sizes and by the neighbouring fraction: bits of a fresh call, close to numpy float64."""
    rng = np.random.default_rng(3)
    sizes = [(40, 900), (5, 7), (3, 1), (1, 3), (41, 901), (2, 2)]
    imgs = [rng.standard_normal(s) for s in sizes]
    _forget_everything()
    seq = []
    for mode in ("wrap", "mirror", "reflect", "nearest"):
        for x in imgs:
            gfgpu.shift(x.astype(np.float32), (0.0, -amount), mode=mode, backend=backend)
            seq.append((mode, x, gfgpu.shift(x.astype(np.float32), (amount, 0.5), mode=mode, backend=backend)))
            seq.append((mode, x, gfgpu.shift(x.astype(np.float32), (0.5, amount), mode=mode, backend=backend)))
    i = 0
    for mode in ("wrap", "mirror", "reflect", "nearest"):
        for x in imgs:
            for amt in ((amount, 0.5), (0.5, amount)):
                _forget_everything()
                fresh = gfgpu.shift(x.astype(np.float32), amt, mode=mode, backend=backend)
                _bits_equal(seq[i][2], fresh)
                ref = gfgpu.shift(x, amt, mode=mode, backend="numpy")
                err = np.abs(np.asarray(seq[i][2], np.float64) - ref).max() / np.abs(ref).max()
                assert err <= 1e-5, (x.shape, mode, amt, err)
                i += 1


def test_more_than_sixteen_directions_then_back_larger_then_smaller(backend):
    """18 directions at a small size (the first evicted from the LRU of 16), then the first ones
    on a larger image than their table (extended), then smaller again, plus a direction whose
    first table has no moving column (gamma*t whole below 1e-12 for a short image): bits of a
    fresh call, and close to the numpy backend's float64 after a clear."""
    rng = np.random.default_rng(5)
    g = greens.UniformGreen(2.0)
    angles = [0.05 + 0.07 * k for k in range(18)] + [2e-14, -2e-14 + np.pi / 4]
    small, large = rng.standard_normal((31, 37)), rng.standard_normal((150, 333))
    mid = rng.standard_normal((60, 70))
    order = ([(a, small) for a in angles] + [(a, large) for a in angles[:3]] + [(angles[-2], large)]
             + [(a, mid) for a in angles[:3]] + [(a, small) for a in angles[::-1]])
    _forget_everything()
    got = [gfgpu.green_filter(x.astype(np.float32), g, angle=a, mode="wrap", backend=backend) for a, x in order]
    for (a, x), out in zip(order, got):
        _forget_everything()
        _bits_equal(out, gfgpu.green_filter(x.astype(np.float32), g, angle=a, mode="wrap", backend=backend))
    for (a, x), out in list(zip(order, got))[::7]:
        _forget_everything()
        ref = gfgpu.green_filter(x, g, angle=a, mode="wrap", backend="numpy")
        err = np.abs(np.asarray(out, np.float64) - ref).max() / np.abs(ref).max()
        assert err <= 1e-4, (a, x.shape, err)


def test_oblique_float32_then_float64_tables_then_float32_again(backend):
    """One direction, float32 at a small size, float64 at a large one, float32 at the large one
    (tables per dtype: different tolerances, different margins): fresh bits each."""
    _skip64(backend, np.float64)
    rng = np.random.default_rng(9)
    g = greens.UniformGreen(6.0)
    seq = [(np.float32, rng.standard_normal((20, 25))), (np.float64, rng.standard_normal((90, 260))),
           (np.float32, rng.standard_normal((90, 260))), (np.float64, rng.standard_normal((20, 25)))]
    _forget_everything()
    got = [gfgpu.green_filter(x.astype(dt), g, angle=-1.1, mode="mirror", backend=backend) for dt, x in seq]
    for (dt, x), out in zip(seq, got):
        _forget_everything()
        _bits_equal(out, gfgpu.green_filter(x.astype(dt), g, angle=-1.1, mode="mirror", backend=backend))


@pytest.mark.parametrize("op", ["derivative", "gradient", "canny"])
def test_two_sided_steps_alternating_sizes_and_modes_have_fresh_bits(backend, op):
    """derivative / gradient / canny at 1-3 px lines, around the two-sided reach and large, modes
    alternating (unit windows keyed by identity): fresh bits each."""
    rng = np.random.default_rng(11)
    shapes = [(64, 300), (1, 5), (3, 2), (2, 3), (40, 41), (300, 64), (7, 1), (65, 301)]
    modes = ["mirror", "wrap", "reflect", "nearest", "constant"]
    dtypes = [np.float32] + ([np.float64] if backend.supports_float64 else [])

    def call(x, mode):
        if op == "derivative":
            return gfgpu.derivative(x, 1.5, mode=mode, backend=backend)
        if op == "gradient":
            return np.stack(gfgpu.gradient(x, 1.5, mode=mode, backend=backend))
        return gfgpu.canny(x, 1.5, mode=mode, backend=backend)

    cases = []
    for k, s in enumerate(shapes):
        if op == "canny" and min(s) < 3:
            continue
        for j in range(2):
            cases.append((rng.standard_normal(s).astype(dtypes[(k + j) % len(dtypes)]), modes[(k + 2 * j) % 5]))
    _forget_everything()
    got = [call(x, m) for x, m in cases]
    for (x, m), out in zip(cases, got):
        _forget_everything()
        fresh = call(x, m)
        if op == "canny":
            np.testing.assert_array_equal(out, fresh)
        else:
            _bits_equal(out, fresh)


def test_threads_at_different_sizes_and_modes_get_fresh_results(backend):
    """Four threads filter at different sizes, modes, angles and dtypes at once from cleared
    caches (the tables are filled concurrently): each result equals the serial fresh one."""
    rng = np.random.default_rng(13)
    g = greens.UniformGreen(20.0)
    dt64 = np.float64 if backend.supports_float64 else np.float32
    jobs = [
        (rng.standard_normal((8, 1700)).astype(np.float32), dict(axis=1, mode="mirror")),
        (rng.standard_normal((8, 1900)).astype(dt64), dict(axis=1, mode="mirror")),
        (rng.standard_normal((900, 6)).astype(np.float32), dict(axis=0, mode="wrap")),
        (rng.standard_normal((70, 90)).astype(np.float32), dict(angle=0.4, mode="reflect")),
        (rng.standard_normal((120, 200)).astype(np.float32), dict(angle=0.4, mode="reflect")),
        (rng.standard_normal((8, 40)).astype(np.float32), dict(axis=1, mode="mirror")),
    ]
    want = []
    for x, kw in jobs:
        _forget_everything()
        want.append(gfgpu.green_filter(x, g, backend=backend, **kw))
    def work(i):
        x, kw = jobs[i]
        return [gfgpu.green_filter(x, g, backend=backend, **kw) for _ in range(2)]

    for _ in range(2):
        _forget_everything()
        results = _in_threads([functools.partial(work, i) for i in range(len(jobs))])
        for w, rs in zip(want, results):
            for r in rs:
                _bits_equal(r, w)


# ---------------------------------------------------------------------------------------------
# 7e5cf12: stereo


def _pair(shape, seed):
    from gfgpu import stereo
    yy, xx = np.mgrid[:shape[0], :shape[1]].astype(np.float64)
    d = 3.0 + 0.05 * xx + 0.02 * yy + np.where((abs(yy - shape[0] / 2) < 7) & (abs(xx - shape[1] / 2) < 9), 4, 0)
    left, right = stereo.random_dot_stereogram(d, seed)
    return left, right


def _disp_equal(got, want):
    if isinstance(want, tuple):
        for g_, w_ in zip(got, want):
            _bits_equal(np.asarray(g_, np.float32), np.asarray(w_, np.float32))
    else:
        _bits_equal(np.asarray(got, np.float32), np.asarray(want, np.float32))


def test_disparity_calls_alternating_options_equal_numpy_bit_for_bit(backend):
    """Calls of one size and range (the kept buffers reused) alternating speckle size (0, 1,
    huge), range (0, tiny, large), confidence returned or thresholded, lr_check, subpixel;
    then another size and range, and back: every map (and confidence) numpy's, NaN bits too."""
    a = _pair((36, 64), 1)
    b = _pair((29, 51), 2)
    calls = [
        (a, 12, dict()),
        (a, 12, dict(speckle_size=1, speckle_range=0.0, return_confidence=True)),
        (a, 12, dict(speckle_size=10**6, speckle_range=0.5)),
        (a, 12, dict(speckle_size=0, return_confidence=True)),
        (a, 12, dict(speckle_size=40, speckle_range=100.0, return_confidence=True)),
        (a, 12, dict(lr_check=False, speckle_size=5, return_confidence=True)),
        (a, 12, dict(min_confidence=0.3, speckle_size=8, return_confidence=True)),
        (a, 12, dict(subpixel=False, speckle_size=8)),
        (a, 12, dict(speckle_size=8, speckle_range=1e-30)),
        (b, 9, dict(speckle_size=3, return_confidence=True)),
        (a, 12, dict(min_disparity=2, speckle_size=6, return_confidence=True)),
        (a, 12, dict(speckle_size=6, return_confidence=True)),
        (b, 9, dict()),
        (a, 12, dict(lr_check=False, return_confidence=True)),
    ]
    want = [gfgpu.disparity(*p, m, backend="numpy", **kw) for p, m, kw in calls]
    for _ in range(2):
        for (p, m, kw), w in zip(calls, want):
            got = gfgpu.disparity(*p, m, backend=backend, **kw)
            try:
                _disp_equal(got, w)
            except AssertionError as exc:
                raise AssertionError(f"{p[0].shape} max {m} {kw}: {exc}") from None


def test_disparity_tiny_heights_and_census_options_alternating_equal_numpy(backend):
    """2-5 rows (the union-find's halves empty or one row), then options the kept buffers' key
    leaves out (census radius, uniqueness, penalties) alternating on one size: numpy's bits."""
    rng = np.random.default_rng(29)
    calls = []
    for shape in ((2, 40), (3, 30), (5, 33), (2, 40)):
        left = rng.random(shape).astype(np.float32)
        calls.append(((left, np.roll(left, -2, axis=1)), 6, dict(speckle_size=3, return_confidence=True)))
    a = _pair((36, 64), 5)
    for kw in (dict(census_radius=1), dict(census_radius=3, uniqueness=0), dict(census_radius=2, p1=3, p2=40),
               dict(census_radius=1, speckle_size=4, speckle_range=0.25), dict(paths=8, speckle_size=4),
               dict(window=5, speckle_size=4, return_confidence=True), dict(census_radius=3)):
        calls.append((a, 12, kw))
    want = [gfgpu.disparity(*p, m, backend="numpy", **kw) for p, m, kw in calls]
    for (p, m, kw), w in zip(calls + calls[::-1], want + want[::-1]):
        got = gfgpu.disparity(*p, m, backend=backend, **kw)
        try:
            _disp_equal(got, w)
        except AssertionError as exc:
            raise AssertionError(f"{p[0].shape} max {m} {kw}: {exc}") from None


def test_disparity_threads_with_different_shapes_and_speckles_equal_numpy(backend):
    """Three threads at once, two sharing a size (the kept buffers taken by one), different
    speckle options: numpy's maps bit for bit."""
    a, b = _pair((36, 64), 3), _pair((30, 57), 4)
    jobs = [(a, 12, dict(speckle_size=5, return_confidence=True)), (a, 12, dict(speckle_size=50)),
            (b, 10, dict(speckle_size=2, speckle_range=2.0, return_confidence=True))]
    want = [gfgpu.disparity(*p, m, backend="numpy", **kw) for p, m, kw in jobs]
    def work(i):
        p, m, kw = jobs[i]
        return [gfgpu.disparity(*p, m, backend=backend, **kw) for _ in range(3)]

    results = _in_threads([functools.partial(work, i) for i in range(len(jobs))])
    for w, rs in zip(want, results):
        for r in rs:
            _disp_equal(r, w)


# ---------------------------------------------------------------------------------------------
# a5b6839: spin and zoom


def _close_to(got, ref, tol):
    got = np.asarray(got, np.float64)
    assert got.shape == ref.shape
    assert np.isfinite(got).all(), "non-finite values (a pixel not written?)"
    err = np.abs(got - ref).max() / max(np.abs(ref).max(), 1e-30)
    assert err <= tol, err


@pytest.mark.parametrize("psf", ["green", "box"])
def test_spin_and_zoom_interleaved_centres_equal_numpy(backend, psf):
    """Rotations about centres on, beside and far off the image (up to twice the diagonal), zooms
    about centres in corners, tiny images, interleaved so that the content-keyed uploads and kept
    arrays of one call are another's neighbours: numpy float64 within float32 rounding."""
    rng = np.random.default_rng(17)
    big, tiny, thin = rng.standard_normal((70, 95)), rng.standard_normal((3, 4)), rng.standard_normal((1, 9))
    diag = np.hypot(69, 94)
    cases = [
        (big, 25.0, "rotation", (34.5, 47.0), "reflect"),
        (big, -40.0, "rotation", (34.5 - 1.9 * diag, 47.0), "wrap"),
        (big, 25.0, "rotation", (-3.0, 100.0), "constant"),
        (big, 25.0, "rotation", (34.5, 47.0 + 1.99 * diag), "nearest"),
        (big, 0.3, "zoom", (0.0, 0.0), "reflect"),
        (big, -0.5, "zoom", (69.0, 94.0), "mirror"),
        (tiny, 90.0, "rotation", (1.0, 1.5), "reflect"),
        (tiny, 0.2, "zoom", (0.0, 3.0), "nearest"),
        (big, 360.0, "rotation", (10.0, 10.0), "wrap"),
        (big, 25.0, "rotation", (34.5, 47.0), "mirror"),
    ]
    if psf == "green":
        cases.append((thin, 45.0, "rotation", (0.0, 4.0), "reflect"))
    want = [gfgpu.motion_blur(x, v, kind=k, psf=psf, center=c, mode=m, cval=0.5, backend="numpy")
            for x, v, k, c, m in cases]
    for rep in range(2):
        for (x, v, k, c, m), w in list(zip(cases, want))[::1 if rep == 0 else -1]:
            got = gfgpu.motion_blur(x.astype(np.float32), v, kind=k, psf=psf, center=c, mode=m, cval=0.5,
                                    backend=backend)
            try:
                _close_to(got, w, 2e-4)
            except AssertionError as exc:
                raise AssertionError(f"{x.shape} {k} {v} centre {c} {m}: {exc}") from None


def test_spin_stacks_channels_and_float64_equal_numpy(backend):
    """A colour stack (channel_axis) and a (2, H, W) stack in float64: numpy float64 within the
    dtype's rounding; an output array filled with NaN first (every pixel must be written)."""
    rng = np.random.default_rng(19)
    rgb = rng.standard_normal((45, 52, 3))
    stack = rng.standard_normal((2, 33, 47))
    for psf in ("green", "box"):
        ref = gfgpu.motion_blur(rgb, 30.0, kind="rotation", psf=psf, center=(-20.0, 60.0), channel_axis=-1,
                                backend="numpy")
        got = gfgpu.motion_blur(rgb.astype(np.float32), 30.0, kind="rotation", psf=psf, center=(-20.0, 60.0),
                                channel_axis=-1, backend=backend)
        _close_to(got, ref, 2e-4)
        ref = gfgpu.motion_blur(stack, 0.4, kind="zoom", psf=psf, center=(5.0, 40.0), backend="numpy")
        if backend.supports_float64:
            out = np.full(stack.shape, np.nan)
            got = gfgpu.motion_blur(stack, 0.4, kind="zoom", psf=psf, center=(5.0, 40.0), output=out,
                                    backend=backend)
            _close_to(got, ref, 1e-9)
        out = np.full(stack.shape, np.nan, np.float32)
        got = gfgpu.motion_blur(stack.astype(np.float32), -60.0, kind="rotation", psf=psf, center=(80.0, -30.0),
                                output=out, backend=backend)
        _close_to(got, gfgpu.motion_blur(stack, -60.0, kind="rotation", psf=psf, center=(80.0, -30.0),
                                         backend="numpy"), 2e-4)


_SPLIT_REFS = {}


def test_spin_split_bands_stacks_float64_in_place_equal_numpy(backend):
    """Spins whose polar grid runs as 3 bands (the coefficients at the end of the second work array,
    the outermost band last), on stacks (planes > 1), float64, written into the image itself and
    into a NaN-filled output, centres off the image: numpy float64 within the dtype's rounding."""
    from gfgpu.motion import polar
    rng = np.random.default_rng(31)
    cases = [((2, 100, 110), (-150.0, -10.0), 15.0, "reflect"), ((120, 260), (5.0, 5.0), -25.0, "wrap"),
             ((3, 2, 300), (0.0, 0.0), 40.0, "constant")]
    for shape, c, a, m in cases:
        assert len(polar.polar_bands(*shape[-2:], *c, split=True)) > 1
        x = rng.standard_normal(shape)
        for psf in ("green", "box"):
            key = (shape, c, a, m, psf)
            if key not in _SPLIT_REFS:
                _SPLIT_REFS[key] = gfgpu.motion_blur(x, a, kind="rotation", psf=psf, center=c, mode=m, backend="numpy")
            ref = _SPLIT_REFS[key]
            # (the numpy backend's float64 is the reference itself)
            dts = [np.float32] + ([np.float64] if backend.supports_float64 and backend.name != "numpy" else [])
            for dt in dts:
                tol = 2e-4 if dt == np.float32 else 1e-9
                same = x.astype(dt)
                got = gfgpu.motion_blur(same, a, kind="rotation", psf=psf, center=c, mode=m, output=same,
                                        backend=backend)
                _close_to(got, ref, tol)
                held = np.full(shape, np.nan, dt)
                got = gfgpu.motion_blur(x.astype(dt), a, kind="rotation", psf=psf, center=c, mode=m, output=held,
                                        backend=backend)
                _close_to(got, ref, tol)


def test_spin_threads_with_different_centres_equal_numpy(backend):
    """Four threads spin one shape about different centres at once (kept arrays and uploads by
    content, under a lock): each numpy's float64 within float32 rounding."""
    rng = np.random.default_rng(23)
    img = rng.standard_normal((64, 80))
    jobs = [((31.5, 39.5), 20.0), ((0.0, 0.0), -35.0), ((100.0, -50.0), 12.0), ((31.5, 39.5), 21.0),
            ((-150.0, -10.0), 9.0)]
    want = [gfgpu.motion_blur(img, a, kind="rotation", center=c, backend="numpy") for c, a in jobs]
    def work(i):
        c, a = jobs[i]
        return [gfgpu.motion_blur(img.astype(np.float32), a, kind="rotation", center=c, backend=backend)
                for _ in range(3)]

    results = _in_threads([functools.partial(work, i) for i in range(len(jobs))])
    for w, rs in zip(want, results):
        for r in rs:
            _close_to(r, w, 2e-4)


# ---------------------------------------------------------------------------------------------
# 84d795d: the OpenCL probe




def test_probe_in_a_fresh_process_whose_cache_home_is_a_file(opencl_cpu_device, tmp_path):
    """XDG_CACHE_HOME pointing to a file from the start: the backend moves its caches to a
    temporary directory, the probe's child runs there, the CPU device is not refused and its
    results equal numpy's."""
    import subprocess
    import sys
    home = tmp_path / "not-a-dir"
    home.write_text("x")
    code = ("import numpy as np, gfgpu, warnings\n"
            "warnings.simplefilter('ignore')\n"
            "from gfgpu.backends.opencl import backend as clb\n"
            "assert any(k == 'cpu' and clb.build_failure(d) is None for _, d, k in clb.opencl_devices())\n"
            "x = np.random.default_rng(0).random((20, 30)).astype(np.float32)\n"
            "a = gfgpu.shift(x, (0.5, 0.25), backend='opencl')\n"
            "b = gfgpu.shift(x.astype(np.float64), (0.5, 0.25), backend='numpy')\n"
            "assert np.abs(a - b).max() < 1e-5\n"
            "print('ok')\n")
    env = dict(os.environ, XDG_CACHE_HOME=str(home))
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stdout.strip().endswith("ok"), res.stderr[-2000:]
    assert home.read_text() == "x"


def test_probe_a_child_that_cannot_start_does_not_refuse_the_device_for_good(opencl_cpu_device, tmp_path, monkeypatch):
    """A probe child that fails before it reaches the device (here: its Python finds a pyopencl
    that does not import, as a process whose pyopencl came from sys.path changes at run time
    would) says nothing about the device's compiler: its verdict must not be kept on disk and
    refuse a working device in every later process."""
    from gfgpu.backends.opencl import probe
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    shim = tmp_path / "shim"
    shim.mkdir()
    (shim / "pyopencl.py").write_text("raise ImportError('this pyopencl does not load in the child')\n")
    monkeypatch.setenv("PYTHONPATH", str(shim))
    probe.wide_vector_failure(dev)          # whatever it answers in this process
    monkeypatch.delenv("PYTHONPATH")        # a later process, whose child imports pyopencl
    assert probe.wide_vector_failure(dev) is None


def test_probe_with_an_undecodable_verdict_file_does_not_raise(opencl_cpu_device, tmp_path, monkeypatch):
    """A verdict file of bytes that are not text (a disk error, another program): the probe
    answers (probing again), it does not raise UnicodeDecodeError out of build_failure."""
    from gfgpu.backends.opencl import backend as clb
    from gfgpu.backends.opencl import probe
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    path = probe._verdict_path(dev)
    os.makedirs(os.path.dirname(path))
    with open(path, "wb") as f:
        f.write(b"\xff\xfe\x80garbage\x00")
    monkeypatch.delitem(clb._build_failures, dev.int_ptr, raising=False)
    try:
        assert probe.wide_vector_failure(dev) is None
        assert clb.build_failure(dev) is None
    finally:
        monkeypatch.delitem(clb._build_failures, dev.int_ptr, raising=False)


def test_probe_whose_verdict_path_is_a_directory_leaves_no_temporary_files(opencl_cpu_device, tmp_path, monkeypatch):
    """The verdict's path taken by a directory: the probe answers and leaves no temporary file
    behind in the cache directory (one per process otherwise)."""
    from gfgpu.backends.opencl import probe
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    path = probe._verdict_path(dev)
    os.makedirs(path)
    for _ in range(2):
        assert probe.wide_vector_failure(dev) is None
    assert sorted(os.listdir(os.path.dirname(path))) == [os.path.basename(path)]


def test_probe_empty_verdict_and_concurrent_probes(opencl_cpu_device, tmp_path, monkeypatch):
    """An empty verdict file is 'works'; four threads probing an empty cache at once all answer
    None and leave exactly one verdict."""
    from gfgpu.backends.opencl import probe
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "a"))
    path = probe._verdict_path(dev)
    os.makedirs(os.path.dirname(path))
    open(path, "w").close()
    assert probe.wide_vector_failure(dev) is None
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "b"))
    answers = _in_threads([functools.partial(probe.wide_vector_failure, dev) for _ in range(4)])
    assert answers == [None] * 4, answers
    kept = os.listdir(tmp_path / "b" / "gfgpu" / "opencl-probe")
    assert len(kept) == 1, kept
