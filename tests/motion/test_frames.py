"""Frames: ``synthesize_motion`` (progressive motion, geometric zoom) and ``interpolate_frames``
(given and estimated velocity)."""


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
