"""The coordinate convention: every pair in array-axis order (rows, cols) -- velocities, zoom
centres and rates, ``estimate_translation``, ``synthesize_motion`` -- and the ``gfgpu blur``
options that map onto them."""


import numpy as np
import pytest

from gfgpu.motion import estimate_translation, motion_blur, synthesize_motion

from .common import centroid


@pytest.mark.parametrize("velocity", [(6.0, 0.0), (0.0, -9.0), (5.0, 5.0), (-4.0, 11.0)])
def test_velocity_is_rows_then_cols(velocity):
    """motion_blur(impulse, (vy, vx)) moves the centroid vy rows down and vx columns right,
    like gfgpu.shift(impulse, (dy, dx)), on a non-square image."""
    import gfgpu
    img = np.zeros((300, 420))
    img[150, 210] = 1.0
    out = motion_blur(img, velocity, mode="constant", backend="numpy")
    cy, cx = centroid(out, 150, 210)
    tol = 0.05 if velocity[0] * velocity[1] == 0 or abs(velocity[0]) == abs(velocity[1]) else 0.5
    assert abs(cy - (150 + velocity[0])) < tol and abs(cx - (210 + velocity[1])) < 0.05
    sy, sx = centroid(gfgpu.shift(img, velocity, mode="constant", backend="numpy"), 150, 210)
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
    np.testing.assert_allclose([centroid(f, 0, 0) for f in frames], [(20, 30), (38, 30), (56, 30)], atol=0.05)


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
