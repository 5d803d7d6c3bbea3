"""The tile schedule of a row pass, against the float64 specification.

A CPU work-item of the OpenCL row kernel runs one register of rows (8 float32, 4 float64) in
vector lanes: a partial chunk up to the destination's first aligned vector, then two tiles at a
time (each loaded, transposed by shuffles, stepped and transposed back), a last whole tile and a
partial end.  Row widths around one and two tiles, row counts that leave lanes empty, both senses,
constant and varying coefficients, destinations off a vector, accumulation, in place, and the
windowed pass of a shift each take a different part of that schedule; forced into its GPU
shapes the kernel runs one row per work-item through the same code.
"""

import numpy as np
import pytest

import gfgpu
from gfgpu import greens
from gfgpu._core import recursion
from gfgpu._core.passes import LinePass, Section

PASSES = {
    "one section": LinePass((Section(lam=0.8 * np.exp(0.3j), kap=0.5 + 0.1j),), tap=0.3),
    "two sections, anticausal": LinePass((Section(lam=0.8 * np.exp(0.3j), kap=0.5 + 0.1j),
                                          Section(lam=0.6 * np.exp(-0.2j), kap=0.2 - 0.3j)), tap=-0.1, reverse=True),
    "varying coefficients": greens.AffineGreen(u1=0.5, x_U=-3.0).line_pass(),
}
# around 1, 2, 3 and 4 tiles of 4 and 8 lanes, and long enough for many tile pairs
WIDTHS = [1, 3, 4, 5, 7, 8, 9, 12, 15, 16, 17, 23, 24, 25, 31, 32, 33, 40, 47, 48, 49, 100, 259]
ROWS = [1, 3, 8, 13]


def reference(x, lp, mode, cval):
    """float64 sequential specification along the rows of a (B, N, M) array."""
    m = x.shape[2]
    plan = recursion.plan_pass(lp, m, mode, np.float64)
    lines = x.astype(np.float64).reshape(-1, m).T
    return recursion.run_reference(lines, plan, cval=cval).T.reshape(x.shape)


def _close(got, want, dtype):
    tol = 2e-6 if dtype == np.float32 else 1e-12
    return np.abs(got - want).max() <= tol * max(1.0, np.abs(want).max())


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", sorted(PASSES))
def test_row_widths_around_tiles(backend, name, dtype, rng):
    lp = PASSES[name]
    for m in WIDTHS:
        for rows, mode in zip(ROWS, ["reflect", "wrap", "constant", "mirror"]):
            x = rng.standard_normal((1, rows, m)).astype(dtype)
            plan = recursion.plan_pass(lp, m, mode, dtype)
            want = reference(x, lp, mode, 0.7)
            src = backend.asarray(x)
            dst = backend.empty(x.shape, dtype)
            assert backend.recurse(src, dst, 2, plan, cval=0.7, check=True) is True
            assert _close(backend.to_host(dst), want, dtype), (m, rows, mode)
            base = rng.standard_normal(x.shape).astype(dtype)
            acc = backend.asarray(base.copy())
            backend.recurse(src, acc, 2, plan, cval=0.7, accumulate=True)
            assert _close(backend.to_host(acc), base + want, dtype), (m, rows, mode, "accumulate")
            backend.recurse(src, src, 2, plan, cval=0.7)
            assert _close(backend.to_host(src), want, dtype), (m, rows, mode, "in place")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_rows_off_a_vector(backend, dtype, rng):
    """Destinations 1 .. 7 samples past a vector: the partial chunk before the aligned tiles."""
    if backend.name == "numpy":
        pytest.skip("numpy arrays: no device offsets")
    lp = PASSES["two sections, anticausal"]
    for m in (24, 49, 64, 259):
        x = rng.standard_normal((1, 9, m)).astype(dtype)
        plan = recursion.plan_pass(lp, m, "nearest", dtype)
        want = reference(x, lp, "nearest", 0.0)
        src = backend.asarray(x)
        flat = backend.empty((x.size + 8,), dtype)
        for offset in range(1, 8):
            dst = backend.reshape(flat[offset:offset + x.size], x.shape)
            backend.recurse(src, dst, 2, plan)
            assert _close(backend.to_host(dst), want, dtype), (m, offset)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_fractional_row_shifts_around_tiles(backend, dtype, rng):
    """A fractional shift along rows: the windowed row pass (tiles where the window's sources are
    consecutive, gathers at the ends)."""
    for m in (5, 9, 17, 33, 48, 100):
        x = rng.standard_normal((11, m)).astype(dtype)
        for s, mode in [(2.5, "reflect"), (-3.25, "wrap"), (0.4, "constant"), (-17.6, "mirror")]:
            want = gfgpu.shift(x.astype(np.float64), (0, s), mode=mode, cval=0.5, backend="numpy")
            got = gfgpu.shift(x, (0, s), mode=mode, cval=0.5, backend=backend)
            assert _close(got, want, dtype), (m, s, mode)


def test_row_tiles_gpu_shaped(gpu_shaped, rng):
    """One row per work-item (LANES = 1) through the same schedule."""
    for name, lp in sorted(PASSES.items()):
        for m in (1, 7, 17, 100):
            x = rng.standard_normal((1, 5, m)).astype(np.float32)
            plan = recursion.plan_pass(lp, m, "reflect", np.float32)
            dst = gpu_shaped.empty(x.shape, np.float32)
            gpu_shaped.recurse(gpu_shaped.asarray(x), dst, 2, plan, cval=0.7)
            assert _close(gpu_shaped.to_host(dst), reference(x, lp, "reflect", 0.7), np.float32), (name, m)
