"""Block-parallel lines, bands of columns and the fused finite check of the recursion primitive.

The specification of block-parallel lines (:func:`gfgpu._core.recursion.run_reference_blocks`)
is checked against the sequential one, and every device backend, on its own launch shapes and
forced into its GPU shapes, against a float64 run of the sequential specification.
"""

import numpy as np
import pytest

import gfgpu
from gfgpu import greens
from gfgpu._core import recursion
from gfgpu._core.passes import LinePass, Section

SEC1 = Section(lam=0.8 * np.exp(0.3j), kap=0.5 + 0.1j)
SEC2 = Section(lam=0.6 * np.exp(-0.2j), kap=0.2 - 0.3j)
PASSES = {
    "one section": LinePass((SEC1,), tap=0.3),
    "two sections, anticausal": LinePass((SEC1, SEC2), tap=-0.1, reverse=True),
    "G_u": greens.UniformGreen(3.0).line_pass(),
    # coefficients that change along the line: blocks carry with the product of their own lam
    "G_U^(1), shift variant": greens.AffineGreen(u1=0.5, x_U=-3.0).line_pass(),
}


def reference(x, lp, axis, mode, cval):
    """float64 sequential specification along ``axis`` of a (B, N, M) array."""
    n = x.shape[axis]
    plan = recursion.plan_pass(lp, n, mode, np.float64)
    lines = np.moveaxis(x.astype(np.float64), axis, 0)
    out = recursion.run_reference(lines.reshape(n, -1), plan, cval=cval).reshape(lines.shape)
    return np.moveaxis(out, 0, axis)


@pytest.mark.parametrize("name", sorted(PASSES))
@pytest.mark.parametrize("block", [1, 7, 64, 1000])
@pytest.mark.parametrize("mode", ["reflect", "wrap", "constant", "nearest", "mirror"])
def test_blocks_spec_equals_sequential(name, block, mode, rng):
    lp = PASSES[name]
    x = rng.standard_normal((300, 5))
    plan = recursion.plan_pass(lp, 300, mode, np.float64)
    want = recursion.run_reference(x, plan, cval=0.7)
    got = recursion.run_reference_blocks(x, plan, block, cval=0.7)
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


def test_blocks_spec_float32_within_rounding(rng):
    x = rng.standard_normal((5000, 3)).astype(np.float32)
    lp = PASSES["two sections, anticausal"]
    want = recursion.run_reference(x.astype(np.float64), recursion.plan_pass(lp, 5000, "reflect", np.float64))
    got = recursion.run_reference_blocks(x, recursion.plan_pass(lp, 5000, "reflect", np.float32), 512)
    assert np.linalg.norm(got - want) / np.linalg.norm(want) < 1e-6


def test_block_powers_carry_a_state_across_a_block():
    lp = PASSES["two sections, anticausal"]
    plan = recursion.plan_pass(lp, 100, "reflect", np.float64)
    power = recursion.block_powers(plan, 30)
    assert power.shape == (2, 4)
    lam = plan.lam[:, 0]
    assert np.allclose(power[:, 0], lam ** 30, rtol=1e-13)


# (B, N, M) shapes whose lines are too few to fill a 2-core CPU: block-parallel on every device
FEW_LINES = [((1, 4, 20000), 2), ((1, 20000, 3), 1), ((1, 9000, 2), 1), ((1, 1, 30000), 2)]
# short lines in blocks on a GPU only: one column in one-work-item groups, where PoCL 3.1 miscompiled
# the carries of two sections
GPU_FEW_LINES = [((1, 300, 1), 1), ((1, 2, 700), 2)]
# shapes whose lines fill the device; 70 columns: bands end in a partial vector
MANY_LINES = [((1, 300, 70), 1), ((1, 300, 70), 2), ((3, 40, 1100), 1), ((2, 33, 257), 2)]


def _run(be, x, lp, axis, mode, cval, accumulate=None, check=False):
    plan = recursion.plan_pass(lp, x.shape[axis], mode, x.dtype)
    src = be.asarray(x)
    dst = be.asarray(accumulate.copy()) if accumulate is not None else be.empty(x.shape, x.dtype)
    res = be.recurse(src, dst, axis, plan, cval=cval, accumulate=accumulate is not None, check=check)
    return be.to_host(dst), res


def _check_backend(be, shapes, dtype, rng):
    tol = 2e-6 if dtype == np.float32 else 1e-12
    for shape, axis in shapes:
        for (name, lp), mode in zip(sorted(PASSES.items()), ["reflect", "wrap", "constant", "mirror"]):
            x = rng.standard_normal(shape).astype(dtype)
            want = reference(x, lp, axis, mode, 0.7)
            got, finite = _run(be, x, lp, axis, mode, 0.7, check=True)
            assert finite is True
            err = np.abs(got - want).max() / np.abs(want).max()
            assert err < tol, (be.name, be.kind, shape, axis, name, mode, err)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_few_long_lines_run_in_blocks(backend, dtype, rng):
    if backend.name == "numpy":
        pytest.skip("the numpy backend runs whole lines (its blocked matrices are its own)")
    for shape, axis in FEW_LINES:
        blocks = _blocks(backend, shape, axis, dtype)
        if backend.name == "opencl" or backend.kind == "gpu":
            assert blocks > 1, (shape, axis)
    _check_backend(backend, FEW_LINES, dtype, rng)


# few long rows whose blocks divide them: the OpenCL CPU kernel runs each line's blocks as rows of a
# view, in the lanes of its vectors (rows_as_blocks)
ROW_BLOCKS = [((1, 4, 65536), 2), ((2, 1, 40960), 2), ((1, 3, 49152), 2)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_few_long_rows_run_as_rows_of_blocks(backend, dtype, rng):
    if backend.name == "opencl" and backend.kind == "cpu":
        for shape, axis in ROW_BLOCKS:
            launch = backend.recurse_shape(shape, axis, np.dtype(dtype))
            assert launch.rows_as_blocks and launch.blocks > 1, (shape, launch)
    _check_backend(backend, ROW_BLOCKS, dtype, rng)
    # accumulating, and the finite check of every sample (a NaN first, in the middle, last)
    x = rng.standard_normal(ROW_BLOCKS[0][0]).astype(dtype)
    base = rng.standard_normal(x.shape).astype(dtype)
    got, _ = _run(backend, x, PASSES["two sections, anticausal"], 2, "reflect", 0.3, accumulate=base)
    want = base + reference(x, PASSES["two sections, anticausal"], 2, "reflect", 0.3)
    assert np.abs(got - want).max() < 2e-5 * np.abs(want).max()
    for where in (0, x.size // 2 + 1, x.size - 1):
        bad = x.copy()
        bad.reshape(-1)[where] = np.nan
        _, finite = _run(backend, bad, PASSES["G_u"], 2, "wrap", 0.0, check=True)
        assert finite is False, where


def _blocks(be, shape, axis, dtype):
    if be.name == "opencl":
        return be.recurse_shape(shape, axis, np.dtype(dtype)).blocks
    return be.recurse_shape(shape, axis)[1]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_gpu_shapes_forced_on_cpu(gpu_shaped, dtype, rng):
    """The GPU branches (one line per work-item, blocks, composition) on the CPU devices."""
    for shape, axis in FEW_LINES + GPU_FEW_LINES:
        assert _blocks(gpu_shaped, shape, axis, dtype) > 1
    _check_backend(gpu_shaped, FEW_LINES + GPU_FEW_LINES + MANY_LINES, dtype, rng)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bands_and_partial_vectors(backend, dtype, rng):
    _check_backend(backend, MANY_LINES, dtype, rng)


@pytest.mark.parametrize("shape, axis", FEW_LINES[:2] + MANY_LINES[:2])
def test_accumulate_and_blocks(backend, shape, axis, rng):
    x = rng.standard_normal(shape).astype(np.float32)
    base = rng.standard_normal(shape).astype(np.float32)
    lp = PASSES["G_u"]
    got, _ = _run(backend, x, lp, axis, "reflect", 0.0, accumulate=base)
    want = base + reference(x, lp, axis, "reflect", 0.0)
    assert np.abs(got - want).max() < 2e-5 * np.abs(want).max()


@pytest.mark.parametrize("where", ["first", "middle", "last"])
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_fused_finite_check_sees_every_sample(backend, where, value, rng):
    for shape, axis in FEW_LINES[:2] + MANY_LINES[:2]:
        x = rng.standard_normal(shape).astype(np.float32)
        flat = x.reshape(-1)
        flat[{"first": 0, "middle": flat.size // 2 + 1, "last": flat.size - 1}[where]] = value
        _, finite = _run(backend, x, PASSES["G_u"], axis, "reflect", 0.0, check=True)
        assert finite is False, (shape, axis)


def test_gpu_shaped_check_sees_every_sample(gpu_shaped, rng):
    for shape, axis in FEW_LINES[:2] + MANY_LINES[:2]:
        x = rng.standard_normal(shape).astype(np.float32)
        x.reshape(-1)[-1] = np.nan
        _, finite = _run(gpu_shaped, x, PASSES["G_u"], axis, "reflect", 0.0, check=True)
        assert finite is False, (shape, axis)


SHIFTS = [(0, 2.5), (-3.25, 0), (7.75, -12.5), (130.5, -0.25)]


@pytest.mark.parametrize("mode", ["reflect", "wrap", "constant", "nearest", "mirror"])
@pytest.mark.parametrize("interpolation", ["green", "cubic"])
def test_windowed_passes_equal_the_gathered_ones(backend, mode, interpolation, rng):
    """A translated pass read through a window index (one pass) equals the numpy backend's
    gather, pass and crop, for shifts beyond the line too, rows and columns."""
    for shape in [(37, 70), (300, 33), (5, 1000)]:
        x = rng.standard_normal(shape).astype(np.float32)
        for s in SHIFTS:
            want = gfgpu.shift(x.astype(np.float64), s, mode=mode, interpolation=interpolation, cval=0.5,
                               backend="numpy")
            got = gfgpu.shift(x, s, mode=mode, interpolation=interpolation, cval=0.5, backend=backend)
            assert np.abs(got - want).max() <= 2e-6 * np.abs(want).max(), (shape, s)


def test_windowed_passes_gpu_shaped(gpu_shaped, rng):
    assert gpu_shaped.recurses_windows
    for shape in [(37, 70), (5, 1000)]:
        x = rng.standard_normal(shape).astype(np.float32)
        for s, mode in zip(SHIFTS, ["reflect", "wrap", "constant", "mirror"]):
            want = gfgpu.shift(x.astype(np.float64), s, mode=mode, cval=0.5, backend="numpy")
            got = gfgpu.shift(x, s, mode=mode, cval=0.5, backend=gpu_shaped)
            assert np.abs(got - want).max() <= 2e-6 * np.abs(want).max(), (shape, s, mode)


def _many_line_passes():
    """52 per-line passes: runs of one direction longer than a CPU work-item's lanes (16 float32,
    8 float64), groups that mix directions, identity lines and a partial last group."""
    forward = [greens.shift_pass(0.05 + 0.02 * i) for i in range(20)]
    backward = [greens.shift_pass(-0.05 - 0.02 * i) for i in range(16)]
    mixed = [greens.UniformGreen(1.3).line_pass() if i % 2 else greens.HomogeneousGreen(2.0).line_pass(reverse=True)
             for i in range(8)]
    tail = [None, greens.shift_pass(0.35), None, greens.shift_pass(-2.7), greens.shift_pass(9.5), None, None,
            greens.shift_pass(0.2)]
    return forward + backward + mixed + tail


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("axis", [1, 2])
def test_per_line_passes_in_vector_lanes(backend, dtype, axis, rng):
    """recurse_lines' CPU path runs adjacent lines in vector lanes, each with its own coefficients:
    against the float64 specification, for lines of one direction, mixed groups and the tail."""
    from gfgpu._core.recursion import plan_lines, run_reference_lines
    passes = _many_line_passes()
    m = len(passes)
    shape = (2, 23, m) if axis == 1 else (2, m, 29)
    n = shape[axis]
    for mode in ["reflect", "wrap", "constant", "nearest", "mirror"]:
        src = (1.0 + rng.standard_normal(shape)).astype(dtype)
        plans = plan_lines(passes, n, mode, dtype)
        plans64 = plan_lines(passes, n, mode, np.float64)
        x = src.astype(np.float64)
        ref = np.stack([run_reference_lines(x[i] if axis == 1 else x[i].T, plans64, -0.5) for i in range(2)])
        ref = ref if axis == 1 else ref.transpose(0, 2, 1)
        tol = 2e-6 if dtype == np.float32 else 1e-12
        out = backend.empty(shape, dtype)
        backend.recurse_lines(backend.asarray(src), out, axis, plans, cval=-0.5)
        got = backend.to_host(out)
        assert np.abs(got - ref).max() <= tol * np.abs(ref).max(), mode
        same = backend.asarray(src.copy())
        backend.recurse_lines(same, same, axis, plans, cval=-0.5)
        assert np.abs(backend.to_host(same) - ref).max() <= tol * np.abs(ref).max(), (mode, "in place")


@pytest.mark.parametrize("offset", [0, 1, 4, 12, 15])
@pytest.mark.parametrize("shape", [(1, 40, 256), (1, 4, 65536)])
def test_rows_into_arrays_that_start_off_a_vector(backend, offset, shape, rng):
    """Row passes whose source and destination start ``offset`` samples into a buffer (a numpy
    ``output=`` starts 16 bytes past a cache line): the OpenCL row kernel aligns its tiles to the
    destination (a partial chunk first); rows of many lines and rows of blocks, both senses,
    accumulating or not, and the fused pair of a step's two passes."""
    if backend.name == "numpy":
        pytest.skip("numpy arrays: no device offsets")
    size = int(np.prod(shape))
    x = rng.standard_normal(shape).astype(np.float32)
    base = rng.standard_normal(shape).astype(np.float32)
    flat_src = backend.empty((size + 16,), np.float32)
    flat_dst = backend.empty((size + 16,), np.float32)
    src = backend.reshape(flat_src[offset:offset + size], shape)
    dst = backend.reshape(flat_dst[(offset * 3) % 16:(offset * 3) % 16 + size], shape)
    backend.copy(backend.asarray(x), src)
    for name in ("G_u", "two sections, anticausal"):
        lp = PASSES[name]
        plan = recursion.plan_pass(lp, shape[2], "reflect", np.float32)
        backend.copy(backend.asarray(base), dst)
        backend.recurse(src, dst, 2, plan, cval=0.0, accumulate=True)
        want = base + reference(x, lp, 2, "reflect", 0.0)
        got = backend.to_host(dst)
        assert np.abs(got - want).max() <= 2e-5 * np.abs(want).max(), (name, offset)
        backend.recurse(src, dst, 2, plan, cval=0.0)
        want = reference(x, lp, 2, "reflect", 0.0)
        assert np.abs(backend.to_host(dst) - want).max() <= 2e-5 * np.abs(want).max(), (name, offset)
    fuse = getattr(backend, "fuses_pair", None)
    first, second = (recursion.plan_pass(lp, shape[2], "reflect", np.float32)
                     for lp in (PASSES["G_u"], greens.UniformGreen(2.0).line_pass(reverse=True)))
    if fuse is not None and fuse(2, first, second):
        backend.recurse_pair(src, dst, 2, first, second, cval=0.0)
        want = reference(x, PASSES["G_u"], 2, "reflect", 0.0) + reference(
            x, greens.UniformGreen(2.0).line_pass(reverse=True), 2, "reflect", 0.0)
        assert np.abs(backend.to_host(dst) - want).max() <= 2e-5 * np.abs(want).max(), offset
