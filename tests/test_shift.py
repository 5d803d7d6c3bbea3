"""``shift`` is a translation: exact integer part at any magnitude, fractional part whose error
does not depend on the magnitude, boundary modes exact; against independent references
(index arithmetic on numpy.pad, direct summation of the closed-form taps, the Fourier shift,
scipy.ndimage.shift)."""

import numpy as np
import pytest
import scipy.ndimage as ndi

import gfgpu
from gfgpu import greens

PAD = {"reflect": "symmetric", "mirror": "reflect", "nearest": "edge", "wrap": "wrap", "constant": "constant"}
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
    kw = {"constant_values": cval} if mode == "constant" else {}
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
        kw = {"constant_values": 0.25} if mode == "constant" else {}
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
    out = gfgpu.shift(img.astype(np.float32), s, mode="wrap", backend=backend.name)
    linear = ndi.shift(img, s, order=1, mode="grid-wrap")
    if float(s[0]).is_integer() and float(s[1]).is_integer():
        assert rel(out, ref) <= 2e-5
    else:
        assert rel(out, ref) <= 0.6 * rel(linear, ref)


def test_error_does_not_grow_with_the_distance(backend):
    img = band_limited((64, 256), seed=2).astype(np.float32)
    errors = [rel(gfgpu.shift(img, (0, d + 0.25), mode="wrap", backend=backend.name), fourier_shift(img, (0, d + 0.25)))
              for d in (0, 3, 40, 200, 1000)]
    assert max(errors) - min(errors) <= 1e-5, errors


@pytest.mark.parametrize("mode", MODES)
def test_cubic_interpolation_is_scipys_order_3(backend, mode):
    img = band_limited((40, 56), seed=3)
    for s in [(0.3, -0.2), (2.5, 7.75), (-9.4, 0.5)]:
        out = gfgpu.shift(img.astype(np.float32), s, mode="wrap", interpolation="cubic", backend=backend.name)
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
    green = rel(gfgpu.shift(img, (0.5, -2.5), mode="wrap", backend="numpy"), ref)
    cubic = rel(gfgpu.shift(img, (0.5, -2.5), mode="wrap", interpolation="cubic", backend="numpy"), ref)
    assert cubic < 0.1 * green


def test_extreme_shifts():
    img = np.random.default_rng(0).random((9, 12))
    np.testing.assert_array_equal(gfgpu.shift(img, (0, 1e-320), backend="numpy"), img)
    np.testing.assert_array_equal(gfgpu.shift(img, (0, 1e30), mode="constant", cval=2.0, backend="numpy"),
                                  np.full_like(img, 2.0))
    period = gfgpu.shift(img, (0, 12 * 10**15), mode="wrap", backend="numpy")
    np.testing.assert_array_equal(period, img)
    for bad in [np.nan, np.inf, "3"]:
        with pytest.raises((ValueError, TypeError), match="shift"):
            gfgpu.shift(img, (0, bad), backend="numpy")
    with pytest.raises(ValueError, match="interpolation"):
        gfgpu.shift(img, 1.5, interpolation="lanczos", backend="numpy")


def test_translated_shift_in_strips_and_dask_equals_one_piece():
    import dask.array as da

    import gfgpu.dask as gd
    img = np.random.default_rng(4).random((200, 60)).astype(np.float32)
    for mode in MODES:
        for s in [(13.25, -4.5), (-300.0, 2.0), (0.4, 0)]:
            ref = gfgpu.shift(img, s, mode=mode, cval=0.5, backend="numpy")
            with gfgpu.working_set("20K"):
                strips = gfgpu.shift(img, s, mode=mode, cval=0.5, backend="numpy")
            lazy = gd.shift(da.from_array(img, chunks=(37, 25)), s, mode=mode, cval=0.5, backend="numpy")
            np.testing.assert_allclose(strips, ref, atol=2e-6)
            np.testing.assert_allclose(lazy.compute(scheduler="synchronous"), ref, atol=2e-6)
