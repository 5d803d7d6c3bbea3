"""The cubic B-spline (gfgpu._core.bspline): tap weights against the closed-form basis, their
integrals against quadrature, the prefilter, the edge continuation of the coefficients against
the prefiltered extended line, and device code that takes the pole from the Python definition."""
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, ndimage

from gfgpu._core import bspline
from gfgpu._core.boundary import MODES, extend_index
from gfgpu._core.bspline import (
    NEAREST_EDGE,
    PREFILTER_GAIN,
    PREFIX_ENDS,
    SPLINE_POLE,
    basis,
    coef_taps,
    pole_series,
    prefix_weights,
    tap_weights,
    weight_integrals,
)

ROOT = Path(__file__).resolve().parents[2]
NP_PAD = {"constant": "constant", "nearest": "edge", "reflect": "symmetric", "mirror": "reflect", "wrap": "wrap"}
FRACTIONS = np.concatenate([[0.0, 0.25, 0.5, 0.75, 1.0, 1e-12, 1 - 1e-12], np.random.default_rng(3).random(200)])


def beta3(t):
    """β3 as truncated powers, ``(1/6) Σ_k (-1)^k C(4, k) (t + 2 - k)_+^3`` (no piecewise branch)."""
    t = np.asarray(t, np.float64)
    return sum((-1) ** k * math.comb(4, k) * np.maximum(t + 2 - k, 0.0) ** 3 for k in range(5)) / 6.0


# --------------------------------------------------------------------------------------
# the weights and their integrals
# --------------------------------------------------------------------------------------
def test_tap_weights_are_the_basis_at_the_four_offsets():
    w = tap_weights(FRACTIONS)
    assert w.shape == (4, len(FRACTIONS))
    for p in range(4):                                   # c[j + p - 1] at x = j + f
        np.testing.assert_allclose(w[p], beta3(FRACTIONS - (p - 1)), rtol=0, atol=1e-13)
    np.testing.assert_allclose(tap_weights(0.0), [1 / 6, 4 / 6, 1 / 6, 0.0], rtol=0, atol=1e-16)


def test_basis_is_the_closed_form():
    t = np.linspace(-2.5, 2.5, 1001)
    np.testing.assert_allclose([basis(v) for v in t], beta3(t), rtol=0, atol=1e-13)
    assert basis(2.0) == basis(-2.0) == basis(3.7) == 0.0 and basis(0.0) == 2.0 / 3.0


def test_tap_weights_sum_to_one_and_reproduce_linear_functions():
    w = tap_weights(FRACTIONS)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, rtol=0, atol=1e-15)
    offsets = np.arange(4)[:, None] - 1.0
    np.testing.assert_allclose((w * offsets).sum(axis=0), FRACTIONS, rtol=0, atol=1e-14)
    # any line a + b x: the spline of its samples is the line itself
    j, a, b = 17, -2.5, 0.75
    np.testing.assert_allclose((w * (a + b * (j + offsets))).sum(axis=0), a + b * (j + FRACTIONS), rtol=1e-14)
    assert (w >= 0).all()


def test_weight_integrals_are_the_quadrature_of_the_weights():
    got = weight_integrals(FRACTIONS[:40])
    for k, f in enumerate(FRACTIONS[:40]):
        for p in range(4):
            ref, _ = integrate.quad(lambda t, p=p: float(tap_weights(t)[p]), 0.0, f, epsabs=1e-15, epsrel=1e-13)
            assert abs(got[p, k] - ref) < 1e-14, (f, p)
    np.testing.assert_allclose(weight_integrals(1.0), [1 / 24, 11 / 24, 11 / 24, 1 / 24], rtol=0, atol=1e-16)
    np.testing.assert_allclose(weight_integrals(0.0), 0.0, atol=0)


def test_prefix_weights_integrate_the_spline_of_a_line(rng):
    """``Σ_{i<j} c[i] + Σ_p prefix_weights(f)[p] c[j-1+p]`` is ∫ s up to ``j + f`` (one constant):
    differences of it are the spline's integral by quadrature."""
    c = rng.standard_normal(40)

    def spline(x):
        k = np.arange(len(c))
        return float((c * beta3(x - k)).sum())

    def prefix(x):
        j = int(np.floor(x))
        return c[:j].sum() + (prefix_weights(x - j) * c[j - 1:j + 3]).sum()

    for a, b in ((5.25, 6.0), (5.25, 31.7), (10.0, 10.5), (7.9, 8.1), (3.0, 36.0)):
        knots = [k for k in range(math.floor(a) + 1, math.ceil(b))]       # the spline's joints inside
        ref, _ = integrate.quad(spline, a, b, limit=200, epsabs=1e-13, points=knots or None)
        assert abs(prefix(b) - prefix(a) - ref) < 1e-11, (a, b)
    np.testing.assert_allclose(prefix_weights(0.0), PREFIX_ENDS, rtol=0, atol=0)
    np.testing.assert_allclose(prefix_weights(1.0) - PREFIX_ENDS, weight_integrals(1.0), rtol=0, atol=1e-16)


# --------------------------------------------------------------------------------------
# the prefilter
# --------------------------------------------------------------------------------------
def test_the_pole_and_gain_invert_the_sampled_spline():
    z = SPLINE_POLE
    assert abs(z - (math.sqrt(3.0) - 2.0)) == 0.0 and abs(z) < 1
    assert abs(z * z + 4 * z + 1) < 1e-15                # a root of the sampled spline (1, 4, 1) / 6
    assert abs(PREFILTER_GAIN * (1 + z) / (1 - z) - 1.0) < 1e-15          # unit DC gain
    k = np.arange(-60, 61)
    p = PREFILTER_GAIN * z ** np.abs(k)
    delta = np.convolve(p, [1 / 6, 4 / 6, 1 / 6], mode="same")
    np.testing.assert_allclose(delta, (k == 0).astype(float), rtol=0, atol=1e-15)


def test_pole_series_is_the_geometric_sum():
    for m in (0, 1, 2, 5, 33, 200):
        assert abs(pole_series(m) - sum(SPLINE_POLE**k for k in range(1, m + 1))) < 1e-16
    np.testing.assert_array_equal(pole_series(np.array([[0, 1], [2, 3]])).shape, (2, 2))


def test_nearest_edge_satisfies_the_interpolation_condition(rng):
    a, b = NEAREST_EDGE
    assert abs(a + b - 1.0) < 1e-16
    for c0, c1 in rng.standard_normal((10, 2)):
        e = a * c0 + b * c1
        c_minus = e + SPLINE_POLE * (c0 - e)             # the coefficient before the line, continued
        assert abs((c_minus + 4 * c0 + c1) / 6 - e) < 1e-15


# --------------------------------------------------------------------------------------
# the coefficients beyond a line's ends
# --------------------------------------------------------------------------------------
def extended_coefficients(line, mode, cval, margin):
    """The spline coefficients of the line extended by ``mode`` (numpy.pad by ``margin``, then the
    prefilter on the whole padded line: its own ends are z^margin away, below float64 rounding)."""
    if mode == "constant":
        padded = np.pad(line, margin, mode="constant", constant_values=cval)
    else:
        padded = np.pad(line, margin, mode=NP_PAD[mode])
    return ndimage.spline_filter1d(padded, order=3, mode="mirror")


@pytest.mark.parametrize("n", [1, 2, 3, 9])
@pytest.mark.parametrize("mode", MODES)
def test_coef_taps_continue_the_coefficients_of_the_extended_line(mode, n, rng):
    line, cval, margin, reach = rng.standard_normal(n), 0.7, 120, 25
    true = extended_coefficients(line, mode, cval, margin)
    c = true[margin:margin + n]                          # the line's own coefficients
    i = np.arange(-reach, n + reach)
    j0, w0, j1, w1 = coef_taps(i, n, mode)
    assert j0.dtype == j1.dtype == np.int64 and ((0 <= j0) & (j0 < n) & (0 <= j1) & (j1 < n)).all()
    inside = (i >= 0) & (i < n)
    assert (j0[inside] == i[inside]).all() and (w0[inside] == 1).all() and (w1[inside] == 0).all()
    base = cval if mode == "constant" else 0.0
    got = w0 * c[j0] + w1 * c[j1] + (1.0 - w0 - w1) * base
    np.testing.assert_allclose(got, true[margin + i], rtol=0, atol=1e-12 * max(1.0, np.abs(true).max()))
    if mode in ("wrap", "reflect", "mirror"):           # periodic: the coefficients extend as the samples
        assert (j0 == extend_index(i, n, mode)).all() and (w0 == 1).all() and (w1 == 0).all()


@pytest.mark.parametrize("mode", MODES)
def test_the_spec_sums_the_continued_coefficients_in_closed_form(mode, rng):
    """gfgpu.motion.spec's closed-form sums of the extended coefficients (what the box kernels
    start from) are the sums of coef_taps' coefficients."""
    from gfgpu.motion import spec as specs
    x = rng.standard_normal((2, 7))
    n, cval = x.shape[-1], 0.4
    base = cval if mode == "constant" else 0.0
    i = np.arange(-60, n + 60)
    j0, w0, j1, w1 = coef_taps(i, n, mode)
    coef = base + w0 * (x[..., j0] - base) + w1 * (x[..., j1] - base)          # coefficient i - 60 + ...
    for j in (-57, -8, -1, 0, 3, n, n + 5, n + 44):
        k = j - i[0]
        brute = coef[..., 60:k].sum(-1) if j >= 0 else -coef[..., k:60].sum(-1)
        got = specs._coef_prefix(x, np.array([j]), mode, cval)
        np.testing.assert_allclose(got, brute[..., None], rtol=0, atol=1e-12, err_msg=f"j = {j}")


def test_the_host_copies_are_the_one_definition():
    from gfgpu import greens
    from gfgpu.motion import spec as specs
    from gfgpu.motion import spline
    assert specs.SPLINE_POLE is SPLINE_POLE and specs.NEAREST_EDGE is NEAREST_EDGE
    assert specs.coef_taps is coef_taps
    # the prefilter passes and the cubic shift are built on the pole and gain defined here
    causal, anticausal = spline.prefilter_passes()
    assert causal.tap == PREFILTER_GAIN and causal.sections[0].lam == SPLINE_POLE
    assert anticausal.sections[0].kap == PREFILTER_GAIN * SPLINE_POLE
    assert greens.cubic_shift_passes(0.25)[0].sections[0].lam == SPLINE_POLE
    # no other copy of the pole's value or formula in the package (device code included)
    copies = []
    for path in sorted((ROOT / "gfgpu").rglob("*")):
        if path.suffix not in (".py", ".cl") or path.name == "bspline.py" and path.parent.name == "_core":
            continue
        text = path.read_text(encoding="utf-8")
        if re.search(r"0\.267949|(math|np|wp)\.sqrt\(3|_bspline3|def _bspline_(weights|integrals)", text):
            copies.append(str(path.relative_to(ROOT)))
    assert not copies, f"copies of the cubic B-spline outside gfgpu/_core/bspline.py: {copies}"


def test_opencl_motion_kernels_take_the_pole_from_bspline(require_backend, monkeypatch, rng):
    """Built with another pole, the box kernel continues the coefficients beyond the line with it
    (the pole reaches motion.cl only as the launcher's SPLINE_POLE define)."""
    be = require_backend("opencl")
    from gfgpu.motion import kernels
    from gfgpu.motion import spec as specs
    src = rng.standard_normal((1, 7, 33)).astype(np.float32)
    window = (-20.5, 1.0, 3.25, 1.0)             # windows reaching far beyond the left end

    def run():
        dst = be.empty(src.shape, np.float32)
        kernels.box_lines(be, be.asarray(src), dst, 2, *window, "constant", 0.7)
        ref = specs.box_lines_reference(src, 2, *window, "constant", 0.7)
        assert np.abs(be.to_host(dst) - ref).max() <= 2e-5 * max(1.0, np.abs(ref).max())
        return ref

    before = run()
    monkeypatch.setattr(bspline, "SPLINE_POLE", -0.4)
    after = run()
    assert np.abs(after - before).max() > 1e-3          # the pole matters there
