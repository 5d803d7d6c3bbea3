"""Zoom blur (kind 'zoom'): the cell weights of G_U^(1) against quadrature, direct O(N²)
summation, the affine pre-image, the fixed point; zoom-out (u1 < 0), run inward from beyond the
border; a fixed point outside the image is refused."""

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from gfgpu.greens import g_affine
from gfgpu.motion import motion_blur, zoom_cell_weights

from .common import float_dtype


def test_cell_weights_are_the_integrals_of_eq11():
    for u1 in (0.3, 1.2, 1.8):
        s = 7.0
        w = zoom_cell_weights(s, np.arange(8.0), u1)
        ref = [quad(lambda xi, s=s, u1=u1: float(g_affine(s, xi, u1, 0.0)), max(k - 0.5, 1e-12),
                    min(k + 0.5, s), limit=200)[0] for k in range(8)]
        np.testing.assert_allclose(w, ref, atol=1e-9)
        assert abs(w.sum() - 1.0) < 1e-12          # unit DC gain (∫ G_U^(1) dx0 = 1)


def _zoom_oracle(line, u1, c):
    """Direct O(N^2) summation of the cell-integrated G_U^(1) outward from c, with the
    two-tap moment correction (own pixel and its predecessor toward c) that makes each
    output's weights sum to 1 and average to the pre-image c + (x - c)/(1 + u1)."""
    n = len(line)
    xs = np.arange(n)
    first_right, first_left = math.floor(c), math.ceil(c)
    out = np.empty(n)
    for x in range(n):
        src = xs[xs <= x] if x >= c else xs[xs >= x]
        dist = (src - c) if x >= c else (c - src)
        s = abs(x - c)
        w = zoom_cell_weights(s, dist, u1)
        first = x == (first_right if x >= c else first_left)
        if s > 0 and not first:
            m0, m1 = w.sum(), (w * dist).sum()
            # d_prev at distance s - 1, d_own at s: d_prev + d_own = 1 - m0 and
            # d_prev (s - 1) + d_own s = s/(1 + u1) - m1
            d_prev = m1 + (1 - m0) * s - s / (1 + u1)
            w[src == x - np.sign(x - c)] += d_prev
            w[src == x] += (1 - m0) - d_prev
        out[x] = (w * line[src]).sum()
    return out


@pytest.mark.parametrize("center", [20.0, 20.5, 20.3, 0.0, 63.0])
def test_zoom_matches_direct_summation(backend, center):
    rng = np.random.default_rng(4)
    dtype = float_dtype(backend)
    img = rng.random((5, 64)).astype(dtype)
    for u1 in (0.1, 0.6, 1.5):
        out = motion_blur(img, (0.0, u1), kind="zoom", center=(2, center), backend=backend.name)
        ref = _zoom_oracle(img[3].astype(np.float64), u1, center)
        tol = 1e-12 if dtype == np.float64 else 1e-5
        assert np.linalg.norm(out[3] - ref) / np.linalg.norm(ref) < tol


def test_zoom_samples_the_affine_preimage():
    ramp = np.tile(np.arange(512.0), (4, 1))
    c = 200.0
    for u1 in (0.1, 0.5, 1.0, 1.5):
        out = motion_blur(ramp, (0.0, u1), kind="zoom", center=(1.5, c), backend="numpy")[1]
        err = out - (c + (np.arange(512) - c) / (1 + u1))
        assert np.abs(err).max() < 1e-9


def test_zoom_maps_points(backend):
    """Output pixel x shows the input at the affine pre-image (both axes), i.e. the point at p
    moves to x_U + (p - x_U)(1 + u1): the zoom applied to the coordinate images."""
    dtype = float_dtype(backend)
    yy, xx = np.mgrid[:200, :240].astype(dtype)
    for cy, cx in ((90.0, 100.0), (89.5, 100.4)):
        for u1 in (0.02, 0.25, 0.8, 1.5, 1.9):
            # separable (rates (u1, u1 + 1e-12): exact to rounding) and along the rays (one rate:
            # the polar resampling leaves 0.094 px here, 0.17 px for other centres, next to the
            # fixed point, where the radial spline mirrors each ray instead of continuing it on the
            # opposite ray)
            for rates, tol in (((u1, u1 + 1e-12), 1e-9 if dtype == np.float64 else 2e-3), (u1, 0.1)):
                mx = motion_blur(xx, rates, kind="zoom", center=(cy, cx), backend=backend.name)
                my = motion_blur(yy, rates, kind="zoom", center=(cy, cx), backend=backend.name)
                ex, ey = mx - (cx + (xx - cx) / (1 + u1)), my - (cy + (yy - cy) / (1 + u1))
                assert np.abs(ex).max() < tol and np.abs(ey).max() < tol, (cx, u1, rates)


def test_zoom_fixed_point_is_kept():
    img = np.random.default_rng(5).random((33, 41))
    out = motion_blur(img, 0.9, kind="zoom", center=(16, 20), backend="numpy")
    assert abs(out[16, 20] - img[16, 20]) < 1e-12
    assert np.array_equal(motion_blur(img, 0.0, kind="zoom", backend="numpy"), img)


# --------------------------------------------------------------------------------------
# zoom-out (u1 < 0): anticausal G_U^(1), run inward from beyond the border
# --------------------------------------------------------------------------------------
def _g_affine_out(s, xi, u1):
    """The bounded zoom-out kernel of eq. 10 (docs/motion.md), written out independently."""
    alpha = 0.5 - 1 / u1
    beta = np.sqrt(1 + u1 - u1 * u1 / 4) / abs(u1)
    t = np.log(xi / s)
    return 2 / (u1 * u1 * beta * xi) * np.exp(-alpha * t) * np.sin(beta * t)


def test_zoom_out_cell_weights_are_the_integrals_of_the_kernel():
    for u1 in (-0.1, -0.5, -0.8):
        s = 7.0
        k = np.arange(7.0, 15.0)
        w = zoom_cell_weights(s, k, u1)
        ref = [quad(lambda xi, s=s, u1=u1: _g_affine_out(s, xi, u1), max(kk - 0.5, s), kk + 0.5,
                    limit=200)[0] for kk in k]
        np.testing.assert_allclose(w, ref, atol=1e-9)
        assert not zoom_cell_weights(s, np.arange(7.0), u1).any()      # nothing nearer than s
        tail = zoom_cell_weights(s, np.arange(7.0, 2e6), u1).sum()
        assert abs(tail - 1.0) < 1e-5                                  # ∫ G dx0 = 1
    assert zoom_cell_weights(0.0, 0.0, -0.4) == 1.0                    # the fixed point stays


def _zoom_out_oracle(line, u1, c, mode):
    """Direct O(N^2) summation of the cell-integrated zoom-out kernel, inward toward c.

    The line is extended by ``n`` pixels beyond each border through ``mode`` (``"constant"``:
    cval 0; ``"nearest"``: the border value); the outermost pixel's cell reaches to infinity
    (it takes the rest of the unit mass).  Where that cell's weight is negligible, the
    two-tap moment correction (own pixel and the next pixel outward) makes the weights
    sum to 1 and average to the pre-image c + (x - c)/(1 + u1).
    """
    n = len(line)
    ext = np.arange(-n, 2 * n)
    inside = (ext >= 0) & (ext < n)
    values = line[np.clip(ext, 0, n - 1)] * (inside if mode == "constant" else 1.0)
    out = np.empty(n)
    for x in range(n):
        src, vals = (ext[ext >= x], values[ext >= x]) if x >= c else (ext[ext <= x], values[ext <= x])
        dist = np.abs(src - c)
        s = abs(x - c)
        w = zoom_cell_weights(s, dist, u1)
        far = np.argmax(dist)
        w[far] += 1.0 - w.sum()
        if s > 0 and abs(w[far]) <= 1e-9:
            m0, m1 = w.sum(), (w * dist).sum()
            # d_next at distance s + 1, d_own at s: d_next + d_own = 1 - m0 and
            # d_next (s + 1) + d_own s = s/(1 + u1) - m1
            d_next = s / (1 + u1) - m1 - (1 - m0) * s
            w[src == x + np.sign(x - c)] += d_next
            w[src == x] += (1 - m0) - d_next
        out[x] = (w * vals).sum()
    return out


@pytest.mark.parametrize("center", [20.0, 20.5, 20.3, 0.0, 63.0])
def test_zoom_out_matches_direct_summation(backend, center):
    rng = np.random.default_rng(7)
    dtypes = [np.float32] + ([np.float64] if backend.supports_float64 else [])
    for dtype, u1, mode in itertools.product(dtypes, (-0.1, -0.5, -0.8), ("constant", "nearest")):
        img = rng.random((5, 64)).astype(dtype)
        tol = 1e-12 if dtype == np.float64 else 1e-5
        out = motion_blur(img, (0.0, u1), kind="zoom", center=(2, center), mode=mode,
                          backend=backend.name)
        ref = _zoom_out_oracle(img[3].astype(np.float64), u1, center, mode)
        assert out.dtype == dtype
        assert np.linalg.norm(out[3] - ref) / np.linalg.norm(ref) < tol, (dtype, u1, mode)


def test_zoom_out_maps_points(backend):
    """Output pixel x shows the input at the pre-image x_U + (x - x_U)/(1 + u1), further out:
    content contracts toward the fixed point.  Checked away from the borders, whose mode
    extension the kernel's power-law tail reaches (docs/motion.md)."""
    dtype = float_dtype(backend)
    yy, xx = np.mgrid[:200, :240].astype(dtype)
    cy, cx = 100.0, 120.0
    u1 = -0.1
    mx = motion_blur(xx, u1, kind="zoom", center=(cy, cx), mode="nearest", backend=backend.name)
    my = motion_blur(yy, u1, kind="zoom", center=(cy, cx), mode="nearest", backend=backend.name)
    ex, ey = mx - (cx + (xx - cx) / (1 + u1)), my - (cy + (yy - cy) / (1 + u1))
    dx, dy = np.abs(xx - cx), np.abs(yy - cy)
    assert np.abs(ex[(dx >= 5) & (dx <= 39)]).max() < 0.1     # 5 px .. a third of the way out
    assert np.abs(ey[(dy >= 5) & (dy <= 33)]).max() < 0.1
    assert np.abs(ex[dx < 5]).max() < 0.2 and np.abs(ey[dy < 5]).max() < 0.2
    # u1 = -0.3 reaches further (tail ~ (s/x0)^alpha, alpha = 3.8): a long line, s <= S/10
    line = np.tile(np.arange(1201, dtype=dtype), (3, 1))
    out = motion_blur(line, (0.0, -0.3), kind="zoom", center=(1, 600), mode="nearest",
                      backend=backend.name)[1]
    err = out - (600 + (np.arange(1201) - 600) / 0.7)
    d = np.abs(np.arange(1201) - 600)
    assert np.abs(err[(d >= 5) & (d <= 60)]).max() < 0.1


@pytest.mark.parametrize("mode", ["nearest", "reflect", "mirror", "wrap", "constant"])
def test_zoom_out_unit_dc_gain(backend, mode):
    dtype = float_dtype(backend)
    img = np.full((2, 37, 50), 0.75, dtype)
    out = motion_blur(img, (-0.25, -0.7), kind="zoom", center=(30, 13.5), mode=mode, cval=0.75,
                      backend=backend.name)
    tol = 1e-12 if dtype == np.float64 else 1e-5
    assert out.dtype == dtype and np.abs(out - 0.75).max() < tol
    # constant mode with another cval: the mass beyond the border is cval's
    dark = motion_blur(img, -0.3, kind="zoom", mode="constant", cval=0.0, backend=backend.name)
    assert dark[0, 18, 25] > 0.74 and dark[0, 0, 0] < 0.6


def test_zoom_out_fixed_point_and_mode_effect():
    img = np.random.default_rng(8).random((33, 41))
    out = motion_blur(img, -0.6, kind="zoom", center=(16, 20), backend="numpy")
    assert abs(out[16, 20] - img[16, 20]) < 1e-12
    ref = motion_blur(img, -0.2, kind="zoom", mode="reflect", backend="numpy")
    wrap = motion_blur(img, -0.2, kind="zoom", mode="wrap", backend="numpy")
    diff = np.abs(ref - wrap)   # the extension matters at the border, hardly near the centre
    assert diff[15:18, 19:22].max() < 1e-5 and diff.max() > 1e-2
    assert np.array_equal(img, np.random.default_rng(8).random((33, 41)))   # input untouched


def test_zoom_about_a_point_outside_the_image_is_refused_by_both_psfs():
    # both zoom layouts (rays, separable lines) split each line at the fixed point
    from gfgpu.motion import motion_blur
    img = np.random.default_rng(2).random((24, 30)).astype(np.float32)
    for psf, rates in (("green", 0.1), ("green", (0.1, 0.2)), ("box", 0.1)):
        with pytest.raises(ValueError, match="center"):
            motion_blur(img, rates, kind="zoom", psf=psf, center=(-40.0, 70.0), backend="numpy")


@pytest.mark.parametrize("shape", [(3, 5000), (5000, 3), (64, 4000)])
@pytest.mark.parametrize("kind, velocity, psf", [("zoom", 0.1, "green"), ("zoom", -0.5, "box"), ("zoom", 0.3, "box"),
                                                 ("rotation", 10.0, "green")])
def test_a_polar_grid_far_larger_than_the_image_is_refused_before_any_work(shape, kind, velocity, psf):
    """A zoom of 3 x 5000 pixels sampled a polar grid of 4e7 points (> 90 s); it is refused with
    the reason before the image is read: a non-finite image gets this refusal, not the
    non-finite one that reading it would give."""
    if kind == "rotation" and shape == (64, 4000):
        pytest.skip("a spin's banded grid of 64 x 4000 fits the budget (it runs)")
    img = np.ones(shape, np.float32)
    img[0, 0] = np.nan
    with pytest.raises(ValueError, match=r"polar grid about center \(row, col\).*samples for .* pixels"):
        motion_blur(img, velocity, kind=kind, psf=psf, backend="numpy")


def test_polar_cost_budget_admits_square_images_and_moderate_strips():
    from gfgpu.motion.polar import POLAR_FLOOR, POLAR_PER_PIXEL, polar_samples
    for h, w in ((2048, 2048), (4096, 4096), (512, 512), (16, 300)):
        for reach, split in ((1.0, False), (2.0, False), (1.0, True)):
            # centred and at a corner: a square's grid is a few samples per pixel
            for cy, cx in (((h - 1) / 2, (w - 1) / 2), (0.0, 0.0)):
                assert polar_samples(h, w, cy, cx, reach, split) <= POLAR_FLOOR + POLAR_PER_PIXEL * h * w
    strip = np.tile(np.linspace(0.0, 1.0, 300), (16, 1))
    out = motion_blur(strip, 0.2, kind="zoom", psf="box", backend="numpy")
    assert out.shape == strip.shape and np.isfinite(out).all()


@pytest.mark.parametrize("u1", [0.3, -0.4])
def test_ray_pass_along_the_polar_columns_equals_the_duplicated_ray_layout(backend, u1):
    """The radial G_U^(1) zoom runs along the columns of the polar grid (one recursion with
    per-position coefficients on axis 1, then each ring's own tap): the same outputs as the
    duplicated layout that the primitive's constant tap once needed (sample k at positions 2k,
    2k + 1, outputs read at 2k + 1; zoom-out laid out from the far end), run by the numpy
    specification of the primitive."""
    from gfgpu._core.recursion import PassPlan, plan_pass, run_reference
    from gfgpu.motion.zoom import _layout, _segment_terms, ray_zoom_pass

    n, m = 40, 9
    dtype = float_dtype(backend)
    rays = np.random.default_rng(11).random((n, m))            # ray sample k (radius k) on row k
    lam_a, kap_a, lam_b, kap_b = _layout(*_segment_terms(u1, 0.0, n))
    zeros = np.zeros((2, 0), np.complex128)
    plan = PassPlan(np.array([lam_a, lam_b]), np.array([kap_a, kap_b]), zeros, np.zeros(2, np.complex128),
                    0.0, False, False)
    order = rays[::-1] if u1 < 0 else rays                      # traversal order: the far end first
    ref = run_reference(np.repeat(order, 2, axis=0), plan)[1::2]
    ref = ref[::-1] if u1 < 0 else ref

    be = backend
    line_pass, own = ray_zoom_pass(u1, n)
    src = be.asarray(rays.astype(dtype)[None])
    dst = be.empty((1, n, m), dtype)
    be.recurse(src, dst, 1, plan_pass(line_pass, n, "constant", dtype), 0.0)
    out = be.to_host(dst)[0].astype(np.float64) + own[:, None] * rays
    tol = 1e-12 if dtype == np.float64 else 2e-5
    assert np.abs(out - ref).max() <= tol * np.abs(ref).max()
