"""Bad inputs of shape from shading and photometric motion: clear errors, raised before any work."""


import numpy as np
import pytest

from gfgpu import shading
from gfgpu.shading import lambertian_shading, shape_from_shading

from .surfaces import gauss_bump, render, sphere


def test_bad_inputs_raise_clear_errors():
    z, p, q = sphere()
    img = render(p, q, (1, 0, 1))
    with pytest.raises(ValueError, match="2-D"):
        shading.shape_from_shading(np.stack([img, img]), light=(1, 0, 1))
    with pytest.raises(ValueError, match="constant"):
        shading.shape_from_shading(np.full((32, 32), 0.5), light=(1, 0, 1))
    with pytest.raises(ValueError, match="points away"):
        shading.shape_from_shading(img, light=(1, 0, -1))
    with pytest.raises(ValueError, match="slant"):
        shading.shape_from_shading(img, light=(0.0, 2.0))
    with pytest.raises(ValueError, match="frontal"):
        shading.shape_from_shading(img, light=(0, 0, 1))
    with pytest.raises(ValueError, match="u must be > 0"):
        shading.shape_from_shading(img, light=(1, 0, 1), u=0)
    with pytest.raises(ValueError, match="k1 must be non-zero"):
        shading.shape_from_shading(img, light=(1, 0, 1), k1=0)
    with pytest.raises(ValueError, match="NaN"):
        shading.shape_from_shading(np.where(img > 0.9, np.nan, img), light=(1, 0, 1))
    with pytest.raises(ValueError, match="mask"):
        shading.shape_from_shading(img, light=(1, 0, 1), mask=np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="boundary"):
        shading.shape_from_shading(img, light=(1, 0, 1), boundary="both")
    with pytest.raises(TypeError, match="light"):
        shading.shape_from_shading(img, light="left")
    with pytest.raises(ValueError, match="pole"):
        shading.photometric_motion(img, light=(1, 0, 1), k0=float(np.median(img)))
    with pytest.raises(ValueError, match="fixed_point"):
        shading.photometric_motion(img, light=(1, 0, 1), fixed_point=5.0)
    with pytest.raises(ValueError, match="shift"):
        shading.photometric_motion(img, light=(1, 0, 1), shift=-1)


@pytest.mark.parametrize("kw, exc, match", [
    ({"u": 15.9}, ValueError, "16 pixels"), ({"u": 0}, ValueError, "u"), ({"u": "a"}, TypeError, "u"),
    ({"k1": 0}, ValueError, "k1"), ({"k1": "x"}, ValueError, "k1"), ({"boundary": None}, ValueError, "boundary"),
    ({"light": (1, 0, 0)}, ValueError, "l3"), ({"light": (1, 0, -1)}, ValueError, "l3"),
    ({"light": (0, 0, 1)}, ValueError, "frontal"), ({"light": (0.0, np.pi / 2)}, ValueError, "slant"),
    ({"light": (np.nan, 0, 1)}, ValueError, "light"), ({"light": "abc"}, TypeError, "light"),
    ({"direction": np.nan}, ValueError, "direction")])
def test_sfs_argument_errors(kw, exc, match):
    args = {"light": (1, 0, 1), "backend": "numpy"} | kw
    with pytest.raises(exc, match=match):
        shape_from_shading(lambertian_shading(gauss_bump(), (1, 0, 1)), **args)


@pytest.mark.parametrize("image, match", [
    (np.random.default_rng(0).random((2, 2)), "4 x 4"), (np.random.default_rng(0).random((1, 9)), "4 x 4"),
    (np.full((64, 64), 0.5), "constant"), (np.zeros((64, 64, 3)), "2-D")])
def test_sfs_bad_image_raises(image, match):
    with pytest.raises(ValueError, match=match):
        shape_from_shading(image, light=(1, 0, 1), backend="numpy")


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_sfs_nonfinite_image_raises(value):
    img = lambertian_shading(gauss_bump(), (1, 0, 1))
    img[10, 10] = value
    with pytest.raises(ValueError, match="image"):
        shape_from_shading(img, light=(1, 0, 1), backend="numpy")


def test_sfs_bad_backend_raises_before_work(monkeypatch):
    # "errors ... raised before work": an unknown backend is only found by green_filter, after the
    # scene analysis (flat background, border test) has run on the whole image
    from gfgpu.shading import gsfs
    calls = []
    real = gsfs.has_background
    monkeypatch.setattr(gsfs, "has_background", lambda *a, **k: calls.append(1) or real(*a, **k))
    with pytest.raises(ValueError, match="backend"):
        shape_from_shading(lambertian_shading(gauss_bump(), (1, 0, 1)), light=(1, 0, 1), backend="foo")
    assert not calls, "the image was analysed before the unknown backend was refused"
