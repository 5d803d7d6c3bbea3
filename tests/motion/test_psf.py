"""Motion blur along the true path with the box and Green PSFs (gfgpu.motion, issue 15).

Every kind (uniform, per-pixel field, spin, zoom) on every backend against a supersampled
rendering that shares nothing with the fast paths: the average of many exactly warped copies
of the image, each resampled by ``scipy.ndimage.map_coordinates`` (cubic spline), weighted by
the PSF's mass over the copy's time cell.  The fused kernels against their numpy
specifications (:mod:`gfgpu.motion.spec`).
"""

import math

import numpy as np
import pytest
import scipy.ndimage as ndi

from gfgpu.greens import g_uniform
from gfgpu.motion import kernels, motion_blur
from gfgpu.motion import spec as specs

SCIPY_MODES = {"wrap": "grid-wrap", "reflect": "reflect", "mirror": "mirror", "nearest": "nearest"}


def _dtypes(be):
    return (np.float32, np.float64) if be.supports_float64 else (np.float32,)


def _bandlimited(n, cut=0.2, seed=0):
    """Unit-variance noise with no frequency above ``cut`` cycles/px (radially)."""
    rng = np.random.default_rng(seed)
    f = np.fft.fft2(rng.standard_normal((n, n)))
    fy, fx = np.fft.fftfreq(n)[:, None], np.fft.fftfreq(n)[None, :]
    img = np.real(np.fft.ifft2(f * (np.hypot(fy, fx) < cut)))
    return img / img.std()


def _time_cells(psf, displace, n):
    """Midpoints and masses of ``n`` cells of the PSF in t (fraction of the motion)."""
    if psf == "box":
        t = (np.arange(n) + 0.5) / n - (0.0 if displace else 0.5)
        return t, np.full(n, 1.0 / n)
    # G_u with u = 1 (mean one velocity), integrated numerically from its closed form (eq. 9)
    edges = np.linspace(0.0, 20.0, n + 1)
    fine = np.linspace(0.0, 20.0, 64 * n + 1)
    dens = g_uniform(fine, 1.0) if displace else \
        np.convolve(g_uniform(fine, 0.5), g_uniform(fine, 0.5)[::-1], "full")[len(fine) - 1:] * (fine[1] - fine[0])
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(fine))])
    mass = np.diff(np.interp(edges, fine, cum))
    t = 0.5 * (edges[1:] + edges[:-1])
    if displace:
        return t, mass / mass.sum()
    # centred: the autocorrelation is even; mirror the half-line cells
    return np.concatenate([-t[::-1], t]), np.concatenate([mass[::-1], mass]) / (2 * mass.sum())


_RENDERED = {}


def _render(img, preimage, psf="box", displace=True, mode="wrap", n=256, key=None):
    """Σ_k w_k I(preimage(x, t_k)): the supersampled rendering (cubic spline, scipy); ``key``
    caches it across the backends of one parametrised test."""
    if key is not None and key in _RENDERED:
        return _RENDERED[key]
    h, w = img.shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    coef = ndi.spline_filter(img.astype(np.float64), 3, mode=SCIPY_MODES[mode])
    acc = np.zeros((h, w))
    for t, wt in zip(*_time_cells(psf, displace, n)):
        py, px = preimage(yy, xx, t)
        acc += wt * ndi.map_coordinates(coef, [py, px], order=3, mode=SCIPY_MODES[mode], prefilter=False)
    if key is not None:
        _RENDERED[key] = acc
    return acc


def _rel(out, ref, margin):
    o, r = out[margin:-margin, margin:-margin], ref[margin:-margin, margin:-margin]
    return float(np.linalg.norm(o - r) / np.linalg.norm(r))


def _spin(degrees, cy, cx):
    def pre(yy, xx, t):   # content turned by t*theta counter-clockwise on screen: read R(-t theta)
        a = math.radians(degrees) * t
        dy, dx = yy - cy, xx - cx
        return cy + math.sin(a) * dx + math.cos(a) * dy, cx + math.cos(a) * dx - math.sin(a) * dy
    return pre


# --------------------------------------------------------------------------------------
# against supersampled renderings, every backend
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("velocity, displace", [((0.0, -9.5), True), ((13.0, -5.0), True), ((-6.0, 11.0), False),
                                                ((7.0, 7.0), True)])
def test_uniform_box_matches_rendering(backend, velocity, displace):
    img = _bandlimited(64, cut=0.15)
    ref = _render(img, lambda yy, xx, t: (yy - t * velocity[0], xx - t * velocity[1]), "box", displace,
                  key=("uniform", velocity, displace))
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), velocity, psf="box", displace=displace, mode="wrap",
                          backend=backend.name)
        assert out.dtype == dtype
        # along an axis only the spline integral differs from the rendering's quadrature
        tol = 1e-3 if velocity[0] == 0.0 else 0.02
        assert _rel(out, ref, 16) < tol


@pytest.mark.parametrize("psf, displace", [("box", True), ("box", False), ("green", True), ("green", False)])
def test_field_matches_rendering(backend, psf, displace):
    img = _bandlimited(48, cut=0.2, seed=3)
    rng = np.random.default_rng(4)
    field = np.stack([ndi.gaussian_filter(rng.standard_normal((48, 48)), 8, mode="wrap") for _ in range(2)])
    field *= 6.0 / np.abs(field).max()
    ref = _render(img, lambda yy, xx, t: (yy - t * field[0], xx - t * field[1]), psf, displace, n=512,
                  key=("field", psf, displace))
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), field, psf=psf, displace=displace, mode="wrap", backend=backend.name)
        assert out.dtype == dtype
        assert _rel(out, ref, 6) < 0.015


@pytest.mark.parametrize("psf, displace, tol", [("box", True, 0.015), ("box", False, 0.015), ("green", True, 0.03),
                                                ("green", False, 0.03)])
def test_spin_matches_rendering(backend, psf, displace, tol):
    img = _bandlimited(64, cut=0.2, seed=5)
    ref = _render(img, _spin(12.0, 30.0, 33.5), psf, displace, mode="reflect", n=512,
                  key=("spin", psf, displace))
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), 12.0, kind="rotation", psf=psf, center=(30.0, 33.5), displace=displace,
                          mode="reflect", backend=backend.name)
        assert out.dtype == dtype
        assert _rel(out, ref, 8) < tol


@pytest.mark.parametrize("psf", ["box", "green"])
def test_spin_in_bands_of_rings_matches_rendering(backend, psf):
    """A spin on an image large enough for the polar grid to run in bands of rings (fewer angles
    on the inner bands, polar.polar_bands): no seam where the bands meet."""
    from gfgpu.motion.polar import polar_bands
    img = _bandlimited(192, cut=0.2, seed=12)
    centre = (90.0, 101.5)
    bands = polar_bands(192, 192, *centre, split=True)
    assert len(bands) >= 2
    ref = _render(img, _spin(9.0, *centre), psf, True, mode="reflect", n=512, key=("banded spin", psf))
    out = motion_blur(img.astype(np.float32), 9.0, kind="rotation", psf=psf, center=centre, mode="reflect",
                      backend=backend.name)
    tol = 0.015 if psf == "box" else 0.03
    assert _rel(out, ref, 8) < tol
    # on the circles where the bands meet, as on the whole image
    yy, xx = np.mgrid[:192, :192]
    r = np.hypot(yy - centre[0], xx - centre[1])
    for _, _, _, r_lo, _ in bands[:-1]:
        ring = np.abs(r - r_lo) < 3
        assert np.linalg.norm((out - ref)[ring]) / np.linalg.norm(ref[ring]) < tol


@pytest.mark.parametrize("u1, displace", [(0.12, True), (0.3, False), (-0.2, True)])
def test_radial_zoom_matches_rendering(backend, u1, displace):
    img = _bandlimited(64, cut=0.2, seed=6)
    cy, cx = 31.0, 28.5
    a = u1 / (1.0 + u1)       # the pre-image moves linearly in time: c + (x - c)(1 - a t)
    ref = _render(img, lambda yy, xx, t: (cy + (yy - cy) * (1 - a * t), cx + (xx - cx) * (1 - a * t)), "box",
                  displace, mode="reflect", key=("zoom", u1, displace))
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), u1, kind="zoom", psf="box", center=(cy, cx), displace=displace,
                          mode="reflect", backend=backend.name)
        assert _rel(out, ref, 6) < 0.015


def _green_zoom_cells(u1, n):
    """``(tau, weight)``: G_U^(1) (eq. 11) as a distribution of ``tau = ln(s/x0)`` (zoom-in,
    density ``C e^(alpha tau) sin(beta tau)``) or ``ln(x0/s)`` (zoom-out, ``-C e^(-alpha tau)
    sin(beta tau)``), cut into ``n`` cells where the tail is below 1e-13; closed-form CDF."""
    alpha = 0.5 - 1.0 / u1
    beta = math.sqrt(1.0 + u1 - u1 * u1 / 4.0) / abs(u1)
    z, c = complex(alpha, beta), 2.0 / (u1 * u1 * beta)
    edges = np.linspace(0.0, 30.0 / abs(alpha), n + 1)
    cdf = (c * (np.exp(z * edges) - 1.0) / z).imag if u1 > 0 else (-c * (1.0 - np.exp(-z * edges)) / z).imag
    cdf[-1] = 1.0
    return 0.5 * (edges[:-1] + edges[1:]), np.diff(cdf)


@pytest.mark.parametrize("u1", [0.12, 0.3, -0.2])
def test_green_zoom_along_rays_matches_rendering(backend, u1):
    img = _bandlimited(64, cut=0.2, seed=6)
    cy, cx = 31.0, 28.5
    if ("green zoom", u1) not in _RENDERED:     # the pre-image c + (x - c) e^(-+tau), weighted by the kernel
        yy, xx = np.mgrid[:64, :64].astype(np.float64)
        coef = ndi.spline_filter(img.astype(np.float64), 3, mode="reflect")
        acc = np.zeros((64, 64))
        for tau, wt in zip(*_green_zoom_cells(u1, 512)):
            f = math.exp(-tau if u1 > 0 else tau)
            acc += wt * ndi.map_coordinates(coef, [cy + (yy - cy) * f, cx + (xx - cx) * f], order=3, mode="reflect",
                                            prefilter=False)
        _RENDERED["green zoom", u1] = acc
    ref = _RENDERED["green zoom", u1]
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), u1, kind="zoom", psf="green", center=(cy, cx), mode="reflect",
                          backend=backend.name)
        assert out.dtype == dtype
        assert _rel(out, ref, 6) < 0.025       # measured 1.2-1.8 %; the separable G_U^(1) is 17-42 % off


def test_anisotropic_box_zoom_is_the_affine_field():
    img = _bandlimited(48, cut=0.2, seed=7)
    u1y, u1x, cy, cx = 0.1, -0.15, 20.0, 25.0
    out = motion_blur(img, (u1y, u1x), kind="zoom", psf="box", center=(cy, cx), mode="reflect", backend="numpy")
    ay, ax = u1y / (1 + u1y), u1x / (1 + u1x)
    ref = _render(img, lambda yy, xx, t: (cy + (yy - cy) * (1 - ay * t), cx + (xx - cx) * (1 - ax * t)), "box",
                  mode="reflect")
    assert _rel(out, ref, 4) < 0.015


# --------------------------------------------------------------------------------------
# properties
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind,v", [("uniform", (1.5, -2.25)), ("zoom", 0.3), ("zoom", -0.2),
                                    ("zoom", (0.1, 0.3)), ("rotation", 25.0), ("field", None)])
def test_backends_agree_with_numpy(backend, kind, v):
    rng = np.random.default_rng(3)
    img = rng.random((13, 17))
    vel = rng.uniform(-2, 2, (2, 13, 17)) if kind == "field" else v
    k = "uniform" if kind == "field" else kind
    for mode in ("constant", "nearest", "wrap"):
        for psf in ("green", "box"):
            args = dict(kind=k, psf=psf, mode=mode, cval=0.4, displace=(mode != "wrap"))
            ref = motion_blur(img, vel, backend="numpy", **args)
            out = motion_blur(img, vel, backend=backend.name, **args)
            np.testing.assert_allclose(out, ref, rtol=0, atol=1e-10, err_msg=f"{mode} {psf}")


def test_box_is_exact_for_fractional_lengths(backend):
    """A box of length L along x on a ramp: the mean of x over [x - L, x] is x - L/2; unit gain."""
    x = np.arange(200.0)
    img = np.tile(x, (4, 1))
    for length in (0.3, 2.5, 7.75, 40.2):
        out = motion_blur(img, (0.0, length), psf="box", mode="nearest", backend=backend.name)
        tol = 1e-9 if backend.supports_float64 else 1e-3
        np.testing.assert_allclose(out[:, 60:150], img[:, 60:150] - length / 2, atol=tol)
        ones = motion_blur(np.ones((8, 64)), (3.0, length), psf="box", mode="reflect", backend=backend.name)
        np.testing.assert_allclose(ones, 1.0, atol=1e-6)


@pytest.mark.parametrize("kwargs", [{"kind": "rotation", "psf": "box"}, {"kind": "rotation", "psf": "green"},
                                    {"kind": "zoom", "psf": "box"}])
def test_polar_blur_writes_into_output(backend, kwargs):
    # a caller's output= is wrapped in place (OpenCL: from an aligned address below it, an offset)
    img = _bandlimited(136, cut=0.2, seed=7)[:, 1:132]     # above 64 KiB: OpenCL wraps host memory
    velocity = 0.1 if kwargs["kind"] == "zoom" else 9.0
    ref = motion_blur(img, velocity, backend="numpy", **kwargs)
    for dtype in _dtypes(backend):
        out = np.empty(img.size + 1, dtype)[1:].reshape(img.shape)     # one element past an allocation
        got = motion_blur(img.astype(dtype), velocity, output=out, backend=backend.name, **kwargs)
        assert got is out
        assert np.abs(out - ref).max() < (1e-4 if dtype == np.float32 else 1e-10)


def test_zero_field_and_zero_angle_are_identities(backend):
    img = _bandlimited(32, seed=8)
    out = motion_blur(img, np.zeros((2, 32, 32)), psf="box", mode="reflect", backend=backend.name)
    tol = 1e-12 if backend.supports_float64 else 1e-5
    assert np.abs(out - img).max() < tol
    assert np.abs(motion_blur(img, 0.0, kind="rotation", psf="box", backend=backend.name) - img).max() < tol


def test_uniform_field_equals_uniform_box():
    img = _bandlimited(64, cut=0.15, seed=9)
    field = np.zeros((2, 64, 64))
    field[0], field[1] = 0.0, 9.0
    a = motion_blur(img, field, psf="box", mode="wrap", backend="numpy")
    b = motion_blur(img, (0.0, 9.0), psf="box", mode="wrap", backend="numpy")
    assert _rel(a, b, 2) < 0.003


def test_rgba_premultiplied_keeps_edges_clean():
    """An opaque white square on a transparent black background, blurred premultiplied: the
    un-premultiplied colour stays white wherever alpha > 0 (no dark fringe)."""
    rgba = np.zeros((40, 60, 4))
    rgba[10:30, 20:40] = 1.0
    alpha = rgba[..., 3:]
    pre = np.concatenate([rgba[..., :3] * alpha, alpha], axis=-1)
    out = motion_blur(pre, (0.0, 12.0), psf="box", channel_axis=-1, mode="constant", backend="numpy")
    a = out[..., 3]
    seen = a > 1e-3
    colour = out[..., :3][seen] / a[seen][:, None]
    np.testing.assert_allclose(colour, 1.0, atol=1e-6)


def test_depth_is_kept():
    img16 = (np.random.default_rng(10).random((20, 30)) * 65535).astype(np.uint16)
    assert motion_blur(img16, (0, 3), psf="box", backend="numpy").dtype == np.float32
    for dtype in (np.float32, np.float64):
        assert motion_blur(img16.astype(dtype), (2, 3), psf="box", backend="numpy").dtype == dtype
        assert motion_blur(img16.astype(dtype), np.ones((2, 20, 30)), psf="box", backend="numpy").dtype == dtype


# --------------------------------------------------------------------------------------
# fused kernels against their specifications, every backend
# --------------------------------------------------------------------------------------
def _check(be, got, ref, dtype):
    got = be.to_host(got).reshape(ref.shape)
    tol = 1e-11 if dtype == np.float64 else 2e-5
    assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("mode", list(specs.MODE_CODES))
def test_fused_kernels_match_specifications(backend, mode, rng):
    for dtype in _dtypes(backend):
        src = rng.standard_normal((2, 7, 33)).astype(dtype)
        for axis in (1, 2):
            for window in [(-5.3, 1.0, 0.0, 1.0), (0.0, 1.0, 7.25, 1.0), (-2.5, 1.0, 2.5, 1.0), (0.0, 0.8, 0.0, 1.0),
                           (0.3, 1.0, 0.3, 1.0), (0.0, 1.0, 0.0, 1.3), (-40.5, 1.0, 0.0, 1.0)]:
                dst = backend.empty(src.shape, dtype)
                kernels.box_lines(backend, backend.asarray(src), dst, axis, *window, mode, 0.7)
                _check(backend, dst, specs.box_lines_reference(src, axis, *window, mode, 0.7), dtype)
        # lines along axis 1 with a multiple of 8 of them: OpenCL/CPU runs them in vector lanes
        cols = rng.standard_normal((2, 40, 32)).astype(dtype)
        for window in [(-5.3, 1.0, 0.0, 1.0), (-2.5, 1.0, 2.5, 1.0), (0.0, 0.8, 0.0, 1.3), (0.3, 1.0, 0.3, 1.0),
                       (-60.5, 1.0, 0.0, 1.0)]:
            dst = backend.empty(cols.shape, dtype)
            kernels.box_lines(backend, backend.asarray(cols), dst, 1, *window, mode, 0.7)
            _check(backend, dst, specs.box_lines_reference(cols, 1, *window, mode, 0.7), dtype)
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        field = (rng.standard_normal((2, 20, 24)) * 4).astype(dtype)
        for psf in range(4):
            out = backend.empty(coef.shape, dtype)
            kernels.field_blur(backend, backend.asarray(coef), backend.asarray(field), out, psf, 2.0, mode, 0.3)
            _check(backend, out, specs.field_blur_reference(coef, field, psf, 2.0, mode, 0.3), dtype)
        polar = backend.empty((2, 18, 64), dtype)
        kernels.to_polar(backend, backend.asarray(coef), polar, 9.5, 11.2, 2, mode, 0.3)
        _check(backend, polar, specs.to_polar_reference(coef, 9.5, 11.2, 2, 18, 64, mode, 0.3), dtype)
        pcoef = rng.standard_normal((2, 18, 64)).astype(dtype)
        base = rng.standard_normal((2, 20, 24)).astype(dtype)
        back = backend.empty((2, 20, 24), dtype)
        wcoef = rng.uniform(0.2, 1.0, 18)           # ring weights' radial coefficients (mirrored at both ends)
        for w in (None, wcoef):
            kernels.from_polar(backend, backend.asarray(pcoef), backend.asarray(base), back, 9.5, 11.2, 0, 0.0,
                               math.inf, w)
            _check(backend, back, specs.from_polar_reference(pcoef, base, 9.5, 11.2, 0, 0.0, math.inf, w), dtype)


def test_box_specification_is_the_spline_integral():
    """box_lines_reference against numerical quadrature of the spline (scipy) on one line."""
    rng = np.random.default_rng(11)
    line = rng.standard_normal(40)
    coef = ndi.spline_filter1d(line, 3, mode="mirror")
    a0, b0 = -3.3, 2.15
    got = specs.box_lines_reference(coef[None, None, :], 2, a0, 1.0, b0, 1.0, "mirror", 0.0)[0, 0]
    for k in (5, 17, 33):
        s = np.linspace(k + a0, k + b0, 20001)
        vals = ndi.map_coordinates(coef, [s], order=3, mode="mirror", prefilter=False)
        assert abs(got[k] - np.trapezoid(vals, s) / (b0 - a0)) < 1e-7
