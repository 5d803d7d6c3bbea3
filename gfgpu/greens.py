"""Green's functions of the chapter's matching equations: closed forms and recursions.

This module is the mathematics of gfgpu and nothing else: float64 closed forms of the
kernels (for references, figures and tests) and the coefficients of the exact first-order
complex recursions that every backend runs (derived in ``docs/derivations.md``, "The
recursion").

Every causal operator here is a sum of *sections*.  A section is the recursion

.. math::

    F[x+1] = \\lambda[x] F[x] + \\kappa[x] I[x], \\qquad y[x] = \\operatorname{Re} F[x]

and an operator adds a direct tap, ``y[x] += tap * I[x]``.  The projection constant of the
chapter's kernels (``c * Im`` or ``c * Re``) is folded into ``kappa`` on the host, in float64.

References
----------
.. [1] J. R. A. Torreão, S. M. C. Victer, J. L. Fernandes, "Green's Functions of Matching
   Equations: A Unifying Approach for Low-level Vision Problems", in *Vision Systems:
   Segmentation and Pattern Recognition*, G. Obinata and A. Dutta (eds.), I-Tech, 2007.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ._core import bspline
from ._core.passes import LinePass, Section
from ._core.shiftfit import shift_coefficients_many as _shift_coefficients_many
from ._core.validation import finite_scalar, positive, scale

__all__ = [
    "g_uniform", "h_homogeneous", "g_affine", "g_affine_approx", "d_uniform",
    "edge_derivative", "edge_projection",
    "Section", "LinePass", "GreenKernel",
    "UniformGreen", "HomogeneousGreen", "AffineGreen", "AffineGreenApprox",
    "shift_pass", "translation_split", "translation_passes", "cubic_shift_passes", "INTERPOLATIONS",
    "derivative_passes", "projection_passes",
    "EDGE_A", "EDGE_ETA",
]

#: Defaults of the multiscale differentiator (chapter §2, optimum of the (ΣΛ)·SRC index).
EDGE_A = 1.1
EDGE_ETA = 3.5


# --------------------------------------------------------------------------------------
# parameter validation
# --------------------------------------------------------------------------------------
def _u1_range(u1):
    v = finite_scalar("u1", u1)
    if not 0.0 < v < 2.0:
        raise ValueError(f"u1 must lie in (0, 2) for a bounded causal G_U^(1) (eq. 12), got {u1!r}")
    return v


# --------------------------------------------------------------------------------------
# closed forms (float64)
# --------------------------------------------------------------------------------------
def g_uniform(x, u):
    """Uniform-matching Green's function G_u (eq. 9).

    .. math:: G_u(x) = \\frac{2}{u} \\sin(x/u)\\, e^{-x/u} \\quad (x > 0), \\qquad 0 \\text{ otherwise}

    Parameters
    ----------
    x : array_like
        Offsets ``x - x0`` in pixels.
    u : float
        Matching displacement, ``u > 0``.

    Returns
    -------
    ndarray of float64

    Examples
    --------
    >>> float(g_uniform(1.0, 1.0))  # doctest: +ELLIPSIS
    0.6191...
    """
    u = scale("u", u)
    x = np.asarray(x, dtype=np.float64)
    t = np.where(x > 0, x, 0.0) / u
    return np.where(x > 0, (2.0 / u) * np.sin(t) * np.exp(-t), 0.0)


def h_homogeneous(x, u):
    """Homogeneous integral operator H_u (eq. 33).

    .. math:: H_u(x) = \\frac{2}{u} \\cos(x/u)\\, e^{-x/u} \\quad (x > 0), \\qquad 0 \\ (x < 0)

    At the jump ``x = 0`` the value is the mean of the one-sided limits, ``1/u`` (the
    trapezoid convention: with it the discrete sum approximates ``∫H_u = 1`` to O(u^-2)).
    """
    u = scale("u", u)
    x = np.asarray(x, dtype=np.float64)
    t = np.where(x > 0, x, 0.0) / u
    return np.where(x > 0, (2.0 / u) * np.cos(t) * np.exp(-t), np.where(x == 0, 1.0 / u, 0.0))


def _affine_params(u1):
    alpha = -1.0 / u1 + 0.5
    beta = math.sqrt(1.0 + u1 - u1 * u1 / 4.0) / u1
    return alpha, beta


def g_affine(x, x0, u1, x_U):
    """Affine-matching Green's function G_U^(1) (eq. 11-12), the exact zoom operator.

    .. math::
        G_U^{(1)}(x, x_0) = \\frac{2}{u_1^2 \\beta (x_0 - x_U)}
        \\Big[\\frac{x - x_U}{x_0 - x_U}\\Big]^{\\alpha}
        \\sin\\Big\\{\\beta \\log\\frac{x - x_U}{x_0 - x_U}\\Big\\}, \\quad x > x_0 > x_U

    with ``alpha = 1/2 - 1/u1`` and ``beta = sqrt(1 + u1 - u1^2/4) / u1``; zero for
    ``x <= x0``.  Bounded over ``(x_U, inf)`` for ``0 < u1 < 2``.
    """
    u1 = _u1_range(u1)
    x_U = finite_scalar("x_U", x_U)
    x, x0 = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(x0, np.float64))
    if np.any((x0 <= x_U) & (x > x0)):
        raise ValueError(f"G_U^(1) is defined for x > x0 > x_U; got x0 <= x_U = {x_U}")
    alpha, beta = _affine_params(u1)
    ok = x > x0
    s = np.where(ok, x - x_U, 2.0)
    s0 = np.where(ok, x0 - x_U, 1.0)
    t = np.log(s / s0)
    return np.where(ok, 2.0 / (u1 * u1 * beta * s0) * np.exp(alpha * t) * np.sin(beta * t), 0.0)


def g_affine_approx(x, x0, sigma, x_U):
    """Approximate affine Green's function G_U^(2) (eq. 14).

    .. math::
        G_U^{(2)}(x, x_0) = \\frac{2|x_U|}{\\sigma^2} \\sin\\Big[\\frac{|x_U|}{\\sigma^2}(x - x_0)\\Big]
        \\exp\\Big[-\\frac{(x - x_U)^2 - (x_0 - x_U)^2}{2\\sigma^2}\\Big], \\quad x > x_0

    It shifts by about ``sigma^2/|x_U|`` with a gain ramp ``1 - x/|x_U|``: a uniform shift, not an
    affine displacement (``docs/derivations.md``, "G_U^(2)").
    """
    sigma = positive("sigma", sigma)
    x_U = finite_scalar("x_U", x_U)
    if x_U == 0:
        raise ValueError("x_U must be non-zero for G_U^(2) (the shift is sigma^2/|x_U|)")
    x, x0 = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(x0, np.float64))
    w0 = abs(x_U) / sigma**2
    ok = x > x0
    d = np.where(ok, x - x0, 0.0)
    e = -((x - x_U) ** 2 - (x0 - x_U) ** 2) / (2 * sigma**2)
    return np.where(ok, 2 * w0 * np.sin(w0 * d) * np.exp(np.where(ok, e, 0.0)), 0.0)


def d_uniform(x, u):
    """Single-scale differentiator D_u (eq. 19): ``-(1/u^2) exp(-|x|/u) sin(x/u)``."""
    u = scale("u", u)
    x = np.asarray(x, dtype=np.float64)
    return -(1.0 / u**2) * np.exp(-np.abs(x) / u) * np.sin(x / u)


def edge_weights(u, a, eta):
    u = scale("u", u)
    a = positive("a", a)
    eta = positive("eta", eta)
    big_a = 2.0 / (u * eta**2 * (1.0 + a))
    big_k = a * eta**2  # the fine scale carries weight a: reproduces the chapter's 3.547 (docs/derivations.md)
    return u, a, eta, big_a, big_k


def edge_derivative(x, u, a=EDGE_A, eta=EDGE_ETA):
    """Multiscale differentiator D(x) (eq. 25-26) with ``K = a eta^2``.

    .. math::
        D(x) = \\frac{1}{2u}[F(-x) - F(x)],\\quad
        F(x) = A[e^{-x/\\eta u}\\sin(x/\\eta u) + K e^{-x/u}\\sin(x/u)] \\ (x>0),

    ``A = 2/(u eta^2 (1+a))``.  Continuous unit ramp response: ``-∫ x D = 1``.

    ``K = a eta^2`` weights the fine scale by ``a``, i.e. ``(I'_eta + a I'_1)/(1 + a)``: with
    it the (ΣΛ)·SRC index at a = 1.1, η = 3.5 is the chapter's 3.547.  Eq. 24 as printed
    would give ``K = eta^2/a`` and 3.538 (``docs/derivations.md``).
    """
    u, a, eta, big_a, big_k = edge_weights(u, a, eta)
    x = np.asarray(x, dtype=np.float64)
    t = np.abs(x)
    f = big_a * (np.exp(-t / (eta * u)) * np.sin(t / (eta * u)) + big_k * np.exp(-t / u) * np.sin(t / u))
    return -np.sign(x) * f / (2 * u)


def edge_projection(x, u, a=EDGE_A, eta=EDGE_ETA):
    """Projection function P = ∫D used along edges (chapter §2; ``docs/derivations.md``).

    .. math::
        P(x) = \\frac{A}{4u}\\big[\\eta u\\, e^{-|x|/\\eta u}(\\sin + \\cos)(|x|/\\eta u)
        + K u\\, e^{-|x|/u}(\\sin + \\cos)(|x|/u)\\big],\\quad ∫P = 1.
    """
    u, a, eta, big_a, big_k = edge_weights(u, a, eta)
    t = np.abs(np.asarray(x, dtype=np.float64))
    v1, v2 = eta * u, u
    return (big_a / (4 * u)) * (v1 * np.exp(-t / v1) * (np.sin(t / v1) + np.cos(t / v1))
                                + big_k * v2 * np.exp(-t / v2) * (np.sin(t / v2) + np.cos(t / v2)))


def _check_fixed_point(name, x_U, n, reverse):
    """The affine kernels' domain (x_U, inf) must contain the whole line (and its extension)."""
    if reverse and not x_U > n - 1:
        raise ValueError(f"{name} applied anticausally on a line of {n} samples needs x_U > {n - 1} "
                         f"(the fixed point beyond the line's end, outside the domain); got x_U = {x_U}")
    if not reverse and not x_U < 0:
        raise ValueError(f"{name} applied causally needs x_U < 0 (the fixed point before the line's "
                         f"first sample, outside the domain); got x_U = {x_U}")


# --------------------------------------------------------------------------------------
# recursions
# --------------------------------------------------------------------------------------
class GreenKernel:
    """Base class of the chapter's Green's functions as line filters.

    Subclasses give the closed form ``__call__(x, x0)`` (float64) and the recursion
    (:meth:`line_pass`).  ``green_filter(input, kernel)`` applies them.
    """

    x_min = -math.inf

    def __call__(self, x, x0):  # pragma: no cover - abstract
        raise NotImplementedError

    def line_pass(self, reverse=False):
        return LinePass((Section(kernel=self) if not self.shift_invariant else self._section(),),
                        self.tap, reverse)

    tap = 0.0
    shift_invariant = False

    def validate_line(self, n, reverse):
        """Raise ``ValueError`` if the kernel is not defined on a line of ``n`` samples."""

    def mirrored(self, n):
        return self


@dataclass(frozen=True)
class UniformGreen(GreenKernel):
    """G_u (eq. 9): shifts by ``u`` toward +x with zero variance and third cumulant ``-u^3``.

    Recursion: ``lam = exp((-1+i)/u)``, ``kap = -i (2/u) lam`` (so that ``y = (2/u) Im F``).
    """

    u: float

    def __post_init__(self):
        object.__setattr__(self, "u", scale("u", self.u))

    shift_invariant = True

    def __call__(self, x, x0):
        return g_uniform(np.asarray(x, np.float64) - np.asarray(x0, np.float64), self.u)

    def _section(self):
        lam = np.exp(complex(-1.0, 1.0) / self.u)
        return Section(lam=lam, kap=-1j * (2.0 / self.u) * lam)


@dataclass(frozen=True)
class HomogeneousGreen(GreenKernel):
    """H_u (eq. 33); the jump at 0 is sampled at its mean ``1/u`` (a direct tap)."""

    u: float

    def __post_init__(self):
        object.__setattr__(self, "u", scale("u", self.u))

    shift_invariant = True

    @property
    def tap(self):
        return 1.0 / self.u

    def __call__(self, x, x0):
        return h_homogeneous(np.asarray(x, np.float64) - np.asarray(x0, np.float64), self.u)

    def _section(self):
        lam = np.exp(complex(-1.0, 1.0) / self.u)
        return Section(lam=lam, kap=(2.0 / self.u) * lam)


@dataclass(frozen=True)
class AffineGreen(GreenKernel):
    """G_U^(1) (eq. 11-12), exact Green's function of the affine matching equation (10).

    ``x_U = -u0/u1`` is the fixed point, in pixel coordinates of the line (0 = first
    sample).  Applied causally it needs ``x_U < 0``; anticausally ``x_U > n - 1``.

    Recursion (s = x - x_U): ``lam = (1 + 1/s)^(alpha + i beta)``, ``kap = lam / s``,
    folded with ``-i * 2/(u1^2 beta)``.
    """

    u1: float
    x_U: float

    def __post_init__(self):
        object.__setattr__(self, "u1", _u1_range(self.u1))
        object.__setattr__(self, "x_U", finite_scalar("x_U", self.x_U))

    @property
    def x_min(self):
        return self.x_U

    def __call__(self, x, x0):
        return g_affine(x, x0, self.u1, self.x_U)

    def coefficients(self, positions):
        alpha, beta = _affine_params(self.u1)
        s = np.asarray(positions, np.float64) - self.x_U
        lam = np.exp(complex(alpha, beta) * np.log1p(1.0 / s))
        c = -1j * 2.0 / (self.u1**2 * beta)
        return lam, c * lam / s

    def validate_line(self, n, reverse):
        _check_fixed_point("G_U^(1)", self.x_U, n, reverse)

    def mirrored(self, n):
        return AffineGreen(self.u1, (n - 1) - self.x_U)


@dataclass(frozen=True)
class AffineGreenApprox(GreenKernel):
    """G_U^(2) (eq. 14): uniform shift ``sigma^2/|x_U|`` with a gain ramp ``1 - x/|x_U|``.

    Causal use needs ``x_U < 0`` (the domain ``(x_U, inf)`` must contain the line),
    anticausal use ``x_U > n - 1``.  Recursion: ``lam = kap = exp(i w0 - (2(x - x_U)+1)/(2 sigma^2))``,
    ``w0 = |x_U|/sigma^2``, folded with ``-i 2 w0``.
    """

    sigma: float
    x_U: float

    def __post_init__(self):
        object.__setattr__(self, "sigma", positive("sigma", self.sigma))
        object.__setattr__(self, "x_U", finite_scalar("x_U", self.x_U))

    @property
    def x_min(self):
        return self.x_U

    @property
    def w0(self):
        return abs(self.x_U) / self.sigma**2

    def __call__(self, x, x0):
        return g_affine_approx(x, x0, self.sigma, self.x_U)

    def coefficients(self, positions):
        x = np.asarray(positions, np.float64)
        lam = np.exp(1j * self.w0 - (2 * (x - self.x_U) + 1) / (2 * self.sigma**2))
        return lam, -1j * 2 * self.w0 * lam

    def validate_line(self, n, reverse):
        _check_fixed_point("G_U^(2)", self.x_U, n, reverse)

    def mirrored(self, n):
        return AffineGreenApprox(self.sigma, (n - 1) - self.x_U)


# --------------------------------------------------------------------------------------
# discrete operators built from G_u: shift, derivative D, projection P
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=256)
def shift_coefficients(u):
    """Taps ``w[0] = tap``, ``w[m] = Re(K lam^(m-1))`` of the discrete shift by ``u``.

    Chosen in the family of G_u's two poles (numerator of degree 2) as the member closest
    (ℓ2 over taps) to the cell-integrated kernel ``∫_{m-1/2}^{m+1/2} G_u`` subject to the
    exact constraints ``Σ w = 1`` and ``Σ m w = u``, with a strong penalty pulling the
    variance to that of the pixel-integrated continuous kernel, 1/12 (``u(1-u)``, the linear
    interpolation variance, below u ≈ 0.092 where 1/12 is not reachable with small taps).
    Computed by :func:`shift_coefficients_many`, so a scalar call and a batch agree.
    """
    lam, kap, tap = shift_coefficients_many(np.array([u], np.float64))
    return complex(lam[0]), complex(kap[0]), float(tap[0])


def shift_coefficients_many(u):
    """:func:`shift_coefficients` for an array of ``u > 0`` at once: ``(lam, kap, tap)`` arrays.

    One batched float64 solve (:mod:`gfgpu._core.shiftfit`) instead of one per ``u``: what
    per-line plans (shears, oblique passes) need for thousands of lines.

    Examples
    --------
    >>> lam, kap, tap = shift_coefficients_many([0.25, 3.0])
    >>> lam.shape, bool(abs(complex(kap[1]) - shift_coefficients(3.0)[1]) < 1e-15)
    ((2,), True)
    """
    return _shift_coefficients_many(u)


def shift_pass(u):
    """The discrete sub-pixel shift by ``u`` (``u > 0`` toward +x, ``u < 0`` anticausal).

    Unit DC gain and first moment exactly ``u`` (to float64 rounding); poles
    ``exp((-1 ± i)/|u|)`` of G_u; see :func:`shift_coefficients` for the numerator.
    """
    v = finite_scalar("shift", u)
    if v == 0:
        raise ValueError("shift must be non-zero here; callers skip zero shifts")
    lam, kap, tap = shift_coefficients(abs(v))
    return LinePass((Section(lam=lam, kap=kap),), tap, reverse=v < 0)


def _damped_sine_moment(v):
    """Σ_{m>=1} m r^m sin(m/v), r = exp(-1/v)."""
    lam = np.exp(complex(-1.0, 1.0) / v)
    return (lam / (1 - lam) ** 2).imag


def derivative_passes(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Causal and anticausal passes of the discrete D (eq. 25-26, or D_u of eq. 19).

    Taps ``D[m] = -sign(m) c [h_{eta u}(|m|) + K h_u(|m|)]`` with ``h_v(m) = e^{-m/v} sin(m/v)``
    (point-sampled), normalised so that ``-Σ m D[m] = 1`` (unit ramp response).
    """
    if single_scale:
        u = scale("u", u)
        scales = ((u, 1.0),)
    else:
        u, a, eta, _, big_k = edge_weights(u, a, eta)
        scales = ((eta * u, 1.0), (u, big_k))
    norm = 2.0 * sum(w * _damped_sine_moment(v) for v, w in scales)
    passes = []
    for sign, reverse in ((-1.0, False), (1.0, True)):
        secs = []
        for v, w in scales:
            lam = np.exp(complex(-1.0, 1.0) / v)
            secs.append(Section(lam=lam, kap=-1j * sign * (w / norm) * lam))
        passes.append(LinePass(tuple(secs), 0.0, reverse))
    return tuple(passes)


def projection_passes(u, a=EDGE_A, eta=EDGE_ETA, single_scale=False):
    """Causal (with the m = 0 tap) and anticausal passes of the discrete projection P.

    Taps ``P[m] ∝ eta u q_{eta u}(|m|) + K u q_u(|m|)``, ``q_v(m) = e^{-m/v}(sin + cos)(m/v)``
    (point-sampled continuous P = ∫D), normalised to unit sum; ``single_scale``: ∫D_u, i.e.
    ``q_u`` alone.
    """
    if single_scale:
        u = scale("u", u)
        scales = ((u, u),)
    else:
        u, a, eta, _, big_k = edge_weights(u, a, eta)
        scales = ((eta * u, eta * u), (u, big_k * u))
    total = 0.0
    for v, w in scales:
        lam = np.exp(complex(-1.0, 1.0) / v)
        total += w * (2 * ((1 - 1j) / (1 - lam)).real - 1.0)
    secs = tuple(Section(lam=np.exp(complex(-1.0, 1.0) / v),
                         kap=(w / total) * (1 - 1j) * np.exp(complex(-1.0, 1.0) / v))
                 for v, w in scales)
    tap = sum(w for _, w in scales) / total
    return (LinePass(secs, tap, False), LinePass(secs, 0.0, True))


def translation_split(s):
    """``(n, f)`` with ``s = n + f``, ``n`` an integer and ``|f| <= 1/2`` (halves toward zero).

    ``n`` is a Python int of any magnitude; fractions below 1e-12 px are dropped (their effect,
    ``|f|`` times the local slope, is below float64 rounding of the samples).
    """
    v = finite_scalar("shift", s)
    n = int(math.copysign(math.ceil(abs(v) - 0.5), v)) if abs(v) < 2**52 else int(v)
    f = v - n
    if abs(f) < 1e-12:
        f = 0.0
    return n, f


#: fractional interpolators of :func:`translation_passes`
INTERPOLATIONS = ("green", "cubic")


def translation_passes(s, interpolation="green"):
    """The passes (one step) of the translation by ``s`` samples: integer part by index
    arithmetic (``LinePass.offset``), fractional part ``|f| <= 1/2`` by ``interpolation``:

    ``"green"``: :func:`shift_pass`, the discrete Green shift G_f (causal for ``f > 0``,
    anticausal for ``f < 0``; unit DC gain, first moment exactly ``f``);
    ``"cubic"``: :func:`cubic_shift_passes`, cubic B-spline interpolation.

    Returns an empty list for ``s = 0``.
    """
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}; got {interpolation!r}")
    n, f = translation_split(s)
    if f == 0.0:
        return [] if n == 0 else [LinePass((), 1.0, False, n)]
    passes = [shift_pass(f)] if interpolation == "green" else cubic_shift_passes(f)
    return [LinePass(lp.sections, lp.tap, lp.reverse, n) for lp in passes]


def cubic_shift_passes(f):
    """The cubic B-spline shift by ``|f| <= 1/2`` as one causal and one anticausal pass.

    Sampling the interpolating cubic spline of the line at ``x - f`` is the filter
    ``h = p * b_f`` with the spline prefilter ``p[k] = c0 z^|k|`` (``z = sqrt(3) - 2``,
    ``c0 = -6 z / (1 - z^2)``) and the four or five taps ``b_f[i] = β3(i - f)``
    (:mod:`gfgpu._core.bspline`); it is geometric beyond ``|m| >= 2`` (``h[m] = A z^m``,
    ``h[-m] = B z^m``), so it is exactly a direct tap, one pole per direction and a one-sample
    correction per direction (scipy.ndimage's ``order=3`` interpolation, evaluated as
    recursions: O(1) per sample).
    """
    z, c0 = bspline.SPLINE_POLE, bspline.PREFILTER_GAIN
    taps = {i: bspline.basis(i - f) for i in range(-2, 3)}

    def h(m):
        return sum(b * c0 * z ** abs(m - i) for i, b in taps.items())
    a = sum(b * c0 * z ** (-i) for i, b in taps.items())     # h[m] = a z^m for m >= 2
    b_ = sum(b * c0 * z**i for i, b in taps.items())         # h[m] = b z^-m for m <= -2
    causal = LinePass((Section(lam=complex(z), kap=complex(a * z)),
                       Section(lam=0j, kap=complex(h(1) - a * z))), float(h(0)), False)
    anticausal = LinePass((Section(lam=complex(z), kap=complex(b_ * z)),
                           Section(lam=0j, kap=complex(h(-1) - b_ * z))), 0.0, True)
    return [causal, anticausal]
