"""Per-line recursion plans, Paeth's three shears, and the spin blur along arcs (motion_blur
kind='rotation'), with the identities of a spin or a zoom too small to see through the polar grid."""
import math

import numpy as np
import pytest

from gfgpu import greens
from gfgpu._core import recursion
from gfgpu.motion import motion_blur, synthesize_motion
from gfgpu.motion.rotation import rotation_shears

MODES = ("constant", "nearest", "reflect", "mirror", "wrap")


def _dtypes(be):
    return [np.float32] + ([np.float64] if be.supports_float64 else [])


# --------------------------------------------------------------------------------------
# the per-line primitive
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("axis", [1, 2])
@pytest.mark.parametrize("mode", MODES)
def test_recurse_lines_equals_one_plan_per_line(backend, axis, mode, rng):
    img = rng.standard_normal((2, 23, 31))
    n, m = img.shape[axis], img.shape[3 - axis]
    amounts = [0.37 * (i - m / 2) + 0.05 for i in range(m)]
    passes = [None if i == 4 else greens.shift_pass(a) for i, a in enumerate(amounts)]
    ref = np.empty_like(img)
    for b in range(img.shape[0]):
        for i in range(m):
            idx = (b, slice(None), i) if axis == 1 else (b, i, slice(None))
            if passes[i] is None:
                ref[idx] = img[idx]
            else:
                plan = recursion.plan_pass(passes[i], n, mode, np.float64)
                ref[idx] = recursion.run_reference(img[idx][:, None], plan, cval=0.5)[:, 0]
    for dtype in _dtypes(backend):
        src = backend.asarray(img.astype(dtype))
        dst = backend.empty(img.shape, dtype)
        backend.recurse_lines(src, dst, axis, recursion.plan_lines(passes, n, mode, dtype), cval=0.5)
        out = backend.to_host(dst)
        tol = 1e-12 if dtype == np.float64 else 2e-5
        assert np.linalg.norm(out - ref) / np.linalg.norm(ref) < tol, dtype


def test_recurse_lines_checks_shapes(backend):
    plans = recursion.plan_lines([greens.shift_pass(1.0)] * 5, 7, "reflect", np.float32)
    src = backend.asarray(np.zeros((1, 5, 7), np.float32))
    with pytest.raises(ValueError, match="plans are for 5 lines of 7"):
        backend.recurse_lines(src, backend.empty((1, 5, 7), np.float32), 1, plans)
    with pytest.raises(ValueError, match="axis must be 1 or 2"):
        backend.recurse_lines(src, backend.empty((1, 5, 7), np.float32), 0, plans)


def test_plan_lines_rejects_multi_section_passes():
    with pytest.raises(ValueError, match="one shift-invariant section"):
        recursion.plan_lines([greens.derivative_passes(1.0)[0]], 8, "reflect", np.float64)


# --------------------------------------------------------------------------------------
# rotation
# --------------------------------------------------------------------------------------
def test_shears_compose_to_the_rotation():
    for degrees in (-80.0, -7.5, 0.0, 30.0, 90.0):
        mat = np.eye(2)
        for axis, rate in rotation_shears(degrees):   # (x, y) matrices, applied right to left
            shear = np.array([[1.0, rate], [0.0, 1.0]]) if axis == -1 else np.array([[1.0, 0.0], [rate, 1.0]])
            mat = shear @ mat
        t = math.radians(degrees)
        np.testing.assert_allclose(mat, [[math.cos(t), math.sin(t)], [-math.sin(t), math.cos(t)]], atol=1e-12)


@pytest.mark.parametrize("psf", ["green", "box"])
def test_spin_keeps_rotation_invariant_content(backend, psf):
    """A function of the radius alone is unchanged by a spin about its centre (every point is
    blurred along its own circle), on a non-square image with an off-centre fixed point."""
    dtype = _dtypes(backend)[-1]
    yy, xx = np.mgrid[:90, :120].astype(np.float64)
    c = (41.0, 57.5)                                 # (row, col)
    r = np.hypot(yy - c[0], xx - c[1])
    img = np.cos(r / 5.0).astype(dtype)
    inner = (r > 3) & (r < 38)
    for degrees in (-6.0, 25.0):
        for displace in (True, False):
            out = motion_blur(img, degrees, kind="rotation", psf=psf, center=c, displace=displace,
                              mode="nearest", backend=backend.name)
            assert np.abs(out - img)[inner].max() < 2e-3


def test_spin_of_radially_symmetric_image_is_unchanged(backend):
    yy, xx = np.mgrid[:81, :81].astype(float)
    r = np.hypot(yy - 40, xx - 40)
    rings = np.cos(r / 4.0)
    for psf in ("green", "box"):
        for deg in (37.0, -360.0):
            out = motion_blur(rings, deg, kind="rotation", psf=psf, center=(40, 40), backend=backend.name)
            assert np.abs(out - rings)[(r > 4) & (r < 36)].max() < 5e-3, (psf, deg)


def test_spin_moves_content_along_the_arc_by_the_angle(backend):
    """Green's PSF has mean exactly one velocity: a blob's angular centroid turns by the angle."""
    yy, xx = np.mgrid[:101, :101].astype(np.float64)
    c = (50.0, 50.0)
    img = np.exp(-((yy - 50.0) ** 2 + (xx - 85.0) ** 2) / 8.0)    # 35 px right of the centre
    for degrees, psf in ((20.0, "green"), (-30.0, "box")):
        out = motion_blur(img, degrees, kind="rotation", psf=psf, center=c, mode="constant", backend=backend.name)
        phi = np.arctan2(c[0] - yy, xx - c[1])
        mean = math.degrees(float((out * phi).sum() / out.sum()))
        expected = degrees if psf == "green" else degrees / 2.0          # the box: the middle of the path
        assert abs(mean - expected) < 0.3
        assert abs(out.sum() - img.sum()) < 1e-3 * img.sum()


def test_rotation_blur_grows_with_radius_and_keeps_the_centre():
    img = np.zeros((129, 129))
    img[64, 64] = 1.0
    img[64, 104] = 1.0                       # 40 px right of the centre
    out = motion_blur(img, 10.0, kind="rotation", displace=False, mode="constant", backend="numpy")
    assert abs(out[64, 64] - 1.0) < 1e-12      # the centre does not move: no blur there
    ring = out[30:100, 90:120]
    assert ring.max() < 0.5                   # the outer impulse is spread along its arc
    ys, xs = np.nonzero(ring > 1e-3 * ring.max())
    assert np.ptp(ys) > 3 * max(np.ptp(xs), 1)   # ... mostly across the radius (tangentially)


def test_rotation_inputs():
    img = np.random.default_rng(1).random((30, 40))
    assert np.array_equal(motion_blur(img, 0.0, kind="rotation", backend="numpy"), img)
    for bad in (361.0, -400.0, float("nan")):
        with pytest.raises(ValueError, match="rotation angle"):
            motion_blur(img, bad, kind="rotation", backend="numpy")
    rgb = np.random.default_rng(2).random((30, 40, 3)).astype(np.float32)
    out = motion_blur(rgb, 8.0, kind="rotation", channel_axis=-1, backend="numpy")
    np.testing.assert_allclose(out[..., 1], motion_blur(rgb[..., 1], 8.0, kind="rotation", backend="numpy"),
                               atol=1e-6)
    frames = synthesize_motion(img, 9.0, 4, kind="rotation", backend="numpy")
    np.testing.assert_allclose(frames[-1], motion_blur(img, 9.0, kind="rotation", backend="numpy"))
    np.testing.assert_array_equal(frames[0], img)


def test_rotation_center_is_row_col():
    """center = (row, col): on a non-square image with an off-centre fixed point, the pixel
    there keeps its value and a point at distance r from it moves along its circle."""
    img = np.zeros((61, 121))
    row, col = 20, 85
    img[row, col] = 1.0
    img[row, col + 20] = 1.0                      # 20 px to the right of the centre
    out = motion_blur(img, 30.0, kind="rotation", psf="box", center=(row, col), mode="constant", backend="numpy")
    assert abs(out[row, col] - 1.0) < 1e-9        # the centre does not move
    # counter-clockwise on screen: the right-hand point moves up (to smaller rows), along its
    # circle: its angular centroid about (row, col) is the middle of the path (box PSF)
    window = out[:row + 5, col + 5:]
    yy, xx = np.mgrid[:window.shape[0], :window.shape[1]]
    phi = np.arctan2(row - yy, xx + col + 5 - col)
    assert abs(math.degrees((window * phi).sum() / window.sum()) - 15.0) < 0.3
    with pytest.raises(ValueError, match="inside the image"):   # (x, y) order would be outside
        motion_blur(img, 0.3, kind="zoom", center=(col, row), backend="numpy")


@pytest.mark.parametrize("mode", ["constant", "nearest", "wrap", "reflect", "mirror"])
def test_tiny_spin_and_zoom_are_identities_in_every_mode(backend, mode):
    """A spin by 1e-6 degree or a zoom by 1e-9 changes (almost) nothing, as scipy.ndimage.rotate
    by that angle does.  Through the polar grid they once lost 0.24 of 2.0 on the border of a
    constant image with mode='constant', and 2.3 (of 31) at column 0 of a ramp with 'wrap'."""
    rng = np.random.default_rng(7)
    for img in (np.full((24, 28), 2.0), np.tile(np.arange(28.0), (24, 1)), rng.random((24, 28))):
        for kw in ({"velocity": 1e-6, "kind": "rotation", "psf": "box"},
                   {"velocity": 1e-6, "kind": "rotation", "psf": "green"},
                   {"velocity": -1e-6, "kind": "rotation", "psf": "green", "displace": False},
                   {"velocity": 1e-9, "kind": "zoom", "psf": "box"},
                   {"velocity": 1e-9, "kind": "zoom", "psf": "green"},
                   {"velocity": -1e-9, "kind": "zoom", "psf": "green"}):
            out = motion_blur(img, mode=mode, cval=0.5, backend=backend.name, **kw)
            np.testing.assert_allclose(out, img, atol=1e-4 * max(1.0, np.ptp(img)), err_msg=f"{kw}")


@pytest.mark.parametrize("mode", ["reflect", "nearest", "wrap"])
@pytest.mark.parametrize("kind, velocity, psf", [("rotation", 10.0, "green"), ("rotation", -25.0, "box"),
                                                 ("zoom", 0.1, "green"), ("zoom", 0.3, "box"), ("zoom", -0.3, "green")])
def test_spin_and_zoom_return_a_constant_image_to_rounding(backend, kind, velocity, psf, mode):
    """w I + R(B P - w P) with w read at each pixel by the radial spline that R applies: a constant
    image comes back exact to rounding in float64 (the closed-form weight at the pixel's radius
    left 2.6e-5 for a spin of 10 degrees, 3.3e-6 for a zoom of 0.1, on every backend)."""
    for dtype in _dtypes(backend):
        img = np.full((40, 52), 3.0, dtype)
        out = motion_blur(img, velocity, kind=kind, psf=psf, mode=mode, backend=backend.name)
        assert out.dtype == dtype
        tol = 1e-13 if dtype == np.float64 else 2e-6
        assert np.abs(out.astype(np.float64) - 3.0).max() <= tol * 3.0


def test_spin_and_zoom_about_two_centres_of_one_shape_in_turn(backend):
    """The polar kernels keep what every call about one centre on one shape shares (the pixels'
    angles, a ring's cosines and sines): calls about two centres in turn each get their own, equal
    to the numpy specification's result."""
    rng = np.random.default_rng(12)
    img = rng.random((48, 60))
    dtype = _dtypes(backend)[-1]
    tol = 1e-10 if dtype == np.float64 else 2e-4
    centres = [(20.0, 25.5), (30.25, 40.0)]
    for _ in range(2):
        for c in centres:
            for kw in ({"velocity": 12.0, "kind": "rotation"}, {"velocity": 0.2, "kind": "zoom", "psf": "box"}):
                out = motion_blur(img.astype(dtype), center=c, backend=backend.name, **kw)
                ref = motion_blur(img, center=c, backend="numpy", **kw)
                np.testing.assert_allclose(out, ref, atol=tol, err_msg=f"{c} {kw}")
