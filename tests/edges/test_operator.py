"""canny's one-signed differentiator (gfgpu.edges.operator): recursions against direct summation of
the closed form's samples, a step response with one extremum, the criteria against quadrature."""
import numpy as np
import pytest
from scipy import integrate, ndimage

from gfgpu import greens
from gfgpu._core.job import Job
from gfgpu.edges import criteria as ec
from gfgpu.edges import edge_gradient
from gfgpu.edges import operator as op


def _sampled(u, a=1.1, eta=3.5, single_scale=False, radius=None):
    """Taps of D and P by direct sampling of the closed forms (float64), normalised as the
    recursions are: -Σ m D[m] = 1, Σ P = 1."""
    radius = radius or int(40 * (u if single_scale else eta * u)) + 8   # tail below e^-40
    m = np.arange(-radius, radius + 1, dtype=np.float64)
    d = op.differentiator(m, u, a, eta, single_scale)
    d /= -np.sum(m * d)
    p = op.step_response(m, u, a, eta, single_scale)
    return m, d, p / p.sum()


@pytest.mark.parametrize("u,single", [(0.3, False), (1.0, False), (2.0, False), (1.0, True)])
def test_gradient_matches_direct_summation(backend, rng, u, single):
    img = rng.random((40, 56))
    m, d, p = _sampled(u, single_scale=single)
    # reference: the sampled taps by direct convolution on the same reflect extension
    pad = len(m) // 2
    ext = np.pad(img, pad, mode="symmetric")
    ref_x = ndimage.convolve1d(ndimage.convolve1d(ext, p, axis=0), d, axis=1)[pad:-pad, pad:-pad]
    ref_y = ndimage.convolve1d(ndimage.convolve1d(ext, p, axis=1), d, axis=0)[pad:-pad, pad:-pad]
    dtype = np.float64 if backend.supports_float64 else np.float32
    gy, gx = op.gradient(Job(backend.asarray(img.astype(dtype)), None, backend), u, "reflect", 0.0,
                         single_scale=single)
    hy, hx = edge_gradient(img.astype(dtype), u, single_scale=single, backend=backend)   # host in, host out
    tol = 1e-12 if dtype == np.float64 else 2e-6
    np.testing.assert_array_equal(hy, backend.to_host(gy))
    np.testing.assert_array_equal(hx, backend.to_host(gx))
    for got, ref in ((backend.to_host(gy), ref_y), (backend.to_host(gx), ref_x)):
        err = np.linalg.norm(got - ref) / np.linalg.norm(ref)
        assert err < tol, err
        assert np.abs(got - ref).max() < 10 * tol * np.abs(ref).max()


@pytest.mark.parametrize("u", [0.05, 0.5, 1.0, 4.0])
@pytest.mark.parametrize("a,eta,single", [(1.1, 3.5, False), (0.2, 1.5, False), (5.0, 8.0, False), (1.1, 3.5, True)])
def test_step_response_has_one_extremum(u, a, eta, single):
    """Every tap of D has the sign of -m and every tap of P is > 0 and decreases with |m|: the
    response to a step rises to one maximum at the step and falls (no side lobes)."""
    m, d, p = _sampled(u, a, eta, single)
    assert np.all(d[m > 0] <= 0) and np.all(d[m < 0] >= 0) and np.all(d[m > 0] < 0)
    half = p[m >= 0]
    assert np.all(half > 0) and np.all(np.diff(half) < 0)
    # the chapter's D does oscillate: its sampled step response changes sign
    if not single and (a, eta) == (1.1, 3.5) and u >= 0.5:
        chapter = greens.edge_projection(m, u)
        assert chapter.min() < -1e-3 * chapter.max()


def test_passes_hold_the_sampled_taps():
    """The sections' impulse responses are the point samples of the closed form."""
    u = 1.3
    m, d, p = _sampled(u)
    pos = m[m >= 1].astype(int)
    causal = [lp for lp in op.derivative_passes(u) if not lp.reverse]
    taps = sum(s.taps(pos) for lp in causal for s in lp.sections)
    np.testing.assert_allclose(taps, d[m >= 1], rtol=1e-12, atol=1e-16)
    causal = [lp for lp in op.projection_passes(u) if not lp.reverse]
    taps = sum(s.taps(pos) for lp in causal for s in lp.sections)
    np.testing.assert_allclose(taps, p[m >= 1], rtol=1e-12, atol=1e-16)
    assert sum(lp.tap for lp in causal) == pytest.approx(p[m == 0][0], rel=1e-12)


def test_criteria_closed_form_matches_quadrature():
    f = lambda x: float(op.differentiator(x, 1.0))
    c = ec.one_signed_criteria(1.1, 3.5)
    e0 = 2 * integrate.quad(lambda x: f(x) ** 2, 0, np.inf, limit=400)[0]
    area = integrate.quad(f, -np.inf, 0, limit=400)[0]
    assert abs(area) / np.sqrt(e0) == pytest.approx(c.sigma, rel=1e-7)
    m2 = 2 * integrate.quad(lambda x: x * x * f(x) ** 2, 0, np.inf, limit=400)[0]
    assert np.sqrt(m2 / e0) == pytest.approx(c.w_rms, rel=1e-7)
    assert c.index == pytest.approx(3.151, abs=1e-3)
    # better detection and localisation than the chapter's D; fewer noise maxima apart
    chapter = ec.edge_operator_criteria(1.1, 3.5)
    assert c.sigma * c.lam > chapter.sigma * chapter.lam and c.src < chapter.src


@pytest.mark.parametrize("kwargs,exc,match", [
    (dict(u=0.0), ValueError, "u must"),
    (dict(u="1"), TypeError, "u must be a real number"),
    (dict(u=1.0, a=-1.0), ValueError, "a must be > 0"),
    (dict(u=1.0, eta=float("nan")), ValueError, "eta must be finite"),
    (dict(u=1.0, projection_scale=0), ValueError, "projection_scale must be > 0"),
])
def test_bad_parameters_name_the_argument(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        op.gradient_programs(**kwargs)
    with pytest.raises(exc, match=match):
        edge_gradient(np.zeros((8, 8)), **kwargs, backend="numpy")


def test_edge_gradient_refuses_other_shapes():
    with pytest.raises(ValueError, match="2-D"):
        edge_gradient(np.zeros((3, 4, 5)), 1.0, backend="numpy")
