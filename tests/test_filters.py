"""Every backend against float64 direct summation of the closed-form kernels."""
import numpy as np
import pytest
from oracle import TapKernel, direct_axis, relerr

import gfgpu
from gfgpu import greens
from gfgpu._core.recursion import MODES

TOL = {np.float32: 1e-5, np.float64: 1e-12}
# axis-aligned angles here; oblique ones against a direct summation of the sheared operator in
# tests/_core/test_oblique.py
ANGLES = {"0deg": 0.0, "90deg": np.pi / 2, "180deg": np.pi, "270deg": 3 * np.pi / 2}
SHAPE = (13, 17)


def _steps_and_reverse(angle, shape):
    c, s = np.cos(angle), np.sin(angle)
    steep = abs(s) > abs(c) + 1e-12
    n = shape[0] if steep else shape[1]
    return n, (s < 0) if steep else (c < 0)


def _kernel(name, n, reverse):
    """A kernel valid on lines of n samples traversed in the given sense."""
    far = -3.5 if not reverse else n - 1 + 3.5
    return {
        "G_u": greens.UniformGreen(2.3),
        "H_u": greens.HomogeneousGreen(1.7),
        "G_U1": greens.AffineGreen(0.6, far),
        "G_U2": greens.AffineGreenApprox(6.0, -40.0 if not reverse else n - 1 + 40.0),
    }[name]


def _image(rng, dtype, shape=SHAPE):
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    img = 1.0 + 0.3 * np.sin(xx / 3.0) + 0.2 * (yy > shape[0] // 2) + 0.1 * rng.standard_normal(shape)
    return img.astype(dtype)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("direction", list(ANGLES))
@pytest.mark.parametrize("kname", ["G_u", "H_u", "G_U1", "G_U2"])
@pytest.mark.parametrize("anticausal", [False, True])
def test_green_filter_matches_direct_sum(backend, rng, kname, direction, mode, dtype, anticausal):
    angle = ANGLES[direction]
    img = _image(rng, dtype)
    n, rev = _steps_and_reverse(angle, SHAPE)
    kernel = _kernel(kname, n, rev != anticausal)
    if direction == "0deg":
        out = gfgpu.green_filter(img, kernel, axis=1, mode=mode, cval=0.5, anticausal=anticausal,
                                 backend=backend)
        ref = direct_axis(img, kernel, 1, mode, 0.5, anticausal)
    else:
        out = gfgpu.green_filter(img, kernel, angle=angle, mode=mode, cval=0.5, anticausal=anticausal,
                                 backend=backend)
        # an axis-aligned angle is the axis pass, traversed in the angle's sense
        steep = abs(np.sin(angle)) > abs(np.cos(angle))
        ref = direct_axis(img, kernel, 0 if steep else 1, mode, 0.5, anticausal != rev)
    assert out.dtype == dtype and out.shape == img.shape
    err = relerr(out, ref)
    assert err <= TOL[dtype], f"relative error {err:.2e}, max abs {np.abs(out - ref).max():.2e}"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape,axis", [((5, 6, 40), 2), ((5, 40, 6), 1), ((40, 3, 4), 0), ((64,), 0)])
def test_axes_of_nd_arrays(backend, rng, shape, axis, dtype):
    img = (1 + rng.standard_normal(shape)).astype(dtype)
    k = greens.UniformGreen(4.0)
    out = gfgpu.green_filter(img, k, axis=axis, mode="mirror", backend=backend)
    assert relerr(out, direct_axis(img, k, axis, "mirror")) <= TOL[dtype]


@pytest.mark.parametrize("u", [0.4, 1.0, 3.0, 12.0])
def test_impulse_response_is_the_closed_form(backend, u):
    n = int(60 * u) + 40
    x0 = 7
    line = np.zeros((1, n))
    line[0, x0] = 1.0
    x = np.arange(n)
    for kernel, closed in ((greens.UniformGreen(u), greens.g_uniform(x - x0, u)),
                           (greens.HomogeneousGreen(u), greens.h_homogeneous(x - x0, u))):
        out = gfgpu.green_filter(line, kernel, mode="constant", backend=backend)[0]
        np.testing.assert_allclose(out, closed, rtol=0, atol=1e-13)
        anti = gfgpu.green_filter(line[:, ::-1], kernel, mode="constant", anticausal=True,
                                  backend=backend)[0]
        np.testing.assert_allclose(anti[::-1], closed, rtol=0, atol=1e-13)
    aff = greens.AffineGreen(0.5, -2.5)
    out = gfgpu.green_filter(line, aff, mode="constant", backend=backend)[0]
    np.testing.assert_allclose(out, greens.g_affine(x, x0, 0.5, -2.5), rtol=0, atol=1e-13)


def test_g_u_causality_and_linearity(backend, rng):
    a, b = rng.standard_normal((2, 3, 50))
    k = greens.UniformGreen(2.0)
    fa = gfgpu.green_filter(a, k, mode="constant", backend=backend)
    fb = gfgpu.green_filter(b, k, mode="constant", backend=backend)
    fab = gfgpu.green_filter(2 * a - 3 * b, k, mode="constant", backend=backend)
    np.testing.assert_allclose(fab, 2 * fa - 3 * fb, atol=1e-12)
    c = a.copy()
    c[:, 30:] += 5.0               # a change at x >= 30 ...
    fc = gfgpu.green_filter(c, k, mode="constant", backend=backend)
    np.testing.assert_array_equal(fc[:, :31], fa[:, :31])   # ... cannot reach x <= 30 (G_u(0) = 0)


@pytest.mark.parametrize("u", [0.25, 0.5, 1.0, 3.0, 10.0, 40.0])
def test_shift_moments(backend, u):
    n = int(50 * u) + 64
    line = np.zeros((1, n))
    x0 = 5
    line[0, x0] = 1.0
    for s in (u, -u):
        src = line if s > 0 else line[:, ::-1].copy()
        out = gfgpu.shift(src, (0.0, s), mode="grid-constant", backend=backend)[0]
        pos = np.arange(n) if s > 0 else np.arange(n)[::-1]
        total = out.sum()
        mean = (out * (pos - x0)).sum() / total
        assert abs(total - 1) < 1e-6 and abs(mean - u) < 1e-6, (total, mean)


def test_shift_moves_a_smooth_image(backend):
    """A smooth image shifted by (dy, dx) matches its analytic translate.

    G_u matches to second order: the residual is the third-order term, |uω|^3/6 relative.
    """
    yy, xx = np.mgrid[:64, :96].astype(np.float64)
    f = lambda y, x: np.sin(2 * np.pi * x / 96) * np.cos(2 * np.pi * y / 64)
    out = gfgpu.shift(f(yy, xx), (1.3, 2.6), mode="grid-wrap", backend=backend)
    ref = f(yy - 1.3, xx - 2.6)
    bound = (2.6 * 2 * np.pi / 96) ** 3 / 6 + (1.3 * 2 * np.pi / 64) ** 3 / 6
    assert np.abs(out - ref).max() < 1.5 * bound


@pytest.mark.parametrize("single_scale", [False, True])
@pytest.mark.parametrize("u", [0.5, 1.0, 2.5])
def test_derivative_and_projection_match_direct_sum(backend, rng, u, single_scale):
    img = rng.standard_normal((9, 70))
    d_pass = greens.derivative_passes(u, single_scale=single_scale)
    p_pass = greens.projection_passes(u, single_scale=single_scale)
    margin = int(45 * 3.5 * u) + 10

    def taps(passes):
        def w(m):
            m = np.asarray(m)
            causal = sum(s.taps(m) for s in passes[0].sections) + passes[0].tap * (m == 0)
            anti = sum(s.taps(-m) for s in passes[1].sections) + passes[1].tap * (m == 0)
            return causal + anti
        return w

    dk, pk = TapKernel(taps(d_pass), margin), TapKernel(taps(p_pass), margin)
    # the oracle sums both sides: feed it the two-sided kernel through causal+anticausal sums
    def two_sided(image, kernel, axis):
        causal = TapKernel(lambda m: np.where(np.asarray(m) >= 0, kernel.taps(m), 0.0), margin)
        anti = TapKernel(lambda m: np.where(np.asarray(m) > 0, kernel.taps(-np.asarray(m)), 0.0), margin)
        return direct_axis(image, causal, axis, "reflect") + direct_axis(image, anti, axis, "reflect", anticausal=True)

    d = gfgpu.derivative(img, u, axis=1, axes=[1], single_scale=single_scale, backend=backend)
    assert relerr(d, two_sided(img, dk, 1)) <= 1e-12
    p = gfgpu.projection(img, u, axis=1, single_scale=single_scale, backend=backend)
    assert relerr(p, two_sided(img, pk, 1)) <= 1e-12
    # closed forms: the taps are the normalised samples of eq. 25-26 and of P = ∫D
    m = np.arange(-30, 31)
    closed_d = greens.d_uniform(m, u) if single_scale else greens.edge_derivative(m, u)
    np.testing.assert_allclose(dk.taps(m) / dk.taps(1), closed_d / closed_d[31], rtol=1e-12, atol=1e-14)
    if not single_scale:
        closed_p = greens.edge_projection(m, u)
        np.testing.assert_allclose(pk.taps(m) / pk.taps(0), closed_p / closed_p[30], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("u", [0.5, 1.0, 3.0])
def test_derivative_ramp_and_projection_sum(backend, u):
    n = 600
    ramp = np.tile(3.0 * np.arange(n, dtype=np.float64) - 7.0, (2, 1))
    d = gfgpu.derivative(ramp, u, axis=1, axes=[1], mode="nearest", backend=backend)
    np.testing.assert_allclose(d[:, 250:350], 3.0, rtol=1e-10)
    impulse = np.zeros((1, n))
    impulse[0, n // 2] = 1
    p = gfgpu.projection(impulse, u, axis=1, mode="constant", backend=backend)
    assert abs(p.sum() - 1) < 1e-10
    np.testing.assert_allclose(p[0, n // 2 - 40: n // 2], p[0, n // 2 + 40: n // 2: -1], atol=1e-15)


def test_gradient_of_a_plane(backend):
    yy, xx = np.mgrid[:160, :200].astype(np.float32)
    gy, gx = gfgpu.gradient(2 * yy - 0.5 * xx, 1.0, mode="nearest", backend=backend)
    assert gy.dtype == np.float32
    np.testing.assert_allclose(gy[60:100, 60:140], 2.0, rtol=1e-4)
    np.testing.assert_allclose(gx[60:100, 60:140], -0.5, rtol=1e-4)


@pytest.mark.parametrize("mode", MODES)
def test_boundary_modes_equal_explicit_padding(backend, rng, mode):
    img = rng.standard_normal((11, 23))
    k = greens.UniformGreen(1.5)
    pad = 200
    np_mode = {"constant": "constant", "nearest": "edge", "reflect": "symmetric", "mirror": "reflect",
               "wrap": "wrap"}[mode]
    kw = {"constant_values": 0.7} if mode == "constant" else {}
    for axis in (0, 1):
        width = [(0, 0), (0, 0)]
        width[axis] = (pad, pad)
        padded = np.pad(img, width, mode=np_mode, **kw)
        full = gfgpu.green_filter(padded, k, axis=axis, mode="constant", backend=backend)
        crop = full[pad:-pad] if axis == 0 else full[:, pad:-pad]
        out = gfgpu.green_filter(img, k, axis=axis, mode=mode, cval=0.7, backend=backend)
        assert relerr(out, crop) < 1e-12
    # oblique lines: the extension across the minor axis is the padded image's
    padded = np.pad(img, [(pad, pad), (0, 0)], mode=np_mode, **kw)
    full = gfgpu.green_filter(padded, k, angle=np.pi / 6, mode=mode, cval=0.7, backend=backend)
    out = gfgpu.green_filter(img, k, angle=np.pi / 6, mode=mode, cval=0.7, backend=backend)
    assert relerr(out, full[pad:-pad]) < 1e-12


def test_stack_and_colour_images(backend, rng):
    stack = rng.standard_normal((3, 20, 24)).astype(np.float32)
    out = gfgpu.shift(stack, (0, 1.5, -2.0), backend=backend)
    for i in range(3):
        one = gfgpu.shift(stack[i], (1.5, -2.0), backend=backend)
        np.testing.assert_allclose(out[i], one, rtol=1e-6, atol=1e-6)
    colour = np.moveaxis(stack, 0, -1).copy()
    outc = gfgpu.shift(colour, (1.5, -2.0), axes=(0, 1), backend=backend)
    np.testing.assert_allclose(np.moveaxis(outc, -1, 0), out, rtol=1e-6, atol=1e-6)
    ob = gfgpu.green_filter(stack, greens.UniformGreen(2.0), angle=0.4, backend=backend)
    for i in range(3):
        np.testing.assert_allclose(ob[i], gfgpu.green_filter(stack[i], greens.UniformGreen(2.0), angle=0.4,
                                                             backend=backend), rtol=1e-6, atol=1e-6)


def test_projection_scale_sets_the_smoothing_along_edges(backend, rng):
    img = rng.standard_normal((40, 50))
    d = gfgpu.derivative(img, 2.0, axis=1, projection_scale=0.5, backend=backend)
    p = gfgpu.projection(img, 1.0, axis=0, backend=backend)          # P at 0.5 * 2.0
    ref = gfgpu.derivative(p, 2.0, axis=1, axes=[1], backend=backend)
    np.testing.assert_allclose(d, ref, rtol=1e-12, atol=1e-12)
    assert relerr(d, gfgpu.derivative(img, 2.0, axis=1, backend=backend)) > 1e-3
    with pytest.raises(ValueError, match="projection_scale must be > 0"):
        gfgpu.gradient(img, 1.0, projection_scale=-1, backend=backend)


# --------------------------------------------------------------------------------------
# the coordinate convention: (rows, cols); channel_axis for colour; keyword-only options
# --------------------------------------------------------------------------------------
def test_shift_colour_channel_axis_equals_per_channel_shifts(backend, rng):
    colour = rng.standard_normal((20, 26, 3)).astype(np.float32)
    out = gfgpu.shift(colour, (1.5, -2.25), channel_axis=-1, mode="nearest", backend=backend)
    for c in range(3):
        one = gfgpu.shift(colour[..., c], (1.5, -2.25), mode="nearest", backend=backend)   # (dy, dx)
        np.testing.assert_allclose(out[..., c], one, rtol=1e-6, atol=1e-6)
    first = gfgpu.shift(np.moveaxis(colour, -1, 0).copy(), (1.5, -2.25), channel_axis=0, mode="nearest",
                        backend=backend)
    np.testing.assert_allclose(np.moveaxis(first, 0, -1), out, rtol=1e-6, atol=1e-6)
    # (dy, dx): an impulse moves dy rows down and dx columns right
    img = np.zeros((120, 200))
    img[20, 40] = 1.0
    moved = gfgpu.shift(img, (3.0, 7.0), mode="constant", backend=backend)
    yy, xx = np.mgrid[:120, :200]
    assert abs((moved * yy).sum() - 23) < 1e-4 and abs((moved * xx).sum() - 47) < 1e-4


def test_channel_axis_of_every_line_operator(backend, rng):
    rgb = rng.standard_normal((24, 30, 3))
    k = greens.UniformGreen(2.0)
    per_channel = {
        "green_filter angle": (lambda im, **kw: gfgpu.green_filter(im, k, angle=0.5, backend=backend, **kw)),
        "green_filter axis": (lambda im, **kw: gfgpu.green_filter(im, k, backend=backend, **kw)),
        "derivative": (lambda im, **kw: gfgpu.derivative(im, 1.0, backend=backend, **kw)),
        "derivative axis 0": (lambda im, **kw: gfgpu.derivative(im, 1.0, axis=0, backend=backend, **kw)),
        "projection": (lambda im, **kw: gfgpu.projection(im, 1.0, backend=backend, **kw)),
        "gradient": (lambda im, **kw: np.stack(gfgpu.gradient(im, 1.0, backend=backend, **kw))),
    }
    for name, op in per_channel.items():
        out = op(rgb, channel_axis=-1)
        for c in range(3):
            np.testing.assert_allclose(out[..., c], op(rgb[..., c]), rtol=1e-12, atol=1e-12, err_msg=name)
    out = gfgpu.green_filter(rgb, k, angle=0.5, channel_axis=-1, output=np.empty_like(rgb), backend=backend)
    np.testing.assert_allclose(out[..., 1], gfgpu.green_filter(rgb[..., 1], k, angle=0.5, backend=backend),
                               atol=1e-12)


def test_channel_axis_on_device_arrays(backend, rng):
    if backend.name == "numpy":
        pytest.skip("host arrays")
    rgb = rng.standard_normal((12, 14, 3)).astype(np.float32)
    dev = backend.asarray(rgb)
    out = gfgpu.shift(dev, (1.5, -0.5), channel_axis=-1)
    np.testing.assert_allclose(backend.to_host(out), gfgpu.shift(rgb, (1.5, -0.5), channel_axis=-1, backend="numpy"),
                               rtol=2e-5, atol=2e-6)
    with pytest.raises(ValueError, match="device array needs the image plane on its last two axes"):
        gfgpu.green_filter(dev, greens.UniformGreen(1.0), angle=0.4, channel_axis=-1)
    first = backend.asarray(np.moveaxis(rgb, -1, 0).copy())
    ob = gfgpu.green_filter(first, greens.UniformGreen(1.0), angle=0.4, channel_axis=0)
    np.testing.assert_allclose(np.moveaxis(backend.to_host(ob), 0, -1),
                               gfgpu.green_filter(rgb, greens.UniformGreen(1.0), angle=0.4, channel_axis=-1,
                                                  backend="numpy"), rtol=2e-5, atol=2e-5)


@pytest.mark.parametrize("call, match", [
    (lambda im: gfgpu.shift(im, (1.0, 1.0), axes=(1, 2), channel_axis=-1), r"axes=\(1, 2\) and channel_axis=-1"),
    (lambda im: gfgpu.gradient(im, 1.0, axes=(0, 2), channel_axis=2), "axes.*channel_axis.*overlap"),
    (lambda im: gfgpu.derivative(im, 1.0, axis=2, channel_axis=-1), "axis=2 and channel_axis=-1"),
    (lambda im: gfgpu.projection(im, 1.0, axis=-1, channel_axis=2), "axis=-1 and channel_axis=2"),
    (lambda im: gfgpu.green_filter(im, greens.UniformGreen(1.0), axis=0, channel_axis=0), "axis=0 and channel_axis"),
    (lambda im: gfgpu.green_filter(im, greens.UniformGreen(1.0), angle=0.3, axes=(0, 2), channel_axis=2),
     "axes.*channel_axis"),
    (lambda im: gfgpu.green_filter(im, greens.UniformGreen(1.0), axes=(0, 1)), "give angle"),
    (lambda im: gfgpu.shift(im, (1.0, 1.0)), "one value per axis.*channel_axis"),
    (lambda im: gfgpu.shift(im, 1.0, channel_axis=3), "channel_axis=3 is out of range"),
])
def test_axes_and_channel_axis_conflicts(call, match):
    with pytest.raises(ValueError, match=match):
        call(np.ones((6, 7, 3)))


def test_options_are_keyword_only():
    img = np.ones((8, 9))
    for call in (lambda: gfgpu.shift(img, 1.0, None, "constant"),
                 lambda: gfgpu.green_filter(img, greens.UniformGreen(1.0), 0),
                 lambda: gfgpu.derivative(img, 1.0, 0),
                 lambda: gfgpu.projection(img, 1.0, 0),
                 lambda: gfgpu.gradient(img, 1.0, "nearest")):
        with pytest.raises(TypeError, match="positional"):
            call()


def test_shift_command_maps_dx_dy(tmp_path):
    """gfgpu shift --dx DX --dy DY is shift(img, (DY, DX)), colour channels per channel."""
    import imageio.v3 as iio

    from gfgpu.cli import main
    rgb = (np.random.default_rng(5).random((20, 30, 3)) * 255).astype(np.uint8)
    iio.imwrite(tmp_path / "in.png", rgb)
    assert main(["shift", str(tmp_path / "in.png"), "-o", str(tmp_path / "o.png"), "--npy", str(tmp_path / "o.npy"),
                 "--dx", "2.5", "--dy", "-1", "--backend", "numpy", "--quiet"]) == 0
    ref = gfgpu.shift(rgb.astype(np.float32), (-1.0, 2.5), channel_axis=-1, backend="numpy")
    np.testing.assert_array_equal(np.load(tmp_path / "o.npy"), ref)
