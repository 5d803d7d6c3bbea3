"""Strips under a working-set limit (gfgpu._core.strips): same results as one piece, bounded memory."""
import os

import numpy as np
import pytest

import gfgpu
from gfgpu import filter_npy
from gfgpu._core import strips
from gfgpu._core.recursion import MODES
from gfgpu.greens import AffineGreen, UniformGreen

SMALL = 150_000   # bytes: a 400 x 300 float32 image (480 kB) runs in 10-row strips


def _ops(name):
    return {
        "shift": lambda img, **kw: gfgpu.shift(img, (3.5, -2.25), **kw),
        "green_filter axis 0 wrap": lambda img, **kw: gfgpu.green_filter(img, UniformGreen(40.0), axis=0,
                                                                          mode="wrap", **kw),
        "green_filter anticausal": lambda img, **kw: gfgpu.green_filter(img, UniformGreen(4.0), axis=0,
                                                                         anticausal=True, mode="mirror", **kw),
        "affine constant": lambda img, **kw: gfgpu.green_filter(img, AffineGreen(0.3, -5.0), axis=0,
                                                                 mode="constant", cval=0.5, **kw),
        "derivative axis 0": lambda img, **kw: gfgpu.derivative(img, 2.0, axis=0, **kw),
        "derivative axis 1": lambda img, **kw: gfgpu.derivative(img, 2.0, axis=1, mode="nearest", **kw),
        "projection": lambda img, **kw: gfgpu.projection(img, 1.5, axis=0, **kw),
        "gradient": lambda img, **kw: np.stack(gfgpu.gradient(img, 1.0, **kw)),
        "motion_blur vertical, in place": lambda img, **kw: gfgpu.motion_blur(img, (15, 0), displace=False, **kw),
    }[name]


OPS = ["shift", "green_filter axis 0 wrap", "green_filter anticausal", "affine constant", "derivative axis 0",
       "derivative axis 1", "projection", "gradient", "motion_blur vertical, in place"]


@pytest.mark.parametrize("op", OPS)
def test_strips_equal_one_piece(backend, op, rng):
    img = rng.random((400, 300)).astype(np.float32)
    keep = img.copy()
    ref = _ops(op)(img, backend=backend)
    with strips.working_set(SMALL):
        out = _ops(op)(img, backend=backend)
    np.testing.assert_array_equal(img, keep)
    assert out.dtype == np.float32 and out.shape == ref.shape
    assert np.linalg.norm(out - ref) <= 2e-6 * np.linalg.norm(ref)
    assert np.abs(out - ref).max() <= 2e-6 * np.abs(ref).max()


@pytest.mark.parametrize("mode", MODES)
def test_strips_float64_every_mode(mode, rng):
    img = rng.standard_normal((257, 40))
    ref = gfgpu.shift(img, (-6.5, 1.0), mode=mode, cval=0.25, backend="numpy")
    with strips.working_set(8_000):     # 25-row strips
        out = gfgpu.shift(img, (-6.5, 1.0), mode=mode, cval=0.25, backend="numpy")
    assert out.dtype == np.float64
    assert np.abs(out - ref).max() <= 1e-12 * np.abs(ref).max()


def test_strips_into_output_and_integer_input(rng):
    img = rng.integers(0, 255, (300, 200), dtype=np.uint8)
    ref = gfgpu.derivative(img, 1.0, axis=0, backend="numpy")
    out = np.full((300, 200), np.nan, np.float64)
    with strips.working_set(50_000):
        got = gfgpu.derivative(img, 1.0, axis=0, output=out, backend="numpy")
    assert got is out
    assert np.abs(out - ref).max() <= 1e-5 * np.abs(ref).max()


def test_stack_planes_larger_than_the_working_set(rng):
    stack = rng.random((3, 120, 90)).astype(np.float32)
    ref = gfgpu.shift(stack, (2.5, -1.5), axes=(1, 2), backend="numpy")
    oblique = gfgpu.motion_blur(stack, (2, 6), backend="numpy")
    with strips.working_set(20_000):    # one plane (43 kB) does not fit: strips within each plane
        out = gfgpu.shift(stack, (2.5, -1.5), axes=(1, 2), backend="numpy")
    assert np.abs(out - ref).max() <= 1e-6
    with strips.working_set(5 * stack[0].nbytes + 1):   # a plane fits: oblique lines are whole
        assert np.abs(gfgpu.motion_blur(stack, (2, 6), backend="numpy") - oblique).max() <= 1e-6


def test_oblique_needs_the_whole_plane(rng):
    img = rng.random((200, 200)).astype(np.float32)
    with strips.working_set(50_000), pytest.raises(ValueError, match="working set"):
        gfgpu.motion_blur(img, (3, 7), backend="numpy")


def test_working_set_settings(monkeypatch):
    assert strips.parse_bytes("512M") == 512 << 20
    assert strips.parse_bytes("1.5G") == 3 << 29
    assert strips.parse_bytes("64KiB") == 64 << 10
    assert strips.parse_bytes(1000) == 1000
    for bad in ("lots", "-1M", "0"):
        with pytest.raises(ValueError, match="working_set"):
            strips.parse_bytes(bad)
    with pytest.raises(TypeError, match="working_set"):
        strips.parse_bytes(1.5)
    monkeypatch.setenv("GFGPU_WORKING_SET", "3M")
    assert strips.get_working_set() == 3 << 20
    with strips.working_set("1K"):
        assert strips.get_working_set() == 1024
    assert strips.get_working_set() == 3 << 20
    monkeypatch.setenv("GFGPU_WORKING_SET", "much")
    with pytest.raises(ValueError, match="GFGPU_WORKING_SET"):
        strips.get_working_set()


def test_cpu_backends_have_no_default_limit(backend):
    if "cpu" in backend.device.lower() or backend.name == "numpy" or getattr(backend, "kind", "") == "cpu":
        assert backend.memory_budget is None


# --------------------------------------------------------------------------------------
# file to file
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("op, params", [("shift", dict(shift=(2.5, -1.5))),
                                        ("derivative", dict(u=1.0, axis=0)),
                                        ("green_filter", dict(kernel=UniformGreen(8.0), axis=0, anticausal=True)),
                                        ("motion_blur", dict(velocity=(9, 0)))])
def test_filter_npy_equals_in_memory(backend, op, params, tmp_path, rng):
    img = rng.random((333, 120)).astype(np.float32)
    src, dst = tmp_path / "in.npy", tmp_path / "out.npy"
    np.save(src, img)
    before = src.read_bytes()
    info = filter_npy(op, src, dst, working_set="60K", backend=backend.name, **params)
    assert info["strips"] > 5
    ref = getattr(gfgpu, op)(img, backend=backend, **params)
    out = np.load(dst)
    assert out.dtype == np.float32 and np.abs(out - ref).max() <= 2e-6 * np.abs(ref).max()
    assert src.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["in.npy", "out.npy"]


def test_filter_npy_motion_velocity_is_rows_then_cols(tmp_path):
    """filter_npy("motion_blur", velocity=(vy, vx)): an impulse moves vy rows down, across strips."""
    img = np.zeros((400, 60), np.float32)
    img[100, 30] = 1.0
    np.save(tmp_path / "in.npy", img)
    info = filter_npy("motion_blur", tmp_path / "in.npy", tmp_path / "out.npy", velocity=(20.0, 0.0), mode="constant",
                      working_set="20K", backend="numpy")
    assert info["strips"] > 5
    out = np.load(tmp_path / "out.npy").astype(np.float64)
    assert abs((out * np.arange(400)[:, None]).sum() / out.sum() - 120.0) < 0.05
    assert np.abs(out[:, :30]).max() < 1e-6 and np.abs(out[:, 31:]).max() < 1e-6


def test_filter_npy_large_strips(backend, tmp_path, rng):
    """Strips above the OpenCL CPU zero-copy size: the device reads freshly read host buffers."""
    img = rng.random((900, 700)).astype(np.float32)
    np.save(tmp_path / "in.npy", img)
    info = filter_npy("shift", tmp_path / "in.npy", tmp_path / "out.npy", shift=(2.5, -1.5),
                             working_set="4M", backend=backend.name)
    assert info["strips"] >= 3 and info["strip_rows"] * 700 * 4 > 1 << 16
    ref = gfgpu.shift(img, (2.5, -1.5), backend=backend)
    assert np.abs(np.load(tmp_path / "out.npy") - ref).max() <= 2e-6


def test_filter_npy_errors_leave_no_output(tmp_path, rng):
    img = rng.random((100, 50))
    img[90, 3] = np.nan
    np.save(tmp_path / "nan.npy", img)
    with pytest.raises(ValueError, match="NaN"):
        filter_npy("shift", tmp_path / "nan.npy", tmp_path / "out.npy", shift=(1.0, 0.0),
                          working_set="20K", backend="numpy")
    assert sorted(os.listdir(tmp_path)) == ["nan.npy"]
    good = tmp_path / "good.npy"
    np.save(good, rng.random((100, 50)))
    with pytest.raises(ValueError, match="source"):
        filter_npy("shift", good, good, shift=(1.0, 0.0), backend="numpy")
    with pytest.raises(ValueError, match="operator"):
        filter_npy("sharpen", good, tmp_path / "o.npy", backend="numpy")
    truncated = tmp_path / "short.npy"
    truncated.write_bytes(good.read_bytes()[:-800])
    with pytest.raises(ValueError, match="truncated"):
        filter_npy("shift", truncated, tmp_path / "o.npy", shift=(1.0, 0.0), backend="numpy")
    np.save(tmp_path / "fortran.npy", np.asfortranarray(rng.random((20, 30))))
    with pytest.raises(ValueError, match="Fortran"):
        filter_npy("shift", tmp_path / "fortran.npy", tmp_path / "o.npy", shift=(1.0, 0.0), backend="numpy")
    (tmp_path / "text.npy").write_text("not an array")
    with pytest.raises(ValueError, match="npy"):
        filter_npy("shift", tmp_path / "text.npy", tmp_path / "o.npy", shift=(1.0, 0.0), backend="numpy")
    with pytest.raises(TypeError, match="downcast"):
        filter_npy("shift", good, tmp_path / "o.npy", shift=(1.0, 0.0), dtype="float32", backend="numpy")
    assert not (tmp_path / "o.npy").exists()


def test_filter_npy_integer_input_gives_float32(tmp_path, rng):
    img = rng.integers(0, 4000, (64, 80), dtype=np.uint16)
    np.save(tmp_path / "in.npy", img)
    filter_npy("shift", tmp_path / "in.npy", tmp_path / "out.npy", shift=(0.0, 3.0), backend="numpy")
    out = np.load(tmp_path / "out.npy")
    assert out.dtype == np.float32
    assert np.abs(out - gfgpu.shift(img, (0.0, 3.0), backend="numpy")).max() <= 1e-3


def test_whole_image_operators_say_so(rng):
    img = rng.random((200, 200)).astype(np.float32)
    with strips.working_set(50_000):
        with pytest.raises(ValueError, match="canny .*needs the whole image"):
            gfgpu.canny(img, 1.0, backend="numpy")
        with pytest.raises(ValueError, match="zoom .*needs the whole image"):
            gfgpu.motion_blur(img, 0.3, kind="zoom", backend="numpy")
