"""gfgpu.dask: chunked results equal the single-array call (exact state carry across chunks)."""
import numpy as np
import pytest

da = pytest.importorskip("dask.array")

import gfgpu  # noqa: E402
import gfgpu.dask as gd  # noqa: E402
from gfgpu.greens import AffineGreen, HomogeneousGreen, UniformGreen  # noqa: E402


def _random_chunks(rng, n):
    cuts = np.sort(rng.choice(np.arange(1, n), size=rng.integers(1, 6), replace=False))
    if rng.random() < 0.5:      # a one-sample chunk somewhere
        cuts = np.union1d(cuts, [cuts[0] + 1] if cuts[0] + 1 < n else [])
    return tuple(int(c) for c in np.diff(np.concatenate([[0], cuts, [n]])))


def _compute(x):
    return x.compute(scheduler="synchronous")


def _close(out, ref, rel=2e-6):
    assert out.shape == ref.shape and out.dtype == ref.dtype
    assert np.linalg.norm(out - ref) <= rel * np.linalg.norm(ref)
    assert np.abs(out - ref).max() <= rel * np.abs(ref).max()


CASES = {
    "shift": (lambda m, img, be: m.shift(img, (4.5, -3.25), backend=be), {}),
    "green_filter axis 0 wrap": (lambda m, img, be: m.green_filter(img, UniformGreen(30.0), axis=0, mode="wrap",
                                                                    backend=be), {}),
    "green_filter axis 1 anticausal": (lambda m, img, be: m.green_filter(img, HomogeneousGreen(3.0), axis=1,
                                                                          anticausal=True, mode="mirror",
                                                                          backend=be), {}),
    "affine axis 1": (lambda m, img, be: m.green_filter(img, AffineGreen(0.3, -5.0), axis=1, mode="constant",
                                                         cval=0.5, backend=be), {}),
    "derivative axis 0": (lambda m, img, be: m.derivative(img, 2.0, axis=0, mode="nearest", backend=be), {}),
    "projection axis 1": (lambda m, img, be: m.projection(img, 1.5, axis=1, backend=be), {}),
    "motion_blur displace=False": (lambda m, img, be: m.motion_blur(img, (0, 11), displace=False, backend=be), {}),
    "shift colour channel_axis": (lambda m, img, be: m.shift(img[:, :81].reshape(97, 27, 3), (2.5, -1.5),
                                                              channel_axis=-1, backend=be), {}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_random_chunkings_equal_single_array(backend, case, rng):
    run, _ = CASES[case]
    img = rng.random((97, 83)).astype(np.float32)
    ref = run(gfgpu, img, backend)
    for _ in range(3):
        chunks = (_random_chunks(rng, 97), _random_chunks(rng, 83))
        out = _compute(run(gd, da.from_array(img, chunks=chunks), backend.name))
        _close(out, ref)


def test_gradient_float64_every_axis_of_a_stack(rng):
    stack = rng.standard_normal((4, 60, 50))
    ref = gfgpu.gradient(stack, 1.0, axes=(1, 2), backend="numpy")
    lazy = gd.gradient(da.from_array(stack, chunks=(3, 17, 20)), 1.0, axes=(1, 2), backend="numpy")
    for out, r in zip(lazy, ref):
        _close(_compute(out), r, rel=1e-12)
    along_stack = gd.shift(da.from_array(stack, chunks=(1, 60, 50)), (1.5, 0, 0), backend="numpy")
    _close(_compute(along_stack), gfgpu.shift(stack, (1.5, 0, 0), backend="numpy"), rel=1e-12)


def test_whole_plane_operators(rng):
    stack = rng.random((3, 64, 48)).astype(np.float32)
    x = da.from_array(stack, chunks=(1, 20, 20))
    oblique = _compute(gd.motion_blur(x, (3, 7), backend="numpy"))
    _close(oblique, gfgpu.motion_blur(stack, (3, 7), backend="numpy"), rel=0)
    zoom = _compute(gd.motion_blur(x, 0.4, kind="zoom", backend="numpy"))
    _close(zoom, gfgpu.motion_blur(stack, 0.4, kind="zoom", backend="numpy"), rel=0)
    edges = _compute(gd.canny(x, 1.0, backend="numpy"))
    expect = np.stack([gfgpu.canny(p, 1.0, backend="numpy") for p in stack])
    assert edges.dtype == bool and (edges == expect).all() and edges.any()


def test_convention_rows_then_cols_and_channel_axis(rng):
    """gfgpu.dask.motion_blur takes (vy, vx) and center=(row, col); channel_axis everywhere."""
    img = np.zeros((300, 200))
    img[100, 60] = 1.0
    out = _compute(gd.motion_blur(da.from_array(img, chunks=(70, 90)), (12.0, 0.0), mode="constant",
                                  backend="numpy"))
    yy = np.arange(300)[:, None]
    assert abs((out * yy).sum() / out.sum() - 112.0) < 0.05 and np.abs(out[:, 61:]).max() < 1e-12   # 12 rows down
    rgb = rng.random((40, 56, 3))
    x = da.from_array(rgb, chunks=(15, 20, 3))
    for kw in (dict(velocity=(3.0, -5.0)), dict(velocity=0.3, kind="zoom", center=(10, 40)),
               dict(velocity=8.0, kind="rotation", center=(30, 12))):
        _close(_compute(gd.motion_blur(x, channel_axis=-1, backend="numpy", **kw)),
               gfgpu.motion_blur(rgb, channel_axis=-1, backend="numpy", **kw), rel=1e-12)
    oblique = gd.green_filter(x, UniformGreen(2.0), angle=0.4, channel_axis=-1, backend="numpy")
    _close(_compute(oblique), gfgpu.green_filter(rgb, UniformGreen(2.0), angle=0.4, channel_axis=-1,
                                                 backend="numpy"), rel=1e-12)
    gy, gx = gd.gradient(x, 1.0, channel_axis=-1, backend="numpy")
    ry, rx = gfgpu.gradient(rgb, 1.0, channel_axis=-1, backend="numpy")
    _close(_compute(gy), ry, rel=1e-12)
    _close(_compute(gx), rx, rel=1e-12)
    with pytest.raises(ValueError, match="axes.*channel_axis"):
        gd.shift(x, (1.0, 1.0), axes=(1, 2), channel_axis=-1)


def test_lazy_and_input_untouched(rng):
    img = rng.random((50, 40))
    keep = img.copy()
    lazy = gd.shift(da.from_array(img, chunks=10), (2.0, 1.0), backend="numpy")
    assert isinstance(lazy, da.Array) and lazy.chunks == ((10,) * 5, (10,) * 4)
    _compute(lazy)
    np.testing.assert_array_equal(img, keep)


def test_bad_input():
    img = np.ones((20, 20))
    with pytest.raises(TypeError, match="dask.array"):
        gd.shift(img, 1.0)
    with pytest.raises(ValueError, match="device"):
        gd.shift(da.from_array(img), 1.0, backend=gfgpu.get_backend("numpy"), device="cpu")
    with pytest.raises(ValueError, match="backend"):
        gd.shift(da.from_array(img), 1.0, backend="cuda")
    with pytest.raises(ValueError, match="mode"):
        gd.shift(da.from_array(img), 1.0, mode="periodic")
    with pytest.raises(TypeError, match="dtype"):
        gd.shift(da.from_array(img.astype(complex)), 1.0)
    bad = da.from_array(img, chunks=5).copy()
    bad[3, 3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        _compute(gd.shift(bad, (1.0, 1.0), backend="numpy"))
    unknown = da.from_array(img, chunks=5)
    unknown = unknown[unknown[:, 0] > 0]
    with pytest.raises(ValueError, match="chunk"):
        gd.shift(unknown, 1.0)


def test_local_cluster_two_worker_processes(rng):
    distributed = pytest.importorskip("distributed")
    img = rng.random((120, 90)).astype(np.float32)
    ref = gfgpu.derivative(img, 1.0, axis=0, backend="numpy")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=40) as cluster, distributed.Client(cluster) as client:
        lazy = gd.derivative(da.from_array(img, chunks=(25, 45)), 1.0, axis=0, backend="numpy")
        out = client.compute(lazy).result(timeout=300)   # a lost worker fails the test, never hangs it
        workers = client.run(lambda: __import__("os").getpid())
    assert len(set(workers.values())) == 2
    _close(out, ref)


def test_backends_pickle_by_name(backend):
    import pickle
    clone = pickle.loads(pickle.dumps(backend))
    assert clone is backend      # rebuilt through get_backend: this process's cached instance
    img = np.random.default_rng(3).random((40, 30)).astype(np.float32)
    out = _compute(gd.shift(da.from_array(img, chunks=15), (1.5, 2.5), backend=backend))
    _close(out, gfgpu.shift(img, (1.5, 2.5), backend=backend))
