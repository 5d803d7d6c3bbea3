"""Two-sided steps (gfgpu/_core/twosided.py, gfgpu/backends/opencl/twosided.cl): the specification
against the passes it fuses, the OpenCL CPU kernel against the specification, and the public
derivative / projection / gradient that run them against the numpy backend and direct summation."""

import numpy as np
import pytest
from oracle import TapKernel, direct_axis, relerr

import gfgpu
from gfgpu import filters, greens
from gfgpu._core.passes import LinePass, Section
from gfgpu._core.recursion import plan_pass, run_reference
from gfgpu._core.twosided import plan_two_sided, run_two_sided_reference
from gfgpu.edges import edge_gradient, operator

MODES = ["reflect", "constant", "nearest", "mirror", "wrap"]
TOL = {np.float32: 2e-5, np.float64: 1e-12}


def _passes(kind):
    """(P, D) passes of the chapter's operator, the one-signed one, and the chapter's with P at
    another scale (four distinct poles)."""
    if kind == "chapter":
        return greens.projection_passes(1.3), greens.derivative_passes(1.3)
    if kind == "one-signed":
        return operator.projection_passes(1.3), operator.derivative_passes(1.3)
    return greens.projection_passes(0.6), greens.derivative_passes(1.3)


@pytest.mark.parametrize("kind", ["chapter", "one-signed", "ratio"])
@pytest.mark.parametrize("mode", MODES)
def test_spec_equals_the_summed_passes(kind, mode, rng):
    """Output o of the spec equals the sum of its passes run one by one (float64)."""
    P, D = _passes(kind)
    n = 41
    x, y = rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    plan = plan_two_sided([(0, P), (1, D)], n, mode, np.float64)
    got = run_two_sided_reference([x, y], plan, (0.7, -1.1))
    for out, src, passes, cval in ((got[0], x, P, 0.7), (got[1], y, D, -1.1)):
        ref = np.zeros_like(src)
        for k, lp in enumerate(passes):
            run_reference(src, plan_pass(lp, n, mode, np.float64), cval, out=ref, accumulate=k > 0)
        assert np.abs(out - ref).max() <= 1e-13 * np.abs(ref).max()


def test_spec_matches_direct_summation(rng):
    """The derivative's two-sided step against its taps summed directly over the padded line (the
    boundary mode as numpy.pad's extension), every mode, a non-zero cval."""
    u, n, margin = 1.7, 57, 400
    x = rng.standard_normal((n, 4))
    passes = greens.derivative_passes(u)

    def side(lp):     # taps of one pass at offsets m >= 0 (m = 0: the direct tap)
        return lambda m: sum(s.taps(np.asarray(m)) for s in lp.sections) + lp.tap * (np.asarray(m) == 0)

    causal, anti = side(passes[0]), side(passes[1])
    for mode in MODES:
        plan = plan_two_sided([(0, passes)], n, mode, np.float64)
        got = run_two_sided_reference([x], plan, (0.4,))[0]
        ref = (direct_axis(x, TapKernel(lambda m: np.where(np.asarray(m) >= 0, causal(m), 0.0), margin), 0, mode, 0.4)
               + direct_axis(x, TapKernel(lambda m: np.where(np.asarray(m) >= 0, anti(m), 0.0), margin), 0, mode,
                             0.4, anticausal=True))
        assert relerr(got, ref) < 1e-12, mode


def test_plans_refuse_what_they_cannot_express():
    shifted = LinePass((Section(lam=0.5 + 0j, kap=0.5 + 0j),), 0.0, False, offset=2)
    assert plan_two_sided([(0, (shifted,))], 16, "reflect", np.float32) is None
    many = tuple(LinePass((Section(lam=complex(0.1 * k, 0.05), kap=1j),), 0.0, False) for k in range(1, 6))
    assert plan_two_sided([(0, many)], 16, "reflect", np.float32) is None       # five complex poles




@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(1, 37, 45), (2, 33, 16), (1, 100, 130), (3, 1, 5), (1, 17, 1), (2, 9, 300)])
@pytest.mark.parametrize("kind", ["chapter", "one-signed", "ratio"])
def test_kernel_matches_spec(cpu_opencl, dtype, shape, kind, rng):
    """Partial vectors and bands, several images, one and two inputs and outputs."""
    from gfgpu.backends.opencl.twosided import run_two_sided
    be, axis = cpu_opencl, 1
    n = shape[axis]
    P, D = _passes(kind)
    for outputs, mode in (([(0, D)], "reflect"), ([(0, P), (0, D)], "wrap"), ([(0, D), (1, P)], "constant")):
        plan = plan_two_sided(outputs, n, mode, dtype)
        xs = [rng.standard_normal(shape).astype(dtype) for _ in set(plan.inputs)]
        cvals = (0.7, -0.3)
        lines = [np.moveaxis(x, axis, 0).reshape(n, -1) for x in xs]
        ref = run_two_sided_reference(lines, plan, cvals)
        dsts = [be.empty(shape, dtype) for _ in plan.inputs]
        assert run_two_sided(be, [be.asarray(x) for x in xs], dsts, axis, plan, cvals, check=True)
        for dst, r in zip(dsts, ref):
            got = np.moveaxis(be.to_host(dst), axis, 0).reshape(n, -1)
            assert np.abs(got - r).max() <= TOL[dtype] * np.abs(r).max()


def test_kernel_check_and_large_arrays(cpu_opencl, rng):
    """Arrays beyond the caches (non-temporal stores) and the finite check's verdicts; an axis
    other than 1 (columns) or 2 (rows) is refused."""
    from gfgpu.backends.opencl.twosided import run_two_sided
    be, axis = cpu_opencl, 1
    shape = (1, 1040, 2064)                 # 8.6 MB float32: the streaming path
    x = rng.standard_normal(shape).astype(np.float32)
    P, D = _passes("chapter")
    plan = plan_two_sided([(0, P), (0, D)], shape[axis], "reflect", np.float32)
    dsts = [be.empty(shape, np.float32) for _ in range(2)]
    assert run_two_sided(be, [be.asarray(x)], dsts, axis, plan, check=True)
    ref = run_two_sided_reference([np.moveaxis(x, axis, 0).reshape(shape[axis], -1)], plan)
    for dst, r in zip(dsts, ref):
        got = np.moveaxis(be.to_host(dst), axis, 0).reshape(shape[axis], -1)
        assert np.abs(got - r).max() <= 2e-5 * np.abs(r).max()
    for bad in (np.nan, np.inf, 2.0**70):
        y = x.copy()
        y[0, 1033, 2050] = bad
        assert not run_two_sided(be, [be.asarray(y)], dsts, axis, plan, check=True)
    with pytest.raises(ValueError, match="axis must be 1"):
        run_two_sided(be, [be.asarray(x)], dsts, 0, plan)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", MODES)
def test_public_operators_match_numpy(backend, dtype, mode, rng):
    """derivative, projection, gradient and canny's gradient on every backend against the numpy
    backend (the passes one by one), a constant extension with a non-zero cval included."""
    if dtype == np.float64 and not backend.supports_float64:
        pytest.skip("no float64 on this device")
    img = (rng.random((37, 45)) * 10).astype(dtype)
    rgb = (rng.random((20, 33, 3)) * 10).astype(dtype)
    vol = (rng.random((9, 17, 21)) * 10).astype(dtype)
    cv = 1.7
    calls = [
        lambda b: [gfgpu.derivative(img, 1.2, axis=0, mode=mode, cval=cv, backend=b)],
        lambda b: [gfgpu.derivative(rgb, 0.8, projection_scale=0.5, channel_axis=-1, mode=mode, cval=cv, backend=b)],
        lambda b: [gfgpu.derivative(vol, 1.1, axis=1, mode=mode, cval=cv, backend=b)],
        lambda b: [gfgpu.projection(img, 1.2, axis=0, mode=mode, cval=cv, backend=b)],
        lambda b: list(gfgpu.gradient(img, 1.2, mode=mode, cval=cv, backend=b)),
        lambda b: list(gfgpu.gradient(rgb, 1.2, single_scale=True, channel_axis=-1, mode=mode, cval=cv, backend=b)),
        lambda b: list(gfgpu.gradient(vol, 0.9, mode=mode, cval=cv, backend=b)),
        lambda b: list(edge_gradient(img, 1.2, mode=mode, cval=cv, backend=b)),
    ]
    for call in calls:
        for got, ref in zip(call(backend), call("numpy")):
            assert got.dtype == dtype and got.shape == ref.shape
            assert np.abs(got - ref).max() <= 4 * TOL[dtype] * np.abs(ref).max()


def test_gpu_branch_matches_numpy(gpu_shaped, rng):
    """Devices without two-sided kernels (GPU launch shapes, forced here on the CPU devices) run
    the passes one by one: the same results."""
    img = (rng.random((40, 52)) * 10).astype(np.float32)
    for mode in ("reflect", "constant"):
        for got, ref in zip(gfgpu.gradient(img, 1.2, mode=mode, cval=0.5, backend=gpu_shaped),
                            gfgpu.gradient(img, 1.2, mode=mode, cval=0.5, backend="numpy")):
            assert np.abs(got - ref).max() <= 1e-4 * np.abs(ref).max()
        got = gfgpu.derivative(img, 1.2, mode=mode, cval=0.5, backend=gpu_shaped)
        ref = gfgpu.derivative(img, 1.2, mode=mode, cval=0.5, backend="numpy")
        assert np.abs(got - ref).max() <= 1e-4 * np.abs(ref).max()


def test_refusals_and_range(cpu_opencl, rng):
    """A non-finite image is refused before any output is written; an image beyond the range limit
    is computed scaled (exact), as the numpy backend does."""
    img = rng.random((30, 40)).astype(np.float32)
    out = np.full_like(img, 3.0)
    bad = img.copy()
    bad[7, 9] = np.nan
    with pytest.raises(ValueError, match="NaN or infinite"):
        gfgpu.derivative(bad, 1.0, output=out, backend=cpu_opencl)
    assert (out == 3.0).all()
    with pytest.raises(ValueError, match="NaN or infinite"):
        gfgpu.gradient(bad, 1.0, backend=cpu_opencl)
    big = img * np.float32(2.0**100)
    for got, ref in zip(gfgpu.gradient(big, 1.0, backend=cpu_opencl), gfgpu.gradient(big, 1.0, backend="numpy")):
        assert np.isfinite(got).all() and np.abs(got - ref).max() <= 1e-4 * np.abs(ref).max()
    got = gfgpu.projection(big, 1.0, output=out, backend=cpu_opencl)
    assert got is out
    ref = gfgpu.projection(big, 1.0, backend="numpy")
    assert np.abs(out - ref).max() <= 1e-5 * np.abs(ref).max()


def test_two_sided_runner_is_chosen_per_device(require_backend):
    """The fused path runs on OpenCL CPU devices only; elsewhere the passes run one by one."""
    assert filters._two_sided_runner(require_backend("numpy")) is None
    be = require_backend("opencl")
    assert (filters._two_sided_runner(be) is not None) == (be.kind == "cpu")


@pytest.mark.parametrize("mode", MODES)
def test_paired_passes_sum_the_same(mode, rng):
    """The one-signed D's four passes (one per scale and direction) as one causal and one
    anticausal pass of four sections (the row pair of an OpenCL CPU device): the same sum."""
    passes = operator.derivative_passes(1.3)
    paired = filters._paired(passes)
    assert len(passes) == 4 and len(paired) == 2 and [lp.reverse for lp in paired] == [False, True]
    assert filters._paired(greens.derivative_passes(1.3)) == list(greens.derivative_passes(1.3))
    x, n = rng.standard_normal((40, 3)), 40

    def summed(ps):
        out = np.zeros_like(x)
        for k, lp in enumerate(ps):
            run_reference(x, plan_pass(lp, n, mode, np.float64), 0.3, out=out, accumulate=k > 0)
        return out
    ref = summed(passes)
    assert np.abs(summed(paired) - ref).max() <= 1e-14 * np.abs(ref).max()
