"""Arrays of the GPU ecosystem in, the same kind out (gfgpu._core.arrays, issue 30).

torch CPU tensors, numpy's own DLPack (an object with only ``__dlpack__`` / ``__dlpack_device__``)
and Warp CPU arrays through DLPack, on every backend: taken without a copy (the view the operator
computes on shares the caller's memory), dtype and shape kept, results equal to the numpy path.
The CUDA branch (a CUDA array taken by Warp on its device through ``from_dlpack``) is forced on
the CPU here by reporting a CPU tensor as a CUDA one; on a GPU machine the ``cuda`` tests run it
for real (``GFGPU_TEST_BACKENDS=warp:cuda:0 pytest tests/test_interop.py``).
"""

import dataclasses

import numpy as np
import pytest

import gfgpu
from gfgpu._core import arrays
from gfgpu.backends import BackendUnavailable, resolve_backend
from gfgpu.greens import UniformGreen
from gfgpu.motion import estimate_translation
from gfgpu.shading import lambertian_shading, shape_from_shading
from gfgpu.stereo import disparity

try:
    import torch  # the `interop` extra
except ImportError:    # pragma: no cover - depends on the environment
    torch = None
needs_torch = pytest.mark.skipif(torch is None, reason="torch is not installed (pip install gfgpu[interop])")


class DLPackOnly:
    """An array that offers nothing but DLPack (no __array__, no buffer)."""

    def __init__(self, array):
        self._array = array

    def __dlpack__(self, **kwargs):
        return self._array.__dlpack__(**kwargs)

    def __dlpack_device__(self):
        return self._array.__dlpack_device__()


class FakeDevice:
    """An array in the memory of DLPack device ``device_type`` (it cannot be exported)."""

    def __init__(self, device_type, shape=(16, 16)):
        self.device_type, self.shape = device_type, shape

    def __dlpack__(self, **kwargs):
        raise AssertionError("a foreign device's array must be refused before it is exported")

    def __dlpack_device__(self):
        return self.device_type, 0


def _image(dtype=np.float32, shape=(24, 40), seed=0):
    return np.random.default_rng(seed).random(shape).astype(dtype)


def _pair(seed=0):
    right = np.random.default_rng(seed).random((32, 80)).astype(np.float32)
    return np.roll(right, 5, axis=1), right


# every public operator of the issue, as f(image, backend) -> result
OPERATORS = {
    "shift": lambda x, be: gfgpu.shift(x, (0.3, -1.7), backend=be),
    "green_filter": lambda x, be: gfgpu.green_filter(x, UniformGreen(1.5), axis=1, backend=be),
    "green_filter_oblique": lambda x, be: gfgpu.green_filter(x, UniformGreen(1.5), angle=0.4, backend=be),
    "derivative": lambda x, be: gfgpu.derivative(x, 1.2, axis=0, backend=be),
    "gradient": lambda x, be: gfgpu.gradient(x, 1.2, backend=be),
    "motion_blur_uniform": lambda x, be: gfgpu.motion_blur(x, (1.5, 2.5), backend=be),
    "motion_blur_field": lambda x, be: gfgpu.motion_blur(
        x, np.stack([np.full((24, 40), 1.5), np.linspace(-2, 2, 40) * np.ones((24, 40))]),
        backend=be),
    "motion_blur_zoom": lambda x, be: gfgpu.motion_blur(x, 0.2, kind="zoom", backend=be),
    "motion_blur_rotation": lambda x, be: gfgpu.motion_blur(x, 10.0, kind="rotation", backend=be),
}


def _host(result):
    if isinstance(result, tuple):
        return tuple(_host(r) for r in result)
    return result.numpy() if torch is not None and isinstance(result, torch.Tensor) else np.asarray(result)


def _same(result, expected):
    if isinstance(expected, tuple):
        assert isinstance(result, tuple) and len(result) == len(expected)
        for r, e in zip(result, expected):
            _same(r, e)
        return
    np.testing.assert_array_equal(_host(result), expected)


@pytest.fixture
def taken(monkeypatch):
    """The arrays the operators compute on, as :func:`gfgpu._core.arrays.take` made them."""
    seen = []
    real = arrays.take

    def spy(array, kind, backend, name="input"):
        out = real(array, kind, backend, name)
        seen.append(out)
        return out

    monkeypatch.setattr(arrays, "take", spy)
    return seen


def _shares(view, base):
    if hasattr(view, "ptr"):      # a warp.array
        return view.ptr == base.__array_interface__["data"][0]
    return np.shares_memory(view, base)


# ---- the kinds ------------------------------------------------------------------------------
@needs_torch
def test_kind_of_names_the_library_and_device():
    t = torch.zeros(3, 4)
    kind = arrays.kind_of(t)
    assert (kind.library, kind.name, kind.device, kind.on_host, kind.on_cuda) == \
        ("torch", "torch.Tensor", "cpu", True, False)
    assert arrays.kind_of(np.zeros(3)) is None and arrays.kind_of([1.0, 2.0]) is None
    assert arrays.kind_of(np.float32) is None     # a dtype given as output= is no array
    assert arrays.kind_of(DLPackOnly(np.zeros(3))).device == "cpu"
    cuda = arrays.kind_of(FakeDevice(2))
    assert (cuda.device, cuda.on_cuda, cuda.on_host) == ("cuda:0", True, False)
    assert arrays.kind_of(FakeDevice(10)).device == "rocm:0"


# ---- torch CPU tensors: torch in, torch out, no copy, equal to numpy -------------------------
@needs_torch
@pytest.mark.parametrize("op", OPERATORS)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_torch_cpu_in_torch_out(op, dtype, backend, taken):
    if dtype == np.float64 and not backend.supports_float64:
        pytest.skip(f"{backend!r} has no float64")
    img = _image(dtype)
    tensor = torch.from_numpy(img.copy())
    expected = _host(OPERATORS[op](img, backend))
    result = OPERATORS[op](tensor, backend)
    for r in result if isinstance(result, tuple) else (result,):
        assert isinstance(r, torch.Tensor) and r.dtype == tensor.dtype and tuple(r.shape) == img.shape
    _same(result, expected)
    assert taken and all(_shares(v, tensor.numpy()) for v in taken), "the input was copied"
    np.testing.assert_array_equal(tensor.numpy(), img)     # and left untouched


@needs_torch
def test_torch_integer_tensor_follows_the_dtype_policy(backend):
    img = (np.arange(24 * 40) % 251).reshape(24, 40).astype(np.uint8)
    result = gfgpu.shift(torch.from_numpy(img), (0.5, 0.5), backend=backend)
    assert isinstance(result, torch.Tensor) and result.dtype == torch.float32
    np.testing.assert_array_equal(result.numpy(), gfgpu.shift(img, (0.5, 0.5), backend=backend))


@needs_torch
def test_torch_batch_and_channels_keep_their_shape(backend):
    img = _image(shape=(2, 3, 20, 24))
    result = gfgpu.derivative(torch.from_numpy(img), 1.0, axis=-1, backend=backend)
    assert isinstance(result, torch.Tensor) and tuple(result.shape) == img.shape
    np.testing.assert_array_equal(result.numpy(), gfgpu.derivative(img, 1.0, axis=-1, backend=backend))


@needs_torch
def test_torch_view_is_taken_as_a_view(backend, taken):
    base = torch.from_numpy(_image(shape=(30, 50)))
    view = base[2:26, 5:45].t()          # strided, transposed: a view of the base's memory
    result = gfgpu.shift(view, (0.25, 1.0), backend=backend)
    assert isinstance(result, torch.Tensor)
    np.testing.assert_array_equal(result.numpy(), gfgpu.shift(view.numpy().copy(), (0.25, 1.0), backend=backend))
    assert np.shares_memory(taken[0], base.numpy())


@needs_torch
@pytest.mark.parametrize("op", ["shift", "derivative", "green_filter", "motion_blur_uniform"])
def test_torch_output(op, backend):
    img = _image()
    fns = {"shift": lambda x, out: gfgpu.shift(x, (0.3, -1.7), output=out, backend=backend),
           "derivative": lambda x, out: gfgpu.derivative(x, 1.2, axis=0, output=out, backend=backend),
           "green_filter": lambda x, out: gfgpu.green_filter(x, UniformGreen(1.5), axis=1, output=out,
                                                             backend=backend),
           "motion_blur_uniform": lambda x, out: gfgpu.motion_blur(x, (1.5, 2.5), output=out, backend=backend)}
    expected = fns[op](img, None)
    for source in (torch.from_numpy(img.copy()), img):      # torch or numpy input, torch output
        out = torch.full(img.shape, -1.0)
        assert fns[op](source, out) is out
        np.testing.assert_array_equal(out.numpy(), expected)
    if backend.supports_float64:
        out64 = torch.zeros(img.shape, dtype=torch.float64)     # a wider output is allowed
        assert fns[op](torch.from_numpy(img), out64) is out64
        np.testing.assert_allclose(out64.numpy(), expected, rtol=1e-6, atol=1e-6)
    with pytest.raises(TypeError, match="downcast"):
        fns[op](torch.from_numpy(img.astype(np.float64)), torch.zeros(img.shape, dtype=torch.float32))
    with pytest.raises(ValueError, match="shape"):
        fns[op](torch.from_numpy(img), torch.zeros(3, 3))


@needs_torch
def test_torch_tensor_that_requires_grad_is_refused_clearly():
    t = torch.zeros(8, 8, requires_grad=True)
    with pytest.raises(TypeError, match=r"input \(torch.Tensor on cpu\) cannot be read through DLPack.*detach"):
        gfgpu.shift(t, (0.5, 0.5), backend="numpy")


@needs_torch
def test_torch_disparity(backend):
    left, right = _pair()
    expected = disparity(left, right, 12, backend=backend)
    result = disparity(torch.from_numpy(left), torch.from_numpy(right), 12, backend=backend)
    assert isinstance(result, torch.Tensor) and result.dtype == torch.float32
    np.testing.assert_array_equal(result.numpy(), expected)
    d, conf = disparity(torch.from_numpy(left), torch.from_numpy(right), 12, return_confidence=True,
                        backend=backend)
    assert isinstance(d, torch.Tensor) and isinstance(conf, torch.Tensor)
    np.testing.assert_array_equal(d.numpy(), expected)


@needs_torch
def test_torch_canny(backend):
    img = _image(np.float64, (40, 40))
    expected = gfgpu.canny(img, 1.0, backend=backend)
    result = gfgpu.canny(torch.from_numpy(img), 1.0, backend=backend)
    np.testing.assert_array_equal(_host(result), expected)
    assert isinstance(result, torch.Tensor)


@needs_torch
def test_torch_stereo_matcher(backend):
    rng = np.random.default_rng(3)
    left = rng.random((40, 60), dtype=np.float32)
    right = np.roll(left, -4, axis=1)
    matcher = gfgpu.StereoMatcher(left.shape, 12, backend=backend)
    expected = matcher.compute(left, right)
    result = matcher.compute(torch.from_numpy(left), torch.from_numpy(right))
    assert isinstance(result, torch.Tensor)
    np.testing.assert_array_equal(result.numpy(), expected)


@needs_torch
def test_torch_canny_values(backend):
    img = _image(np.float64, (40, 40))
    np.testing.assert_array_equal(_host(gfgpu.canny(torch.from_numpy(img), 1.0, backend=backend)),
                                  gfgpu.canny(img, 1.0, backend=backend))


@needs_torch
@pytest.mark.parametrize("op", ["shift", "derivative", "gradient"])
def test_torch_channel_axis(op, backend):
    img = _image(shape=(20, 24, 3))
    fns = {"shift": lambda x: gfgpu.shift(x, (0.5, -1.5), channel_axis=-1, backend=backend),
           "derivative": lambda x: gfgpu.derivative(x, 1.0, axis=0, channel_axis=-1, backend=backend),
           "gradient": lambda x: gfgpu.gradient(x, 1.0, channel_axis=-1, backend=backend)}
    result = fns[op](torch.from_numpy(img))
    assert all(isinstance(r, torch.Tensor) for r in (result if isinstance(result, tuple) else (result,)))
    _same(result, _host(fns[op](img)))


@needs_torch
@pytest.mark.parametrize("op", ["green_filter_oblique", "motion_blur"])
def test_torch_channel_axis_moved(op):
    img = _image(shape=(20, 24, 3))
    fns = {"green_filter_oblique": lambda x: gfgpu.green_filter(x, UniformGreen(1.0), angle=0.3, channel_axis=-1,
                                                                backend="numpy"),
           "motion_blur": lambda x: gfgpu.motion_blur(x, (0.0, 2.0), channel_axis=-1, backend="numpy")}
    result = fns[op](torch.from_numpy(img))
    np.testing.assert_array_equal(_host(result), fns[op](img))
    assert isinstance(result, torch.Tensor)


@needs_torch
def test_torch_streamed_strips():
    t = torch.from_numpy(_image(shape=(300, 300)))
    with gfgpu.working_set(64 * 1024):     # both streamed in strips (carried states: rounding differs in-memory)
        result = gfgpu.shift(t, (0.5, 0.5), backend="numpy")
        expected = gfgpu.shift(t.numpy(), (0.5, 0.5), backend="numpy")
    np.testing.assert_array_equal(_host(result), expected)
    assert isinstance(result, torch.Tensor)


# ---- an object with only DLPack; Warp CPU arrays through DLPack -----------------------------
@pytest.mark.parametrize("op", OPERATORS)
def test_dlpack_only_object(op, backend, taken):
    img = _image()
    expected = _host(OPERATORS[op](img, backend))
    result = OPERATORS[op](DLPackOnly(img), backend)
    _same(result, expected)     # no namespace to convert back to: numpy out
    assert all(isinstance(r, np.ndarray) for r in (result if isinstance(result, tuple) else (result,)))
    assert taken and all(_shares(v, img) for v in taken)


@needs_torch
def test_warp_cpu_array_through_dlpack(backend, require_backend, taken):
    wp_be = require_backend("warp")
    img = _image()
    host = wp_be.asarray(img)              # a warp.array on the CPU
    result = gfgpu.shift(DLPackOnly(host), (0.3, -1.7), backend=backend)
    np.testing.assert_array_equal(result, gfgpu.shift(img, (0.3, -1.7), backend=backend))
    assert np.shares_memory(taken[0], host.numpy())
    # torch sees the same memory through DLPack, and gets torch back
    as_torch = torch.from_dlpack(host)
    out = gfgpu.shift(as_torch, (0.3, -1.7), backend=backend)
    assert isinstance(out, torch.Tensor) and np.shares_memory(taken[1], host.numpy())


# ---- host-only functions: any kind, moved to the host once, or one clear error ----------------
def _kinds(img, require_backend):
    kinds = {"torch": torch.from_numpy(img.copy()), "dlpack": DLPackOnly(img.copy())}
    kinds["warp"] = require_backend("warp").asarray(img)
    return kinds


@needs_torch
def test_host_only_functions_take_every_kind(require_backend):
    from scipy.ndimage import gaussian_filter
    big = gaussian_filter(np.random.default_rng(0).random((140, 160)), 2.0).astype(np.float32)
    f0, f1 = big[20:120, 20:140].copy(), big[17:117, 15:135].copy()
    yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    shading = lambertian_shading(8 * np.exp(-(xx**2 + yy**2) / 200), (1, 0, 1)).astype(np.float32)
    left, right = _pair()
    depth = shape_from_shading(shading, light=(1, 0, 1), backend="numpy")
    disp = disparity(left, right, 12, backend="numpy")
    for name in ("torch", "dlpack", "warp"):
        a0, a1 = _kinds(f0, require_backend)[name], _kinds(f1, require_backend)[name]
        assert estimate_translation(a0, a1) == estimate_translation(f0, f1) == (3.0, 5.0), name
        est = shape_from_shading(_kinds(shading, require_backend)[name], light=(1, 0, 1), backend="numpy")
        np.testing.assert_array_equal(_host(est), depth)
        assert isinstance(est, torch.Tensor) == (name == "torch")
        d = disparity(_kinds(left, require_backend)[name], _kinds(right, require_backend)[name], 12,
                      backend="numpy")
        np.testing.assert_array_equal(_host(d), disp)
        mid = gfgpu.interpolate_frames(_kinds(f0, require_backend)[name], _kinds(f1, require_backend)[name], 1,
                                       velocity=(3.0, 5.0), backend="numpy")
        np.testing.assert_array_equal(mid, gfgpu.interpolate_frames(f0, f1, 1, velocity=(3.0, 5.0),
                                                                    backend="numpy"))


@needs_torch
def test_host_array_is_a_view_for_host_memory():
    img = _image()
    t = torch.from_numpy(img)
    assert np.shares_memory(arrays.host_array(t, "x"), img)
    assert np.shares_memory(arrays.host_array(DLPackOnly(img), "x"), img)


def test_host_array_reads_opencl_arrays_back(require_backend):
    be = require_backend("opencl")
    img = _image()
    np.testing.assert_array_equal(arrays.host_array(be.asarray(img), "x").reshape(img.shape), img)


@pytest.mark.parametrize("call", [
    lambda x: estimate_translation(x, np.zeros((8, 8))),
    lambda x: gfgpu.interpolate_frames(x, np.zeros((8, 8)), 1, velocity=(0, 1), backend="numpy"),
    lambda x: shape_from_shading(x, light=(1, 0, 1), backend="numpy"),
    lambda x: disparity(x, np.zeros((8, 8)), 4, backend="numpy"),
    lambda x: gfgpu.shift(x, (0.5, 0.5), backend="numpy"),
], ids=["estimate_translation", "interpolate_frames", "shape_from_shading", "disparity", "shift"])
def test_no_array_at_all_is_one_clear_error(call):
    with pytest.raises(TypeError) as err:
        call(object())
    assert "dtype object" not in str(err.value)


# ---- foreign devices: one error naming the array's device and who could take it --------------
def test_cuda_array_without_a_cuda_backend_names_its_device(require_backend):
    if any(d.startswith("cuda") for d in gfgpu.backends.warp.warp_devices()):
        pytest.skip("a CUDA device is present: the array would be taken (tests below)")
    with pytest.raises(BackendUnavailable, match=r"input is a test_interop.FakeDevice on cuda:0.*warp backend on "
                                                 r"cuda:0"):
        resolve_backend(array=FakeDevice(2))
    with pytest.raises(BackendUnavailable, match="cuda:0"):
        gfgpu.shift(FakeDevice(2), (0.5, 0.5))


@pytest.mark.parametrize("name", ["numpy", "opencl"])
def test_cuda_array_on_a_host_backend_is_refused(name, require_backend):
    be = require_backend(name)
    with pytest.raises(TypeError, match=rf"on cuda:0; the {name} backend .* cannot read that memory.*warp backend "
                                        rf"on cuda:0"):
        gfgpu.shift(FakeDevice(2), (0.5, 0.5), backend=be)


def test_memory_no_backend_reads_is_refused():
    with pytest.raises(BackendUnavailable, match=r"on rocm:0; no gfgpu backend reads that memory"):
        gfgpu.shift(FakeDevice(10), (0.5, 0.5))
    with pytest.raises(TypeError, match=r"on rocm:0"):
        gfgpu.shift(FakeDevice(10), (0.5, 0.5), backend="numpy")


# ---- the CUDA branch, forced on the CPU: a CPU tensor reported as a CUDA one -------------------
@pytest.fixture
def as_if_cuda(monkeypatch):
    """Every foreign array reported on DLPack device CUDA 0, so the Warp backend takes it
    through ``from_dlpack`` as a device array (the branch a CUDA tensor takes)."""
    real = arrays.kind_of

    def cuda_kind(array, own=False):
        kind = real(array, own)
        if kind is None or kind.library in ("warp", "pyopencl"):
            return kind
        return dataclasses.replace(kind, device_type=arrays.DLPACK_CUDA, device_id=0)

    monkeypatch.setattr(arrays, "kind_of", cuda_kind)


@needs_torch
@pytest.mark.parametrize("op", [k for k in OPERATORS if k != "green_filter_oblique"])
def test_cuda_branch_forced_on_warp_cpu(op, as_if_cuda, require_backend, taken):
    be = require_backend("warp")
    if not be.wp_device.is_cpu:
        pytest.skip("a real GPU: test_torch_cuda runs the branch there")
    img = _image()
    tensor = torch.from_numpy(img.copy())
    expected = _host(OPERATORS[op](img, be))
    result = OPERATORS[op](tensor, be)
    for r in result if isinstance(result, tuple) else (result,):
        assert isinstance(r, torch.Tensor) and r.dtype == torch.float32
    _same(result, expected)
    assert all(type(v).__module__.startswith("warp") and v.ptr == tensor.data_ptr() for v in taken)


@needs_torch
def test_cuda_branch_forced_output_and_refusals(as_if_cuda, require_backend):
    be = require_backend("warp")
    if not be.wp_device.is_cpu:
        pytest.skip("a real GPU: test_torch_cuda runs the branch there")
    img = _image()
    out = torch.zeros(img.shape)
    assert gfgpu.shift(torch.from_numpy(img), (0.3, -1.7), output=out, backend=be) is out
    np.testing.assert_array_equal(out.numpy(), gfgpu.shift(img, (0.3, -1.7), backend=be))
    with pytest.raises(TypeError, match=r"torch.Tensor on cuda:0; the numpy backend"):
        gfgpu.shift(torch.from_numpy(img), (0.3, -1.7), backend="numpy")
    with pytest.raises(TypeError, match="float32 or float64"):    # device inputs: converted on the device
        gfgpu.shift(torch.zeros(8, 8, dtype=torch.int32), (0.5, 0.5), backend=be)


# ---- real CUDA (a GPU machine: torch with CUDA and the Warp backend on cuda:N) ---------------
def _cuda_warp(require_backend):
    be = require_backend("warp")
    if be.wp_device.is_cpu or not torch.cuda.is_available():
        pytest.skip("needs a CUDA GPU for both Warp and torch (the device check)")
    return be


@needs_torch
@pytest.mark.parametrize("op", OPERATORS)
def test_torch_cuda(op, require_backend):
    be = _cuda_warp(require_backend)
    img = _image()
    tensor = torch.from_numpy(img.copy()).to(f"cuda:{be.wp_device.ordinal}")
    expected = _host(OPERATORS[op](img, be))
    result = OPERATORS[op](tensor, None)     # the tensor's own device decides
    for r in result if isinstance(result, tuple) else (result,):
        assert isinstance(r, torch.Tensor) and r.device == tensor.device and r.dtype == tensor.dtype
    got = tuple(r.cpu().numpy() for r in result) if isinstance(result, tuple) else result.cpu().numpy()
    for g, e in zip(got if isinstance(got, tuple) else (got,), expected if isinstance(expected, tuple) else
                    (expected,)):
        np.testing.assert_allclose(g, e, rtol=1e-5, atol=1e-5 * float(np.abs(e).max()))


@needs_torch
def test_torch_cuda_output_and_disparity(require_backend):
    be = _cuda_warp(require_backend)
    img = _image()
    tensor = torch.from_numpy(img.copy()).to(f"cuda:{be.wp_device.ordinal}")
    out = torch.empty_like(tensor)
    assert gfgpu.shift(tensor, (0.3, -1.7), output=out) is out
    np.testing.assert_allclose(out.cpu().numpy(), gfgpu.shift(img, (0.3, -1.7), backend=be), rtol=1e-5, atol=1e-6)
    left, right = _pair()
    d = disparity(torch.from_numpy(left).to(tensor.device), torch.from_numpy(right).to(tensor.device), 12)
    assert isinstance(d, torch.Tensor) and d.device == tensor.device
    np.testing.assert_array_equal(d.cpu().numpy(), disparity(left, right, 12, backend=be))


def test_cupy_cuda(require_backend):
    be = _cuda_warp(require_backend)
    cupy = pytest.importorskip("cupy")
    img = _image()
    with cupy.cuda.Device(be.wp_device.ordinal):
        x = cupy.asarray(img)
        result = gfgpu.shift(x, (0.3, -1.7))
    assert isinstance(result, cupy.ndarray) and result.device.id == be.wp_device.ordinal
    np.testing.assert_allclose(cupy.asnumpy(result), gfgpu.shift(img, (0.3, -1.7), backend=be), rtol=1e-5,
                               atol=1e-6)


# ---- the README's example runs verbatim ---------------------------------------------------------
@needs_torch
def test_readme_pytorch_pipeline_runs(tmp_path):
    import os
    import re
    import subprocess
    import sys
    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "README.md")
    if not os.path.exists(path):
        pytest.skip("not running from a source checkout")
    section = open(path, encoding="utf-8").read().split("\n## gfgpu in a PyTorch pipeline", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    res = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    # the transform's tensors: two batches of two, each disparity map at its pair's disparity (4 + i px)
    rows = [line for line in res.stdout.splitlines() if line.startswith("torch.Size")]
    assert rows == ["torch.Size([2, 64, 96]) torch.Size([2, 64, 96]) [4.0, 5.0]",
                    "torch.Size([2, 64, 96]) torch.Size([2, 64, 96]) [6.0, 7.0]"]


def test_light_estimate_takes_a_dlpack_only_object():
    """estimate_illuminant reads any array kind on the host (not "dtype object")."""
    from gfgpu.shading import estimate_illuminant
    yy, xx = np.mgrid[:64, :64]
    r2 = ((yy - 32.0) ** 2 + (xx - 32.0) ** 2) / 20.0 ** 2
    nz = np.sqrt(np.clip(1 - r2, 0, None))
    img = np.where(r2 < 1, nz, 1.0)           # a frontally lit sphere on a frontal plane
    (want, want_albedo), (got, got_albedo) = estimate_illuminant(img), estimate_illuminant(DLPackOnly(img))
    np.testing.assert_array_equal(got, want)
    assert got_albedo == want_albedo
