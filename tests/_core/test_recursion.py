"""The recursion primitive (gfgpu._core.recursion): plans and their numpy specification.

``run_reference`` is checked against float64 direct summation of the closed-form kernels
(``oracle.direct_line``), every boundary mode against the same pass run on the explicitly
extended line (``numpy.pad``), causal against anticausal, the plan cache, and the per-line
variant ``run_reference_lines`` against ``run_reference`` line by line.
"""
import dataclasses

import numpy as np
import pytest
from oracle import direct_line, pad_line, relerr

from gfgpu import greens
from gfgpu._core import recursion
from gfgpu._core.passes import LinePass, Section
from gfgpu._core.recursion import MODES, plan_lines, plan_pass, run_reference, run_reference_lines

TOL = {np.float32: 1e-5, np.float64: 1e-12}
N = 29


def _kernel(name, n, anticausal):
    """A kernel valid on lines of ``n`` samples run in the given sense (its fixed point outside)."""
    return {
        "G_u": greens.UniformGreen(2.3),
        "H_u": greens.HomogeneousGreen(1.7),
        "G_U1": greens.AffineGreen(0.6, n - 1 + 3.5 if anticausal else -3.5),
        "G_U2": greens.AffineGreenApprox(6.0, n - 1 + 40.0 if anticausal else -40.0),
    }[name]


def _lines(rng, n=N, m=3, dtype=np.float64):
    x = np.arange(n)[:, None]
    return (1.0 + 0.4 * np.sin(x / 3.0 + np.arange(m)) + 0.2 * rng.standard_normal((n, m))).astype(dtype)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("anticausal", [False, True], ids=["causal", "anticausal"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kname", ["G_u", "H_u", "G_U1", "G_U2"])
def test_run_reference_is_the_direct_sum_of_the_closed_form(rng, kname, mode, anticausal, dtype):
    kernel = _kernel(kname, N, anticausal)
    lines = _lines(rng, dtype=dtype)
    plan = plan_pass(kernel.line_pass(reverse=anticausal), N, mode, dtype)
    out = run_reference(lines, plan, cval=0.5)
    assert out.dtype == dtype and out.shape == lines.shape
    ref = np.stack([direct_line(lines[:, i], kernel, mode, 0.5, anticausal) for i in range(lines.shape[1])], 1)
    assert relerr(out, ref) <= TOL[dtype]


# passes of every kind: one or several sections, a direct tap, shift-variant coefficients
PASSES = {
    "G_u": greens.UniformGreen(2.3).line_pass(),
    "H_u anticausal": greens.HomogeneousGreen(1.7).line_pass(reverse=True),
    "shift 2.6": greens.shift_pass(2.6),
    "shift -0.4": greens.shift_pass(-0.4),
    "D causal": greens.derivative_passes(1.5)[0],
    "D anticausal": greens.derivative_passes(1.5)[1],
    "G_U1": greens.AffineGreen(0.6, -3.5).line_pass(),
    "G_U1 anticausal": greens.AffineGreen(1.2, N - 1 + 7.5).line_pass(reverse=True),
    "G_U2 anticausal": greens.AffineGreenApprox(6.0, N - 1 + 40.0).line_pass(reverse=True),
}
#: G_U^(2)'s frequency |x_U|/sigma^2 depends on where the line starts: it is no kernel of x - x_U
#: alone, so it has no equivalent on a longer line
TRANSLATABLE = [name for name in PASSES if not name.startswith("G_U2")]


def _extended_pass(line_pass, margin):
    """``line_pass`` on the line with ``margin`` samples prepended (before the traversal start):
    a shift-variant kernel's fixed point moves with the line's origin where the samples come
    first (causal); appended samples (anticausal) leave the coordinates as they are."""
    if line_pass.shift_invariant or line_pass.reverse:
        return line_pass
    sections = tuple(Section(kernel=dataclasses.replace(s.kernel, x_U=s.kernel.x_U + margin))
                     for s in line_pass.sections)
    return LinePass(sections, line_pass.tap, line_pass.reverse)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", TRANSLATABLE)
def test_boundary_mode_is_an_extension_of_the_input(rng, name, mode):
    """The mode, realised as the initial state, equals running on the line extended by numpy.pad."""
    line_pass = PASSES[name]
    lines = _lines(rng)
    cval = -0.7
    out = run_reference(lines, plan_pass(line_pass, N, mode, np.float64), cval=cval)
    # where the kernel's domain ends before the line (G_U), the extension it sees is finite
    if line_pass.shift_invariant:
        margin = 2000
    else:
        k = line_pass.sections[0].kernel.mirrored(N) if line_pass.reverse else line_pass.sections[0].kernel
        margin = int(np.ceil(-k.x_min)) - 1
    side = "right" if line_pass.reverse else "left"
    ext = np.stack([pad_line(lines[:, i], margin, mode, cval, side) for i in range(lines.shape[1])], 1)
    longer = _extended_pass(line_pass, margin)
    # on the extended line, nothing lies beyond: constant mode with cval 0 and an extension long
    # enough for the kernel to have decayed below float64 rounding (or the whole finite domain)
    ref = run_reference(ext, plan_pass(longer, N + margin, "constant", np.float64), cval=0.0)
    ref = ref[:N] if line_pass.reverse else ref[margin:]
    assert relerr(out, ref) <= 1e-12


@pytest.mark.parametrize("mode", ["constant", "nearest"])
@pytest.mark.parametrize("name", list(PASSES))
def test_causal_passes_do_not_look_ahead(rng, name, mode):
    """Output k depends on samples up to k only (from k on, anticausally); the modes whose
    extension reads no sample beyond the first keep that true at the line's start."""
    line_pass = PASSES[name]
    lines = _lines(rng)
    plan = plan_pass(line_pass, N, mode, np.float64)
    out = run_reference(lines, plan)
    k = N // 2
    changed = lines.copy()
    if line_pass.reverse:
        changed[: k - 1] += 10.0 * rng.standard_normal((k - 1, lines.shape[1]))
        np.testing.assert_array_equal(run_reference(changed, plan)[k:], out[k:])
        assert not np.allclose(run_reference(changed, plan)[: k - 1], out[: k - 1])
    else:
        changed[k + 1:] += 10.0 * rng.standard_normal((N - k - 1, lines.shape[1]))
        np.testing.assert_array_equal(run_reference(changed, plan)[:k + 1], out[:k + 1])
        assert not np.allclose(run_reference(changed, plan)[k + 1:], out[k + 1:])


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kernel", [greens.UniformGreen(2.3), greens.HomogeneousGreen(0.8)], ids=["G_u", "H_u"])
def test_anticausal_is_causal_on_the_reversed_line(rng, kernel, mode):
    lines = _lines(rng)
    anti = run_reference(lines, plan_pass(kernel.line_pass(reverse=True), N, mode, np.float64), cval=0.3)
    causal = run_reference(lines[::-1], plan_pass(kernel.line_pass(), N, mode, np.float64), cval=0.3)[::-1]
    np.testing.assert_allclose(anti, causal, rtol=0, atol=1e-13)
    # and a mirrored shift-variant kernel is the same kernel seen from the other end
    k = greens.AffineGreen(0.6, -3.5)
    anti = run_reference(lines, plan_pass(k.mirrored(N).line_pass(reverse=True), N, mode, np.float64), cval=0.3)
    causal = run_reference(lines[::-1], plan_pass(k.line_pass(), N, mode, np.float64), cval=0.3)[::-1]
    np.testing.assert_allclose(anti, causal, rtol=0, atol=1e-13)


def test_float32_runs_in_float32_within_rounding_of_float64(rng):
    lines = _lines(rng)
    for line_pass in PASSES.values():
        ref = run_reference(lines, plan_pass(line_pass, N, "reflect", np.float64))
        out = run_reference(lines.astype(np.float32), plan_pass(line_pass, N, "reflect", np.float32))
        assert out.dtype == np.float32
        assert relerr(out, ref) <= 1e-5


def test_output_and_accumulate(rng):
    lines = _lines(rng)
    plan = plan_pass(PASSES["D causal"], N, "mirror", np.float64)
    ref = run_reference(lines, plan, cval=0.2)
    out = np.full_like(lines, 3.0)
    assert run_reference(lines, plan, cval=0.2, out=out) is out
    np.testing.assert_array_equal(out, ref)
    acc = np.full_like(lines, 3.0)
    run_reference(lines, plan, cval=0.2, out=acc, accumulate=True)
    np.testing.assert_allclose(acc, ref + 3.0, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(lines, _lines(np.random.default_rng(12345)))   # input untouched


# --------------------------------------------------------------------------------------
# plans
# --------------------------------------------------------------------------------------
def test_plans_are_cached_and_read_only():
    a = plan_pass(greens.UniformGreen(2.0).line_pass(), 64, "reflect", np.float32)
    # equal passes (built anew), equal dtype spellings: the same plan object
    assert plan_pass(greens.UniformGreen(2.0).line_pass(), 64, "reflect", "float32") is a
    assert plan_pass(greens.UniformGreen(2.0).line_pass(), np.int64(64), "reflect", np.dtype("float32")) is a
    for other in (plan_pass(greens.UniformGreen(2.0).line_pass(), 65, "reflect", np.float32),
                  plan_pass(greens.UniformGreen(2.0).line_pass(), 64, "wrap", np.float32),
                  plan_pass(greens.UniformGreen(2.0).line_pass(), 64, "reflect", np.float64),
                  plan_pass(greens.UniformGreen(2.5).line_pass(), 64, "reflect", np.float32),
                  plan_pass(greens.UniformGreen(2.0).line_pass(reverse=True), 64, "reflect", np.float32)):
        assert other is not a
    assert isinstance(a, recursion.PassPlan) and a.n == 64 and a.sections == 1 and a.constant and not a.reverse
    for arr in (a.lam, a.kap, a.omega, a.omega_c):
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[...] = 0


def test_plan_layout():
    plan = plan_pass(PASSES["D anticausal"], 40, "reflect", np.float32)
    assert plan.reverse and plan.sections == 2 and plan.lam.shape == plan.kap.shape == (2, 40)
    lam, kap, omega, omega_c = plan.packed(np.float32)
    assert lam.shape == (2, 40, 2) and omega.shape == (2, plan.omega.shape[1], 2) and omega_c.shape == (2, 2)
    assert all(a.dtype == np.float32 and a.flags.c_contiguous for a in (lam, kap, omega, omega_c))
    np.testing.assert_allclose(lam[..., 0] + 1j * lam[..., 1], plan.lam, rtol=1e-6)
    # constant mode folds the extension into omega_c; the others into omega (at most n samples)
    const = plan_pass(PASSES["G_u"], 40, "constant", np.float64)
    assert const.omega.shape[1] == 0 and abs(const.omega_c[0]) > 0
    near = plan_pass(PASSES["G_u"], 40, "nearest", np.float64)
    assert near.omega.shape[1] == 1 and near.omega_c[0] == 0
    assert plan_pass(PASSES["G_u"], 40, "wrap", np.float64).omega.shape[1] <= 40
    variant = plan_pass(PASSES["G_U1"], 40, "reflect", np.float64)
    assert not variant.constant and not np.allclose(variant.lam[:, 0], variant.lam[:, -1])


def test_plan_errors():
    with pytest.raises(ValueError, match="mode must be one of constant, nearest, reflect, mirror, wrap; got 'edge'"):
        plan_pass(PASSES["G_u"], 10, "edge", np.float64)
    with pytest.raises(ValueError, match="mode must be one of"):
        recursion.check_mode("symmetric")
    assert recursion.check_mode("wrap") == "wrap"
    with pytest.raises(ValueError, match="x_U < 0"):
        plan_pass(greens.AffineGreen(0.6, 2.0).line_pass(), 10, "reflect", np.float64)
    with pytest.raises(ValueError, match="x_U > 9"):
        plan_pass(greens.AffineGreen(0.6, 5.0).line_pass(reverse=True), 10, "reflect", np.float64)
    with pytest.raises(ValueError, match="one shift-invariant section"):
        plan_lines([PASSES["D causal"]], 10, "reflect", np.float64)
    with pytest.raises(ValueError, match="one shift-invariant section"):
        plan_lines([PASSES["G_U1"]], 10, "reflect", np.float64)


# --------------------------------------------------------------------------------------
# per-line plans
# --------------------------------------------------------------------------------------
LINE_PASSES = [greens.UniformGreen(1.3).line_pass(), None, greens.shift_pass(-2.7), greens.shift_pass(0.35),
               greens.HomogeneousGreen(2.0).line_pass(reverse=True), greens.UniformGreen(1.3).line_pass(),
               greens.shift_pass(9.5), None]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", MODES)
def test_run_reference_lines_is_run_reference_line_by_line(rng, mode, dtype):
    m = len(LINE_PASSES)
    lines = _lines(rng, m=m, dtype=dtype)
    plans = plan_lines(LINE_PASSES, N, mode, dtype)
    assert isinstance(plans, recursion.LinePlans) and plans.lines == m and plans.n == N
    out = run_reference_lines(lines, plans, cval=0.4)
    assert out.dtype == dtype
    for i, lp in enumerate(LINE_PASSES):
        if lp is None:          # identity
            np.testing.assert_array_equal(out[:, i], lines[:, i])
            continue
        ref = run_reference(lines[:, i:i + 1], plan_pass(lp, N, mode, dtype), cval=0.4)[:, 0]
        np.testing.assert_allclose(out[:, i], ref, rtol=0, atol=(1e-5 if dtype == np.float32 else 1e-13))
    into = np.empty_like(lines)
    assert run_reference_lines(lines, plans, cval=0.4, out=into) is into
    np.testing.assert_array_equal(into, out)


def test_line_plans_layout():
    plans = plan_lines(LINE_PASSES, 20, "reflect", np.float64)
    np.testing.assert_array_equal(plans.reverse, [False, False, True, False, True, False, False, False])
    np.testing.assert_array_equal(plans.tap[[1, 7]], 1.0)
    np.testing.assert_array_equal(plans.lam[[1, 7]], 0)
    assert plans.lam[0] == plans.lam[5] == plan_pass(LINE_PASSES[0], 20, "reflect", np.float64).lam[0, 0]
    lam, kap, tap, reverse, omega, omega_c = plans.packed(np.float32)
    assert lam.shape == (8, 2) and tap.shape == (8,) and reverse.dtype == np.int32
    assert omega.shape == (8, plans.omega.shape[1], 2) and omega_c.shape == (8, 2)
