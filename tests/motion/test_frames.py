"""Frames: ``synthesize_motion`` (progressive motion, geometric zoom) and ``interpolate_frames``
(given and estimated velocity)."""


import warnings

import numpy as np
import pytest

from gfgpu.motion import estimate_translation, interpolate_frames, synthesize_motion

from .common import centroid, float_dtype


def test_synthesize_motion_moves_progressively(backend):
    img = np.zeros((64, 600), float_dtype(backend))
    img[32, 20] = 1.0
    frames = synthesize_motion(img, (0.0, 36.0), 5, mode="constant", backend=backend.name)
    assert frames.shape == (5, 64, 600)
    np.testing.assert_array_equal(frames[0], img)
    cx = [centroid(f, 32, 20)[1] for f in frames]
    np.testing.assert_allclose(cx, [20, 29, 38, 47, 56], atol=0.05)


def test_synthesize_zoom_scales_geometrically():
    xx = np.tile(np.arange(128.0), (16, 1))
    calls = []
    frames = synthesize_motion(xx, 0.44, 3, kind="zoom", center=(8, 40), backend="numpy",
                               progress=lambda: calls.append(1))
    assert len(calls) == 3
    for f, scale in zip(frames, (1.0, 1.2, 1.44)):
        np.testing.assert_allclose(f[8, 100], 40 + 60 / scale, atol=0.1)
    with pytest.raises(ValueError, match="n_frames"):
        synthesize_motion(xx, (1, 0), 1)


def test_interpolate_frames_given_and_estimated_velocity():
    from importlib import resources

    import imageio.v3 as iio
    with resources.as_file(resources.files("gfgpu.data").joinpath("camera.png")) as path:
        big = iio.imread(path).astype(np.float64) / 255
    f0, f1 = big[130:330, 140:340], big[124:324, 131:331]   # f1 = f0 moved by (dy, dx) = (6, 9)
    dy, dx = estimate_translation(f0, f1)
    assert abs(dx - 9) < 0.1 and abs(dy - 6) < 0.1
    mids = interpolate_frames(f0, f1, 2)
    given = interpolate_frames(f0, f1, 2, velocity=(6.0, 9.0))
    assert mids.shape == (2,) + f0.shape
    assert np.abs(mids - given).max() < 0.02
    # frame k sits at k/3 of the way: (3, 2) and (6, 4) px, integer shifts cut from `big`
    inner = (slice(20, -20), slice(20, -20))
    for k, mid in enumerate(mids, start=1):
        ty, tx = 2 * k, 3 * k
        truth = big[130 - ty:330 - ty, 140 - tx:340 - tx]
        fade = (1 - k / 3) * f0 + (k / 3) * f1
        err = np.sqrt(np.mean((mid - truth)[inner] ** 2))
        assert err < 0.6 * np.sqrt(np.mean((fade - truth)[inner] ** 2))
    with pytest.raises(ValueError, match="same shape"):
        interpolate_frames(f0, f1[:-1], 1)
    with pytest.raises(ValueError, match="n must be"):
        interpolate_frames(f0, f1, 0)


def _shifted_texture(sigma, shift, dtype, size=(120, 150), big=256, seed=3):
    """Gaussian-blurred (σ px) white noise and the same texture moved by ``shift`` (dy, dx):
    a periodic band-limited texture moved exactly by its Fourier phase ramp, then cut out
    away from the period's seam, so that the true shift is known to rounding."""
    rng = np.random.default_rng(seed)
    fy = np.fft.fftfreq(big)[:, None]
    fx = np.fft.fftfreq(big)[None, :]
    spec = np.fft.fft2(rng.standard_normal((big, big))) * np.exp(-2 * np.pi ** 2 * sigma ** 2 * (fy ** 2 + fx ** 2))
    spec[big // 2, :] = spec[:, big // 2] = 0      # no Nyquist bins: the moved texture stays real
    moved = spec * np.exp(-2j * np.pi * (fy * shift[0] + fx * shift[1]))
    cut = (slice(60, 60 + size[0]), slice(50, 50 + size[1]))
    return np.fft.ifft2(spec).real[cut].astype(dtype), np.fft.ifft2(moved).real[cut].astype(dtype)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("sigma", [0, 1, 2, 3, 4])
def test_estimate_translation_smooth_textures(sigma, dtype):
    # phase correlation whitens the nearly empty high-frequency bins of a smooth texture and
    # finds a false peak near zero: σ = 3, (3, 5) gave (0.15, 0.05) without a warning
    for shift in ((3.0, 5.0), (2.35, -4.65), (-6.8, 1.45), (-0.5, -0.25)):
        f0, f1 = _shifted_texture(sigma, shift, dtype)
        with warnings.catch_warnings():
            warnings.simplefilter("error")         # a good match draws no warning
            dy, dx = estimate_translation(f0, f1)
        assert abs(dy - shift[0]) <= 0.05 and abs(dx - shift[1]) <= 0.05, (sigma, shift, (dy, dx))


@pytest.mark.parametrize("sigma", [0, 4])
def test_interpolate_frames_midpoint_on_smooth_texture(sigma):
    shift = (3.3, -5.7)
    f0, f1 = _shifted_texture(sigma, shift, np.float64)
    _, truth = _shifted_texture(sigma, (shift[0] / 2, shift[1] / 2), np.float64)
    mid = interpolate_frames(f0, f1, 1, backend="numpy")[0]
    given = interpolate_frames(f0, f1, 1, velocity=shift, backend="numpy")[0]
    inner = (slice(12, -12), slice(12, -12))
    # the estimated velocity builds the same midpoint as the true one (old: off by a pixel)
    assert np.abs(mid - given)[inner].max() <= 0.05 * np.abs(f0).max()
    err = np.sqrt(np.mean((mid - truth)[inner] ** 2) / np.mean(truth[inner] ** 2))
    fade = np.sqrt(np.mean((0.5 * (f0 + f1) - truth)[inner] ** 2) / np.mean(truth[inner] ** 2))
    assert err < 0.5 * fade


def test_estimate_translation_without_structure():
    flat = np.full((64, 64), 7.0)
    for f0, f1 in ((flat, flat), (flat, flat + np.eye(64)), (np.zeros((64, 64)), np.zeros((64, 64)))):
        with pytest.warns(RuntimeWarning, match="no structure to match"):
            assert estimate_translation(f0, f1) == (0.0, 0.0)     # old: (-0.75, -0.75), no warning
    rng = np.random.default_rng(0)
    with pytest.warns(RuntimeWarning, match="unreliable"):
        estimate_translation(rng.random((64, 64)), rng.random((64, 64)))   # unrelated frames


def test_estimate_translation_and_counts_refuse_bad_arguments():
    f = np.random.default_rng(1).random((32, 32))
    for bad in (True, 2.0, "20"):
        with pytest.raises(TypeError, match="upsample_factor"):
            estimate_translation(f, f, upsample_factor=bad)
    with pytest.raises(ValueError, match="upsample_factor"):
        estimate_translation(f, f, upsample_factor=0)
    with pytest.raises(ValueError, match="frame1 contains NaN"):
        estimate_translation(f, np.where(f > 0.5, np.nan, f))
    for bad in (True, 1.0, "1"):
        with pytest.raises(TypeError, match="n must be an integer"):
            interpolate_frames(f, f, bad, velocity=(0, 0))     # old: n=True made one frame
        with pytest.raises(TypeError, match="n_frames must be an integer"):
            synthesize_motion(f, (0, 1), bad)
