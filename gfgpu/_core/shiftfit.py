"""The moment-fitted discrete Green shift: its coefficients for many shifts at once.

Pure float64 mathematics below :mod:`gfgpu.greens` (which exposes it as
``greens.shift_coefficients`` and ``greens.shift_coefficients_many``), so that per-line plans
(the oblique shears of :mod:`gfgpu._core.oblique`, the rotation's shears) can build thousands
of shifts in one vectorised call.  Derivation: ``docs/derivations.md``, "The discrete shift: a
moment fit with G_u's poles".
"""

from __future__ import annotations

import numpy as np

__all__ = ["shift_coefficients_many", "SMALL_SHIFT", "FLAT"]

#: below this shift the fit is solved as a least-squares KKT system (see :func:`shift_coefficients_many`)
SMALL_SHIFT = 0.08
#: curvature along the free direction, relative to the fit's scale, below which the KKT route is taken
FLAT = 1e-6


def shift_coefficients_many(u):
    """``(lam, kap, tap)`` arrays of the discrete shift by each ``u > 0`` (any shape).

    The taps ``w[0] = tap``, ``w[m] = Re(kap lam^(m-1))`` keep G_u's poles
    ``lam = exp((-1+i)/u)`` and are, among those with ``Σ w = 1`` and ``Σ m w = u`` exactly,
    the closest (ℓ2 over taps) to the cell-integrated kernel ``∫_{m-1/2}^{m+1/2} G_u``, with a
    strong quadratic penalty (weight ``rho``) pulling the variance to 1/12 (``u(1-u)`` below
    u ≈ 0.092).  Unknowns ``x = (tap, Re kap, Im kap)``.

    The two constraints leave a line ``x0 + τ d`` (``d`` normal to both constraint rows) and
    the penalised quadratic is minimised over ``τ`` in closed form.  Where that is (nearly)
    degenerate, ``u < SMALL_SHIFT`` (``|lam| < e^-12``: ``Im kap`` barely reaches the taps) or
    a curvature along ``d`` below ``FLAT`` of the fit's scale (real poles, ``u`` near
    ``1/(k π)``), the 5x5 KKT system is solved instead, by SVD with the cut-off of
    ``numpy.linalg.lstsq`` (singular values below ``5 eps`` of the largest dropped: ``Im kap``
    at its minimum-norm value) and two steps of iterative refinement.  The result agrees with a
    per-``u`` ``lstsq`` of the KKT system to about 2e-13 in the taps (5e-11 within 1e-6 of
    ``1/(k π)``): the rounding of that ill-conditioned system itself.

    Returns complex128, complex128 and float64 arrays of ``u``'s shape.
    """
    u = np.asarray(u, np.float64)
    shape = u.shape
    u = u.reshape(-1)
    lam = np.exp(complex(-1.0, 1.0) / u)
    parts = _fit_terms(u, lam)
    x, flat = _solve_reduced(u, *parts)
    # the KKT route where the fit is (nearly) degenerate along its free direction
    hard = (u < SMALL_SHIFT) | flat
    if hard.any():
        x[hard] = _solve_kkt(u[hard], *(p[hard] for p in parts))
    return lam.reshape(shape), (x[:, 1] + 1j * x[:, 2]).reshape(shape), x[:, 0].reshape(shape)


def _fit_terms(u, lam):
    """Constraint rows, normalised variance row and target, tap-space Gram matrix, prior, rho."""
    m = len(u)
    h = 0.5 / u
    tap_cell = 1.0 - np.exp(-h) * (np.sin(h) + np.cos(h))
    k_cell = (1 - 1j) * np.sqrt(lam) * (1 - lam)
    # Σ_{m>=1} m^k lam^(m-1) for k = 0, 1, 2
    s0, s1, s2 = 1 / (1 - lam), 1 / (1 - lam) ** 2, (1 + lam) / (1 - lam) ** 3
    zero, one = np.zeros(m), np.ones(m)
    rows = np.stack([np.stack([one, s0.real, -s0.imag], -1), np.stack([zero, s1.real, -s1.imag], -1)], 1)
    var = np.where((u < 0.5) & (u * (1 - u) < 1 / 12), u * (1 - u), 1 / 12)
    second = np.stack([zero, s2.real, -s2.imag], -1)
    norm = np.linalg.norm(second, axis=-1)
    second = second / norm[:, None]
    second_target = (var + u * u) / norm
    # tap-space Gram matrix of (tap, Re K, Im K)
    abs2, z2 = 1 / (1 - np.abs(lam) ** 2), 1 / (1 - lam**2)
    rr, ii, ri = 0.5 * (abs2 + z2.real), 0.5 * (abs2 - z2.real), 0.5 * z2.imag
    gram = np.zeros((m, 3, 3))
    gram[:, 0, 0] = 1.0
    gram[:, 1, 1], gram[:, 2, 2] = rr, ii
    gram[:, 1, 2] = gram[:, 2, 1] = -ri
    prior = np.stack([tap_cell, k_cell.real, k_cell.imag], -1)
    rho = 1e4 * np.maximum(1.0, np.abs(gram).max(axis=(1, 2)))
    return rows, second, second_target, gram, prior, rho


def _solve_reduced(u, rows, second, second_target, gram, prior, rho):
    """Minimise (x - prior)ᵀ G (x - prior) + rho (secondᵀx - target)² on {rows x = (1, u)}."""
    r1, r2 = rows[:, 0], rows[:, 1]
    # a particular solution: tap from the first row, the larger of Re/Im K from the second
    use_re = np.abs(r2[:, 1]) >= np.abs(r2[:, 2])
    a = np.where(use_re, u / np.where(use_re, r2[:, 1], 1.0), 0.0)
    b = np.where(use_re, 0.0, u / np.where(use_re, 1.0, r2[:, 2]))
    x0 = np.stack([1.0 - r1[:, 1] * a - r1[:, 2] * b, a, b], -1)
    d = np.cross(r1, r2)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    gd = np.einsum("mij,mj->mi", gram, d)
    sd = (second * d).sum(-1)
    num = (gd * (x0 - prior)).sum(-1) + rho * sd * ((second * x0).sum(-1) - second_target)
    den = (gd * d).sum(-1) + rho * sd * sd
    flat = den <= FLAT * (rho + np.trace(gram, axis1=1, axis2=2))
    tau = np.where(flat, 0.0, -num / np.where(flat, 1.0, den))
    return x0 + tau[:, None] * d, flat


def _solve_kkt(u, rows, second, second_target, gram, prior, rho):
    """The 5x5 KKT system by SVD with lstsq's cut-off, refined twice."""
    m = len(u)
    kkt = np.zeros((m, 5, 5))
    kkt[:, :3, :3] = gram + rho[:, None, None] * second[:, :, None] * second[:, None, :]
    kkt[:, :3, 3:] = np.swapaxes(rows, 1, 2)
    kkt[:, 3:, :3] = rows
    rhs = np.concatenate([np.einsum("mij,mj->mi", gram, prior) + rho[:, None] * second * second_target[:, None],
                          np.stack([np.ones(m), u], -1)], -1)
    left, sing, right = np.linalg.svd(kkt)
    keep = sing > np.finfo(np.float64).eps * 5 * sing[:, :1]
    inv = np.where(keep, 1.0 / np.where(keep, sing, 1.0), 0.0)

    def pinv_solve(b):
        return np.einsum("mji,mj->mi", right, inv * np.einsum("mji,mj->mi", left, b))

    sol = pinv_solve(rhs)
    for _ in range(2):
        sol = sol + pinv_solve(rhs - np.einsum("mij,mj->mi", kkt, sol))
    return sol[:, :3]
