"""Per-line recursion plans and the three-shear rotation blur (motion_blur kind='rotation')."""
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


def _shear_oracle(img, rate, axis, centre):
    """Direct summation of each line's shift taps w[0] = tap, w[m] = Re(K lam^(m-1)), zeros
    beyond the image (mode 'constant', cval 0); causal for a positive displacement."""
    out = np.empty_like(img)
    lines = img if axis == -1 else img.T
    res = out if axis == -1 else out.T
    n = lines.shape[1]
    m = np.arange(1, n)
    for i, line in enumerate(lines):
        d = rate * (i - centre)
        if abs(d) <= 1e-9:
            res[i] = line
            continue
        lam, kap, tap = greens.shift_coefficients(abs(d))
        w = np.concatenate([[tap], np.real(kap * lam ** (m - 1))])
        full = np.convolve(line if d > 0 else line[::-1], w)[:n]
        res[i] = full if d > 0 else full[::-1]
    return out


@pytest.mark.parametrize("displace", [True, False])
def test_rotation_matches_direct_summation(backend, displace, rng):
    img = rng.random((40, 52))
    degrees, centre = 12.0, (17.5, 30.0)    # (row, col)
    shears = rotation_shears(degrees) if displace else rotation_shears(-degrees / 2) + rotation_shears(degrees / 2)
    ref = img
    for axis, rate in shears:
        ref = _shear_oracle(ref, rate, axis, centre[0] if axis == -1 else centre[1])
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), degrees, kind="rotation", center=centre, displace=displace,
                          mode="constant", backend=backend.name)
        assert out.dtype == dtype
        tol = 1e-12 if dtype == np.float64 else 1e-5
        assert np.linalg.norm(out - ref) / np.linalg.norm(ref) < tol


def test_rotation_maps_points(backend):
    """Output pixel q shows the input at c + R^-1 (q - c): the rotation of the coordinate
    images (exact for linear content away from the borders, every shear being moment-exact)."""
    dtype = _dtypes(backend)[-1]
    yy, xx = np.mgrid[:200, :220].astype(dtype)
    c = (96.0, 109.5)                               # (row, col)
    inner = np.hypot(xx - c[1], yy - c[0]) < 45
    tol = 1e-6 if dtype == np.float64 else 2e-3     # float64: the tails reaching the border
    for degrees in (-6.0, 4.0):
        t = math.radians(degrees)
        mx = motion_blur(xx, degrees, kind="rotation", center=c, mode="nearest", backend=backend.name)
        my = motion_blur(yy, degrees, kind="rotation", center=c, mode="nearest", backend=backend.name)
        dx, dy = xx - c[1], yy - c[0]
        px, py = c[1] + math.cos(t) * dx - math.sin(t) * dy, c[0] + math.sin(t) * dx + math.cos(t) * dy
        assert np.abs(mx - px)[inner].max() < tol and np.abs(my - py)[inner].max() < tol
        # in place (displace=False): the identity map, blurred symmetrically
        kx = motion_blur(xx, degrees, kind="rotation", center=c, mode="nearest", displace=False,
                         backend=backend.name)
        assert np.abs(kx - xx)[inner].max() < tol


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
    for bad in (95.0, -90.5, float("nan")):
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
    out = motion_blur(img, 30.0, kind="rotation", center=(row, col), mode="constant", backend="numpy")
    assert abs(out[row, col] - 1.0) < 1e-9        # the centre does not move
    # counter-clockwise on screen: the right-hand point moves up (to smaller rows)
    window = out[:row + 5, col + 5:]
    yy, xx = np.mgrid[:window.shape[0], :window.shape[1]]
    cy = (window * yy).sum() / window.sum()
    cx = (window * xx).sum() / window.sum() + col + 5
    t = math.radians(30.0)
    assert abs(cy - (row - 20 * math.sin(t))) < 0.2 and abs(cx - (col + 20 * math.cos(t))) < 0.2   # tails cut
    with pytest.raises(ValueError, match="inside the image"):   # (x, y) order would be outside
        motion_blur(img, 0.3, kind="zoom", center=(col, row), backend="numpy")
