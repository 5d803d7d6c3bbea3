"""Closed forms: continuous moments by quadrature, discrete operators' moments, validation."""
import numpy as np
import pytest
from scipy import integrate

from gfgpu import greens

quad = lambda f, a, b: integrate.quad(f, a, b, limit=400, epsabs=1e-13, epsrel=1e-12)[0]


@pytest.mark.parametrize("u", [0.5, 1.0, 3.0])
def test_g_u_moments_and_equation(u):
    g = lambda t: float(greens.g_uniform(t, u))
    assert quad(g, 0, np.inf) == pytest.approx(1, abs=1e-9)
    assert quad(lambda t: t * g(t), 0, np.inf) == pytest.approx(u, abs=1e-9)      # mean u
    assert quad(lambda t: t * t * g(t), 0, np.inf) == pytest.approx(u * u, abs=1e-8)  # variance 0
    # (u^2/2) G'' + u G' + G = 0 for x > 0 (eq. 7 away from the source); H_u likewise (eq. 34)
    x = np.linspace(0.3, 5, 50) * u
    h = 1e-4
    for f in (lambda t: greens.g_uniform(t, u), lambda t: greens.h_homogeneous(t, u)):
        d1 = (f(x + h) - f(x - h)) / (2 * h)
        d2 = (f(x + h) - 2 * f(x) + f(x - h)) / h**2
        np.testing.assert_allclose(u * u / 2 * d2 + u * d1 + f(x), 0, atol=2e-5 / u)


def test_h_u_moments_and_relation():
    u = 1.3
    hfun = lambda t: float(greens.h_homogeneous(t, u))
    assert quad(hfun, 0, np.inf) == pytest.approx(1, abs=1e-9)
    assert quad(lambda t: t * hfun(t), 0, np.inf) == pytest.approx(0, abs=1e-9)
    assert quad(lambda t: t * t * hfun(t), 0, np.inf) == pytest.approx(-u * u, abs=1e-8)
    assert float(greens.h_homogeneous(0.0, u)) == pytest.approx(1 / u)   # mean of the jump


@pytest.mark.parametrize("u1", [0.2, 0.5, 1.5])
def test_affine_exact_is_a_zero_variance_affine_warp(u1):
    x_U, x = -10.0, 20.0
    s = x - x_U
    # integrate over t = log(s/s0), x0 = x_U + s e^{-t}, dx0 = s e^{-t} dt (removes the singularity)
    # where G |dx0/dt| = (2/(u1^2 beta)) e^{alpha t} sin(beta t) (checked against g_affine first)
    alpha, beta = 0.5 - 1 / u1, np.sqrt(1 + u1 - u1 * u1 / 4) / u1
    x0 = lambda t: x_U + s * np.exp(-t)
    g = lambda t: 2 / (u1 * u1 * beta) * np.exp(alpha * t) * np.sin(beta * t)
    ts = np.linspace(0.01, 10, 37)  # beyond, x0 - x_U loses digits to cancellation
    np.testing.assert_allclose(greens.g_affine(x, x0(ts), u1, x_U) * s * np.exp(-ts), g(ts),
                               rtol=1e-9, atol=1e-12)
    m0 = quad(g, 0, np.inf)
    m1 = quad(lambda t: (x - x0(t)) * g(t), 0, np.inf)
    m2 = quad(lambda t: (x - x0(t)) ** 2 * g(t), 0, np.inf)
    assert m0 == pytest.approx(1, abs=1e-6)
    assert m1 == pytest.approx(u1 * s / (1 + u1), rel=1e-6)
    assert m2 - m1**2 == pytest.approx(0, abs=1e-5 * s * s)


def test_affine_approx_shift_is_sigma2_over_xu():
    sigma, x_U = 10.0, -400.0
    g = lambda x0: float(greens.g_affine_approx(0.0, x0, sigma, x_U))
    m0 = quad(g, x_U, 0)
    d = quad(lambda x0: -x0 * g(x0), x_U, 0) / m0
    u0, u1 = sigma**2 / abs(x_U), sigma**2 / x_U**2
    assert d == pytest.approx(u0 * (1 - u1 / 2), rel=2e-3)


def test_edge_operator_closed_forms():
    u = 1.0
    # D = (1/2u)[G(-x) - G(x)] at a single scale (eq. 19) and unit continuous ramp response
    x = np.linspace(-6, 6, 121)
    np.testing.assert_allclose(greens.d_uniform(x, u),
                               (greens.g_uniform(-x, u) - greens.g_uniform(x, u)) / (2 * u), atol=1e-15)
    ramp = quad(lambda t: -t * float(greens.edge_derivative(t, u)), -np.inf, np.inf)
    assert ramp == pytest.approx(1, abs=1e-8)
    # P = ∫D: derivative of P is D, and ∫P = 1
    h = 1e-5
    xs = np.array([-3.0, -0.7, 0.4, 2.2])
    dp = (greens.edge_projection(xs + h, u) - greens.edge_projection(xs - h, u)) / (2 * h)
    np.testing.assert_allclose(dp, greens.edge_derivative(xs, u), atol=1e-8)
    assert quad(lambda t: float(greens.edge_projection(t, u)), -np.inf, np.inf) == pytest.approx(1, abs=1e-8)


@pytest.mark.parametrize("u", [0.05, 0.25, 1 / np.pi, 0.5, 1.0, 3.0, 10.0, 40.0])
def test_shift_taps_have_unit_gain_and_mean_u(u):
    lp = greens.shift_pass(u)
    sec = lp.sections[0]
    m = np.arange(1, int(80 * u) + 80)
    taps = np.concatenate([[lp.tap], sec.taps(m)])
    k = np.arange(len(taps))
    assert taps.sum() == pytest.approx(1, abs=1e-12)
    assert (k * taps).sum() == pytest.approx(u, abs=1e-10 * max(u, 1))
    assert sec.lam == pytest.approx(np.exp((-1 + 1j) / u), rel=1e-15)   # G_u's poles
    if u >= 0.25 and abs(u - 1 / np.pi) > 1e-3:   # at u = 1/(k pi) the poles are real: var is free
        var = (k * k * taps).sum() - u * u
        assert var == pytest.approx(1 / 12, abs=2e-3)


@pytest.mark.parametrize("call,match", [
    (lambda: greens.UniformGreen(0), "u must be > 0"),
    (lambda: greens.UniformGreen(-1.0), "u must be > 0"),
    (lambda: greens.HomogeneousGreen(float("nan")), "u must be finite"),
    (lambda: greens.AffineGreen(2.0, -5), r"u1 must lie in \(0, 2\)"),
    (lambda: greens.AffineGreen(0.0, -5), r"u1 must lie in \(0, 2\)"),
    (lambda: greens.AffineGreenApprox(0.0, -5), "sigma must be > 0"),
    (lambda: greens.g_affine_approx(1.0, 0.0, 3.0, 0.0), "x_U must be non-zero"),
    (lambda: greens.g_affine(1.0, -6.0, 0.5, -5.0), "x0 > x_U"),
    (lambda: greens.edge_derivative(0.0, 1.0, a=-1), "a must be > 0"),
    (lambda: greens.edge_projection(0.0, 1.0, eta=0), "eta must be > 0"),
    (lambda: greens.shift_pass(float("inf")), "shift must be finite"),
])
def test_bad_parameters_name_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()
