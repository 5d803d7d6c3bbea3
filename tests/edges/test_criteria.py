"""The edge operator's criteria (gfgpu.edges.criteria): the chapter's index 3.547 and its optimum
(a, η) = (1.1, 3.5), the reference filters (Deriche, Gaussian derivative), closed forms against
quadrature."""
import numpy as np
import pytest
from scipy import integrate

from gfgpu import greens
from gfgpu.edges import criteria as ec


def test_chapter_index_3547():
    assert ec.edge_operator_criteria(1.1, 3.5).index == pytest.approx(3.547, abs=1e-3)


def test_grid_optimum_is_a11_eta35():
    a = np.round(np.arange(0.1, 3.0001, 0.1), 10)
    eta = np.round(np.arange(1.1, 6.0001, 0.1), 10)
    grid = ec.index_grid(a, eta)
    i, j = np.unravel_index(np.argmax(grid), grid.shape)
    assert (a[i], eta[j]) == (1.1, 3.5)


def test_reference_filters():
    # closed form for Deriche's family: 4√2 π (1+m²)^½ / ((5+m²)(6+3m²+m⁴))^½, here m = 1
    closed = 4 * np.sqrt(2) * np.pi * np.sqrt(2) / np.sqrt(6 * 10)
    assert ec.deriche_criteria(1.0).index == pytest.approx(closed, rel=1e-12)
    best = max(ec.deriche_criteria(m).index for m in np.linspace(0.5, 0.8, 301))
    assert best == pytest.approx(3.336, abs=1e-3)
    assert ec.gaussian_derivative_criteria().index == pytest.approx(2.989, abs=1e-3)


def test_closed_form_integrals_match_quadrature():
    """The closed-form Σ, Λ of D(x) agree with quadrature of greens.edge_derivative."""
    f = lambda x: float(greens.edge_derivative(x, 1.0))
    e0 = 2 * integrate.quad(lambda x: f(x) ** 2, 0, np.inf, limit=400)[0]
    area = integrate.quad(f, -np.inf, 0, limit=400)[0]
    h = 1e-6
    slope = (f(h) - f(-h)) / (2 * h)
    c = ec.edge_operator_criteria(1.1, 3.5)
    assert abs(area) / np.sqrt(e0) == pytest.approx(c.sigma, rel=1e-7)
    e1 = 2 * integrate.quad(lambda x: ((f(x + h) - f(x - h)) / (2 * h)) ** 2, 0, np.inf, limit=400)[0]
    assert abs(slope) / np.sqrt(e1) == pytest.approx(c.lam, rel=1e-4)
