"""The edge detector's differentiator: the chapter's two-scale D(x) with one-signed lobes.

The chapter's D (eq. 25-26, :func:`gfgpu.greens.edge_derivative`) is built from damped sines
``h_v(x) = e^{-x/v} sin(x/v)``.  Its response to a step is its integral P, which oscillates:
P has an extremum at every zero of D, i.e. at ``x = k π η u`` (about 11 px apart at u = 1,
η = 3.5), of relative height 1.0 %, 0.04 %, ... .  Non-maximum suppression keeps every
extremum, so a step gives parallel "ghost" edges wherever the lobes clear the low threshold:
at any contrast above ~1 with the default thresholds, and at every contrast with low ones.
No threshold rule can remove them (their height is proportional to the edge that causes them).

Canny's step detector must have a step response with one extremum, i.e. be one-signed on each
half line.  This operator keeps the chapter's structure (two scales ηu and u, the fine one
weighted by a, ``K = a η²``, unit ramp response, P = ∫D along edges) and replaces each damped
sine by the one-signed hump with the same value, slope and envelope at the origin:

.. math::
    ψ_v(x) = e^{-x/v} - e^{-2x/v} = e^{-x/v}(1 - e^{-x/v}), \\qquad
    F(x) = A[ψ_{ηu}(x) + K ψ_u(x)], \\qquad D(x) = \\frac{1}{2u}[F(-x) - F(x)]

(``sin t`` → ``1 - e^{-t}``: both are ``t + O(t²)``).  Each ψ is two real-pole sections, so
the cost (two recursions per pass) and exactness are those of the chapter's D.  Its step
response ``P(x) ∝ Σ w v (e^{-|x|/v} - ½ e^{-2|x|/v})`` is positive and decreases with |x|:
one extremum, at the edge.  Canny's index (ΣΛ)·SRC is 3.151 at a = 1.1, η = 3.5
(:func:`gfgpu.edges.criteria.edge_detector_criteria`; chapter's D 3.547, Deriche 3.336,
Gaussian derivative 2.989): the chapter's D scores higher because the index does not count
the deterministic side lobes, only noise maxima.
"""

from __future__ import annotations

import numpy as np

from .._core.passes import LinePass, Section
from .._core.program import Program
from .._core.validation import positive, scale
from ..filters import job_gradient
from ..greens import EDGE_A, EDGE_ETA

__all__ = ["scales", "differentiator", "step_response", "derivative_passes", "projection_passes",
           "gradient_programs", "gradient"]


def scales(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """``((v, w), ...)``: the scales v (pixels) of the ψ terms and their weights w.

    Two-scale: ``((η u, 1), (u, a η²))``; ``single_scale``: ``((u, 1),)``.  Raises ValueError
    (naming the argument) for ``u``, ``a`` or ``eta`` out of range.
    """
    u = scale("u", u)
    if single_scale:
        return ((u, 1.0),)
    a = positive("a", a)
    eta = positive("eta", eta)
    scale("eta * u", eta * u)
    return ((eta * u, 1.0), (u, a * eta * eta))


def _psi(t, v):
    return np.exp(-t / v) - np.exp(-2.0 * t / v)


def differentiator(x, u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Continuous D(x) (float64 closed form), normalised to unit ramp response ``-∫ x D = 1``."""
    sc = scales(u, a, eta, single_scale)
    x = np.asarray(x, dtype=np.float64)
    t = np.abs(x)
    # ∫_0^∞ x ψ_v = v² - v²/4 = 3v²/4
    norm = 2.0 * sum(w * 0.75 * v * v for v, w in sc)
    return -np.sign(x) * sum(w * _psi(t, v) for v, w in sc) / norm


def step_response(x, u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Continuous P = ∫_{-∞}^x D (float64): the response to a unit step (and the smoothing
    along edges); even, positive, decreasing in |x|, ``∫P = 1``."""
    sc = scales(u, a, eta, single_scale)
    t = np.abs(np.asarray(x, dtype=np.float64))
    norm = 2.0 * sum(w * 0.75 * v * v for v, w in sc)
    # ∫_t^∞ ψ_v = v e^{-t/v} - (v/2) e^{-2t/v}
    return sum(w * (v * np.exp(-t / v) - 0.5 * v * np.exp(-2.0 * t / v)) for v, w in sc) / norm


def _poles(v):
    return np.exp(-1.0 / v), np.exp(-2.0 / v)


def derivative_passes(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Passes of the discrete D (summed): causal, then anticausal, one per scale.

    Taps ``D[m] = -sign(m) c Σ w ψ_v(|m|)`` (point samples), ``c`` such that ``-Σ m D[m] = 1``
    (unit ramp response; ``Σ_{m>=1} m r^m = r/(1-r)²``).  Each ψ is two real-pole sections.
    """
    sc = scales(u, a, eta, single_scale)
    norm = 0.0
    for v, w in sc:
        r1, r2 = _poles(v)
        norm += 2.0 * w * (r1 / (1 - r1) ** 2 - r2 / (1 - r2) ** 2)
    passes = []
    # one pass per scale: the device recursions hold at most two sections (summed in the step)
    for sign, reverse in ((-1.0, False), (1.0, True)):
        for v, w in sc:
            r1, r2 = _poles(v)
            # Section taps are Re(kap lam^(m-1)): kap = c r gives c r^m
            passes.append(LinePass((Section(lam=complex(r1), kap=complex(sign * w / norm * r1)),
                                    Section(lam=complex(r2), kap=complex(-sign * w / norm * r2))), 0.0, reverse))
    return tuple(passes)


def projection_passes(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Passes of the discrete P, the smoothing along edges (summed; the first holds the m = 0
    tap), causal then anticausal, one per scale.

    Taps ``P[m] ∝ Σ w v (r1^|m| - ½ r2^|m|)``, the point-sampled P = ∫D, normalised to unit
    sum (``Σ_m r^|m| = (1+r)/(1-r)``); every tap is positive.
    """
    sc = scales(u, a, eta, single_scale)
    total = 0.0
    for v, w in sc:
        r1, r2 = _poles(v)
        total += w * v * ((1 + r1) / (1 - r1) - 0.5 * (1 + r2) / (1 - r2))
    tap = sum(0.5 * w * v for v, w in sc) / total
    passes = []
    for reverse in (False, True):
        for k, (v, w) in enumerate(sc):
            r1, r2 = _poles(v)
            secs = (Section(lam=complex(r1), kap=complex(w * v / total * r1)),
                    Section(lam=complex(r2), kap=complex(-0.5 * w * v / total * r2)))
            passes.append(LinePass(secs, tap if (k == 0 and not reverse) else 0.0, reverse))
    return tuple(passes)


def gradient_programs(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False, projection_scale=1.0):
    """The two :class:`~gfgpu._core.program.Program` s of a 2-D image's gradient ``(d/dy, d/dx)``:
    D across the axis, P (at ``projection_scale`` times D's u) along the other."""
    ratio = positive("projection_scale", projection_scale)
    d = list(derivative_passes(u, a, eta, single_scale))
    p = list(projection_passes(scale("u", u) * ratio, a, eta, single_scale))
    return Program([(p, 1, None), (d, 0, None)]), Program([(p, 0, None), (d, 1, None)])


def gradient(job, u, mode, cval, a=EDGE_A, eta=EDGE_ETA, single_scale=False, projection_scale=1.0):
    """``(gy, gx)`` of the 2-D image of ``job`` (a :class:`~gfgpu._core.job.Job`), on its backend:
    the programs of :func:`gradient_programs`, run by :func:`gfgpu.filters.job_gradient` (on an
    OpenCL CPU device as two kernels that share the row passes' states)."""
    ratio = positive("projection_scale", projection_scale)
    d = derivative_passes(u, a, eta, single_scale)
    p = projection_passes(scale("u", u) * ratio, a, eta, single_scale)
    return job_gradient(job, d, p, [0, 1], mode, cval)
