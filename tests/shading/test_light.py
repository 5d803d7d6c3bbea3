"""The light estimate (estimate_illuminant, method='background'): frontal and oblique lights on
the survey's sphere and vase and on our own objects, refusals where the image does not determine
the light, and shape_from_shading(light=None) refusing what it refuses with the light given."""

import numpy as np
import pytest

from gfgpu import shading

from .surfaces import cut_sphere, ellipsoid_on_plane, light_error_deg, render, survey_sphere, survey_vase, texture

NOISE = 0.02


def _image(surface, light, noise, seed=0):
    _, p, q = surface()
    img = render(p, q, light)
    if noise:
        img = img + noise * np.random.default_rng(seed).standard_normal(img.shape)
    return img


@pytest.mark.parametrize("surface", [survey_sphere, survey_vase, ellipsoid_on_plane])
@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_frontal_light_is_estimated_frontal(surface, noise):
    # Zheng & Chellappa's moments read the frontally lit sphere about 22 deg off, with a tilt
    est, albedo = shading.estimate_illuminant(_image(surface, (0, 0, 1), noise))
    assert light_error_deg(est, (0, 0, 1)) < 3.0
    assert abs(albedo - 1.0) < 0.02


@pytest.mark.parametrize("surface, light, tol", [
    (survey_sphere, (1, 0, 1), 3), (survey_sphere, (-1, 0, 1), 3), (survey_sphere, (0, 1, 1), 3),
    (survey_sphere, (5, 5, 7), 3), (survey_sphere, (1, 1, 2), 3), (survey_vase, (1, 0, 1), 3),
    (survey_vase, (-1, 0, 1), 3),
    # the tilt's axis leans toward an elongated object's axes (docs/shading.md: 2-8 deg)
    (ellipsoid_on_plane, (1, 0, 1), 5), (ellipsoid_on_plane, (5, 5, 7), 5),
    (ellipsoid_on_plane, (0, 1, 1), 5)])
@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_oblique_light_is_estimated(surface, light, tol, noise):
    # (Zheng & Chellappa's moments: 5-7 deg on the sphere, 11-22 deg on the vase, 18-21 deg on an ellipsoid)
    est, albedo = shading.estimate_illuminant(_image(surface, light, noise))
    assert light_error_deg(est, light) < tol
    assert abs(albedo - 1.0) < 0.02


def test_exactly_frontal_answer_for_a_frontal_light():
    # a light the image cannot tell from frontal is reported as (0, 0, 1), not a guessed tilt
    est, _ = shading.estimate_illuminant(_image(survey_sphere, (0, 0, 1), NOISE))
    assert est.tolist() == [0.0, 0.0, 1.0]


def test_refuses_an_image_without_a_reference_plane():
    _, p, q = texture(96)
    with pytest.raises(ValueError, match="no flat background"):
        shading.estimate_illuminant(render(p, q, (1, 0, 1)))
    with pytest.raises(ValueError, match="no flat background"):
        shading.shape_from_shading(render(p, q, (1, 0, 1)), backend="numpy")
    # the published moments stay available, under their assumption
    est, _ = shading.estimate_illuminant(render(p, q, (1, 0, 1)), method="zheng-chellappa")
    assert est.shape == (3,)


def test_refuses_an_object_with_no_surface_facing_the_light():
    # a hemisphere centred on the left border, lit from the upper left: its normal along L lies
    # beyond the frame, and its brightest visible point is on the frame, brighter than the plane
    img = shading.lambertian_shading(cut_sphere(96), (-1, -1, 2))
    with pytest.raises(ValueError, match="no visible surface faces the light"):
        shading.estimate_illuminant(img)
    with pytest.raises(ValueError, match="no visible surface faces the light"):
        shading.shape_from_shading(img, backend="numpy")
    shading.shape_from_shading(img, light=(-1, -1, 2), backend="numpy")      # the light given: runs


def test_bad_method_is_refused():
    with pytest.raises(ValueError, match="method"):
        shading.estimate_illuminant(_image(survey_sphere, (1, 0, 1), 0.0), method="moments")


@pytest.mark.parametrize("surface", [survey_sphere, survey_vase])
@pytest.mark.parametrize("noise", [0.0, NOISE])
def test_estimated_light_refuses_what_the_explicit_light_refuses(surface, noise):
    img = _image(surface, (0, 0, 1), noise)
    with pytest.raises(ValueError, match="frontal"):
        shading.shape_from_shading(img, light=(0, 0, 1), backend="numpy")
    with pytest.raises(ValueError, match="estimated light .* is frontal"):
        shading.shape_from_shading(img, backend="numpy")


@pytest.mark.parametrize("light", [(1, 0, 1), (-1, 0, 1), (5, 5, 7)])
def test_estimated_light_runs_gsfs_like_the_true_light(backend, light):
    img = _image(survey_sphere, light, 0.0)
    given = shading.shape_from_shading(img, light=light, backend=backend.name)
    est = shading.shape_from_shading(img, backend=backend.name)
    z, _, _ = survey_sphere()
    obj = z > 0
    rel = np.abs(est - given)[obj].mean() / np.abs(given[obj]).mean()
    assert rel < 0.1


def test_mask_gives_the_object_and_its_background():
    z, p, q = survey_sphere()
    img = render(p, q, (1, 0, 1))
    est, _ = shading.estimate_illuminant(img, mask=z > 0)
    assert light_error_deg(est, (1, 0, 1)) < 3.0
    with pytest.raises(ValueError, match="background pixels"):
        shading.estimate_illuminant(img, mask=np.arange(img.size).reshape(img.shape) >= 10)
