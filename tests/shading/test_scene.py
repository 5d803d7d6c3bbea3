"""Scene analysis: a flat background or a texture filling the frame, the noise level, and the light
estimate (with and without the background)."""

import math

import numpy as np
import pytest

from gfgpu import shading

from .surfaces import SIZE, gaussians, grid, render, sphere, texture


def test_background_and_texture_scenes_are_told_apart():
    for light in ((1, 0, 1), (5, 5, 7)):
        for surface, expected in ((sphere, True), (gaussians, True), (texture, False)):
            z, p, q = surface()
            assert shading.has_background(render(p, q, light)) is expected
    z, p, q = sphere()
    flat = shading.flat_background(render(p, q, (1, 0, 1)))
    y, x = grid()
    outside = x * x + y * y > (0.35 * SIZE + 10) ** 2      # beyond the smoothing and erosion
    assert flat[outside].mean() > 0.9 and not flat[x * x + y * y < (0.3 * SIZE) ** 2].any()
    _, p, q = texture()
    assert not shading.flat_background(render(p, q, (1, 0, 1))).any()


def test_noise_sigma_estimates_white_noise():
    rng = np.random.default_rng(0)
    z, p, q = texture(128)
    img = render(p, q, (1, 0, 1))
    assert shading.noise_sigma(img) < 0.002          # smooth shading barely registers
    assert abs(shading.noise_sigma(img + 0.02 * rng.standard_normal(img.shape)) - 0.02) < 0.003


# --------------------------------------------------------------------------------------
# light estimate
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("tilt_deg", [0, 45, 120, -90])
def test_illuminant_tilt_of_a_sphere(tilt_deg):
    y, x = grid(96)
    z = np.sqrt(np.clip(60.0**2 - x * x - y * y, 0, None))
    light = (math.radians(tilt_deg), math.radians(40))
    # the sphere nearly fills the frame (no flat background to fix the slant): the published moments
    est, albedo = shading.estimate_illuminant(shading.lambertian_shading(z, light), method="zheng-chellappa")
    tilt = math.degrees(math.atan2(est[1], est[0]))
    assert abs((tilt - tilt_deg + 180) % 360 - 180) < 5
    assert 0.5 < albedo < 1.5


def test_illuminant_ignores_a_flat_background():
    z, p, q = sphere(96)
    light = shading.parse_light((1, 0, 1))
    img = render(p, q, light)
    angle = {}
    for exclude in (False, True):
        est, _ = shading.estimate_illuminant(img, method="zheng-chellappa", exclude_background=exclude)
        angle[exclude] = math.degrees(math.acos(min(1.0, float(est @ light))))
    est, _ = shading.estimate_illuminant(img)       # the plane's level over the object's peak
    angle["background"] = math.degrees(math.acos(min(1.0, float(est @ light))))
    assert angle[False] > 15 and angle[True] < 8 and angle["background"] < 3
