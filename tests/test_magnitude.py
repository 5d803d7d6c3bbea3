"""Images near the limits of their dtype (issue 31): a float32 image of values up to 1e38 (or as
small as 1e-30) gives the float64 specification's result, scaled, on every backend and entry
point; no intermediate sum overflows a range the output can hold (gfgpu._core.magnitude)."""

import numpy as np
import pytest

import gfgpu
from gfgpu._core.magnitude import host_in_range, host_peak, range_limit, scale_exponent
from gfgpu.greens import UniformGreen

SCALES = [1e38, -1e38, 1e-30]


def _image(rng, shape=(24, 40)):
    """All positive: sums accumulate (a signed random image cancels and hides an overflow)."""
    img = rng.uniform(0.2, 1.0, shape)
    img[5:11, 7:19] += 1.5
    return img / np.abs(img).max()


OPERATORS = {
    "shift": lambda x, b: gfgpu.shift(x, (1.5, -2.25), backend=b),
    "shift-integer": lambda x, b: gfgpu.shift(x, (0, 3), backend=b),
    "shift-cubic": lambda x, b: gfgpu.shift(x, (0.5, 1.25), interpolation="cubic", backend=b),
    "shift-wrap": lambda x, b: gfgpu.shift(x, (1.5, -2.25), mode="wrap", backend=b),
    "shift-constant": lambda x, b: gfgpu.shift(x, (1.5, -2.25), mode="constant", backend=b),
    "green-axis0": lambda x, b: gfgpu.green_filter(x, UniformGreen(3), axis=0, backend=b),
    "green-axis1": lambda x, b: gfgpu.green_filter(x, UniformGreen(40), axis=1, backend=b),
    "green-oblique": lambda x, b: gfgpu.green_filter(x, UniformGreen(3), angle=0.5, backend=b),
    "derivative": lambda x, b: gfgpu.derivative(x, 2.0, axis=1, backend=b),
    "gradient": lambda x, b: np.stack(gfgpu.gradient(x, 2.0, backend=b)),
    "projection": lambda x, b: gfgpu.projection(x, 2.0, axis=0, backend=b),
    "motion-uniform": lambda x, b: gfgpu.motion_blur(x, (3, 5), backend=b),
    "motion-uniform-box": lambda x, b: gfgpu.motion_blur(x, (3, 5), psf="box", backend=b),
    "motion-oblique-box": lambda x, b: gfgpu.motion_blur(x, (3, 7), psf="box", displace=False, backend=b),
    "motion-zoom": lambda x, b: gfgpu.motion_blur(x, 0.2, kind="zoom", backend=b),
    "motion-zoom-box": lambda x, b: gfgpu.motion_blur(x, 0.2, kind="zoom", psf="box", backend=b),
    "motion-rotation": lambda x, b: gfgpu.motion_blur(x, 10.0, kind="rotation", backend=b),
    "motion-field": lambda x, b: gfgpu.motion_blur(x, np.full((2,) + x.shape, 2.0), backend=b),
    "interpolate-frames": lambda x, b: gfgpu.interpolate_frames(x, np.roll(x, 2, axis=1), 1, velocity=(0, 2),
                                                                backend=b)[0],
}


def _check(got, ref, s, dtype=np.float32):
    got = np.asarray(got, np.float64)
    assert np.isfinite(got).all(), "inf or NaN where the float64 specification is finite"
    # float32 rounding of the passes (a few ulps of the image's peak per pass)
    tol = 2e-5 * np.abs(ref).max() if dtype == np.float32 else 1e-9 * np.abs(ref).max()
    np.testing.assert_allclose(got / s, ref, rtol=0, atol=tol)


class _References(dict):
    """The numpy backend's float64 result of each operator on the unit image, on first use."""

    def __missing__(self, name):
        value = self[name] = np.asarray(OPERATORS[name](IMAGE, "numpy"), np.float64)
        return value


IMAGE = _image(np.random.default_rng(31))
_REFS = _References()


@pytest.fixture
def references():
    return IMAGE, _REFS


@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.parametrize("name", list(OPERATORS))
def test_every_operator_near_the_limits_of_float32(backend, references, name, scale):
    img, refs = references
    x = (img * scale).astype(np.float32)
    _check(OPERATORS[name](x, backend), refs[name], scale)


@pytest.mark.parametrize("name", ["shift", "green-oblique", "derivative", "motion-uniform", "motion-rotation"])
def test_float64_near_its_limit(backend, references, name):
    if not backend.supports_float64:
        pytest.skip("no float64 on this device")
    img, refs = references
    _check(OPERATORS[name](img * 1e307, backend), refs[name], 1e307, np.float64)


@pytest.mark.parametrize("name", ["shift", "green-axis0", "derivative", "gradient"])
def test_gpu_launch_shapes_near_the_limit(gpu_shaped, references, name):
    """The device checks (grid-stride, block-parallel lines, the translate kernel) see the range."""
    img, refs = references
    _check(OPERATORS[name]((img * 1e38).astype(np.float32), gpu_shaped), refs[name], 1e38)


def test_device_arrays_and_output_near_the_limit(backend, references):
    img, refs = references
    x = (img * 1e38).astype(np.float32)
    dev = backend.asarray(x)
    got = gfgpu.derivative(dev, 2.0, axis=1, backend=backend)
    _check(backend.to_host(got), refs["derivative"], 1e38)
    out = np.full(x.shape, 7.0, np.float32)
    assert gfgpu.shift(x, (1.5, -2.25), output=out, backend=backend) is out
    _check(out, refs["shift"], 1e38)
    got = gfgpu.motion_blur(dev, 10.0, kind="rotation", backend=backend)
    _check(backend.to_host(got), refs["motion-rotation"], 1e38)


@pytest.mark.parametrize("mode", ["constant", "grid-constant"])
def test_a_constant_beside_the_image_is_scaled_with_it(backend, mode, rng):
    img = _image(rng)
    for call in (lambda x, c, b: gfgpu.shift(x, (1.5, -2.25), mode=mode, cval=c, backend=b),
                 lambda x, c, b: gfgpu.green_filter(x, UniformGreen(3), angle=0.5, mode=mode, cval=c, backend=b),
                 lambda x, c, b: gfgpu.motion_blur(x, (3, 5), mode=mode, cval=c, backend=b),
                 lambda x, c, b: gfgpu.motion_blur(x, 10.0, kind="rotation", mode=mode, cval=c, backend=b)):
        ref = np.asarray(call(img, 0.75, "numpy"), np.float64)
        _check(call((img * 1e38).astype(np.float32), 0.75e38, backend), ref, 1e38)
        # an image in range and a constant beyond it
        _check(call((img * 1e30).astype(np.float32), 0.75e30, backend), ref, 1e30)


def test_strips_near_the_limit(backend, references):
    img, refs = references
    x = (img * 1e38).astype(np.float32)
    with gfgpu.working_set(x.nbytes // 3):
        _check(gfgpu.derivative(x, 2.0, axis=1, backend=backend), refs["derivative"], 1e38)
        _check(gfgpu.green_filter(x, UniformGreen(3), axis=0, backend=backend), refs["green-axis0"], 1e38)


def test_dask_near_the_limit(backend, references):
    """Tasks whose lines lie in their block (scaled by their own peak) and carried steps."""
    da = pytest.importorskip("dask.array")
    import gfgpu.dask as gd
    img, refs = references
    x = da.from_array((img * 1e38).astype(np.float32), chunks=(12, 20))
    b = backend.name
    for name, call in (("green-axis0", lambda: gd.green_filter(x, UniformGreen(3), axis=0, backend=b)),
                       ("shift", lambda: gd.shift(x, (1.5, -2.25), backend=b)),
                       ("green-oblique", lambda: gd.green_filter(x, UniformGreen(3), angle=0.5, backend=b)),
                       ("motion-uniform", lambda: gd.motion_blur(x, (3, 5), backend=b))):
        _check(call().compute(scheduler="synchronous"), refs[name], 1e38)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nonfinite_is_still_refused_beside_huge_values(backend, bad):
    x = np.full((16, 20), 3e38, np.float32)
    x[3, 4] = bad
    out = np.full(x.shape, 7.0, np.float32)
    for call in (lambda: gfgpu.shift(x, (1.5, 0), backend=backend),
                 lambda: gfgpu.derivative(x, 2.0, axis=1, output=out, backend=backend),
                 lambda: gfgpu.motion_blur(x, 10.0, kind="rotation", backend=backend)):
        with pytest.raises(ValueError, match="NaN or infinite"):
            call()
    assert (out == 7.0).all()


def test_range_limit_and_scale():
    assert range_limit(np.float32) == 2.0 ** 64 and range_limit(np.float64) == 2.0 ** 512
    assert scale_exponent(1e19, np.float32) == 0
    e = scale_exponent(3e38, np.float32)
    assert 0.5 <= np.ldexp(3e38, e) < 1
    x = np.array([1.0, -5e30, 2.0], np.float32)
    assert host_peak(x) == pytest.approx(5e30) and not host_in_range(x)
    assert np.isnan(host_peak(np.array([1.0, np.nan]))) and host_peak(np.array([-np.inf, 1])) == np.inf
    assert host_in_range(np.array([1e19, -1e19], np.float32)) and host_in_range(np.arange(3))
