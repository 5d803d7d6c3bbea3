"""Shape from shading (GSFS) and photometric motion: identities, accuracy, backends, errors."""
import math

import numpy as np
import pytest

import gfgpu
from gfgpu import shading
from gfgpu.greens import HomogeneousGreen, UniformGreen

SIZE = 64


def _grid(size=SIZE):
    c = (size - 1) / 2
    yy, xx = np.mgrid[:size, :size].astype(np.float64)
    return yy - c, xx - c


def _sphere(size=SIZE):
    y, x = _grid(size)
    r = 0.35 * size
    inside = x * x + y * y < r * r
    z = np.where(inside, np.sqrt(np.clip(r * r - x * x - y * y, 0, None)), 0.0)
    zz = np.maximum(z, 1e-3 * r)
    return z, np.where(inside, -x / zz, 0.0), np.where(inside, -y / zz, 0.0)


def _gaussians(size=SIZE):
    y, x = _grid(size)
    z, p, q = (np.zeros_like(x) for _ in range(3))
    for cx, cy, a, w in [(-12, -10, 7, 8), (15, -12, 5, 6), (0, 14, 8, 7), (-15, 15, 4, 4.5)]:
        g = a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * w * w))
        z += g
        p += -g * (x - cx) / (w * w)
        q += -g * (y - cy) / (w * w)
    return z, p, q


def _render(p, q, light):
    L = shading.parse_light(light)
    return np.maximum(0.0, (L[2] - L[0] * p - L[1] * q) / np.sqrt(1 + p * p + q * q))


def _pearson(a, b):
    return float(np.corrcoef(np.ravel(a), np.ravel(b))[0, 1])


# ----------------------------------------------------------------------------------------
# the operator
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("u", [0.7, 3.0, 25.0])
def test_fused_kernel_is_half_sum_of_g_and_h(backend, rng, u):
    img = rng.standard_normal((9, 80))
    be = backend.name
    half = 0.5 * (gfgpu.green_filter(img, UniformGreen(u), mode="reflect", backend=be)
                  + gfgpu.green_filter(img, HomogeneousGreen(u), mode="reflect", backend=be))
    fused = gfgpu.green_filter(img, shading.ShadingGreen(u), mode="reflect", backend=be)
    np.testing.assert_allclose(fused, half, rtol=0, atol=1e-12 * np.abs(half).max())


def test_fused_kernel_matches_its_closed_form():
    u = 4.0
    line = np.zeros(200)
    line[10] = 1.0
    out = gfgpu.green_filter(line, shading.ShadingGreen(u), mode="constant", backend="numpy")
    ref = shading.ShadingGreen(u)(np.arange(200), 10)
    np.testing.assert_allclose(out, ref, atol=1e-14)


def test_eq32_identity_holds_to_third_order():
    """Ī2 = ½(G+H)*I1 equals I2 + (½G − G*H + ½H)*I2, I2 = G*I1, up to O((uω)³) (docs/derivations.md)."""
    u, n = 20.0, 4096
    errs = []
    for k in (16, 8):          # uω = 0.49, 0.25: halving uω must cut the error about 8-fold
        x = np.arange(n)
        i1 = np.cos(2 * np.pi * k * x / n)
        f = lambda img, kern: gfgpu.green_filter(img, kern, mode="wrap", backend="numpy")
        G, H = UniformGreen(u), HomogeneousGreen(u)
        lhs = f(i1, shading.ShadingGreen(u))
        i2 = f(i1, G)
        rhs = i2 + 0.5 * f(i2, G) - f(f(i2, H), G) + 0.5 * f(i2, H)
        errs.append(np.abs(lhs - rhs).max())
    uw = u * 2 * np.pi * 16 / n
    assert errs[0] < 1.5 * 0.75 * uw**3          # residual (3/4)|ε|³, docs/derivations.md
    assert 5.0 < errs[0] / errs[1] < 11.0        # third order: ratio 2³ = 8


# ----------------------------------------------------------------------------------------
# accuracy and backends
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("surface, light", [(_sphere, (1, 0, 1)), (_sphere, (-1, 0, 1)),
                                            (_sphere, (5, 5, 7)), (_gaussians, (1, 0, 1)),
                                            (_gaussians, (5, 5, 7)), (_gaussians, (-1, 0, 1))])
def test_gsfs_depth_correlates_with_truth(backend, surface, light):
    # (the sphere under (0,1,2) reaches r = 0.85 only: docs/shading.md)
    z, p, q = surface()
    img = _render(p, q, light).astype(np.float32)
    est = shading.shape_from_shading(img, light=light, backend=backend.name)
    assert est.dtype == np.float32 and est.shape == img.shape
    assert _pearson(est, z) >= 0.9


def test_gsfs_backends_agree(backend):
    z, p, q = _gaussians()
    img = _render(p, q, (5, 5, 7)).astype(np.float32)
    ref = shading.shape_from_shading(img, light=(5, 5, 7), k1=1.0, backend="numpy")
    out = shading.shape_from_shading(img, light=(5, 5, 7), k1=1.0, backend=backend.name)
    np.testing.assert_allclose(out, ref, rtol=0, atol=2e-5 * np.abs(ref).max())


def test_gsfs_own_scale_is_near_the_least_squares_scale():
    z, p, q = _gaussians()
    img = _render(p, q, (1, 0, 1))
    est = shading.shape_from_shading(img, light=(1, 0, 1), backend="numpy")
    a = np.polyfit(est.ravel(), z.ravel(), 1)[0]
    assert 0.5 < a < 2.0           # the re-rendering rule finds the depth scale within 2x


def test_gsfs_k1_options_scale_the_same_shape():
    z, p, q = _sphere()
    img = _render(p, q, (1, 0, 1))
    unit = shading.shape_from_shading(img, light=(1, 0, 1), k1=1.0, backend="numpy")
    lin = shading.shape_from_shading(img, light=(1, 0, 1), k1="linear", backend="numpy")
    ren = shading.shape_from_shading(img, light=(1, 0, 1), backend="numpy")
    for other in (lin, ren):
        assert abs(_pearson(unit, other)) > 1 - 1e-9
    assert _pearson(lin, z) > 0.9            # k1 = -ρ sin σ < 0 gives the right sign
    np.testing.assert_allclose(shading.shape_from_shading(img, light=(1, 0, 1), k1=-2.0, backend="numpy"),
                               -0.5 * unit, atol=1e-12)


def test_gsfs_light_given_as_tilt_slant_matches_vector():
    z, p, q = _gaussians()
    img = _render(p, q, (1, 1, math.sqrt(2)))
    a = shading.shape_from_shading(img, light=(1, 1, math.sqrt(2)), k1=1.0, backend="numpy")
    b = shading.shape_from_shading(img, light=(math.pi / 4, math.pi / 4), k1=1.0, backend="numpy")
    np.testing.assert_allclose(a, b, atol=1e-9)


def test_gsfs_does_not_modify_input_and_keeps_float64():
    z, p, q = _sphere()
    img = _render(p, q, (1, 0, 1))
    copy = img.copy()
    est = shading.shape_from_shading(img, light=(1, 0, 1), backend="numpy")
    assert est.dtype == np.float64
    np.testing.assert_array_equal(img, copy)
    est8 = shading.shape_from_shading((img * 255).astype(np.uint8), light=(1, 0, 1), backend="numpy")
    assert est8.dtype == np.float32


def test_photometric_motion_recovers_a_frontally_lit_cap(backend):
    y, x = _grid()
    z = np.sqrt(48.0**2 - x * x - y * y)
    img = shading.lambertian_shading(z, (0, 0, 1)).astype(np.float32)
    est = shading.photometric_motion(img, light=(0, 0, 1), backend=backend.name)
    assert est.dtype == np.float32
    assert _pearson(est, z) >= 0.95


def _texture(size=SIZE, seed=3):
    """A smooth random surface filling the frame (no background), RMS slope 0.4."""
    from scipy import ndimage
    rng = np.random.default_rng(seed)
    z = ndimage.gaussian_filter(rng.standard_normal((size, size)), 4.0, mode="reflect")
    q, p = np.gradient(z)
    z *= 0.4 / math.sqrt(float((p * p + q * q).mean()))
    q, p = np.gradient(z)
    return z, p, q


def test_background_and_texture_scenes_are_told_apart():
    for light in ((1, 0, 1), (5, 5, 7)):
        for surface, expected in ((_sphere, True), (_gaussians, True), (_texture, False)):
            z, p, q = surface()
            assert shading.has_background(_render(p, q, light)) is expected
    z, p, q = _sphere()
    flat = shading.flat_background(_render(p, q, (1, 0, 1)))
    y, x = _grid()
    outside = x * x + y * y > (0.35 * SIZE + 10) ** 2      # beyond the smoothing and erosion
    assert flat[outside].mean() > 0.9 and not flat[x * x + y * y < (0.3 * SIZE) ** 2].any()
    _, p, q = _texture()
    assert not shading.flat_background(_render(p, q, (1, 0, 1))).any()


def test_background_boundary_puts_line_ends_on_the_reference_plane(backend):
    z, p, q = _sphere()
    img = _render(p, q, (1, 0, 1))
    est = shading.shape_from_shading(img, light=(1, 0, 1), k1=1.0, boundary="background",
                                     backend=backend.name)
    # each row's constant and ramp are the least-squares fit putting its anchors (flat pixels and
    # both ends) on one plane: equal anchor means and no anchor-weighted ramp left, row by row
    anchors = shading.flat_background(img)
    anchors[:, [0, -1]] = True
    t = np.arange(SIZE) - (SIZE - 1) / 2
    means = [est[i, anchors[i]].mean() for i in range(SIZE)]
    ramps = [np.polyfit(t[anchors[i]], est[i, anchors[i]], 1)[0] for i in range(SIZE)]
    assert np.ptp(means) < 1e-6 * np.ptp(est) and np.abs(ramps).max() < 1e-6 * np.ptp(est)
    assert abs(_pearson(est, z)) > 0.9


def test_free_boundary_gives_zero_mean_lines_and_beats_the_background_prior_on_texture(backend):
    z, p, q = _texture()
    img = _render(p, q, (1, 0, 1))
    free = shading.shape_from_shading(img, light=(1, 0, 1), k1=1.0, boundary="free", backend=backend.name)
    np.testing.assert_allclose(free.mean(axis=1), 0, atol=1e-9 * np.abs(free).max())
    auto = shading.shape_from_shading(img, light=(1, 0, 1), k1=1.0, backend=backend.name)
    np.testing.assert_array_equal(auto, free)          # 'auto' sees no background here
    bg = shading.shape_from_shading(img, light=(1, 0, 1), boundary="background", backend=backend.name)
    assert abs(_pearson(free, z)) > _pearson(bg, z) and abs(_pearson(free, z)) > 0.8


def test_noise_sigma_estimates_white_noise():
    rng = np.random.default_rng(0)
    z, p, q = _texture(128)
    img = _render(p, q, (1, 0, 1))
    assert shading.noise_sigma(img) < 0.002          # smooth shading barely registers
    assert abs(shading.noise_sigma(img + 0.02 * rng.standard_normal(img.shape)) - 0.02) < 0.003


# ----------------------------------------------------------------------------------------
# light estimate
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("tilt_deg", [0, 45, 120, -90])
def test_illuminant_tilt_of_a_sphere(tilt_deg):
    y, x = _grid(96)
    z = np.sqrt(np.clip(60.0**2 - x * x - y * y, 0, None))
    light = (math.radians(tilt_deg), math.radians(40))
    est, albedo = shading.estimate_illuminant(shading.lambertian_shading(z, light))
    tilt = math.degrees(math.atan2(est[1], est[0]))
    assert abs((tilt - tilt_deg + 180) % 360 - 180) < 5
    assert 0.5 < albedo < 1.5


def test_illuminant_ignores_a_flat_background():
    z, p, q = _sphere(96)
    light = shading.parse_light((1, 0, 1))
    img = _render(p, q, light)
    angle = {}
    for exclude in (False, True):
        est, _ = shading.estimate_illuminant(img, exclude_background=exclude)
        angle[exclude] = math.degrees(math.acos(min(1.0, float(est @ light))))
    assert angle[False] > 15 and angle[True] < 8


# ----------------------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------------------
def test_bad_inputs_raise_clear_errors():
    z, p, q = _sphere()
    img = _render(p, q, (1, 0, 1))
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


def test_frontal_light_runs_with_an_explicit_direction():
    z, p, q = _sphere()
    img = _render(p, q, (0, 0, 1))
    est = shading.shape_from_shading(img, light=(0, 0, 1), direction=0.0, backend="numpy")
    assert np.isfinite(est).all()
