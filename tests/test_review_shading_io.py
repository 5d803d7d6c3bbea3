"""Review of d51fc3c (shape from shading: bordered objects, mask = object, u bound) and df31f92
(host in/out, the translate primitive with its fused finite check, aligned OpenCL host wrapping).

A failing test here is a defect report (nothing is marked xfail)."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import gfgpu
from gfgpu.shading import lambertian_shading, shape_from_shading

MODES = ("constant", "nearest", "reflect", "mirror", "wrap")


# ---- exact integer translation by index arithmetic (the reference) ---------------------------
def _source_index(n, k, mode):
    idx = np.arange(n) - k
    if mode == "constant":
        return np.where((idx >= 0) & (idx < n), idx, -1)
    if mode == "nearest":
        return np.clip(idx, 0, n - 1)
    if mode == "wrap":
        return idx % n
    if mode == "reflect":                 # half-sample symmetric, period 2n
        p = idx % (2 * n)
        return np.where(p < n, p, 2 * n - 1 - p)
    if n == 1:                            # mirror: whole-sample symmetric, period 2n - 2
        return np.zeros_like(idx)
    p = idx % (2 * n - 2)
    return np.where(p < n, p, 2 * n - 2 - p)


def _exact_shift(a, shifts, mode):
    out = np.asarray(a)
    for ax, k in enumerate(shifts):
        idx = _source_index(out.shape[ax], k, mode)
        out = np.take(out, np.maximum(idx, 0), axis=ax)
        if mode == "constant":
            sl = [slice(None)] * out.ndim
            sl[ax] = idx < 0
            out[tuple(sl)] = 0
    return out


# ---- B: non-finite host input must leave output= untouched ------------------------------------
@pytest.mark.parametrize("shape, shift", [((48, 400), (1, -2)), ((48, 400), (0, 3)), ((8, 48, 48), (1, 1, 1)),
                                          ((3, 40, 200), (0.5, 1, 3))],
                         ids=["2d-two-steps", "2d-one-step", "3d-three-steps", "3d-frac-first"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_shift_nonfinite_input_leaves_output_untouched(backend, shape, shift, dtype):
    # arrays of >= 64 KiB so that OpenCL (CPU) writes the caller's output in place
    for value in (np.nan, np.inf, -np.inf):
        for pos in (0, -1, int(np.prod(shape)) // 2 + 7):
            a = np.ones(shape, dtype)
            a.reshape(-1)[pos] = value
            out = np.full(shape, 7, dtype)
            with pytest.raises(ValueError, match="input"):
                gfgpu.shift(a, shift, output=out, mode="constant", backend=backend.name)
            assert (out == 7).all(), f"output written before the non-finite error ({value}, element {pos})"


# ---- B: integer shifts against exact index arithmetic ----------------------------------------
def test_shift_integer_exact_every_mode(backend):
    rng = np.random.default_rng(0)
    for shape in [(1, 1), (1, 7), (6, 1), (5, 6), (3, 2100)]:
        a = rng.standard_normal(shape).astype(np.float32)
        h, w = shape
        for mode in MODES:
            for dy, dx in [(0, 1), (1, -1), (h - 1, -(w - 1)), (-h, w), (10**6, -10**6), (-(10**6) - 3, 2 * w - 1),
                           (0, w // 2 + 5)]:
                got = gfgpu.shift(a, (dy, dx), mode=mode, backend=backend.name)
                np.testing.assert_array_equal(got, _exact_shift(a, (dy, dx), mode),
                                              err_msg=f"{shape} {mode} {(dy, dx)}")


def _views(base):
    yield "strided", base[::2, 1::3]
    yield "negative-stride", base[::-1, ::-1]
    yield "big-endian", base.astype(">f4")
    ro = base.copy()
    ro.setflags(write=False)
    yield "read-only", ro
    yield "misaligned-4", np.frombuffer(b"\0" * 4 + base.tobytes(), np.float32, offset=4).reshape(base.shape)
    yield "misaligned-2", np.frombuffer(bytearray(b"\0" * 2 + base.tobytes()), np.float32, offset=2).reshape(base.shape)
    yield "offset-view", base[37:, 5:]
    yield "uint16", (np.abs(base) * 1000).astype(np.uint16)


def test_shift_host_views(backend):
    base = np.random.default_rng(1).standard_normal((150, 160)).astype(np.float32)
    for name, a in _views(base):
        want = _exact_shift(np.asarray(a, np.float32), (3, -7), "wrap")
        got = gfgpu.shift(a, (3, -7), mode="wrap", backend=backend.name)
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_shift_outputs_and_aliasing(backend):
    a = np.random.default_rng(2).standard_normal((150, 160)).astype(np.float32)
    want = _exact_shift(a, (3, -7), "wrap")
    outs = {"f64": np.zeros(a.shape), "big-endian": np.zeros(a.shape, ">f4"),
            "strided": np.zeros((150, 320), np.float32)[:, ::2], "negative-stride": np.zeros(a.shape, np.float32)[::-1],
            "misaligned": np.frombuffer(bytearray(a.nbytes + 8), np.float32, a.size, offset=2).reshape(a.shape),
            "offset-64": np.frombuffer(bytearray(a.nbytes + 128), np.float32, a.size, offset=64).reshape(a.shape)}
    for name, out in outs.items():
        r = gfgpu.shift(a, (3, -7), mode="wrap", backend=backend.name, output=out)
        assert r is out, name
        np.testing.assert_array_equal(np.asarray(out, np.float32), want, err_msg=name)
    x = a.copy()
    gfgpu.shift(x, (3, -7), mode="wrap", backend=backend.name, output=x)
    np.testing.assert_array_equal(x, want)
    buf = np.zeros((151, 160), np.float32)
    buf[:-1] = a
    gfgpu.shift(buf[:-1], (3, -7), mode="wrap", backend=backend.name, output=buf[1:])
    np.testing.assert_array_equal(buf[1:], want)


def test_shift_channel_axis(backend):
    a = np.random.default_rng(5).standard_normal((40, 50, 3)).astype(np.float32)
    for mode in MODES:
        got = gfgpu.shift(a, (4, -9), channel_axis=-1, mode=mode, backend=backend.name)
        np.testing.assert_array_equal(got, _exact_shift(a, (4, -9, 0), mode), err_msg=mode)


def test_shift_threads_match_serial(backend):
    rng = np.random.default_rng(7)
    imgs = [rng.standard_normal((120 + i, 200 - i)).astype(np.float32) for i in range(8)]
    calls = [(im, (i - 3 + 0.25 * (i % 2), 2 * i - 7), MODES[i % 5]) for i, im in enumerate(imgs)]
    serial = [gfgpu.shift(im, s, mode=m, backend=backend.name) for im, s, m in calls]
    with ThreadPoolExecutor(4) as ex:
        futs = [ex.submit(gfgpu.shift, im, s, mode=m, backend=backend.name) for im, s, m in calls * 3]
        res = [f.result() for f in futs]
    for i, r in enumerate(res):
        np.testing.assert_array_equal(r, serial[i % 8])


# ---- A: shape from shading --------------------------------------------------------------------
def _gauss(n=64):
    yy, xx = np.mgrid[-n // 2:n // 2, -n // 2:n // 2] + 0.5
    return 8 * np.exp(-(xx**2 + yy**2) / 200)


def _cut_sphere(n=64):
    yy, xx = np.mgrid[:n, :n] + 0.5
    return np.sqrt(np.clip(20.0**2 - xx**2 - (yy - n / 2) ** 2, 0, None))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_sfs_backends_agree(backend, dtype):
    for z, light, kw in [(_gauss(), (1, 0, 1), {}), (_cut_sphere(), (5, 5, 7), {}),
                         (_cut_sphere(), (-1, 2, 1), {}), (_gauss(), (1, 0, 0.05), {"mask": _gauss() > 0.5}),
                         (_gauss(), (5, 5, 7), {"boundary": "free"})]:
        img = lambertian_shading(z, light).astype(dtype)
        ref = shape_from_shading(img, light=light, backend="numpy", **kw)
        got = shape_from_shading(img, light=light, backend=backend.name, **kw)
        assert got.dtype == dtype
        tol = 1e-5 if dtype == np.float32 else 1e-10
        assert np.abs(got - ref).max() <= tol * np.abs(ref).max()


def test_sfs_mask_is_the_object():
    z = _gauss()
    img = lambertian_shading(z, (1, 0, 1))
    m = z > 0.5
    for mask in (m, m.astype(np.uint8), m.tolist()):
        est = shape_from_shading(img, light=(1, 0, 1), mask=mask, backend="numpy")
        assert (est[~m] == 0).all()
        assert np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.99
    full = shape_from_shading(img, light=(1, 0, 1), mask=np.ones(z.shape, bool), backend="numpy")
    np.testing.assert_array_equal(full, shape_from_shading(img, light=(1, 0, 1), backend="numpy"))


@pytest.mark.parametrize("mask, match", [(np.zeros((64, 64), bool), "mask"), (np.ones((64, 63), bool), "mask"),
                                         (np.ones(64 * 64, bool), "mask")], ids=["empty", "wrong-shape", "1-d"])
def test_sfs_bad_mask_raises(mask, match):
    with pytest.raises(ValueError, match=match):
        shape_from_shading(lambertian_shading(_gauss(), (1, 0, 1)), light=(1, 0, 1), mask=mask, backend="numpy")


@pytest.mark.parametrize("mask", [np.full((64, 64), np.nan), np.full((64, 64), 0.5)], ids=["nan", "fractional"])
def test_sfs_non_boolean_mask_is_refused(mask):
    # docstring: "mask : (H, W) bool array_like"; a NaN or fractional mask is silently all True today
    with pytest.raises((TypeError, ValueError), match="mask"):
        shape_from_shading(lambertian_shading(_gauss(), (1, 0, 1)), light=(1, 0, 1), mask=mask, backend="numpy")


@pytest.mark.parametrize("kw, exc, match", [
    ({"u": 15.9}, ValueError, "16 pixels"), ({"u": 0}, ValueError, "u"), ({"u": "a"}, TypeError, "u"),
    ({"k1": 0}, ValueError, "k1"), ({"k1": "x"}, ValueError, "k1"), ({"boundary": None}, ValueError, "boundary"),
    ({"light": (1, 0, 0)}, ValueError, "l3"), ({"light": (1, 0, -1)}, ValueError, "l3"),
    ({"light": (0, 0, 1)}, ValueError, "frontal"), ({"light": (0.0, np.pi / 2)}, ValueError, "slant"),
    ({"light": (np.nan, 0, 1)}, ValueError, "light"), ({"light": "abc"}, TypeError, "light"),
    ({"direction": np.nan}, ValueError, "direction")])
def test_sfs_argument_errors(kw, exc, match):
    args = {"light": (1, 0, 1), "backend": "numpy"} | kw
    with pytest.raises(exc, match=match):
        shape_from_shading(lambertian_shading(_gauss(), (1, 0, 1)), **args)


def test_sfs_quarter_line_u_is_accepted():
    z = _gauss()
    est = shape_from_shading(lambertian_shading(z, (1, 0, 1)), light=(1, 0, 1), u=16, backend="numpy")
    assert np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.9


@pytest.mark.parametrize("image, match", [
    (np.random.default_rng(0).random((2, 2)), "4 x 4"), (np.random.default_rng(0).random((1, 9)), "4 x 4"),
    (np.full((64, 64), 0.5), "constant"), (np.zeros((64, 64, 3)), "2-D")])
def test_sfs_bad_image_raises(image, match):
    with pytest.raises(ValueError, match=match):
        shape_from_shading(image, light=(1, 0, 1), backend="numpy")


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_sfs_nonfinite_image_raises(value):
    img = lambertian_shading(_gauss(), (1, 0, 1))
    img[10, 10] = value
    with pytest.raises(ValueError, match="image"):
        shape_from_shading(img, light=(1, 0, 1), backend="numpy")


@pytest.mark.parametrize("convert", [lambda i: (i * 255).astype(np.uint8), lambda i: (i * 65535).astype(np.uint16),
                                     lambda i: i.astype(">f8")], ids=["uint8", "uint16", "big-endian"])
def test_sfs_input_dtypes(convert):
    z = _gauss()
    est = shape_from_shading(convert(lambertian_shading(z, (1, 0, 1))), light=(1, 0, 1), backend="numpy")
    assert est.dtype == np.float32
    assert np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.99


def test_sfs_bad_backend_raises_before_work(monkeypatch):
    # "errors ... raised before work": an unknown backend is only found by green_filter, after the
    # scene analysis (flat background, border test) has run on the whole image
    from gfgpu.shading import gsfs
    calls = []
    real = gsfs.has_background
    monkeypatch.setattr(gsfs, "has_background", lambda *a, **k: calls.append(1) or real(*a, **k))
    with pytest.raises(ValueError, match="backend"):
        shape_from_shading(lambertian_shading(_gauss(), (1, 0, 1)), light=(1, 0, 1), backend="foo")
    assert not calls, "the image was analysed before the unknown backend was refused"
