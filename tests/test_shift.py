"""``shift`` is a translation: exact integer part at any magnitude, fractional part whose error
does not depend on the magnitude, boundary modes exact; against independent references
(index arithmetic on numpy.pad, direct summation of the closed-form taps, the Fourier shift,
scipy.ndimage.shift); and host arrays in and out of it (views, byte orders, misaligned and
aliased outputs, threads), a non-finite input leaving ``output=`` untouched."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import scipy.ndimage as ndi

import gfgpu
from gfgpu import greens

#: the modes that are an extension of the input (scipy's filter meaning; for ``shift`` the
#: interpolation-only ``constant`` and ``wrap`` are tested in test_scipy_modes.py), as numpy.pad
PAD = {"reflect": "symmetric", "grid-mirror": "symmetric", "mirror": "reflect", "nearest": "edge",
       "grid-wrap": "wrap", "grid-constant": "constant"}
MODES = tuple(PAD)


def _dtype(be, dtype):
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("no float64 on this device")
    return dtype


def band_limited(shape, seed=0, width=0.12):
    rng = np.random.default_rng(seed)
    ky = np.fft.fftfreq(shape[0])[:, None]
    kx = np.fft.rfftfreq(shape[1])[None, :]
    spec = rng.normal(size=ky.shape[:1] + kx.shape[1:]) + 1j * rng.normal(size=ky.shape[:1] + kx.shape[1:])
    img = np.fft.irfft2(spec * np.exp(-(ky**2 + kx**2) / width**2), shape)
    return img / img.std()


def fourier_shift(img, s):
    ky = np.fft.fftfreq(img.shape[0])[:, None]
    kx = np.fft.rfftfreq(img.shape[1])[None, :]
    return np.fft.irfft2(np.fft.rfft2(img) * np.exp(-2j * np.pi * (ky * s[0] + kx * s[1])), img.shape)


def rel(out, ref):
    return float(np.linalg.norm(out - ref) / np.linalg.norm(ref))


def extended(line, pad, mode, cval):
    """The boundary mode's extension of ``line`` (numpy.pad, independent of gfgpu)."""
    kw = {"constant_values": cval} if mode == "grid-constant" else {}
    return np.pad(line, pad, mode=PAD[mode], **kw)


def direct_translation(line, s, mode, cval):
    """y[x] = Σ_m w[m] E[x - n - m] with the closed-form taps of the discrete Green shift."""
    n, f = greens.translation_split(s)
    if f == 0:
        w = {0: 1.0}
    else:
        lam, kap, tap = greens.shift_coefficients(abs(f))
        m = np.arange(1, 80)
        taps = np.real(kap * lam ** (m - 1))
        w = {0: tap, **{int(k) * (1 if f > 0 else -1): float(t) for k, t in zip(m, taps)}}
    size = len(line)
    reach = abs(n) + 100
    ext = extended(line, reach, mode, cval)
    x = np.arange(size)
    return sum(t * ext[reach + x - n - k] for k, t in w.items())


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_integer_shifts_are_exact_at_any_magnitude(backend, mode, dtype, rng):
    dtype = _dtype(backend, dtype)
    img = rng.random((23, 31)).astype(dtype)
    for s in [(0, 3), (-5, 0), (7, -11), (0, 40), (-100, 63), (24, -1)]:
        out = gfgpu.shift(img, s, mode=mode, cval=0.25, backend=backend.name)
        reach = max(abs(s[0]), abs(s[1])) + 2
        kw = {"constant_values": 0.25} if mode == "grid-constant" else {}
        ext = np.pad(img, reach, mode=PAD[mode], **kw)
        ref = ext[reach - s[0]:reach - s[0] + 23, reach - s[1]:reach - s[1] + 31]
        assert out.dtype == dtype
        np.testing.assert_array_equal(out, ref.astype(dtype))


@pytest.mark.parametrize("mode", MODES)
def test_fractional_part_at_the_borders_equals_direct_summation(backend, mode, rng):
    dtype = _dtype(backend, np.float64) if backend.supports_float64 else np.float32
    line = rng.random(37)
    for s in [0.3, -0.45, 5.25, -12.5, 60.2, -0.5, 0.5, 1.5]:
        ref = direct_translation(line, s, mode, 0.5)
        out = gfgpu.shift(line.astype(dtype), s, mode=mode, cval=0.5, backend=backend.name)
        tol = 1e-12 if dtype == np.float64 else 2e-6
        assert np.abs(out - ref).max() <= tol, (s, np.abs(out - ref).max())


@pytest.mark.parametrize("s", [(0, 10), (0, -7), (3.25, -7.5), (0, 12.5), (-20.75, 0.4)])
def test_fractional_error_beats_linear_interpolation(backend, s):
    img = band_limited((96, 128))
    ref = fourier_shift(img, s)
    out = gfgpu.shift(img.astype(np.float32), s, mode="grid-wrap", backend=backend.name)
    linear = ndi.shift(img, s, order=1, mode="grid-wrap")
    if float(s[0]).is_integer() and float(s[1]).is_integer():
        assert rel(out, ref) <= 2e-5
    else:
        assert rel(out, ref) <= 0.6 * rel(linear, ref)


def test_error_does_not_grow_with_the_distance(backend):
    img = band_limited((64, 256), seed=2).astype(np.float32)
    errors = [rel(gfgpu.shift(img, (0, d + 0.25), mode="grid-wrap", backend=backend.name),
                  fourier_shift(img, (0, d + 0.25))) for d in (0, 3, 40, 200, 1000)]
    assert max(errors) - min(errors) <= 1e-5, errors


@pytest.mark.parametrize("mode", MODES)
def test_cubic_interpolation_is_scipys_order_3(backend, mode):
    img = band_limited((40, 56), seed=3)
    for s in [(0.3, -0.2), (2.5, 7.75), (-9.4, 0.5)]:
        out = gfgpu.shift(img.astype(np.float32), s, mode="grid-wrap", interpolation="cubic", backend=backend.name)
        ref = ndi.shift(img, s, order=3, mode="grid-wrap")
        assert np.abs(out - ref).max() <= 1e-5
    # every mode: the same spline on the extension (interior only; scipy extends differently)
    out = gfgpu.shift(img, (1.25, -0.75), mode=mode, interpolation="cubic", backend="numpy")
    ref = ndi.shift(img, (1.25, -0.75), order=3, mode="grid-wrap")
    inner = (slice(12, -12), slice(12, -12))
    ref_mode = ndi.shift(np.pad(img, 30, mode=PAD[mode]), (1.25, -0.75), order=3, mode="grid-wrap")[30:-30, 30:-30]
    assert np.abs(out[inner] - ref_mode[inner]).max() <= 1e-9
    assert ref.shape == out.shape


def test_cubic_is_more_accurate_than_green():
    img = band_limited((96, 128))
    ref = fourier_shift(img, (0.5, -2.5))
    green = rel(gfgpu.shift(img, (0.5, -2.5), mode="grid-wrap", backend="numpy"), ref)
    cubic = rel(gfgpu.shift(img, (0.5, -2.5), mode="grid-wrap", interpolation="cubic", backend="numpy"), ref)
    assert cubic < 0.1 * green


def test_extreme_shifts():
    img = np.random.default_rng(0).random((9, 12))
    np.testing.assert_array_equal(gfgpu.shift(img, (0, 1e-320), backend="numpy"), img)
    for mode in ("constant", "grid-constant"):
        np.testing.assert_array_equal(gfgpu.shift(img, (0, 1e30), mode=mode, cval=2.0, backend="numpy"),
                                      np.full_like(img, 2.0))
    period = gfgpu.shift(img, (0, 12 * 10**15), mode="grid-wrap", backend="numpy")
    np.testing.assert_array_equal(period, img)
    # scipy's wrap: period n - 1 = 11; a source on a multiple of 11 from the left reads sample 11
    folds = gfgpu.shift(img, (0, 11 * 10**14), mode="wrap", backend="numpy")
    np.testing.assert_array_equal(folds, _exact_shift(img, (0, 11 * 10**14), "wrap"))
    np.testing.assert_array_equal(folds[:, 1:], img[:, 1:])
    np.testing.assert_array_equal(folds[:, 0], img[:, 11])
    for bad in [np.nan, np.inf, "3"]:
        with pytest.raises((ValueError, TypeError), match="shift"):
            gfgpu.shift(img, (0, bad), backend="numpy")
    with pytest.raises(ValueError, match="interpolation"):
        gfgpu.shift(img, 1.5, interpolation="lanczos", backend="numpy")


def test_translated_shift_in_strips_and_dask_equals_one_piece():
    import dask.array as da

    import gfgpu.dask as gd
    img = np.random.default_rng(4).random((200, 60)).astype(np.float32)
    for mode in MODES + ("constant", "wrap"):
        for s in [(13.25, -4.5), (-300.0, 2.0), (0.4, 0)]:
            ref = gfgpu.shift(img, s, mode=mode, cval=0.5, backend="numpy")
            with gfgpu.working_set("20K"):
                strips = gfgpu.shift(img, s, mode=mode, cval=0.5, backend="numpy")
            lazy = gd.shift(da.from_array(img, chunks=(37, 25)), s, mode=mode, cval=0.5, backend="numpy")
            np.testing.assert_allclose(strips, ref, atol=2e-6)
            np.testing.assert_allclose(lazy.compute(scheduler="synchronous"), ref, atol=2e-6)


# --------------------------------------------------------------------------------------
# host arrays in and out: integer shifts against exact index arithmetic, views, outputs,
# aliasing, threads; a non-finite input leaves output= untouched
# --------------------------------------------------------------------------------------
#: every mode name, in the order the thread test deals them out
HOST_MODES = ("constant", "nearest", "reflect", "mirror", "wrap", "grid-constant", "grid-wrap", "grid-mirror")


# ---- exact integer translation by index arithmetic (the reference) ---------------------------
def _source_index(n, k, mode):
    """Integer shifts by ``k``: the sample each output reads, -1 for cval (scipy's meanings: for
    integer sources ``constant`` is ``grid-constant``; ``wrap`` folds with period n - 1)."""
    idx = np.arange(n) - k
    if mode in ("constant", "grid-constant"):
        return np.where((idx >= 0) & (idx < n), idx, -1)
    if mode == "nearest":
        return np.clip(idx, 0, n - 1)
    if mode == "grid-wrap":
        return idx % n
    if mode == "wrap":                    # scipy's map_coordinate: truncating division by n - 1
        if n == 1:
            return np.zeros_like(idx)
        return np.where(idx < 0, idx + (n - 1) * ((-idx) // (n - 1) + 1),
                        np.where(idx > n - 1, idx - (n - 1) * (idx // (n - 1)), idx))
    if mode in ("reflect", "grid-mirror"):   # half-sample symmetric, period 2n
        p = idx % (2 * n)
        return np.where(p < n, p, 2 * n - 1 - p)
    if n == 1:                            # mirror: whole-sample symmetric, period 2n - 2
        return np.zeros_like(idx)
    p = idx % (2 * n - 2)
    return np.where(p < n, p, 2 * n - 2 - p)


def _exact_shift(a, shifts, mode):
    out = np.asarray(a)
    for ax, k in enumerate(shifts):
        idx = _source_index(out.shape[ax], k, mode)
        out = np.take(out, np.maximum(idx, 0), axis=ax)
        if mode in ("constant", "grid-constant"):
            sl = [slice(None)] * out.ndim
            sl[ax] = idx < 0
            out[tuple(sl)] = 0
    return out


# ---- a non-finite host input must leave output= untouched ------------------------------------
@pytest.mark.parametrize("shape, shift", [((48, 400), (1, -2)), ((48, 400), (0, 3)), ((8, 48, 48), (1, 1, 1)),
                                          ((3, 40, 200), (0.5, 1, 3))],
                         ids=["2d-two-steps", "2d-one-step", "3d-three-steps", "3d-frac-first"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", ["constant", "grid-constant"])
def test_shift_nonfinite_input_leaves_output_untouched(backend, shape, shift, dtype, mode):
    # arrays of >= 64 KiB so that OpenCL (CPU) writes the caller's output in place
    for value in (np.nan, np.inf, -np.inf):
        for pos in (0, -1, int(np.prod(shape)) // 2 + 7):
            a = np.ones(shape, dtype)
            a.reshape(-1)[pos] = value
            out = np.full(shape, 7, dtype)
            with pytest.raises(ValueError, match="input"):
                gfgpu.shift(a, shift, output=out, mode=mode, backend=backend.name)
            assert (out == 7).all(), f"output written before the non-finite error ({value}, element {pos})"


# ---- integer shifts against exact index arithmetic ----------------------------------------
def test_shift_integer_exact_every_mode(backend):
    rng = np.random.default_rng(0)
    for shape in [(1, 1), (1, 7), (6, 1), (5, 6), (3, 2100)]:
        a = rng.standard_normal(shape).astype(np.float32)
        h, w = shape
        for mode in HOST_MODES:
            for dy, dx in [(0, 1), (1, -1), (h - 1, -(w - 1)), (-h, w), (10**6, -10**6), (-(10**6) - 3, 2 * w - 1),
                           (0, w // 2 + 5)]:
                got = gfgpu.shift(a, (dy, dx), mode=mode, backend=backend.name)
                np.testing.assert_array_equal(got, _exact_shift(a, (dy, dx), mode),
                                              err_msg=f"{shape} {mode} {(dy, dx)}")


def _views(base):
    yield "strided", base[::2, 1::3]
    yield "negative-stride", base[::-1, ::-1]
    yield "big-endian", base.astype(">f4")
    ro = base.copy()
    ro.setflags(write=False)
    yield "read-only", ro
    yield "misaligned-4", np.frombuffer(b"\0" * 4 + base.tobytes(), np.float32, offset=4).reshape(base.shape)
    yield "misaligned-2", np.frombuffer(bytearray(b"\0" * 2 + base.tobytes()), np.float32, offset=2).reshape(base.shape)
    yield "offset-view", base[37:, 5:]
    yield "uint16", (np.abs(base) * 1000).astype(np.uint16)


@pytest.mark.parametrize("mode", ["wrap", "grid-wrap"])
def test_shift_host_views(backend, mode):
    base = np.random.default_rng(1).standard_normal((150, 160)).astype(np.float32)
    for name, a in _views(base):
        want = _exact_shift(np.asarray(a, np.float32), (3, -7), mode)
        got = gfgpu.shift(a, (3, -7), mode=mode, backend=backend.name)
        np.testing.assert_array_equal(got, want, err_msg=name)


@pytest.mark.parametrize("mode", ["wrap", "grid-wrap"])
def test_shift_outputs_and_aliasing(backend, mode):
    a = np.random.default_rng(2).standard_normal((150, 160)).astype(np.float32)
    want = _exact_shift(a, (3, -7), mode)
    outs = {"f64": np.zeros(a.shape), "big-endian": np.zeros(a.shape, ">f4"),
            "strided": np.zeros((150, 320), np.float32)[:, ::2], "negative-stride": np.zeros(a.shape, np.float32)[::-1],
            "misaligned": np.frombuffer(bytearray(a.nbytes + 8), np.float32, a.size, offset=2).reshape(a.shape),
            "offset-64": np.frombuffer(bytearray(a.nbytes + 128), np.float32, a.size, offset=64).reshape(a.shape)}
    for name, out in outs.items():
        r = gfgpu.shift(a, (3, -7), mode=mode, backend=backend.name, output=out)
        assert r is out, name
        np.testing.assert_array_equal(np.asarray(out, np.float32), want, err_msg=name)
    x = a.copy()
    gfgpu.shift(x, (3, -7), mode=mode, backend=backend.name, output=x)
    np.testing.assert_array_equal(x, want)
    buf = np.zeros((151, 160), np.float32)
    buf[:-1] = a
    gfgpu.shift(buf[:-1], (3, -7), mode=mode, backend=backend.name, output=buf[1:])
    np.testing.assert_array_equal(buf[1:], want)


def test_shift_channel_axis(backend):
    a = np.random.default_rng(5).standard_normal((40, 50, 3)).astype(np.float32)
    for mode in HOST_MODES:
        got = gfgpu.shift(a, (4, -9), channel_axis=-1, mode=mode, backend=backend.name)
        np.testing.assert_array_equal(got, _exact_shift(a, (4, -9, 0), mode), err_msg=mode)


def test_shift_threads_match_serial(backend):
    rng = np.random.default_rng(7)
    imgs = [rng.standard_normal((120 + i, 200 - i)).astype(np.float32) for i in range(8)]
    calls = [(im, (i - 3 + 0.25 * (i % 2), 2 * i - 7), HOST_MODES[i % len(HOST_MODES)]) for i, im in enumerate(imgs)]
    serial = [gfgpu.shift(im, s, mode=m, backend=backend.name) for im, s, m in calls]
    with ThreadPoolExecutor(4) as ex:
        futs = [ex.submit(gfgpu.shift, im, s, mode=m, backend=backend.name) for im, s, m in calls * 3]
        res = [f.result() for f in futs]
    for i, r in enumerate(res):
        np.testing.assert_array_equal(r, serial[i % 8])
