"""Uniform motion (``motion_blur``, kind 'uniform', Green PSF): an impulse or an edge moves by the
velocity, ``displace=False`` keeps the centroid, longer is blurrier, identities, channels, dtypes."""


import numpy as np
import pytest

from gfgpu.motion import motion_blur

from .common import centroid, float_dtype


@pytest.mark.parametrize("velocity", [(0.0, 12.5), (-7.25, 0.0), (0.0, -14.3), (9.5, 9.5), (6.0, -6.0),
                                      (-3.3, 3.3)])
def test_impulse_displacement_equals_velocity(backend, velocity):
    """velocity = (vy, vx): the impulse moves vy rows down and vx columns right."""
    img = np.zeros((512, 512), float_dtype(backend))
    img[256, 256] = 1.0
    out = motion_blur(img, velocity, mode="constant", backend=backend.name)
    assert out.dtype == img.dtype
    assert abs(out.sum() - 1.0) < 1e-5
    cy, cx = centroid(out, 256, 256)
    assert abs(cy - (256 + velocity[0])) < 0.05
    assert abs(cx - (256 + velocity[1])) < 0.05


def test_edge_displacement_equals_velocity(backend):
    x = np.arange(512)
    img = np.tile((x >= 200).astype(float_dtype(backend)), (8, 1))
    out = motion_blur(img, (0.0, 17.5), mode="nearest", backend=backend.name)
    # the edge's position is the integral of its derivative's first moment
    d = np.diff(out[4].astype(np.float64))
    assert abs((d * (x[1:] - 0.5)).sum() / d.sum() - (199.5 + 17.5)) < 0.05


def test_oblique_displacement_exact_on_average():
    """Minor-axis displacement is quantised per pixel (digital lines) but exact on average."""
    v = (4.0, 10.0)   # (vy, vx)
    errs = []
    for x in range(40, 50):
        img = np.zeros((200, 256))
        img[90 + x % 3, x] = 1.0
        out = motion_blur(img, v, mode="constant", backend="numpy")
        cy, cx = centroid(out, 0, 0)
        assert abs(cx - (x + v[1])) < 0.05          # dominant axis exact
        errs.append(cy - (90 + x % 3 + v[0]))
    assert max(abs(e) for e in errs) <= 0.5 + 1e-6
    assert abs(np.mean(errs)) < 0.05


def test_displace_false_keeps_centroid(backend):
    img = np.zeros((256, 256), float_dtype(backend))
    img[128, 128] = 1.0
    for v in [(0.0, 20.0), (11.0, 0.0), (-8.0, -8.0)]:
        out = motion_blur(img, v, displace=False, mode="constant", backend=backend.name)
        cy, cx = centroid(out, 128, 128)
        assert abs(cx - 128) < 1e-3 and abs(cy - 128) < 1e-3
        # symmetric blur: the PSF is even along the motion
        line = out[128] if v[0] == 0 else (out[:, 128] if v[1] == 0 else np.diagonal(out))
        np.testing.assert_allclose(line[128 - 100:128], line[128 + 100:128:-1], atol=1e-6)


def test_blur_length_is_monotonic():
    rng = np.random.default_rng(1)
    img = rng.random((128, 256))
    for displace in (True, False):
        energy = []
        for length in (1, 2, 4, 8, 16, 32):
            out = motion_blur(img, (0.0, length), displace=displace, mode="wrap", backend="numpy")
            energy.append(float((np.diff(out, axis=1) ** 2).mean()))
        assert all(b < a for a, b in zip(energy, energy[1:])), energy


def test_zero_velocity_is_a_copy(backend):
    img = np.random.default_rng(2).random((16, 24)).astype(np.float32)
    out = motion_blur(img, (0, 0), backend=backend.name)
    assert out is not img and np.array_equal(out, img)


def test_colour_and_stack_are_per_channel():
    rng = np.random.default_rng(3)
    rgb = rng.random((40, 50, 3)).astype(np.float32)
    out = motion_blur(rgb, (2.0, 5.0), channel_axis=-1, backend="numpy")
    assert out.shape == rgb.shape
    for c in range(3):
        np.testing.assert_allclose(out[..., c], motion_blur(rgb[..., c], (2.0, 5.0), backend="numpy"),
                                   rtol=1e-6, atol=1e-6)
    stack = np.moveaxis(rgb, -1, 0).copy()
    np.testing.assert_allclose(motion_blur(stack, 0.4, kind="zoom", backend="numpy"),
                               np.moveaxis(motion_blur(rgb, 0.4, kind="zoom", channel_axis=-1,
                                                       backend="numpy"), -1, 0), atol=1e-6)


def test_integer_input_gives_float32_and_is_not_modified():
    img = (np.arange(64 * 64) % 251).reshape(64, 64).astype(np.uint8)
    before = img.copy()
    out = motion_blur(img, (1.0, 3.0), backend="numpy")
    assert out.dtype == np.float32 and np.array_equal(img, before)
