"""What comes next to the map: hole filling, depth and reprojection (Q), point clouds, 16-bit PNG,
the colour bar, and the ``gfgpu disparity`` command that writes them."""


import numpy as np
import pytest

from gfgpu import stereo

from .scenes import random_dot_pair, square


def test_fill_holes_takes_background():
    d = np.array([[1.0, np.nan, np.nan, 5.0], [np.nan, 2.0, np.nan, np.nan]], np.float32)
    np.testing.assert_array_equal(stereo.fill_holes(d), [[1, 1, 1, 5], [2, 2, 2, 2]])


def test_fill_smooth_edges_has_no_streaks():
    rng = np.random.default_rng(0)
    d = np.full((40, 60), 10.0, np.float32) + rng.normal(0, 1, (40, 60)).astype(np.float32)
    d[:, :12] = np.nan                                   # the left band
    d[10:14, 30:33] = np.nan                             # an occlusion: the row rule
    rows = stereo.fill_holes(d)
    smooth = stereo.fill_holes(d, edges="smooth")
    np.testing.assert_array_equal(smooth[10:14, 30:33], rows[10:14, 30:33])
    # row-copied band: each row repeats its own edge value; smooth: neighbouring rows blend
    assert np.abs(np.diff(smooth[:, :8], axis=0)).mean() < 0.3 * np.abs(np.diff(rows[:, :8], axis=0)).mean()
    assert np.isfinite(smooth).all()
    with pytest.raises(ValueError, match="edges"):
        stereo.fill_holes(d, edges="nope")


def test_disparity_to_depth_and_q():
    d = np.array([[8.0, np.nan, -1.0], [0.0, 16.0, 4.0]], np.float32)
    z = stereo.disparity_to_depth(d, 400, 0.2)
    np.testing.assert_allclose(z, [[10, np.nan, np.nan], [np.nan, 5, 20]], equal_nan=True)
    np.testing.assert_allclose(stereo.disparity_to_depth(d, 400, 0.2, doffs=8)[1, 0], 10)
    q = stereo.stereo_q(400, 0.2, (1.0, 2.0))
    pts = stereo.reproject_to_3d(d, q)
    np.testing.assert_allclose(pts[..., 2][d > 0], z[d > 0], rtol=1e-6)
    assert np.isnan(pts[0, 1]).all() and np.isnan(pts[1, 0]).all() and pts[0, 2, 2] < 0   # NaN, W = 0, behind
    np.testing.assert_allclose(pts[0, 0], [(0 - 2) * 10 / 400, (0 - 1) * 10 / 400, 10], rtol=1e-6)
    for bad in (0, -1, np.inf):
        with pytest.raises(ValueError, match="focal_px"):
            stereo.disparity_to_depth(d, bad, 1)
    with pytest.raises(ValueError, match="q must be"):
        stereo.reproject_to_3d(d, np.eye(3))
    with pytest.raises(ValueError, match="center"):
        stereo.stereo_q(1, 1, (1, 2, 3))


def test_reproject_matches_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(0)
    d = rng.uniform(1, 30, (7, 9)).astype(np.float32)
    q = stereo.stereo_q(500, 0.12, (3.2, 4.1), cx_right=5.0)
    ours = stereo.reproject_to_3d(d, q)
    ref = cv2.reprojectImageTo3D(d, q)
    np.testing.assert_allclose(ours, ref, rtol=1e-5, atol=1e-6)


def test_ply_png16_colour_bar(tmp_path):
    plyfile = pytest.importorskip("plyfile")
    from gfgpu import io
    pts = np.arange(24, dtype=np.float32).reshape(2, 4, 3)
    pts[0, 1] = np.nan
    cols = np.arange(24, dtype=np.uint8).reshape(2, 4, 3)
    assert io.write_ply(tmp_path / "c.ply", pts, cols) == 7
    v = plyfile.PlyData.read(tmp_path / "c.ply")["vertex"]
    np.testing.assert_array_equal(v["z"], pts.reshape(-1, 3)[[0, 2, 3, 4, 5, 6, 7], 2])
    np.testing.assert_array_equal(v["red"], cols.reshape(-1, 3)[[0, 2, 3, 4, 5, 6, 7], 0])
    with pytest.raises(ValueError, match="points"):
        io.write_ply(tmp_path / "x.ply", np.zeros((4, 2)))
    png = io.disparity_to_png16(np.array([[0.5, np.nan, 255.99, -2]], np.float32))
    np.testing.assert_array_equal(png, [[128, 0, 65533, 0]])
    bar = io.colour_bar(100, 0, 63)
    assert bar.shape == (100, 48, 3) and bar.dtype == np.uint8 and (bar[:, 30:] == 255).any()   # labels


def test_cli_writes_png(tmp_path):
    pytest.importorskip("imageio")
    from gfgpu import io
    from gfgpu.cli import main
    left, right, _ = random_dot_pair(square)
    import imageio.v3 as iio
    iio.imwrite(tmp_path / "l.png", left.astype(np.uint8))
    iio.imwrite(tmp_path / "r.png", right.astype(np.uint8))
    out = tmp_path / "d.png"
    rc = main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(out),
               "--max-disparity", "16", "--npy", str(tmp_path / "d.npy"),
               "--pfm", str(tmp_path / "d.pfm"), "--backend", "numpy"])
    assert rc == 0
    png = iio.imread(out)
    assert png.shape == (left.shape[0], left.shape[1] + 4 + 64, 3) and png.dtype == np.uint8   # + colour bar
    raw = np.load(tmp_path / "d.npy")
    assert raw.shape == left.shape and np.nanmedian(raw) == pytest.approx(4.0, abs=0.25)
    pfm = io.read_pfm(tmp_path / "d.pfm")
    np.testing.assert_array_equal(np.isnan(pfm), np.isnan(raw))


def test_cli_ply_png16_confidence(tmp_path):
    pytest.importorskip("plyfile")
    import imageio.v3 as iio
    import plyfile

    from gfgpu.cli import main
    left, right, _ = random_dot_pair(square)
    iio.imwrite(tmp_path / "l.png", left.astype(np.uint8))
    iio.imwrite(tmp_path / "r.png", right.astype(np.uint8))
    rc = main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(tmp_path / "d.png"),
               "--png16", str(tmp_path / "d16.png"), "--ply", str(tmp_path / "c.ply"), "--focal", "100",
               "--baseline", "0.5", "--confidence", str(tmp_path / "c.npy"), "--fill", "--backend", "numpy"])
    assert rc == 0
    png = iio.imread(tmp_path / "d.png")
    assert png.shape[0] == left.shape[0] and png.shape[1] > left.shape[1]     # the colour bar
    d16 = iio.imread(tmp_path / "d16.png")
    assert d16.dtype == np.uint16 and abs(np.median(d16[:, 30:]) - 4 * 256) < 26   # filled, background 4 px
    z = plyfile.PlyData.read(tmp_path / "c.ply")["vertex"]["z"]
    assert np.median(z) == pytest.approx(100 * 0.5 / 4, rel=0.02)
    conf = np.load(tmp_path / "c.npy")
    assert conf.shape == left.shape and 0 <= conf.min() and conf.max() <= 1
    assert main(["disparity", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o", str(tmp_path / "e.png"),
                 "--ply", str(tmp_path / "e.ply"), "--backend", "numpy"]) != 0     # no camera given


def test_infinite_disparities_are_unknown_in_depth_and_points():
    # Middlebury PFMs mark unknown pixels with +inf: f b / inf = 0 put them at the camera
    d = np.array([[np.inf, 16.0], [-np.inf, 8.0]], np.float32)
    z = stereo.disparity_to_depth(d, 400, 0.2)
    np.testing.assert_allclose(z, [[np.nan, 5], [np.nan, 10]], equal_nan=True)
    np.testing.assert_allclose(stereo.disparity_to_depth(d, 400, 0.2, doffs=-4.0), [[np.nan, 80 / 12],
                                                                                   [np.nan, 20]], equal_nan=True)
    pts = stereo.reproject_to_3d(d, stereo.stereo_q(400, 0.2, (0.0, 0.0)))
    assert (np.isnan(z) == np.isnan(pts).all(axis=-1)).all()     # the same pixels unknown in both
    np.testing.assert_allclose(pts[..., 2], z, rtol=1e-6, equal_nan=True)


@pytest.mark.parametrize("call, exc, message", [
    (lambda d: stereo.disparity_to_depth(d, True, 1), TypeError, "focal_px must be a real number"),
    (lambda d: stereo.disparity_to_depth(d, 1, np.True_), TypeError, "baseline must be a real number"),
    (lambda d: stereo.disparity_to_depth(d, 1, 1, doffs="a"), TypeError, "doffs must be a real number"),
    (lambda d: stereo.disparity_to_depth(d, "800", 1), TypeError, "focal_px must be a real number"),
    (lambda d: stereo.stereo_q(1, 1, "ab"), ValueError, "center must be"),
    (lambda d: stereo.stereo_q(1, 1, (1, "a")), TypeError, "center must be a real number"),
    (lambda d: stereo.stereo_q(1, 1, (1, True)), TypeError, "center must be a real number"),
    (lambda d: stereo.stereo_q(True, 1, (1, 2)), TypeError, "focal_px must be a real number"),
    (lambda d: stereo.stereo_q(1, 1, (1, 2), cx_right="x"), TypeError, "cx_right must be a real number"),
])
def test_geometry_arguments_of_the_wrong_type_are_named(call, exc, message):
    with pytest.raises(exc, match=message):
        call(np.ones((2, 3)))


@pytest.mark.parametrize("kwargs, exc, message", [
    ({"lr_check": "False"}, TypeError, "lr_check must be True or False"),
    ({"lr_check": 0}, TypeError, "lr_check must be True or False"),
    ({"subpixel": "no"}, TypeError, "subpixel must be True or False"),
    ({"method": "affine", "sigma": "a"}, TypeError, "sigma must be a real number"),
    ({"method": "affine", "sigma": True}, TypeError, "sigma must be a real number"),
    ({"method": "affine", "sigma": -1.0}, ValueError, "sigma must be > 0"),
    ({"method": "affine", "lr_check": "False"}, TypeError, "lr_check must be True or False"),
])
def test_disparity_flags_and_sigma_are_checked(kwargs, exc, message):
    left = right = np.ones((24, 40))
    with pytest.raises(exc, match=message):
        stereo.disparity(left, right, 8, backend="numpy", **kwargs)
