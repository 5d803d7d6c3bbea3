"""Bad inputs of ``motion_blur``: refused with a message naming the argument, before any work (a
caller's ``output=`` left untouched)."""


import numpy as np
import pytest

from gfgpu.motion import motion_blur


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(velocity=(1.0, np.nan)), ValueError, "velocity must be finite"),
    (dict(velocity=(1.0, 2.0, 3.0)), ValueError, "pair"),
    (dict(velocity=3.0), ValueError, r"pair \(vy, vx\)"),
    (dict(velocity=("a", 1)), TypeError, "velocity must be a real number"),
    (dict(velocity=(1.0, 1.0), kind="spin"), ValueError, "kind must be one of"),
    (dict(velocity=2.0, kind="zoom"), ValueError, r"u1\) must lie in \(2 - 2\*sqrt\(2\), 2\)"),
    (dict(velocity=-0.83, kind="zoom"), ValueError, r"-0.8284, 2\)"),
    (dict(velocity=(0.2, -1.0), kind="zoom"), ValueError, "real beta for zoom-out"),
    (dict(velocity=0.5, kind="zoom", center=(5, 40)), ValueError, "center"),
    (dict(velocity=0.5, kind="zoom", center=(-1, 5)), ValueError, "inside the image"),
    (dict(velocity=(1.0, 1.0), mode="edge"), ValueError, "mode must be one of"),
])
def test_bad_inputs(kwargs, exc, match):
    img = np.zeros((20, 30))
    with pytest.raises(exc, match=match):
        motion_blur(img, backend="numpy", **kwargs)


def test_bad_images():
    with pytest.raises(ValueError, match="non-finite|NaN"):
        motion_blur(np.full((8, 8), np.inf), (0.0, 1.0), backend="numpy")
    with pytest.raises(ValueError, match="at least 2"):
        motion_blur(np.zeros(8), (0.0, 1.0), backend="numpy")
    with pytest.raises(TypeError):
        motion_blur(np.zeros((8, 8), complex), (0.0, 1.0), backend="numpy")


def test_nonfinite_field_raises_before_writing_output(backend):
    img = np.random.default_rng(0).random((8, 9))
    for bad in (np.nan, np.inf, 5000.0):
        field = np.zeros((2, 8, 9))
        field[1, 3, 4] = bad
        out = np.full((8, 9), 7.0)
        with pytest.raises(ValueError, match="velocity field"):
            motion_blur(img, field, output=out, backend=backend.name)
        assert (out == 7.0).all()


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(velocity=(1.0, 1.0), psf="gauss"), ValueError, "psf must be one of"),
    (dict(velocity=np.zeros((2, 20, 31))), ValueError, r"shape \(2, H, W\) = \(2, 20, 30\)"),
    (dict(velocity=np.zeros((3, 20, 30))), ValueError, r"\(2, H, W\)"),
    (dict(velocity=np.full((2, 20, 30), np.nan)), ValueError, "field must be finite"),
    (dict(velocity=np.full((2, 20, 30), 5000.0)), ValueError, "within ±4096"),
    (dict(velocity=np.zeros((2, 20, 30), bool)), TypeError, "real float or integer"),
    (dict(velocity=np.zeros((2, 20, 30), complex)), TypeError, "real float or integer"),
    (dict(velocity=np.zeros((2, 20, 30)), kind="zoom"), ValueError, "goes with kind='uniform'"),
    (dict(velocity=400.0, kind="rotation"), ValueError, r"\[-360, 360\]"),
    (dict(velocity=10.0, kind="rotation", center=(500.0, 20.0)), ValueError, "within"),
    (dict(velocity=0.2, kind="zoom", psf="box", center=(-1.0, 5.0)), ValueError, "inside the image"),
    (dict(velocity=(1.0, 1.0), psf="box", displace="yes"), TypeError, "displace"),
])
def test_bad_inputs_are_refused_before_work(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        motion_blur(np.zeros((20, 30)), backend="numpy", **kwargs)
