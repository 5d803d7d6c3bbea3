"""Type-in/type-out, dtype policy, bad inputs, backend selection and packaging."""
import importlib.resources
import os
import subprocess
import sys
import zipfile

import numpy as np
import pytest

import gfgpu
from gfgpu import greens

G = greens.UniformGreen(2.0)


@pytest.mark.parametrize("dtype,expected", [(np.float32, np.float32), (np.float64, np.float64),
                                            (np.uint8, np.float32), (np.int16, np.float32),
                                            (np.bool_, np.float32), (np.float16, np.float32)])
def test_dtype_policy(backend, dtype, expected):
    img = (np.arange(60).reshape(6, 10) % 7).astype(dtype)
    for out in (gfgpu.green_filter(img, G, backend=backend), gfgpu.shift(img, (0.5, 1.5), backend=backend),
                gfgpu.derivative(img, 1.0, backend=backend), *gfgpu.gradient(img, 1.0, backend=backend)):
        assert isinstance(out, np.ndarray) and out.dtype == expected and out.shape == img.shape


def test_input_is_never_modified_and_output_argument(backend, rng):
    img = rng.standard_normal((8, 12))
    before = img.copy()
    out = np.empty_like(img)
    res = gfgpu.shift(img, (1.0, -2.0), output=out, backend=backend)
    assert res is out
    np.testing.assert_array_equal(img, before)
    np.testing.assert_allclose(out, gfgpu.shift(img, (1.0, -2.0), backend=backend))
    res = gfgpu.green_filter(img.astype(np.float32), G, output=np.float64, backend=backend)
    assert res.dtype == np.float64
    zero = gfgpu.shift(img, 0.0, backend=backend)
    np.testing.assert_array_equal(zero, img)
    assert zero is not img


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_output_written_in_place_or_through_a_copy(backend, rng, dtype):
    # 192 x 160 is above the size from which CPU devices share host memory instead of copying
    img = rng.standard_normal((192, 160)).astype(dtype)
    shift = (0.0, -2.25)                # one pass: an aliased output would be read after written
    ref = gfgpu.shift(img, shift, backend=backend)
    tol = dict(rtol=0, atol=1e-12 if dtype == np.float64 else 1e-6)
    raw = np.zeros(img.nbytes + 8, np.uint8)
    outputs = {"fresh": np.empty_like(img),
               "strided": np.empty((192, 320), dtype)[:, ::2],
               "unaligned": raw[8:].view(dtype).reshape(img.shape),
               "in place": img.copy()}
    for name, out in outputs.items():
        src = out if name == "in place" else img
        res = gfgpu.shift(src, shift, output=out, backend=backend)
        assert res is out, name
        np.testing.assert_allclose(out, ref, err_msg=name, **tol)
    if backend.name == "numpy" or (dtype == np.float64 and not backend.supports_float64):
        return
    dev = backend.asarray(img)
    dev_out = backend.empty(img.shape, dtype)
    assert gfgpu.shift(dev, shift, output=dev_out) is dev_out
    np.testing.assert_allclose(backend.to_host(dev_out), ref, **tol)
    assert gfgpu.shift(dev, shift, output=dev) is dev      # in place on the device
    np.testing.assert_allclose(backend.to_host(dev), ref, **tol)


def test_device_arrays_stay_on_their_device(backend, rng):
    if backend.name == "numpy":
        pytest.skip("host arrays")
    img = rng.standard_normal((8, 12)).astype(np.float32)
    dev = backend.asarray(img)
    out = gfgpu.shift(dev, (0.5, 1.5))          # resolved from the array itself
    assert backend.owns(out) and not isinstance(out, np.ndarray)
    np.testing.assert_allclose(backend.to_host(out), gfgpu.shift(img, (0.5, 1.5), backend="numpy"),
                               rtol=2e-5, atol=2e-6)
    np.testing.assert_array_equal(backend.to_host(dev), img)


@pytest.mark.parametrize("call,exc,match", [
    (lambda be: gfgpu.green_filter(np.ones((4, 4)), greens.UniformGreen(1), mode="bogus", backend=be),
     ValueError, "mode must be one of"),
    (lambda be: gfgpu.green_filter(np.array([1.0, np.nan]), G, backend=be), ValueError, "NaN or infinite"),
    (lambda be: gfgpu.shift(np.array([[1.0, np.inf]]), 1.0, backend=be), ValueError, "NaN or infinite"),
    (lambda be: gfgpu.green_filter(np.float64(3.0), G, backend=be), ValueError, "at least 1 dimension"),
    (lambda be: gfgpu.green_filter(np.ones((0, 4)), G, backend=be), ValueError, "input is empty"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4), complex), G, backend=be), TypeError, "real numeric dtype"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), G, axis=2, backend=be), ValueError, "axis=2 is out of range"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), "G_u", backend=be), TypeError, "kernel must be"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), greens.AffineGreenApprox(3.0, 1.0), backend=be),
     ValueError, "x_U < 0"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), greens.AffineGreen(0.5, 2.0), anticausal=True, backend=be),
     ValueError, "x_U > 3"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), G, cval=np.nan, backend=be), ValueError, "cval must be finite"),
    (lambda be: gfgpu.green_filter(np.ones((3, 4)), G, angle="x", backend=be), TypeError, "angle must be"),
    (lambda be: gfgpu.shift(np.ones((3, 4)), (1.0, 2.0, 3.0), backend=be), ValueError, "one value per axis"),
    (lambda be: gfgpu.shift(np.ones((3, 4)), (1.0, np.nan), backend=be), ValueError, "shift must be finite"),
    (lambda be: gfgpu.derivative(np.ones((3, 4)), 0.0, backend=be), ValueError, "u must be > 0"),
    (lambda be: gfgpu.derivative(np.ones((3, 4)), -1.0, backend=be), ValueError, "u must be > 0"),
    (lambda be: gfgpu.shift(np.ones((3, 4)), 1.0, output=np.ones((3, 4), np.float32), backend=be),
     TypeError, "downcast"),
    (lambda be: gfgpu.shift(np.ones((3, 4)), 1.0, output=np.ones((4, 4)), backend=be), ValueError, "shape"),
])
def test_bad_inputs_raise_clear_errors(backend, call, exc, match):
    with pytest.raises(exc, match=match):
        call(backend)


def test_backend_selection_rule(monkeypatch):
    with pytest.raises(ValueError, match="backend must be one of"):
        gfgpu.shift(np.ones((3, 4)), 1.0, backend="cuda")
    with gfgpu.use_backend("numpy") as be:
        assert be.name == "numpy"
        from gfgpu.backends import resolve_backend
        assert resolve_backend().name == "numpy"
        assert resolve_backend("numpy").name == "numpy"
    monkeypatch.setenv("GFGPU_BACKEND", "numpy")
    from gfgpu.backends import resolve_backend
    assert resolve_backend().name == "numpy"
    listing = gfgpu.devices()
    assert listing[0].backend == "numpy" and listing[0].usable
    assert {d.backend for d in listing} == {"numpy", "warp", "opencl"}
    for d in listing:
        assert d.usable or d.note      # an unusable device always says why


def test_an_opencl_device_that_cannot_compile_is_never_chosen_and_says_why(monkeypatch):
    """A device can be listed and fail every build (PyOpenCL's bundled PoCL on AMD Zen 5: "unknown
    target CPU 'generic'"): the default choice skips it, choosing it names the reason."""
    opencl = pytest.importorskip("gfgpu.backends.opencl")
    if opencl.unavailable_reason() is not None:
        pytest.skip(f"no usable OpenCL device: {opencl.unavailable_reason()}")
    from gfgpu.backends.base import BackendUnavailable
    from gfgpu.backends.opencl import backend as clb
    devs = opencl.opencl_devices()
    working = [i for i, d, _ in devs if opencl.build_failure(d) is None]
    assert working and opencl.build_failure(devs[working[0]][1]) is None     # the probe really built
    broken_index, broken = working[0], devs[working[0]][1]
    reason = "OpenCL device 'x' (PoCL) cannot compile kernels (error: unknown target CPU 'generic')"
    monkeypatch.setitem(clb._build_failures, broken.int_ptr, reason)
    with pytest.raises(BackendUnavailable, match="unknown target CPU"):
        opencl.OpenCLBackend(broken_index)                  # chosen by index: the reason, not a crash later
    with pytest.raises(BackendUnavailable, match="unknown target CPU"):
        opencl.OpenCLBackend(broken)
    # a context, a queue, an array of the caller's on that device
    import pyopencl as cl
    import pyopencl.array as cla
    ctx = cl.Context([broken])
    for spec in (ctx, cl.CommandQueue(ctx)):
        with pytest.raises(BackendUnavailable, match="unknown target CPU"):
            opencl.OpenCLBackend(spec)
    with pytest.raises(BackendUnavailable, match="unknown target CPU"):
        gfgpu.shift(cla.to_device(cl.CommandQueue(ctx), np.ones((4, 5), np.float32)), 0.5)
    with pytest.raises(TypeError, match="device must be"):
        opencl.OpenCLBackend(True)                          # not index 1
    listing = {d.device.split(":")[0]: d for d in gfgpu.devices() if d.backend == "opencl"}
    entry = listing[str(broken_index) if len(working) > 1 else "-"]      # "-": the backend as a whole
    assert not entry.usable and "unknown target CPU" in entry.note
    if len(working) > 1:                                    # the default takes a device that compiles
        assert opencl.OpenCLBackend().cl_device.int_ptr != broken.int_ptr
    else:                                                   # none compiles: unavailable, with the reason
        assert "unknown target CPU" in opencl.unavailable_reason()
        with pytest.raises(BackendUnavailable, match="unknown target CPU"):
            opencl.OpenCLBackend()


def test_import_is_lazy():
    code = ("import sys, gfgpu; gfgpu.greens.UniformGreen(1.0); "
            "print(any(m in sys.modules for m in ('warp', 'pyopencl')))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "False"


def test_kernels_ship_with_the_package():
    for package, name in (("gfgpu.backends.opencl", "recurse.cl"), ("gfgpu.backends.opencl", "recurse_lines.cl"),
                          ("gfgpu.edges", "edges.cl"), ("gfgpu.stereo", "stereo.cl"), ("gfgpu.motion", "motion.cl")):
        cl = importlib.resources.files(package).joinpath(name)
        assert cl.is_file() and "__kernel" in cl.read_text()


@pytest.mark.skipif(os.environ.get("GFGPU_SKIP_WHEEL") == "1", reason="GFGPU_SKIP_WHEEL=1")
def test_wheel_contains_the_kernels(tmp_path):
    import shutil
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if not os.path.exists(os.path.join(root, "pyproject.toml")):
        pytest.skip("not running from a source checkout")
    # build from a copy of the tracked sources: a build in the checkout leaves build/ behind,
    # whose stale files a later wheel would carry
    src = tmp_path / "src"
    shutil.copytree(root, src, ignore=shutil.ignore_patterns(".git", ".venv", "build", "dist", "*.egg-info",
                                                             "__pycache__", ".pytest_cache", ".ruff_cache"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w",
                    str(tmp_path / "wheel"), str(src)], check=True, capture_output=True)
    wheel = next((tmp_path / "wheel").glob("gfgpu-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    package = os.path.join(root, "gfgpu")
    expected = {os.path.relpath(os.path.join(d, f), root).replace(os.sep, "/")
                for d, _, files in os.walk(package) if "__pycache__" not in d
                for f in files if f.endswith((".py", ".cl", ".png"))}
    assert expected <= names, sorted(expected - names)
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(meta).decode()
    assert f"Version: {gfgpu.__version__}" in text and "License-Expression: MIT" in text


def test_float64_on_a_device_without_fp64_is_an_error_not_a_downcast():
    from gfgpu.backends.numpy import NumpyBackend
    no_fp64 = NumpyBackend()
    no_fp64.supports_float64 = False      # stands in for a GPU without cl_khr_fp64
    with pytest.raises(TypeError, match="no float64 support"):
        gfgpu.shift(np.ones((4, 4)), 1.0, backend=no_fp64)
    out = gfgpu.shift(np.ones((4, 4), np.float32), 1.0, backend=no_fp64)
    assert out.dtype == np.float32


def test_cli_outputs_are_written_atomically_with_normal_permissions(tmp_path):
    from gfgpu.cli import main
    out = tmp_path / "g.png"
    assert main(["gradient", "--example", "camera", "-o", str(out), "--backend", "numpy"]) == 0
    import imageio.v3 as iio
    img = iio.imread(out)
    assert img.shape == (512, 512, 3) and img.dtype == np.uint8 and img.max() > 0
    umask = os.umask(0)
    os.umask(umask)
    assert (out.stat().st_mode & 0o777) == (0o666 & ~umask)
    assert [p.name for p in tmp_path.iterdir()] == ["g.png"]      # no temporary left behind


def test_host_views_outlive_the_callers_reference(backend, rng):
    """A device that reads host memory in place keeps it until its kernels have run."""
    from gfgpu import greens
    from gfgpu._core.recursion import plan_pass
    plan = plan_pass(greens.UniformGreen(3.0).line_pass(), 512, "reflect", np.float32)
    expect, outs = [], []
    for _ in range(8):
        host = rng.random((1, 512, 512)).astype(np.float32)      # 1 MiB: shared, not copied, on CPU OpenCL
        expect.append(gfgpu.green_filter(host[0], greens.UniformGreen(3.0), axis=0, backend="numpy"))
        out = backend.empty(host.shape, np.float32)
        backend.recurse(backend.host_view(host), out, 1, plan)   # the view is dropped at once
        del host
        np.ones((1, 512, 512), np.float32)                         # reuse freed memory if any
        outs.append(out)
    for out, ref in zip(outs, expect):
        assert np.abs(backend.to_host(out)[0] - ref).max() <= 1e-5


WIDE = 2_000_000_003      # float32 rounds it to 2,000,000,000


@pytest.mark.parametrize("dtype", [np.int32, np.uint32, np.int64, np.uint64])
def test_wide_integers_are_computed_in_float64(backend, dtype):
    # float32 holds integers exactly only up to 2**24: int32/uint32/int64/uint64 images were
    # computed (and returned) in float32, so shift(img, (0, 0)) lost the last digits
    img = (WIDE + np.arange(48).reshape(6, 8) % 5).astype(dtype)
    same = gfgpu.shift(img, (0, 0), backend=backend)
    assert same.dtype == np.float64
    np.testing.assert_array_equal(same, img.astype(np.float64))
    ref = img.astype(np.float64)
    calls = [lambda x: gfgpu.shift(x, (0.5, -1.5), backend=backend),
             lambda x: gfgpu.green_filter(x, G, backend=backend),
             lambda x: gfgpu.derivative(x, 1.0, backend=backend),
             lambda x: gfgpu.projection(x, 1.0, backend=backend),
             lambda x: gfgpu.gradient(x, 1.0, backend=backend)[1],
             lambda x: gfgpu.motion_blur(x, (1.0, 2.5), backend=backend),
             lambda x: gfgpu.synthesize_motion(x, (1.0, 2.5), 2, backend=backend)[1],
             lambda x: gfgpu.interpolate_frames(x, x, 1, velocity=(0.5, 1.0), backend=backend)[0]]
    for call in calls:
        out = call(img)
        assert out.dtype == np.float64
        np.testing.assert_array_equal(out, call(ref))


def test_wide_integers_in_the_other_entry_points(tmp_path):
    img = (WIDE + np.arange(48).reshape(6, 8) % 5).astype(np.int32)
    np.save(tmp_path / "in.npy", img)
    info = gfgpu.filter_npy("shift", tmp_path / "in.npy", tmp_path / "out.npy", shift=(0, 0), backend="numpy")
    assert info["dtype"] == "float64"
    np.testing.assert_array_equal(np.load(tmp_path / "out.npy"), img)
    gfgpu.filter_npy("shift", tmp_path / "in.npy", tmp_path / "o32.npy", shift=(0, 0), dtype="float32",
                     backend="numpy")       # asked for: float32's rounding
    assert np.load(tmp_path / "o32.npy").dtype == np.float32
    from gfgpu.shading.params import checked_image
    assert checked_image(img).dtype == np.float64
    da = pytest.importorskip("dask.array")
    import gfgpu.dask as gd
    out = gd.shift(da.from_array(img, chunks=(3, 4)), (0, 0), backend="numpy").compute()
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, img)


def test_wide_integers_on_a_device_without_fp64_need_output_float32():
    from gfgpu.backends.numpy import NumpyBackend
    no_fp64 = NumpyBackend()
    no_fp64.supports_float64 = False
    img = np.full((4, 4), WIDE, np.int32)
    with pytest.raises(TypeError, match="output=numpy.float32"):
        gfgpu.shift(img, (0, 0), backend=no_fp64)
    out = gfgpu.shift(img, (0, 0), output=np.float32, backend=no_fp64)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(gfgpu.shift(img.astype(np.int16) * 0 + 7, 1.0, backend=no_fp64), 7)


# --------------------------------------------------------------------------------------
# the lazy top level (PEP 562): import gfgpu loads nothing heavy, every public name is reachable
# --------------------------------------------------------------------------------------
_IMPORT_GFGPU = """
import sys
import gfgpu
print(" ".join(sorted(m for m in sys.modules if m.split(".")[0] in ("gfgpu", "numpy", "scipy"))))
"""


def test_import_gfgpu_loads_no_operator(tmp_path):
    """``import gfgpu`` took ~5 s (numpy, scipy, every operator; issue 31): now only its version."""
    out = subprocess.run([sys.executable, "-c", _IMPORT_GFGPU], capture_output=True, text=True, check=True,
                         timeout=120, cwd=tmp_path).stdout.split()
    assert out == ["gfgpu", "gfgpu._version"]


def test_every_public_name_is_reachable_and_is_its_modules_object():
    import importlib

    sources = gfgpu._SOURCES
    assert set(sources) == set(gfgpu.__all__) - {"__version__"} and len(gfgpu.__all__) == len(set(gfgpu.__all__))
    for name, (module, attribute) in sources.items():
        owner = importlib.import_module(f"gfgpu.{module}")
        expected = owner if attribute is None else getattr(owner, attribute)
        assert getattr(gfgpu, name) is expected, name
    assert set(gfgpu.__all__) <= set(dir(gfgpu))
    assert not {"_SOURCES", "_SUBMODULES", "_importlib", "__getattr__"} & set(dir(gfgpu))
    from gfgpu import StereoMatcher, shift
    assert shift is gfgpu.filters.shift and StereoMatcher is gfgpu.stereo.StereoMatcher
    namespace = {}
    exec("from gfgpu import *", namespace)
    assert set(gfgpu.__all__) <= set(namespace)
    with pytest.raises(AttributeError, match="module 'gfgpu' has no attribute 'no_such_name'"):
        gfgpu.no_such_name  # noqa: B018
    with pytest.raises(ImportError, match="cannot import name 'no_such_name'"):
        exec("from gfgpu import no_such_name", {})


_DIR_AND_SUBMODULES = """
import gfgpu
print(" ".join(dir(gfgpu)))
print(gfgpu.io.__name__, gfgpu.stereo.__name__, gfgpu._core.__name__)
"""


def test_dir_and_submodules_are_as_after_an_eager_import(tmp_path):
    """``dir(gfgpu)`` in a fresh interpreter lists what the eager ``import gfgpu`` listed: the public
    names, the dunders and the subpackages it loaded (``gfgpu.io`` works without importing it)."""
    out = subprocess.run([sys.executable, "-c", _DIR_AND_SUBMODULES], capture_output=True, text=True, check=True,
                         timeout=120, cwd=tmp_path).stdout.splitlines()
    expected = set(gfgpu.__all__) | {"_core", "_version", "backends", "edges", "filters", "greens", "io", "motion",
                                     "out_of_core", "shading", "stereo"}
    dunders = {"__all__", "__builtins__", "__cached__", "__doc__", "__file__", "__loader__", "__name__",
               "__package__", "__path__", "__spec__"}
    assert set(out[0].split()) == expected | dunders
    assert out[1] == "gfgpu.io gfgpu.stereo gfgpu._core"
