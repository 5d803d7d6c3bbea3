"""Motion blur, zoom and frame synthesis (gfgpu.motion)."""

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from gfgpu.greens import g_affine
from gfgpu.motion import (
    estimate_translation,
    interpolate_frames,
    motion_blur,
    synthesize_motion,
    zoom_cell_weights,
)


def _dtype(be):
    return np.float64 if be.supports_float64 else np.float32


def _centroid(img, y, x, r=None):
    """(row, col) centroid of ``img`` (optionally in a window of radius r about (y, x))."""
    yy, xx = np.mgrid[: img.shape[0], : img.shape[1]]
    w = img.astype(np.float64)
    if r is not None:
        w = np.where((np.abs(yy - y) <= r) & (np.abs(xx - x) <= r), w, 0.0)
    return float((w * yy).sum() / w.sum()), float((w * xx).sum() / w.sum())


# --------------------------------------------------------------------------------------
# uniform motion
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("velocity", [(0.0, 12.5), (-7.25, 0.0), (0.0, -14.3), (9.5, 9.5), (6.0, -6.0),
                                      (-3.3, 3.3)])
def test_impulse_displacement_equals_velocity(backend, velocity):
    """velocity = (vy, vx): the impulse moves vy rows down and vx columns right."""
    img = np.zeros((512, 512), _dtype(backend))
    img[256, 256] = 1.0
    out = motion_blur(img, velocity, mode="constant", backend=backend.name)
    assert out.dtype == img.dtype
    assert abs(out.sum() - 1.0) < 1e-5
    cy, cx = _centroid(out, 256, 256)
    assert abs(cy - (256 + velocity[0])) < 0.05
    assert abs(cx - (256 + velocity[1])) < 0.05


def test_edge_displacement_equals_velocity(backend):
    x = np.arange(512)
    img = np.tile((x >= 200).astype(_dtype(backend)), (8, 1))
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
        cy, cx = _centroid(out, 0, 0)
        assert abs(cx - (x + v[1])) < 0.05          # dominant axis exact
        errs.append(cy - (90 + x % 3 + v[0]))
    assert max(abs(e) for e in errs) <= 0.5 + 1e-6
    assert abs(np.mean(errs)) < 0.05


def test_displace_false_keeps_centroid(backend):
    img = np.zeros((256, 256), _dtype(backend))
    img[128, 128] = 1.0
    for v in [(0.0, 20.0), (11.0, 0.0), (-8.0, -8.0)]:
        out = motion_blur(img, v, displace=False, mode="constant", backend=backend.name)
        cy, cx = _centroid(out, 128, 128)
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


# --------------------------------------------------------------------------------------
# zoom
# --------------------------------------------------------------------------------------
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
    dtype = _dtype(backend)
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
    dtype = _dtype(backend)
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
    dtype = _dtype(backend)
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
    dtype = _dtype(backend)
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


# --------------------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------
# frames
# --------------------------------------------------------------------------------------
def test_synthesize_motion_moves_progressively(backend):
    img = np.zeros((64, 600), _dtype(backend))
    img[32, 20] = 1.0
    frames = synthesize_motion(img, (0.0, 36.0), 5, mode="constant", backend=backend.name)
    assert frames.shape == (5, 64, 600)
    np.testing.assert_array_equal(frames[0], img)
    cx = [_centroid(f, 32, 20)[1] for f in frames]
    np.testing.assert_allclose(cx, [20, 29, 38, 47, 56], atol=0.05)


def test_synthesize_zoom_scales_geometrically():
    xx = np.tile(np.arange(128.0), (16, 1))
    calls = []
    frames = synthesize_motion(xx, 0.44, 3, kind="zoom", center=(8, 40), backend="numpy",
                               progress=lambda: calls.append(1))
    assert len(calls) == 3
    for f, scale in zip(frames, (1.0, 1.2, 1.44)):
        np.testing.assert_allclose(f[8, 100], 40 + 60 / scale, atol=0.1)
    with pytest.raises(ValueError, match="n_frames"):
        synthesize_motion(xx, (1, 0), 1)


def test_interpolate_frames_given_and_estimated_velocity():
    from importlib import resources

    import imageio.v3 as iio
    with resources.as_file(resources.files("gfgpu.data").joinpath("camera.png")) as path:
        big = iio.imread(path).astype(np.float64) / 255
    f0, f1 = big[130:330, 140:340], big[124:324, 131:331]   # f1 = f0 moved by (dy, dx) = (6, 9)
    dy, dx = estimate_translation(f0, f1)
    assert abs(dx - 9) < 0.1 and abs(dy - 6) < 0.1
    mids = interpolate_frames(f0, f1, 2)
    given = interpolate_frames(f0, f1, 2, velocity=(6.0, 9.0))
    assert mids.shape == (2,) + f0.shape
    assert np.abs(mids - given).max() < 0.02
    # frame k sits at k/3 of the way: (3, 2) and (6, 4) px, integer shifts cut from `big`
    inner = (slice(20, -20), slice(20, -20))
    for k, mid in enumerate(mids, start=1):
        ty, tx = 2 * k, 3 * k
        truth = big[130 - ty:330 - ty, 140 - tx:340 - tx]
        fade = (1 - k / 3) * f0 + (k / 3) * f1
        err = np.sqrt(np.mean((mid - truth)[inner] ** 2))
        assert err < 0.6 * np.sqrt(np.mean((fade - truth)[inner] ** 2))
    with pytest.raises(ValueError, match="same shape"):
        interpolate_frames(f0, f1[:-1], 1)
    with pytest.raises(ValueError, match="n must be"):
        interpolate_frames(f0, f1, 0)


# --------------------------------------------------------------------------------------
# the coordinate convention: every pair in array-axis order (rows, cols)
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("velocity", [(6.0, 0.0), (0.0, -9.0), (5.0, 5.0), (-4.0, 11.0)])
def test_velocity_is_rows_then_cols(velocity):
    """motion_blur(impulse, (vy, vx)) moves the centroid vy rows down and vx columns right,
    like gfgpu.shift(impulse, (dy, dx)), on a non-square image."""
    import gfgpu
    img = np.zeros((300, 420))
    img[150, 210] = 1.0
    out = motion_blur(img, velocity, mode="constant", backend="numpy")
    cy, cx = _centroid(out, 150, 210)
    tol = 0.05 if velocity[0] * velocity[1] == 0 or abs(velocity[0]) == abs(velocity[1]) else 0.5
    assert abs(cy - (150 + velocity[0])) < tol and abs(cx - (210 + velocity[1])) < 0.05
    sy, sx = _centroid(gfgpu.shift(img, velocity, mode="constant", backend="numpy"), 150, 210)
    assert abs(sy - (150 + velocity[0])) < 1e-3 and abs(sx - (210 + velocity[1])) < 1e-3


def test_zoom_center_is_row_col_and_rates_are_rows_then_cols():
    """center = (row, col): on a non-square image with an off-centre fixed point the fixed
    point stays put; a rate pair is (u1_y, u1_x)."""
    yy, xx = np.mgrid[:40, :90].astype(float)
    row, col = 12.0, 63.0
    for u1 in (0.5, -0.2):
        my = motion_blur(yy, u1, kind="zoom", center=(row, col), mode="nearest", backend="numpy")
        mx = motion_blur(xx, u1, kind="zoom", center=(row, col), mode="nearest", backend="numpy")
        assert abs(my[12, 63] - row) < 1e-9 and abs(mx[12, 63] - col) < 1e-9
        if u1 > 0:   # zoom-in: every pixel shows its pre-image about (row, col) (along the rays: 0.1 px)
            assert np.abs(mx - (col + (xx - col) / (1 + u1))).max() < 0.1
            assert np.abs(my - (row + (yy - row) / (1 + u1))).max() < 0.1
    impulse = np.zeros((40, 90))
    impulse[12, 63] = 1.0
    out = motion_blur(impulse, 0.7, kind="zoom", center=(row, col), backend="numpy")
    assert abs(out[12, 63] - 1.0) < 1e-12 and np.unravel_index(np.argmax(out), out.shape) == (12, 63)
    # (u1_y, u1_x) = (0, 0.5): columns zoomed, rows untouched
    only_x = motion_blur(xx, (0.0, 0.5), kind="zoom", center=(row, col), backend="numpy")
    np.testing.assert_allclose(only_x, col + (xx - col) / 1.5, atol=1e-9)
    np.testing.assert_allclose(motion_blur(yy, (0.0, 0.5), kind="zoom", center=(row, col), backend="numpy"), yy,
                               atol=1e-9)
    with pytest.raises(ValueError, match=r"center \(row, col\) = \(63, 12\)"):
        motion_blur(impulse, 0.5, kind="zoom", center=(col, row), backend="numpy")


def test_estimate_translation_returns_dy_dx():
    from scipy.ndimage import gaussian_filter
    big = gaussian_filter(np.random.default_rng(11).random((180, 220)), 2.0)
    f0, f1 = big[20:140, 30:190], big[17:137, 36:196]      # content of f1: 3 rows down, 6 cols left
    dy, dx = estimate_translation(f0, f1)
    assert abs(dy - 3.0) < 0.1 and abs(dx + 6.0) < 0.1
    rgb = np.stack([f0, 2 * f0, f0 + 1], axis=-1), np.stack([f1, 2 * f1, f1 + 1], axis=-1)
    assert np.allclose(estimate_translation(*rgb), (dy, dx))
    with pytest.raises(TypeError):
        estimate_translation(f0, f1, 20)                    # upsample_factor is keyword-only


def test_synthesize_motion_velocity_is_rows_then_cols():
    img = np.zeros((600, 50))
    img[20, 30] = 1.0
    frames = synthesize_motion(img, (36.0, 0.0), 3, mode="constant", backend="numpy")
    np.testing.assert_allclose([_centroid(f, 0, 0) for f in frames], [(20, 30), (38, 30), (56, 30)], atol=0.05)


def test_blur_command_maps_dx_dy_and_center(tmp_path, capsys):
    """gfgpu blur: --dx/--dy become velocity=(dy, dx); --center-x/--center-y become center=(row, col)."""
    import imageio.v3 as iio

    from gfgpu import io
    from gfgpu.cli import main
    rgb = (np.random.default_rng(12).random((30, 50, 3)) * 255).astype(np.uint8)
    src = tmp_path / "in.png"
    iio.imwrite(src, rgb)
    work = rgb.astype(np.float32)
    cases = [(["--dx", 6, "--dy", -2], dict(velocity=(-2.0, 6.0))),
             (["--dy", 3], dict(velocity=(3.0, 0.0))),
             (["--zoom", 0.3, "--center-x", 40, "--center-y", 8], dict(velocity=0.3, kind="zoom", center=(8, 40))),
             (["--rotate", 10, "--center-x", 12], dict(velocity=10.0, kind="rotation", center=(14.5, 12)))]
    for i, (argv, kw) in enumerate(cases):
        out = tmp_path / f"o{i}.png"
        assert main(["blur", str(src), "-o", str(out), *map(str, argv), "--backend", "numpy", "--quiet"]) == 0
        ref = io.to_display_8bit(motion_blur(work, channel_axis=-1, backend="numpy", **kw), rgb)
        np.testing.assert_array_equal(iio.imread(out), ref)
    assert main(["blur", str(src), "-o", str(tmp_path / "x.png"), "--dx", "1", "--zoom", "0.2", "--quiet"]) == 2
    assert "give one motion" in capsys.readouterr().err



def test_zoom_about_a_point_outside_the_image_is_refused_by_both_psfs():
    # both zoom layouts (rays, separable lines) split each line at the fixed point
    from gfgpu.motion import motion_blur
    img = np.random.default_rng(2).random((24, 30)).astype(np.float32)
    for psf, rates in (("green", 0.1), ("green", (0.1, 0.2)), ("box", 0.1)):
        with pytest.raises(ValueError, match="center"):
            motion_blur(img, rates, kind="zoom", psf=psf, center=(-40.0, 70.0), backend="numpy")


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
