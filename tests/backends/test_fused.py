"""Every backend against the numpy specification of everything it runs.

The generic primitives of the :class:`~gfgpu.backends.base.Backend` contract (``recurse``,
``recurse_lines``, ``gather``) against :func:`gfgpu._core.recursion.run_reference`,
:func:`~gfgpu._core.recursion.run_reference_lines` and numpy indexing; and every fused kernel
registered with :mod:`gfgpu.backends.fused` against its ``.spec``, on random inputs: integer
outputs bit for bit, float outputs to 1e-5 (float32) or 1e-12 (float64) relative.  The inputs
come from each feature's builders, beside its tests (``tests/<feature>/kernel_inputs.py``,
collected by :mod:`backends.builders`); a kernel registered without a builder fails
:func:`test_every_registered_kernel_is_tested`.
"""
import importlib
import pkgutil

import numpy as np
import pytest
from oracle import relerr

import gfgpu
from gfgpu import greens
from gfgpu._core.recursion import MODES, plan_lines, plan_pass, run_reference, run_reference_lines
from gfgpu.backends import BACKENDS, fused

from .builders import BUILDERS, TOL, collect


def _import_every_application():
    """Applications register their kernels when imported: import every gfgpu module but device
    code (the backends' and the features' ``_warp``/``_opencl`` modules), which registers nothing
    and needs its device library (a machine may lack one: its kernels are then skipped, not the
    whole file)."""
    for info in pkgutil.walk_packages(gfgpu.__path__, "gfgpu."):
        device_code = info.name.startswith(("gfgpu.backends.warp.", "gfgpu.backends.opencl.")) or \
            info.name.rpartition(".")[2] in ("_warp", "_opencl")
        if info.name == "gfgpu.__main__" or device_code:
            continue
        importlib.import_module(info.name)


_import_every_application()
#: every feature's input builders (tests/<feature>/kernel_inputs.py)
BUILDER_MODULES = collect()
REGISTERED = sorted(fused.registered())


def _need_dtype(be, dtype):
    if np.dtype(dtype) == np.float64 and not be.supports_float64:
        pytest.skip(f"{be} has no float64")


# --------------------------------------------------------------------------------------
# every registered fused kernel, with its feature's input builder
# --------------------------------------------------------------------------------------
def test_every_registered_kernel_is_tested():
    assert REGISTERED, "no fused kernel registered: the applications did not import"
    assert {"stereo.census", "stereo.cost", "stereo.sgm", "stereo.select", "stereo.match", "stereo.sweep",
            "edges.nms"} <= set(REGISTERED)
    missing = sorted(set(REGISTERED) - set(BUILDERS))
    stale = sorted(set(BUILDERS) - set(REGISTERED))
    assert not missing, (f"registered fused kernels without an input builder in tests/<feature>/kernel_inputs.py "
                         f"(modules {BUILDER_MODULES}): {missing}")
    assert not stale, f"input builders for kernels nobody registers: {stale}"
    for name, kernel in fused.registered().items():
        assert set(kernel.launchers) == set(BACKENDS), f"{name} runs on {sorted(kernel.launchers)} only"
        # the numpy specification: the spec module of the feature that registers the kernel
        feature = name.partition(".")[0]
        assert callable(kernel.spec) and kernel.spec.__module__ == f"gfgpu.{feature}.spec", name


@pytest.mark.parametrize("name", REGISTERED)
def test_fused_kernel_matches_its_spec(backend, name):
    kernel = fused.registered()[name]
    if name not in BUILDERS:
        pytest.fail(f"fused kernel {name!r} has no input builder in tests/{name.partition('.')[0]}/kernel_inputs.py")
    if backend.name not in kernel.launchers:
        pytest.fail(f"fused kernel {name!r} has no launcher on the {backend.name} backend")
    BUILDERS[name](backend, kernel, np.random.default_rng(sum(map(ord, name))))


@pytest.mark.parametrize("name", REGISTERED)
def test_fused_kernel_matches_its_spec_in_gpu_launch_shapes(gpu_shaped, name):
    # the branches only a GPU takes (one line per work-item where a CPU uses vector lanes), forced
    # on the CPU devices
    kernel = fused.registered()[name]
    if name in BUILDERS and gpu_shaped.name in kernel.launchers:
        BUILDERS[name](gpu_shaped, kernel, np.random.default_rng(sum(map(ord, name))))


# --------------------------------------------------------------------------------------
# the generic primitives
# --------------------------------------------------------------------------------------
PASSES = {
    "G_u": greens.UniformGreen(2.3).line_pass(),
    "H_u anticausal": greens.HomogeneousGreen(1.7).line_pass(reverse=True),
    "shift -3.6": greens.shift_pass(-3.6),
    "D (two sections)": greens.derivative_passes(1.5)[0],
    "G_U1": greens.AffineGreen(0.6, -3.5).line_pass(),
    "G_U2 anticausal": greens.AffineGreenApprox(6.0, 80.0).line_pass(reverse=True),
}


# (B, N, M) and the axis of the lines: columns (1) and rows (2), one line, lines of one sample
LAYOUTS = [((2, 17, 5), 1), ((3, 4, 23), 2), ((1, 1, 40), 2), ((2, 33, 1), 1), ((1, 3, 1), 2)]


def _reference_pass(src, axis, line_pass, mode, cval):
    """run_reference (float64) on every line of a (B, N, M) array."""
    b, n, m = src.shape
    x = src.astype(np.float64)
    if axis == 1:
        plan = plan_pass(line_pass, n, mode, np.float64)
        return np.stack([run_reference(x[i], plan, cval) for i in range(b)])
    plan = plan_pass(line_pass, m, mode, np.float64)
    return run_reference(x.reshape(b * n, m).T, plan, cval).T.reshape(b, n, m)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", list(PASSES))
def test_recurse_matches_run_reference(backend, name, dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(7)
    for shape, axis in LAYOUTS:
        n = shape[axis]
        if name.startswith("G_U2") and n <= 1:
            continue
        for mode in MODES:
            src = (1.0 + rng.standard_normal(shape)).astype(dtype)
            plan = plan_pass(PASSES[name], n, mode, dtype)
            ref = _reference_pass(src, axis, PASSES[name], mode, 0.25)
            what = f"{name} {shape} axis {axis} {mode}"
            out = backend.empty(shape, dtype)
            backend.recurse(backend.asarray(src), out, axis, plan, cval=0.25)
            got = backend.to_host(out)
            assert got.dtype == dtype and relerr(got, ref) <= TOL[np.dtype(dtype)], what
            base = rng.standard_normal(shape).astype(dtype)
            acc = backend.asarray(base.copy())
            backend.recurse(backend.asarray(src), acc, axis, plan, cval=0.25, accumulate=True)
            assert relerr(backend.to_host(acc), ref + base) <= TOL[np.dtype(dtype)], f"{what} accumulate"
            same = backend.asarray(src.copy())
            backend.recurse(same, same, axis, plan, cval=0.25)          # dst may be src
            assert relerr(backend.to_host(same), ref) <= TOL[np.dtype(dtype)], f"{what} in place"


LINE_PASSES = [greens.UniformGreen(1.3).line_pass(), None, greens.shift_pass(-2.7), greens.shift_pass(0.35),
               greens.HomogeneousGreen(2.0).line_pass(reverse=True), greens.shift_pass(9.5), None]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_recurse_lines_matches_run_reference_lines(backend, dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(8)
    lines = len(LINE_PASSES)
    for shape, axis in (((2, 19, lines), 1), ((3, lines, 26), 2), ((1, lines, 1), 2)):
        n = shape[axis]
        for mode in MODES:
            src = (1.0 + rng.standard_normal(shape)).astype(dtype)
            plans = plan_lines(LINE_PASSES, n, mode, dtype)
            plans64 = plan_lines(LINE_PASSES, n, mode, np.float64)
            x = src.astype(np.float64)
            ref = np.stack([run_reference_lines(x[i] if axis == 1 else x[i].T, plans64, -0.5)
                            for i in range(shape[0])])
            ref = ref if axis == 1 else ref.transpose(0, 2, 1)
            out = backend.empty(shape, dtype)
            backend.recurse_lines(backend.asarray(src), out, axis, plans, cval=-0.5)
            what = f"{shape} axis {axis} {mode}"
            assert relerr(backend.to_host(out), ref) <= TOL[np.dtype(dtype)], what
            same = backend.asarray(src.copy())
            backend.recurse_lines(same, same, axis, plans, cval=-0.5)
            assert relerr(backend.to_host(same), ref) <= TOL[np.dtype(dtype)], f"{what} in place"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("index_dtype", [np.int32, np.int64])
def test_gather_matches_numpy_indexing(backend, dtype, index_dtype):
    _need_dtype(backend, dtype)
    rng = np.random.default_rng(9)
    src = rng.standard_normal((2, 9, 13)).astype(dtype)
    for out_shape in ((5, 7), (2, 13, 9), (1,)):
        size = int(np.prod(out_shape))
        index = rng.integers(-3, src.size, size).astype(index_dtype)
        index[:1] = src.size - 1
        out = backend.empty(out_shape, dtype)
        backend.gather(backend.asarray(src), index, 2.5, out)
        ref = np.where(index < 0, dtype(2.5), src.reshape(-1)[np.maximum(index, 0)]).reshape(out_shape)
        np.testing.assert_array_equal(backend.to_host(out), ref, err_msg=f"gather into {out_shape}")
