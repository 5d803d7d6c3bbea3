"""Canny's performance criteria for infinite-extent step-edge filters, in closed form.

For an odd detector ``f`` (``f(x) = -F(x)`` for ``x > 0``, ``F(-x)`` for ``x < 0``) whose
half-kernel is a sum of (complex) exponentials, e.g. damped sines
``F(x) = Σ_j c_j e^{-p_j x} sin(q_j x)``, every integral below is a finite sum over pairs of
exponentials:

* detection ``Σ = |∫_{-∞}^0 f| / (∫f²)^{1/2}``;
* localisation ``Λ = |f'(0)| / (∫f'²)^{1/2}``;
* mean distance between noise-response maxima ``x_max = 2π (∫f'² / ∫f''²)^{1/2}``;
* RMS width ``W_rms = (∫x² f² / ∫f²)^{1/2}`` and single-response ratio ``SRC = x_max / W_rms``;
* the index ``(ΣΛ)·SRC``, which is 3.547 for the chapter's D(x) at a = 1.1, η = 3.5 (3.151
  for the one-signed D that :func:`gfgpu.canny` uses, :func:`one_signed_criteria`)
  (this RMS-width convention is the one that reproduces the chapter's figure; other widths
  tried do not: ``docs/derivations.md``, "The differentiator D and the projection P").

All measures are invariant to amplitude and to the scale ``u``.

References
----------
.. [1] J. Canny, "A computational approach to edge detection", IEEE PAMI 8(6), 1986.
.. [2] Torreão et al. 2007, §2 (the 3.547 figure and the (a, η) optimum).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..greens import EDGE_A, EDGE_ETA, edge_weights
from .operator import scales

__all__ = ["Criteria", "exponential_criteria", "damped_sine_criteria", "edge_operator_criteria",
           "one_signed_criteria", "deriche_criteria",
           "gaussian_derivative_criteria", "index_grid"]


@dataclass(frozen=True)
class Criteria:
    sigma: float       # Σ, detection
    lam: float         # Λ, localisation
    x_max: float       # mean distance between noise maxima
    w_rms: float       # RMS width of f²

    @property
    def src(self):
        return self.x_max / self.w_rms

    @property
    def index(self):
        """(ΣΛ)·SRC."""
        return self.sigma * self.lam * self.src


def _pair_sum(b, r, n):
    """∫_0^∞ x^n (Σ b_k e^{-r_k x})² dx = Σ_{ij} b_i b_j n! / (r_i + r_j)^{n+1}."""
    tot = b[:, None] * b[None, :] * math.factorial(n) / (r[:, None] + r[None, :]) ** (n + 1)
    return float(tot.sum().real)


def exponential_criteria(amp, rate):
    """Canny's criteria for ``F(x) = Re Σ_k amp_k e^{-rate_k x}`` (x > 0), closed form.

    Parameters
    ----------
    amp, rate : array_like of complex
        Amplitudes and rates (real parts > 0) of the exponentials; a real ``F`` needs the
        conjugate pairs of complex terms, or real terms.
    """
    amp = np.asarray(amp, dtype=np.complex128)
    rate = np.asarray(rate, dtype=np.complex128)
    if np.any(rate.real <= 0):
        raise ValueError(f"decay rates must have real parts > 0, got {rate}")
    area = float(np.sum(amp / rate).real)                  # ∫_0^∞ F
    slope0 = float(np.sum(-amp * rate).real)               # F'(0)
    e0 = 2 * _pair_sum(amp, rate, 0)                        # ∫ f² over the whole line
    e1 = 2 * _pair_sum(amp * (-rate), rate, 0)              # ∫ f'²
    e2 = 2 * _pair_sum(amp * rate**2, rate, 0)              # ∫ f''²
    m2 = 2 * _pair_sum(amp, rate, 2)                        # ∫ x² f²
    return Criteria(abs(area) / math.sqrt(e0), abs(slope0) / math.sqrt(e1),
                    2 * math.pi * math.sqrt(e1 / e2), math.sqrt(m2 / e0))


def damped_sine_criteria(c, p, q):
    """Canny's criteria for ``F(x) = Σ c_j e^{-p_j x} sin(q_j x)`` (x > 0), closed form.

    Parameters
    ----------
    c, p, q : array_like
        Amplitudes, decay rates (> 0) and angular frequencies of the damped sines.
    """
    c, p, q = (np.asarray(v, dtype=np.float64) for v in (c, p, q))
    if np.any(p <= 0):
        raise ValueError(f"decay rates p must be > 0, got {p}")
    # sin(qx) e^{-px} = (e^{-(p-iq)x} - e^{-(p+iq)x}) / 2i
    return exponential_criteria(np.concatenate([c / 2j, -c / 2j]), np.concatenate([p - 1j * q, p + 1j * q]))


def edge_operator_criteria(a=EDGE_A, eta=EDGE_ETA):
    """Criteria of the chapter's D(x) (eq. 25-26, ``K = a η²``), from its closed form."""
    u, a, eta, big_a, big_k = edge_weights(1.0, a, eta)
    return damped_sine_criteria([big_a, big_a * big_k], [1 / (eta * u), 1 / u], [1 / (eta * u), 1 / u])


def one_signed_criteria(a=EDGE_A, eta=EDGE_ETA):
    """Criteria of canny's one-signed D (:mod:`gfgpu.edges.operator`): each damped sine
    ``e^{-t} sin t`` of the chapter's D replaced by ``e^{-t} - e^{-2t}``."""
    amp, rate = [], []
    for v, w in scales(1.0, a, eta):
        amp += [w, -w]
        rate += [1 / v, 2 / v]
    return exponential_criteria(amp, rate)


def deriche_criteria(m):
    """Deriche's filter ``-e^{-α|x|} sin(ωx)`` with ``m = ω/α`` (α = 1)."""
    return damped_sine_criteria([1.0], [1.0], [float(m)])


def gaussian_derivative_criteria():
    """First derivative of a Gaussian (Canny's approximation), by quadrature."""
    from scipy import integrate

    def integral(g):
        return 2 * integrate.quad(g, 0, np.inf, epsabs=1e-14, epsrel=1e-12, limit=200)[0]

    f = lambda x: x * np.exp(-x * x / 2)
    d1 = lambda x: (1 - x * x) * np.exp(-x * x / 2)
    d2 = lambda x: (x**3 - 3 * x) * np.exp(-x * x / 2)
    e0, e1, e2 = integral(lambda x: f(x) ** 2), integral(lambda x: d1(x) ** 2), integral(lambda x: d2(x) ** 2)
    area = integral(f) / 2
    m2 = integral(lambda x: x * x * f(x) ** 2)
    return Criteria(area / math.sqrt(e0), 1.0 / math.sqrt(e1), 2 * math.pi * math.sqrt(e1 / e2), math.sqrt(m2 / e0))


def index_grid(a_values, eta_values):
    """(ΣΛ)·SRC of D(x) over a grid: array of shape (len(a_values), len(eta_values))."""
    return np.array([[edge_operator_criteria(a, e).index for e in eta_values] for a in a_values])
