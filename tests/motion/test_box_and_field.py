"""The box exposure and the per-pixel velocity field against the cubic spline along the path.

The field tests here check the exact cells (``quadrature="exact"``, cells of at most one pixel);
the default Gauss rule has its own tests in ``test_field_rule.py``.

References are independent of the library: scipy.ndimage.map_coordinates (order 3) on an image
padded with numpy's own extension of each mode, averaged over many points of the path (G_u's
weights integrated numerically from its closed form, eq. 9).
"""

import numpy as np
import pytest
from scipy import ndimage as ndi

from gfgpu.greens import g_uniform
from gfgpu.motion import motion_blur

NP_PAD = {"reflect": "symmetric", "mirror": "reflect", "nearest": "edge", "wrap": "wrap", "constant": "constant"}


PAD = 60


def box_reference(img, vx, displace, mode, n=400):
    """Mean of the cubic spline of each row (extended by ``mode``) over the box path along x."""
    pad = np.pad(img, ((0, 0), (PAD, PAD)), mode=NP_PAD[mode])
    h, w = img.shape
    t = (np.arange(n) + 0.5) / n
    if not displace:
        t = t - 0.5
    yy, xx = np.mgrid[:h, :w].astype(float)
    acc = np.zeros((h, w))
    for ti in t:
        acc += ndi.map_coordinates(pad, [yy, xx + PAD - ti * vx], order=3, mode="mirror")
    return acc / n


def path_reference(img, field, mode, t, weights, pad=PAD):
    """Σ_k w_k S(x - t_k v(x)): the cubic spline of ``img`` extended by ``mode`` (numpy's padding,
    ``pad`` pixels on every side) along every pixel's path; ``field`` (2, H, W) or a pair."""
    padded = np.pad(img, pad, mode=NP_PAD[mode])
    h, w = img.shape
    vy, vx = (np.broadcast_to(np.asarray(c, float), (h, w)) for c in field)
    yy, xx = np.mgrid[:h, :w].astype(float)
    acc = np.zeros((h, w))
    for ti, wi in zip(t, weights):
        acc += wi * ndi.map_coordinates(padded, [yy + pad - ti * vy, xx + pad - ti * vx], order=3, mode="mirror")
    return acc


def green_cells(n=3000, tmax=20.0):
    """Midpoints and masses of ``n`` cells of G_u (u = one velocity) on ``[0, tmax]``, from eq. 9
    integrated by the trapezoid rule on a grid 16 times finer."""
    edges = np.linspace(0.0, tmax, n + 1)
    fine = np.linspace(0.0, tmax, 16 * n + 1)
    dens = g_uniform(fine, 1.0)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(fine))])
    mass = np.diff(np.interp(edges, fine, cum))
    return 0.5 * (edges[1:] + edges[:-1]), mass / mass.sum()


# --------------------------------------------------------------------------------------
# the box along an axis, of any length
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["reflect", "mirror", "wrap", "constant", "nearest"])
def test_box_along_axis_is_exact_average_of_spline_path(backend, mode):
    """Box of length L along x = mean of the cubic spline over [x - L, x] (exact, fractional L),
    'nearest' included: its spline is the one of the edge-extended image (it once continued the
    edge coefficient instead, 0.23 off at the border)."""
    img = np.random.default_rng(1).random((3, 24))
    for vx, displace in [(2.5, True), (-2.5, True), (3.0, False)]:
        ref = box_reference(img, vx, displace, mode)
        out = motion_blur(img, (0, vx), psf="box", displace=displace, mode=mode, backend=backend.name)
        np.testing.assert_allclose(out, ref, atol=2e-5, err_msg=f"mode={mode} vx={vx} displace={displace}")


def test_box_nearest_long_window_tends_to_edge_value(backend):
    """'nearest' extends the image by its edge value, so a box far longer than the image averages
    (almost only) that edge value.  It once gave the edge *spline coefficient* c[0] (-0.41 for an
    edge value 0.0027): the coefficients were clamped like samples."""
    img = np.random.default_rng(0).random((3, 11))
    out = np.asarray(motion_blur(img, (0, 1e4), psf="box", mode="nearest", backend=backend.name))
    np.testing.assert_allclose(out[:, 5], img[:, 0], atol=2e-3)


@pytest.mark.parametrize("vx", [1e6, -1e9])
def test_box_of_any_length_averages_the_extension(backend, vx):
    """The part of a window beyond the image is summed in closed form (whole periods, geometric
    tails): any length up to 1e9 px costs O(1) per pixel and averages the extension (the first
    window was once summed cell by cell: minutes at 1e9 px, then refused beyond 1e6 px)."""
    img = np.random.default_rng(4).random((3, 11))
    edge = img[:, :1] if vx > 0 else img[:, -1:]
    mean = img.mean(axis=1, keepdims=True)
    mirror = (2 * img.sum(axis=1, keepdims=True) - img[:, :1] - img[:, -1:]) / 20
    for mode, value in (("nearest", edge), ("constant", 0.25), ("wrap", mean), ("reflect", mean), ("mirror", mirror)):
        out = np.asarray(motion_blur(img, (0, vx), psf="box", mode=mode, cval=0.25, backend=backend.name))
        # the window's share inside the image: 11 / |vx|
        np.testing.assert_allclose(out, np.broadcast_to(value, img.shape), atol=20.0 / abs(vx) + 1e-9,
                                   err_msg=mode)


def test_box_lengths_up_to_1e9_px_average_the_extension():
    # the first window's sum is in closed form (whole periods, geometric tails): a (0, 1e9) box ran
    # for minutes when it summed its window (review of issue 15); beyond 1e9 px both PSFs refuse
    from gfgpu.motion import motion_blur
    img = np.random.default_rng(2).random((3, 11))
    expected = {"nearest": img[:, :1], "constant": 0.25, "wrap": img.mean(axis=1, keepdims=True),
                "reflect": img.mean(axis=1, keepdims=True)}
    for mode, value in expected.items():
        out = motion_blur(img, (0.0, 1e9), psf="box", mode=mode, cval=0.25, backend="numpy")
        np.testing.assert_allclose(out, np.broadcast_to(value, img.shape), atol=1e-7, err_msg=mode)
    for psf in ("box", "green"):
        out = np.full_like(img, 7.0)
        with pytest.raises(ValueError, match="at most 1e\\+09"):
            motion_blur(img, (0.0, 2e9), psf=psf, output=out, backend="numpy")
        assert (out == 7.0).all()


# --------------------------------------------------------------------------------------
# the velocity field (the exact cells)
# --------------------------------------------------------------------------------------
@pytest.fixture
def exact_cells(monkeypatch):
    """The field tests of this module run the exact cells (``quadrature="exact"``; the default is
    the Gauss rule): this module's ``motion_blur`` takes it."""
    import functools
    import sys
    monkeypatch.setattr(sys.modules[__name__], "motion_blur", functools.partial(motion_blur, quadrature="exact"))


def test_field_nearest_border_matches_spline_of_edge_extended_image(backend, exact_cells):
    """The field blur reads the same extension in 'nearest' mode (an impulse on the edge, a path
    out of the image): the mean of a spline that never exceeds 1.1, not 1.4."""
    line = np.zeros((1, 12))
    line[0, 0] = 1.0
    field = np.zeros((2, 1, 12))
    field[1] = 2.0
    t = (np.arange(2000) + 0.5) / 2000
    ref = path_reference(line, field, "nearest", t, np.full(t.size, 1 / t.size))
    out = motion_blur(line, field, psf="box", mode="nearest", backend=backend.name)
    np.testing.assert_allclose(out, ref, atol=2e-4)


@pytest.mark.parametrize("mode", ["nearest", "constant"])
def test_field_near_corners_is_the_spline_of_the_extended_image(backend, mode, exact_cells):
    """Oblique paths that leave the image across a corner read the 2-D extension (each axis in
    turn): against scipy on the image padded by numpy."""
    rng = np.random.default_rng(5)
    img = rng.random((9, 10))
    field = rng.uniform(-5, 5, (2, 9, 10))
    t = (np.arange(1500) + 0.5) / 1500
    pad = np.pad(img, PAD, mode="constant", constant_values=0.3) if mode == "constant" else None
    if pad is None:
        ref = path_reference(img, field, mode, t, np.full(t.size, 1 / t.size))
    else:       # numpy pads 'constant' with zeros: shift the image by cval instead
        ref = path_reference(img - 0.3, field, mode, t, np.full(t.size, 1 / t.size)) + 0.3
    out = motion_blur(img, field, psf="box", mode=mode, cval=0.3, backend=backend.name)
    np.testing.assert_allclose(out, ref, atol=1e-3)


def test_field_uniform_equals_uniform_box(backend, exact_cells):
    """A uniform field gives the uniform box: 3 Gauss-Legendre nodes per pixel of path (one
    midpoint per half pixel was 2.4e-2 off at L = 0.5 and 5e-3 at L = 2.5, on white noise)."""
    img = np.random.default_rng(1).random((4, 40))
    for vx in (0.25, 0.5, 1.0, 2.5, 7.3, -2.5):
        field = np.zeros((2,) + img.shape)
        field[1] = vx
        for displace in (True, False):
            uni = motion_blur(img, (0, vx), psf="box", mode="reflect", displace=displace, backend=backend.name)
            fld = motion_blur(img, field, psf="box", mode="reflect", displace=displace, backend=backend.name)
            np.testing.assert_allclose(fld, uni, atol=2e-3, err_msg=f"vx={vx} displace={displace}")


def test_green_field_is_the_mean_of_its_path_for_short_paths(backend, exact_cells):
    """G_u along a short path: cells of at most half a velocity whatever the length (one midpoint
    per half pixel put 1.6e-2 of error at L = 0.5 and 1.9e-2 at L = 0.25 on white noise)."""
    img = np.random.default_rng(6).random((6, 30))
    t, w = green_cells()
    for v in ((0.0, 0.25), (0.0, 0.5), (0.0, 1.0), (0.4, -1.7), (0.0, 3.0)):
        ref = path_reference(img, v, "reflect", t, w)
        field = np.zeros((2,) + img.shape)
        field[0], field[1] = v
        out = motion_blur(img, field, psf="green", mode="reflect", backend=backend.name)
        np.testing.assert_allclose(out, ref, atol=1e-3, err_msg=f"v={v}")


# --------------------------------------------------------------------------------------
# the velocity field's budget: a bounded number of cells per pixel (issues 27, 31)
# --------------------------------------------------------------------------------------
def _bandlimited(n, cut, seed=0):
    """Unit-variance noise with no frequency above ``cut`` cycles/px (radially)."""
    rng = np.random.default_rng(seed)
    f = np.fft.fft2(rng.standard_normal((n, n)))
    fy, fx = np.fft.fftfreq(n)[:, None], np.fft.fftfreq(n)[None, :]
    img = np.real(np.fft.ifft2(f * (np.hypot(fy, fx) < cut)))
    return img / img.std()


def _smooth_field(n, peak, seed=1):
    rng = np.random.default_rng(seed)
    field = np.stack([ndi.gaussian_filter(rng.standard_normal((n, n)), n / 6, mode="wrap") for _ in range(2)])
    return field * (peak / np.abs(field).max())


def test_field_cells_are_bounded_by_the_budget():
    """However long the path, a pixel takes at most FIELD_CELLS cells (3 samples each); short paths
    keep their cells of at most one pixel."""
    from gfgpu.motion import spec
    from gfgpu.motion.field import FIELD_CELLS, FIELD_DENSITY, FIELD_MAX
    for code, most in enumerate(FIELD_CELLS):
        assert most >= spec.PSF_MIN_CELLS[code]
        lengths = np.array([0.0, 0.3, 5.0, 30.0, 1000.0, FIELD_MAX])
        cells = spec.psf_cells(code, lengths, FIELD_DENSITY, most)
        unbounded = spec.psf_cells(code, lengths, FIELD_DENSITY)
        assert cells.max() == most and (cells <= most).all()
        np.testing.assert_array_equal(cells, np.minimum(unbounded, most))
    assert spec.psf_cells(0, np.array([30.0]), FIELD_DENSITY, FIELD_CELLS[0])[0] == 30


@pytest.mark.parametrize("psf", range(4))
def test_field_budget_kernel_matches_specification(backend, psf):
    """The fused kernel with a budget against its float64 specification, paths far beyond it."""
    from gfgpu.motion import kernels, spec
    rng = np.random.default_rng(11 + psf)
    dtypes = (np.float32, np.float64) if backend.supports_float64 else (np.float32,)
    for dtype in dtypes:
        coef = rng.standard_normal((2, 14, 17)).astype(dtype)
        field = (rng.standard_normal((2, 14, 17)) * 60).astype(dtype)
        field[:, 3, 4] = 0.0
        for mode in ("wrap", "nearest", "constant"):
            out = backend.empty(coef.shape, dtype)
            kernels.field_blur(backend, backend.asarray(coef), backend.asarray(field), out, psf, 1.0, mode, 0.3, 9 + 36)
            ref = spec.field_blur_reference(coef, field, psf, 1.0, mode, 0.3, 9 + 36)
            got = backend.to_host(out).reshape(ref.shape)
            tol = 1e-11 if dtype == np.float64 else 2e-5
            assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max()), (dtype, mode)


@pytest.mark.parametrize("psf, copies", [("box", 512), ("green", 2048)])
def test_field_up_to_30_px_matches_the_supersampled_rendering(backend, psf, copies, exact_cells):
    """A smooth field with |v| up to 30 px within the budget: within 2 % (rel. L2, 4-px margin) of
    the average of exactly warped copies (scipy's cubic spline; G_u's mass per time cell from its
    closed form), on band-limited noise (cut 0.25 cycles/px), float32 and float64."""
    img = _bandlimited(40, 0.25, seed=2)
    field = _smooth_field(40, 30.0)
    if psf == "box":
        t = (np.arange(copies) + 0.5) / copies
        wts = np.full(copies, 1.0 / copies)
    else:
        t, wts = green_cells(copies, 20.0)
    coef = ndi.spline_filter(img, 3, mode="grid-wrap")
    yy, xx = np.mgrid[:40, :40].astype(float)
    ref = np.zeros_like(img)
    for ti, wi in zip(t, wts):
        ref += wi * ndi.map_coordinates(coef, [yy - ti * field[0], xx - ti * field[1]], order=3, mode="grid-wrap",
                                        prefilter=False)
    for dtype in (np.float32, np.float64) if backend.supports_float64 else (np.float32,):
        out = motion_blur(img.astype(dtype), field, psf=psf, mode="wrap", backend=backend.name)
        d, r = (out - ref)[4:-4, 4:-4], ref[4:-4, 4:-4]
        assert np.linalg.norm(d) / np.linalg.norm(r) < 0.02, dtype


def test_field_beyond_the_budget_runs_its_exact_cells_or_is_refused(backend, exact_cells):
    """Paths longer than the budget's cells are never sampled more sparsely (a 4096-px box field
    of noise came out 0.45 off the row mean): within the total limit they run their exact cells
    (the unbounded specification, and the uniform blur for a uniform field); beyond it the call
    is refused before work, with the reason (it ran 64 s for the box on 64 x 64)."""
    from gfgpu.motion import spec
    from gfgpu.motion.field import FIELD_DENSITY, FIELD_TOTAL
    img = _bandlimited(24, 0.2, seed=4)
    field = np.zeros((2, 24, 24))
    field[1] = 100.0
    field[0] = np.linspace(-60, 60, 24)[None, :]
    coef = ndi.spline_filter(img, 3, mode="grid-wrap")[None]
    tol = 1e-9 if backend.supports_float64 else 1e-4
    for psf, code in (("box", 0), ("green", 1)):
        out = motion_blur(img, field, psf=psf, mode="wrap", backend=backend.name)
        ref = spec.field_blur_reference(coef, field, code, FIELD_DENSITY, "wrap", 0.0)[0]
        np.testing.assert_allclose(out, ref, atol=tol)
    uniform = np.zeros((2, 24, 24))
    uniform[1] = 100.0
    np.testing.assert_allclose(motion_blur(img, uniform, psf="box", mode="wrap", backend=backend.name),
                               motion_blur(img, (0.0, 100.0), psf="box", mode="wrap", backend=backend.name), atol=tol)
    long = np.zeros((2, 24, 24))
    long[1] = 4096.0
    assert 3 * 4096 * 24 * 24 > FIELD_TOTAL
    bad = img.copy()
    bad[0, 0] = np.nan          # refused before the image is read
    for psf in ("box", "green"):
        with pytest.raises(ValueError, match="velocity field too long for its cost budget"):
            motion_blur(bad, long, psf=psf, backend=backend.name)


@pytest.mark.parametrize("bad, match", [(4096.5, "within ±4096"), (np.inf, "finite"), (np.nan, "finite")])
def test_field_beyond_the_largest_velocity_is_refused_before_work(backend, bad, match, exact_cells):
    img = np.random.default_rng(0).random((6, 7))
    field = np.zeros((2, 6, 7))
    field[0, 2, 3] = bad
    out = np.full_like(img, 5.0)
    with pytest.raises(ValueError, match=match):
        motion_blur(img, field, output=out, backend=backend.name)
    assert (out == 5.0).all()
