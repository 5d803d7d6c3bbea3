"""Plans at a new line length (gfgpu._core.recursion, twosided, oblique): what an image of another
size reuses, and that the reuse gives every bit an uncached computation gives.

A shift-invariant pass's initial window depends on the line's length only through a few scalars
(``lam^period``), a two-sided step's through its unit sections' windows, an oblique direction's
column filters not at all (column ``t`` depends on ``gamma * t``): the caches are keyed by those.
Each cached result is compared bit for bit with the same quantity computed here without the caches,
by the routines the caches call (the geometric series, Thiran's design), over line lengths short
and long, in orders that hit and miss, every mode and dtype.
"""

import itertools

import numpy as np
import pytest

from gfgpu import greens
from gfgpu._core import lines, oblique, recursion, twosided
from gfgpu._core.passes import LinePass, Section
from gfgpu._core.recursion import MODES, TOL, plan_pass
from gfgpu.edges import operator as edge_operator


def _bits(a):
    a = np.asarray(a)
    return a.dtype.str, a.shape, np.ascontiguousarray(a).tobytes()


def _uncached_plan(line_pass, n, mode, dtype):
    """``(lam, kap, omega, omega_c)`` of a shift-invariant pass on lines of ``n``: each section's
    window by the geometric series itself, the pass's window cut as plan_pass cuts it."""
    tol = TOL[np.dtype(dtype)]
    omegas, omega_cs = [], []
    for sec in line_pass.sections:
        om, oc = recursion._line_initial_weights(np.array([complex(sec.lam)]), np.array([complex(sec.kap)]), n,
                                                 mode, tol)
        omegas.append(om[0])
        omega_cs.append(complex(oc[0]))
    length = max(len(o) for o in omegas)
    omega = np.zeros((len(omegas), length), np.complex128)
    for s, o in enumerate(omegas):
        omega[s, :len(o)] = o
    if length:
        big = np.abs(omega).max(axis=0)
        keep = np.nonzero(big > tol * max(big.max(), 1e-300))[0]
        omega = omega[:, : (keep[-1] + 1 if keep.size else 0)]
    lam = np.array([np.full(n, sec.lam, np.complex128) for sec in line_pass.sections])
    kap = np.array([np.full(n, sec.kap, np.complex128) for sec in line_pass.sections])
    return lam, kap, omega, np.array(omega_cs, np.complex128)


PASSES = {
    "G_u 3": greens.UniformGreen(3.0).line_pass(),
    "G_u 0.7 anticausal": greens.UniformGreen(0.7).line_pass(reverse=True),
    "G_u 40": greens.UniformGreen(40.0).line_pass(),
    "D": greens.derivative_passes(1.0, greens.EDGE_A, greens.EDGE_ETA, False)[0],
    "P anticausal": greens.projection_passes(2.5, greens.EDGE_A, greens.EDGE_ETA, False)[1],
    "one-signed D": edge_operator.derivative_passes(1.0)[0],
    "one-signed P": edge_operator.projection_passes(1.5)[1],
    # a unit section (the two-sided steps' own; zeros of either sign: test_..._zero_sign below)
    "unit": LinePass((Section(lam=0.6 + 0.3j, kap=1.0 + 0.0j),)),
    "real poles": LinePass((Section(lam=0.5 + 0.0j, kap=0.25 + 0.0j), Section(lam=complex(-0.3, -0.0), kap=-1 + 0j)),
                           tap=0.5),
}
# short lines (within the reach: computed in full), the benchmark's lengths, in an order that hits
LENGTHS = [1, 2, 3, 40, 1000, 1200, 1100, 1300, 1299, 4096, 83, 84, 85, 700]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", list(PASSES))
def test_a_plan_at_any_length_has_the_bits_of_an_uncached_one(name, mode, dtype):
    line_pass = PASSES[name]
    for n in LENGTHS:
        plan = plan_pass(line_pass, n, mode, dtype)
        want = _uncached_plan(line_pass, n, mode, dtype)
        for got, ref in zip((plan.lam, plan.kap, plan.omega, plan.omega_c), want):
            assert _bits(got) == _bits(ref), (name, mode, n)
        assert plan.constant and plan.tap == line_pass.tap and plan.reverse == line_pass.reverse
        for arr in (plan.lam, plan.kap, plan.omega, plan.omega_c):
            assert not arr.flags.writeable
        for got, ref in zip(plan.packed(dtype), want):
            expect = np.stack([ref.real, ref.imag], axis=-1).astype(dtype)
            assert _bits(got) == _bits(expect) and got.flags.c_contiguous


@pytest.mark.parametrize("mode", MODES)
def test_a_new_line_length_sums_no_geometric_series(monkeypatch, mode):
    """An image of another size costs a few scalar operations per section, not the window's
    series (before: every section's series at every new length)."""
    calls = []
    series = recursion._line_initial_weights
    monkeypatch.setattr(recursion, "_line_initial_weights", lambda *a, **k: calls.append(a[2]) or series(*a, **k))
    passes = [greens.UniformGreen(3.0).line_pass(), *edge_operator.derivative_passes(1.0),
              *greens.projection_passes(1.0, greens.EDGE_A, greens.EDGE_ETA, False)]
    for lp in passes:
        plan_pass(lp, 1000, mode, np.float32)
    calls.clear()
    for lp in passes:
        plan_pass(lp, 1100, mode, np.float32)
    assert calls == []


def test_sections_whose_bits_differ_only_in_a_zero_sign_keep_their_own_windows():
    """Sections that compare equal (-0.0 == 0.0) but differ in bits share no cached window.  (Whole
    passes that compare equal share one plan at a given length, as plan_pass's cache always did.)"""
    tol = TOL[np.dtype(np.float32)]
    plus = recursion._invariant_weights(0.6 + 0.3j, 1.0 + 0.0j, 500, "mirror", tol)
    minus = recursion._invariant_weights(0.6 + 0.3j, complex(1.0, -0.0), 600, "mirror", tol)
    ref = recursion._line_initial_weights(np.array([0.6 + 0.3j]), np.array([complex(1.0, -0.0)]), 600, "mirror", tol)
    assert plus[2] != minus[2]
    assert _bits(minus[0]) == _bits(ref[0][0])


def _uncached_two_sided(key, n, mode, dtype):
    """omega and omega_c of a two-sided plan from a plan_pass of each unit section and direction
    (the plan's definition), none of the cached windows shared."""
    plan = twosided.plan_two_sided(key, n, mode, dtype)
    nin, S = plan.lam.shape
    omega = np.zeros(plan.omega.shape, np.complex128)
    omega_c = np.zeros(plan.omega_c.shape, np.complex128)
    for i, d, s in itertools.product(range(nin), range(2), range(S)):
        if plan.lam[i, s] == 0 and s > 0:
            continue
        lam, kap, om, oc = _uncached_plan(LinePass((Section(lam=plan.lam[i, s], kap=1.0 + 0j),), 0.0, bool(d)), n,
                                          mode, dtype)
        omega[i, d, s, :om.shape[1]] = om[0]
        omega_c[i, d, s] = oc[0]
    return plan, omega, omega_c


@pytest.mark.parametrize("mode", MODES)
def test_a_two_sided_plan_at_any_length_has_the_bits_of_an_uncached_one(mode):
    d = tuple(edge_operator.derivative_passes(1.0))
    p = tuple(edge_operator.projection_passes(1.0))
    dd = tuple(greens.derivative_passes(2.0, greens.EDGE_A, greens.EDGE_ETA, False))
    for key, n in itertools.product(([(0, p), (0, d)], [(0, dd)]), [3, 1000, 1100, 1300, 50, 1301]):
        plan, omega, omega_c = _uncached_two_sided(key, n, mode, np.float32)
        assert _bits(plan.omega) == _bits(omega) and _bits(plan.omega_c) == _bits(omega_c), (mode, n)
        assert plan.n == n and not plan.omega.flags.writeable


def _uncached_columns(steps, gamma, dtype_str):
    """column_delays without its table: Thiran's design of every moving column of this length."""
    _, d = lines.shear_offsets(steps, gamma)
    moving = d != 0
    if not moving.any():
        return [], d, 0
    tol = TOL[np.dtype(dtype_str)]
    stages, margin = [], 0
    for lam_m, kap_m, tap_m in oblique.allpass_delay(d[moving]):
        lam, kap, tap = np.zeros(steps, np.complex128), np.zeros(steps, np.complex128), np.ones(steps)
        lam[moving], kap[moving], tap[moving] = lam_m, kap_m, tap_m
        mag = np.maximum(np.abs(lam_m), 1e-300)
        scale = np.maximum(np.abs(kap_m), 1.0)
        margin += max(int(np.max(np.ceil(np.log(tol / scale) / np.log(mag)))), 0) + 1
        stages.append((lam, kap, tap))
    return stages, d, margin


@pytest.mark.parametrize("angle", [0.3, -2.0, 1.2, 0.05, np.pi / 4, 0.0, 1e-7, np.arctan(0.5)])
@pytest.mark.parametrize("dtype_str", ["<f4", "<f8"])
def test_column_delays_at_any_length_have_the_bits_of_an_uncached_design(angle, dtype_str):
    _, _, gamma = lines.direction(angle)
    for steps in (1200, 1300, 900, 2500, 1, 2, 3, 7, 2600, 1250):
        stages, d, margin = oblique.column_delays(steps, gamma, dtype_str)
        ref_stages, ref_d, ref_margin = _uncached_columns(steps, gamma, dtype_str)
        assert margin == ref_margin and _bits(d) == _bits(ref_d) and len(stages) == len(ref_stages)
        for got, ref in zip(stages, ref_stages):
            for a, b in zip(got, ref):
                assert _bits(a) == _bits(b), (angle, steps)
                assert not a.flags.writeable


def test_a_longer_image_designs_only_its_new_columns(monkeypatch):
    """The column filters of a direction at a new image size: the columns already designed are
    reused, and a table is a quarter longer than asked, so that an image that grows a little
    designs none (before: Thiran's design, one 3 x 3 eigenvalue problem per column, at every size)."""
    designed = []
    design = oblique.allpass_delay

    def counted(d):
        designed.append(len(d))
        return design(d)

    monkeypatch.setattr(oblique, "allpass_delay", counted)
    oblique.column_delays.cache_clear()
    gamma = lines.direction(0.3)[2]
    oblique.column_delays(1200, gamma, "<f4")
    first = sum(designed)
    assert 1200 * 0.9 < first <= 1200 * 1.25 + 64
    for steps in (1300, 900, 1250, 1):            # a little longer, or shorter: nothing designed
        oblique.column_delays(steps, gamma, "<f4")
    assert sum(designed) == first
    oblique.column_delays(3000, gamma, "<f4")     # far longer: the columns beyond the table only
    assert 0 < sum(designed) - first <= 3000 * 1.25 + 64 - 1200
    oblique.column_delays.cache_clear()
