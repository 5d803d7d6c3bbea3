"""Inputs, parameters and processes from real use: each kind of fault with the right value or
the exact message (byte order, parameter types, canny's edge cases, fork)."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import gfgpu


@pytest.mark.parametrize("order", [">f4", ">f8"])
def test_big_endian_input_and_output(backend, order, rng):
    if np.dtype(order).itemsize == 8 and not backend.supports_float64:
        pytest.skip("no float64 on this device")
    native = rng.random((21, 33)).astype(np.dtype(order).newbyteorder("="))
    swapped = native.astype(order)
    calls = [
        lambda x, **kw: gfgpu.shift(x, (1.5, -2.25), backend=backend.name, **kw),
        lambda x, **kw: gfgpu.green_filter(x, gfgpu.UniformGreen(2.0), axis=0, backend=backend.name, **kw),
        lambda x, **kw: gfgpu.derivative(x, 1.0, axis=1, backend=backend.name, **kw),
        lambda x, **kw: gfgpu.motion_blur(x, (3, 5), backend=backend.name, **kw),
    ]
    for call in calls:
        ref = call(native)
        np.testing.assert_array_equal(call(swapped), ref)
        out = np.empty(native.shape, order)
        assert call(swapped, output=out) is out
        np.testing.assert_array_equal(out, ref)
    gy, gx = gfgpu.gradient(swapped, 1.0, backend=backend.name)
    np.testing.assert_array_equal(gy, gfgpu.gradient(native, 1.0, backend=backend.name)[0])


def test_big_endian_npy_file(tmp_path, rng):
    img = rng.random((40, 30)).astype(">f4")
    np.save(tmp_path / "be.npy", img)
    gfgpu.filter_npy("shift", tmp_path / "be.npy", tmp_path / "out.npy", shift=(2.5, -1.0), backend="numpy")
    ref = gfgpu.shift(img.astype("<f4"), (2.5, -1.0), backend="numpy")
    np.testing.assert_allclose(np.load(tmp_path / "out.npy"), ref, atol=1e-6)


@pytest.mark.parametrize("call, message", [
    (lambda img: gfgpu.green_filter(img, gfgpu.UniformGreen(1.0), anticausal="False"),
     "anticausal must be True or False"),
    (lambda img: gfgpu.motion_blur(img, (2, 3), displace="False"), "displace must be True or False"),
    (lambda img: gfgpu.derivative(img, 1.0, axis=1.5), "axis must be an integer"),
    (lambda img: gfgpu.derivative(img, 1.0, axis="0"), "axis must be an integer"),
    (lambda img: gfgpu.green_filter(img, gfgpu.UniformGreen("3")), "u must be a real number"),
    (lambda img: gfgpu.shift(img, ("1", 0)), "shift must be a real number"),
    (lambda img: gfgpu.shift(img, 1.0, output=[0.0] * 4), "output must be a numpy array"),
    (lambda img: gfgpu.shift(img, 1.0, backend="warp", device=["cpu"]), "device must be"),
    (lambda img: gfgpu.canny(img, 1.0, use_quantiles="yes"), "use_quantiles must be True or False"),
])
def test_parameters_of_the_wrong_type_are_errors(call, message):
    img = np.ones((8, 9))
    with pytest.raises(TypeError, match=message):
        call(img)


def test_big_endian_output_is_written_and_read_only_output_refused():
    img = np.ones((6, 7), np.float32)
    ro = np.empty((6, 7), np.float32)
    ro.setflags(write=False)
    with pytest.raises(ValueError, match="read-only"):
        gfgpu.shift(img, 1.0, output=ro, backend="numpy")


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.uint8])
def test_canny_flat_image_has_no_edges(backend, dtype):
    if dtype == np.float64 and not backend.supports_float64:
        pytest.skip("no float64 on this device")
    flat = np.full((40, 50), 180 if dtype == np.uint8 else 0.7, dtype)
    assert not gfgpu.canny(flat, 1.0, 0.1, 0.9, use_quantiles=True, backend=backend.name).any()
    assert not gfgpu.canny(flat, 1.0, backend=backend.name).any()


def test_canny_empty_mask_with_quantiles_has_no_edges(rng):
    img = rng.random((30, 40))
    edges = gfgpu.canny(img, 1.0, 0.2, 0.9, use_quantiles=True, mask=np.zeros(img.shape, bool), backend="numpy")
    assert edges.shape == img.shape and not edges.any()


FORK_SCRIPT = textwrap.dedent("""
    import multiprocessing as mp, sys
    import numpy as np, gfgpu
    from gfgpu.backends import BackendUnavailable
    img = np.ones((32, 32), np.float32)
    parent = sys.argv[1]
    ref = gfgpu.shift(img, (0, 1.5), backend=parent)

    def automatic(_):
        return float(gfgpu.shift(img, (0, 1.5)).sum())

    def explicit(name):
        try:
            return float(gfgpu.shift(img, (0, 1.5), backend=name).sum())
        except BackendUnavailable as exc:
            return str(exc)

    if __name__ == "__main__":
        with mp.get_context("fork").Pool(2) as pool:
            print(pool.map(automatic, [0, 1]))
            print(pool.map(explicit, ["numpy", "opencl"]))
    """)


@pytest.mark.parametrize("parent", ["numpy", "opencl", "warp"])
def test_forked_children_get_fresh_backends_or_a_clear_error(tmp_path, require_backend, parent):
    require_backend(parent)
    script = tmp_path / "fork.py"
    script.write_text(FORK_SCRIPT)
    res = subprocess.run([sys.executable, str(script), parent], capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stderr[-2000:]
    auto, explicit = res.stdout.strip().splitlines()[-2:]
    assert auto == str([float(32 * 32)] * 2)
    numpy_sum, opencl = eval(explicit)
    assert numpy_sum == 32 * 32
    if parent == "opencl":
        assert "forked" in opencl and "spawn" in opencl


@pytest.mark.parametrize("shape", [(2, 3, 2, 4, 5), (2, 1, 3, 2, 4, 5)])
def test_arrays_of_many_dimensions_on_every_backend(backend, shape, rng):
    x = rng.random(shape).astype(np.float32)
    calls = [
        lambda b: gfgpu.shift(x, 1.5, backend=b),
        lambda b: gfgpu.gradient(x, 1.0, backend=b)[-1],
        lambda b: gfgpu.green_filter(x, gfgpu.UniformGreen(2.0), angle=0.3, backend=b),
        lambda b: gfgpu.motion_blur(x, (2, 3), backend=b),
        lambda b: gfgpu.motion_blur(x, 5.0, kind="rotation", backend=b),
    ]
    for call in calls:
        out = call(backend.name)
        assert out.shape == shape
        np.testing.assert_allclose(out, call("numpy"), atol=2e-5)
    with gfgpu.working_set("2K"):
        np.testing.assert_allclose(gfgpu.shift(x, 1.5, backend=backend.name), gfgpu.shift(x, 1.5, backend="numpy"),
                                   atol=2e-5)


@pytest.mark.parametrize("arr, call, message", [
    (np.float64(3.0), lambda a: gfgpu.shift(a, 1.0), "input must have at least 1 dimension"),
    (np.ones(5), lambda a: gfgpu.motion_blur(a, (1, 1)), "input must have at least 2 dimension"),
    (np.ones(5), lambda a: gfgpu.canny(a), "input must have at least 2 dimension"),
    (np.ones((0, 4)), lambda a: gfgpu.shift(a, 1.0), "input is empty"),
])
def test_too_few_dimensions_name_the_input(arr, call, message):
    with pytest.raises(ValueError, match=message):
        call(arr)


THREADS_SCRIPT = textwrap.dedent("""
    import sys, threading
    import numpy as np, gfgpu
    img = np.ones((16, 16), np.float32)
    out = []
    threads = [threading.Thread(target=lambda: out.append(float(gfgpu.shift(img, (0, 1.5), backend="warp").sum())))
               for _ in range(16)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    print(sorted(set(out)))
    print("stderr-still-works", file=sys.stderr)
    """)


def test_threads_starting_warp_at_once_keep_stderr(tmp_path, require_backend):
    require_backend("warp")
    script = tmp_path / "threads.py"
    script.write_text(THREADS_SCRIPT)
    for _ in range(3):
        res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=240)
        assert res.returncode == 0, res.stderr[-2000:]
        assert res.stdout.strip() == str([256.0])
        assert "stderr-still-works" in res.stderr
        assert "Could not find or load the NVIDIA CUDA driver" not in res.stderr


@pytest.mark.parametrize("mode", ["reflect", "mirror", "wrap", "nearest", "constant"])
def test_large_scales_keep_a_constant_image_constant_fast(mode):
    """The boundary state sums in closed form: accuracy does not depend on u (the term-by-term
    sum was truncated, 0.7032 at u = 1e7, and took minutes for the derivative)."""
    img = np.full((24, 40), 0.7)
    for u in (1e4, 1e7, 1e9):
        out = gfgpu.green_filter(img, gfgpu.UniformGreen(u), mode=mode, cval=0.7, backend="numpy")
        assert np.abs(out - 0.7).max() < 1e-7
        d = gfgpu.derivative(img, u, axis=1, mode=mode, cval=0.7, backend="numpy")
        assert np.abs(d).max() < 1e-12


@pytest.mark.parametrize("call, message", [
    (lambda img: gfgpu.green_filter(img, gfgpu.UniformGreen(1e30)), r"u must lie in \[0.002, 1e\+09\]"),
    (lambda img: gfgpu.derivative(img, 1e-30), r"u must lie in"),
    (lambda img: gfgpu.canny(img, 1e12), r"u must lie in"),
    (lambda img: gfgpu.green_filter(img, gfgpu.UniformGreen(2.0), angle=1e300), r"angle must lie within"),
    (lambda img: gfgpu.motion_blur(img, (0, 1e12)), r"velocity must be at most"),
])
def test_parameters_far_outside_their_range_are_refused_before_work(call, message):
    with pytest.raises(ValueError, match=message):
        call(np.ones((16, 16)))


def test_device_views_are_processed(backend, rng):
    """Sliced, stepped and transposed device arrays are copied to contiguous on the device."""
    if backend.name == "numpy":
        pytest.skip("host arrays: numpy views are ordinary inputs")
    img = rng.random((20, 30)).astype(np.float32)
    dev = backend.asarray(img)
    if backend.name == "opencl":
        views = [(dev[2:15:2, 3:25], img[2:15:2, 3:25]), (dev.T, img.T), (dev[:, ::3], img[:, ::3])]
    else:
        views = [(dev[2:15, 3:25], img[2:15, 3:25]), (dev[5], img[5])]
    for view, ref in views:
        out = gfgpu.shift(view, 1.5)
        assert backend.owns(out)
        expect = gfgpu.shift(np.ascontiguousarray(ref), 1.5, backend="numpy")
        np.testing.assert_allclose(backend.to_host(out), expect, atol=2e-6)


def test_a_tiny_sweep_step_is_refused_before_work():
    left, right = gfgpu.stereo.random_dot_stereogram(np.full((20, 30), 3.0))
    with pytest.raises(ValueError, match="sweep_step must lie in"):
        gfgpu.disparity(left, right, 8, method="uniform", sweep_step=1e-7)
    with pytest.raises(TypeError, match="sweep_step must be a real number"):
        gfgpu.disparity(left, right, 8, method="uniform", sweep_step="0.5")


CACHE_SCRIPT = ("import numpy as np, gfgpu; "
                "print(gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5), backend='opencl').sum())")


def test_unwritable_cache_falls_back_or_says_which_variable(tmp_path, require_backend):
    import os
    require_backend("opencl")
    afile = tmp_path / "a-file"
    afile.write_text("")
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_CACHE_HOME", "POCL_CACHE_DIR")}
    res = subprocess.run([sys.executable, "-c", CACHE_SCRIPT], capture_output=True, text=True, timeout=240,
                         env=dict(env, HOME=str(afile)))          # ~/.cache cannot be created
    assert res.returncode == 0 and res.stdout.strip() == "64.0", res.stderr[-2000:]
    assert "XDG_CACHE_HOME or POCL_CACHE_DIR" in res.stderr
    res = subprocess.run([sys.executable, "-c", CACHE_SCRIPT], capture_output=True, text=True, timeout=240,
                         env=dict(env, POCL_CACHE_DIR=str(afile)))
    assert res.returncode != 0
    assert f"POCL_CACHE_DIR={str(afile)!r} is not a writable directory" in res.stderr


def test_a_memory_limit_is_named_when_a_runtime_cannot_start(require_backend):
    require_backend("warp")
    code = textwrap.dedent("""
        import resource; resource.setrlimit(resource.RLIMIT_AS, (600 * 2**20, resource.RLIM_INFINITY))
        import numpy as np, gfgpu
        try:
            print("ran", gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5), backend="warp").sum())
        except Exception as exc:
            print(type(exc).__name__, exc)
        """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=240)
    out = res.stdout.strip()
    if out.startswith("ran"):
        pytest.skip("Warp starts within 600 MiB here")
    assert "BackendUnavailable" in out and "address-space limit" in out, out


def test_dask_zero_d_is_an_error():
    import dask.array as da

    import gfgpu.dask as gd
    with pytest.raises(ValueError, match="at least 1 dimension"):
        gd.shift(da.from_array(np.float64(3.0)), 1.0)


def test_filter_npy_runs_an_oblique_blur_that_fits(tmp_path, rng):
    img = rng.random((30, 32)).astype(np.float32)
    np.save(tmp_path / "a.npy", img)
    gfgpu.filter_npy("motion_blur", tmp_path / "a.npy", tmp_path / "b.npy", velocity=(3, 5), backend="numpy")
    np.testing.assert_allclose(np.load(tmp_path / "b.npy"), gfgpu.motion_blur(img, (3, 5), backend="numpy"),
                               atol=1e-6)
    with pytest.raises(ValueError, match="exceeds the working set"):
        gfgpu.filter_npy("motion_blur", tmp_path / "a.npy", tmp_path / "c.npy", velocity=(3, 5),
                         working_set="4K", backend="numpy")


def test_interpolate_frames_names_its_frames(rng):
    f0 = rng.random((32, 32))
    f1 = f0.copy()
    f1[3, 3] = np.nan
    with pytest.raises(ValueError, match="frame1 contains NaN"):
        gfgpu.interpolate_frames(f0, f1, 2)
    with pytest.raises(TypeError, match="frame0 must be a real numeric array"):
        gfgpu.interpolate_frames(f0.astype(complex), f0, 2)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_canny_gives_the_same_edges_on_every_backend(backend, seed):
    img = np.random.default_rng(seed).random((24, 40)).astype(np.float32)
    ref = gfgpu.canny(img, 1.0, backend="numpy")
    np.testing.assert_array_equal(gfgpu.canny(img, 1.0, backend=backend.name), ref)
    ref_q = gfgpu.canny(img, 1.0, 0.5, 0.8, use_quantiles=True, backend="numpy")
    out_q = gfgpu.canny(img, 1.0, 0.5, 0.8, use_quantiles=True, backend=backend.name)
    np.testing.assert_array_equal(out_q, ref_q)


def test_device_outputs_and_inputs_of_the_wrong_kind_are_clear_errors(require_backend):
    be = require_backend("opencl")
    import pyopencl.array as cla
    img = np.arange(12, dtype=np.float32).reshape(3, 4)
    big = cla.zeros(be.queue, (3, 8), np.float32)
    with pytest.raises(ValueError, match="non-contiguous view"):
        gfgpu.shift(cla.to_device(be.queue, img), (0, 1), output=big[:, :4])
    np.testing.assert_array_equal(big.get(), 0)           # nothing written outside (or inside) the view
    with pytest.raises(TypeError, match="device input must be float32 or float64"):
        gfgpu.shift(cla.to_device(be.queue, img.astype(np.int32)), (0, 1.5))
    with pytest.raises(TypeError, match="backend='opencl'"):
        gfgpu.shift(cla.to_device(be.queue, img), (0, 1.5), backend="numpy")
    with pytest.raises(TypeError, match="shift must be a real number"):
        gfgpu.shift(img, True)


@pytest.mark.parametrize("where", [0, -1, 70000])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nonfinite_input_is_refused_and_the_output_left_untouched(backend, where, bad):
    # large enough for the host-memory paths (zero-copy views, the check fused into the pass)
    img = np.linspace(0, 1, 300 * 301, dtype=np.float32).reshape(300, 301)
    img.reshape(-1)[where] = bad
    for call in (lambda **kw: gfgpu.shift(img, (0, 3), backend=backend, **kw),      # one fused pass
                 lambda **kw: gfgpu.shift(img, (-2, 3), backend=backend, **kw),     # two passes
                 lambda **kw: gfgpu.shift(img, (0, 2.5), backend=backend, **kw)):   # a recursion
        with pytest.raises(ValueError, match="input contains NaN or infinite values"):
            call()
        out = np.full(img.shape, 7.0, np.float32)
        with pytest.raises(ValueError, match="input contains NaN or infinite values"):
            call(output=out)
        assert (out == 7.0).all()              # nothing written before the error


@pytest.mark.parametrize("shift", [(0, 3), (-5, 0), (0, -400), (2, -1)])
@pytest.mark.parametrize("mode", ["reflect", "constant", "grid-wrap", "nearest", "mirror"])
def test_integer_translation_is_index_arithmetic_on_every_backend(backend, shift, mode, rng):
    # numpy.pad builds each mode's extension independently of the translate primitive
    img = rng.random((37, 300)).astype(np.float32)
    pad_mode = {"reflect": "symmetric", "mirror": "reflect", "nearest": "edge", "grid-wrap": "wrap",
                "constant": "constant"}[mode]
    big = 450
    ext = np.pad(img, big, mode=pad_mode, **({"constant_values": 1.25} if mode == "constant" else {}))
    dy, dx = shift
    ref = ext[big - dy:big - dy + 37, big - dx:big - dx + 300]
    out = np.empty_like(img)
    res = gfgpu.shift(img, shift, mode=mode, cval=1.25, output=out, backend=backend)
    assert res is out
    np.testing.assert_array_equal(out, ref)
    np.testing.assert_array_equal(gfgpu.shift(img, shift, mode=mode, cval=1.25, backend=backend), ref)


def test_threads_launching_one_kernel_at_once_get_their_own_results(require_backend):
    # a pyopencl kernel call sets the shared kernel object's arguments and then enqueues it;
    # without a lock two threads swapped arguments (wrong pixels in shift and disparity under a
    # tiny switch interval): every launch now holds one lock
    import sys
    import threading
    be = require_backend("opencl")
    rng = np.random.default_rng(0)
    imgs = [rng.random(shape).astype(np.float32) for shape in ((64, 80), (70, 50), (33, 91), (52, 61))]
    refs = [gfgpu.shift(a, (1.5, -2.25), backend="numpy") for a in imgs]
    bad = []

    def work(t):
        for rep in range(20):
            i = (t + rep) % 4
            if np.abs(gfgpu.shift(imgs[i], (1.5, -2.25), backend=be) - refs[i]).max() > 1e-3:
                bad.append((t, rep, i))

    saved = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=work, args=(t,)) for t in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(saved)
    assert not bad


@pytest.mark.parametrize("bad", [1.5, True, "-1", np.float64(0.0)])
@pytest.mark.parametrize("call", [
    lambda img, bad: gfgpu.motion_blur(img, (1, 2), channel_axis=bad),
    lambda img, bad: gfgpu.synthesize_motion(img, (1, 2), 2, channel_axis=bad),
    lambda img, bad: gfgpu.interpolate_frames(img, img, 1, velocity=(1, 2), channel_axis=bad),
    lambda img, bad: gfgpu.interpolate_frames(img, img, 1, channel_axis=bad),     # estimated velocity
    lambda img, bad: gfgpu.shift(img, (1, 2), channel_axis=bad),
])
def test_a_channel_axis_that_is_not_an_integer_is_an_error(call, bad):
    # int() made motion_blur take 1.5 and True as axis 1 and '-1' as the last axis
    with pytest.raises(TypeError, match="channel_axis must be an integer"):
        call(np.ones((6, 7, 3)), bad)


def test_a_channel_axis_on_a_grey_image_is_named_as_the_mistake():
    with pytest.raises(ValueError, match="drop channel_axis"):
        gfgpu.shift(np.ones((6, 7)), (1.0, 2.0), channel_axis=-1)
    with pytest.raises(ValueError, match="shift must have one value per axis") as err:
        gfgpu.shift(np.ones((6, 7, 3)), (1.0, 2.0, 0.0, 1.0), channel_axis=-1)
    assert "drop channel_axis" not in str(err.value)


def test_an_unknown_gfgpu_backend_variable_is_named(monkeypatch):
    monkeypatch.setenv("GFGPU_BACKEND", "bogus")
    with pytest.raises(ValueError, match="GFGPU_BACKEND='bogus'.*numpy, warp, opencl"):
        gfgpu.shift(np.ones((4, 4)), 1.0)
    with pytest.raises(ValueError, match="backend must be one of"):
        gfgpu.shift(np.ones((4, 4)), 1.0, backend="bogus")     # an argument: named as one
    gfgpu.shift(np.ones((4, 4)), 1.0, backend="numpy")          # an argument overrides the variable


@pytest.mark.parametrize("dtype, exc, message", [
    ("bogus", TypeError, "dtype must be float32 or float64"),
    (np.int32, TypeError, "dtype must be float32 or float64"),
    (True, TypeError, "dtype must be float32 or float64"),
    ("float16", TypeError, "dtype must be float32 or float64"),
])
def test_filter_npy_names_a_bad_dtype(tmp_path, dtype, exc, message):
    np.save(tmp_path / "in.npy", np.ones((8, 9), np.float32))
    with pytest.raises(exc, match=message):
        gfgpu.filter_npy("shift", tmp_path / "in.npy", tmp_path / "out.npy", shift=(1, 0), dtype=dtype,
                         backend="numpy")
    assert not (tmp_path / "out.npy").exists()
