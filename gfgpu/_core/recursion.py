"""The one recursion primitive: its host-side plan and its executable specification.

Every backend implements :func:`run_reference` (below, in numpy) on its device.  A *plan*
(:class:`PassPlan`) holds everything a kernel needs for one pass over lines of ``n``
samples, in traversal order (reversed lines for anticausal passes):

* ``lam[s, k]``, ``kap[s, k]``  complex recursion coefficients of section ``s`` at step ``k``
  (``constant=True``: every column equals column 0, kernels may read ``[s, 0]`` once);
* ``omega[s, j]`` (``j < L``) and ``omega_c[s]``: the initial state, the boundary mode realised
  exactly as ``F_s[0] = Σ_j omega[s, j] I[j] + omega_c[s] cval`` (``docs/derivations.md``,
  "Boundary modes as initial states");
* ``tap``: direct term.

For each line ``I[0..n-1]`` (traversal order) a kernel computes::

    F_s = Σ_{j<L} omega[s, j] I[j] + omega_c[s] * cval           (complex)
    for k in 0..n-1:
        y = Σ_s Re F_s + tap * I[k]
        out[k] = y            (or out[k] += y when accumulating)
        F_s = lam[s, k] F_s + kap[s, k] I[k]

Boundary modes (scipy.ndimage names, :mod:`gfgpu._core.boundary`) extend the line beyond its
first sample.  The infinite sum over the extension is folded into ``omega`` exactly (geometric series
summed in float64; terms below ``tol`` relative to the largest are dropped, ``tol`` = 1e-18
for float64 and 1e-10 for float32, i.e. far below each type's rounding).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .boundary import MODES, check_mode, extend_index
from .boundary import period as mode_period
from .lru import LRU
from .passes import LinePass

__all__ = ["MODES", "TOL", "check_mode", "PassPlan", "plan_pass", "invariant_window", "run_reference", "block_powers",
           "packed_block_powers", "run_reference_blocks",
           "LinePlans", "plan_lines", "line_plans", "run_reference_lines"]

TOL = {np.dtype(np.float32): 1e-10, np.dtype(np.float64): 1e-18}
_MAX_EXTENSION = 50_000_000

@dataclass(frozen=True, eq=False)
class PassPlan:
    lam: np.ndarray      # (S, n) complex128
    kap: np.ndarray      # (S, n) complex128
    omega: np.ndarray    # (S, L) complex128
    omega_c: np.ndarray  # (S,)   complex128
    tap: float
    reverse: bool
    constant: bool

    @property
    def n(self):
        return self.lam.shape[1]

    @property
    def sections(self):
        return self.lam.shape[0]

    def packed(self, dtype):
        """Real arrays for device kernels: (S, n, 2) lam and kap, (S, L, 2) omega, (S, 2) omega_c."""
        def split(z):
            out = np.empty(z.shape + (2,), dtype)
            out[..., 0] = z.real        # (the cast of astype: round to nearest)
            out[..., 1] = z.imag
            return out
        return split(self.lam), split(self.kap), split(self.omega), split(self.omega_c)


def _initial_weights(section, n, mode, tol):
    """omega (length <= n) and omega_c for one section, by summing the kernel over x0 < 0.

    Shift-invariant sections sum in closed form over the periods of the extension (geometric
    series), so cost and accuracy do not depend on how slowly the section decays.
    """
    if section.shift_invariant:
        return _invariant_weights(complex(section.lam), complex(section.kap), n, mode, tol)[:2]
    # shift-variant: Kc(0, x0) = (Π_{x0<x<0} lam[x]) kap[x0], over the domain x0 > x_min
    lo = section.x_min
    count = _MAX_EXTENSION if not math.isfinite(lo) else int(math.ceil(-lo)) - 1
    if count > _MAX_EXTENSION:
        raise ValueError(f"the kernel's domain extends {count} samples beyond the line; "
                         f"at most {_MAX_EXTENSION} are summed for the boundary condition")
    if count <= 0:
        return np.zeros(0, np.complex128), 0j
    x0 = -np.arange(1, count + 1, dtype=np.float64)          # -1, -2, ...
    lam, kap = section.coefficients(x0)
    # log of the product of lam over (x0, 0): cumulative from the right
    log_prod = np.concatenate([[0.0 + 0j], np.cumsum(np.log(lam[:-1]))])
    weights = np.exp(log_prod) * kap
    if mode == "constant":
        return np.zeros(0, np.complex128), weights.sum()
    idx = extend_index(x0.astype(np.int64), n, mode)
    omega = np.bincount(idx, weights.real, minlength=n) + 1j * np.bincount(idx, weights.imag, minlength=n)
    return omega, 0j


@lru_cache(maxsize=256)
def _reach(lam, tol):
    """``cut + 1`` of :func:`_line_initial_weights` for one pole: the initial window of a line
    longer than it holds every term above ``tol`` (computed by the same operations)."""
    mag = np.abs(np.array([lam]))
    safe = np.where((mag > 0) & (mag < 1), mag, 0.5)
    cut = np.where(mag > 0, np.ceil(np.log(tol) / np.log(safe)) + 1, 1)
    return float(cut[0] + 1)


_CACHE_SIZE = 1024          # sections' weights and passes' assembled windows kept (least recently used dropped)
_weights = LRU(_CACHE_SIZE)     # what a section's weights depend on -> (row, omega_c, tail)
_windows = LRU(_CACHE_SIZE)     # the weights' keys of a pass's sections -> its (omega, omega_c)


def _bits(*values):
    """The bytes of complex ``values``: a cache key that tells -0.0 from 0.0 (which compare equal)."""
    return struct.pack(f"<{2 * len(values)}d", *(x for z in values for x in (z.real, z.imag)))


def _pole(lam, kap):
    """One section's coefficients as the one-line arrays of :func:`_line_initial_weights`, their
    bytes (a key) and the logarithm :func:`_powers` takes of ``lam``."""
    return _pole_cached(_bits(lam, kap))


@lru_cache(maxsize=256)
def _pole_cached(key):
    lam_r, lam_i, kap_r, kap_i = struct.unpack("<4d", key)
    lam_a, kap_a = np.array([complex(lam_r, lam_i)]), np.array([complex(kap_r, kap_i)])
    log = np.log(lam_a) if lam_a[0] != 0 else None
    for a in (lam_a, kap_a) + ((log,) if log is not None else ()):
        a.setflags(write=False)
    return lam_a, kap_a, key, log


def _pole_power(lam_a, log, k):
    """``_powers(lam_a, [k])[:, 0]`` by the same operations, with the pole's logarithm taken once."""
    if log is None:
        return _powers(lam_a, [k])[:, 0]
    return np.exp(log[:, None] * np.asarray([k], np.float64)[None, :])[:, 0]


def _invariant_weights(lam, kap, n, mode, tol):
    """``(row, omega_c, key)``: omega and omega_c of one shift-invariant section on lines of
    ``n``, what :func:`_line_initial_weights` gives for that one line, cached by ``key``, what
    they depend on (None: computed in full, uncached).

    A line longer than the section's reach depends on ``n`` only through the period's power
    ``lam^period`` (in ``amp = kap / (1 - lam^period)``), for ``wrap`` through where the window
    sits (the line's last samples) and for ``mirror`` through its first weight
    (``amp lam^(period - 1)``, set here); ``constant`` and ``nearest`` not at all.  Those
    scalars are computed here by the same operations, and a new line length whose ``amp`` is
    bit-equal to a seen one's reuses its row (so a plan at a new image size costs a few scalar
    operations per section, not the geometric series).  Short lines (``n`` within the reach)
    are computed in full.
    """
    lam_a, kap_a, pole, log = _pole(lam, kap)
    if mode in ("constant", "nearest") or n == 1:
        key = (mode, n == 1, pole, tol)
    else:
        if n <= _reach(lam, tol):
            omega, omega_c = _line_initial_weights(lam_a, kap_a, n, mode, tol)
            return omega[0], complex(omega_c[0]), None
        period = mode_period(n, mode)
        amp = kap_a / (1 - _pole_power(lam_a, log, period))
        key = (mode, pole, tol, amp.tobytes())

    def make():
        omega, omega_c = _line_initial_weights(lam_a, kap_a, n, mode, tol)
        row = omega[0]
        # wrap: the window is the line's last samples (zeros before them), kept as that tail
        tail = mode == "wrap" and n > 1
        if tail:
            row = row[n - int(_reach(lam, tol)):].copy()
        row.setflags(write=False)
        return row, complex(omega_c[0]), tail

    row, omega_c, tail = _weights.get(key, make)
    if tail:
        full = np.zeros(n, row.dtype)
        full[n - len(row):] = row
        return full, omega_c, key
    if mode == "mirror" and n > 1:
        # the first sample's weight is the one term of the far end (m = 2n - 2): lam^(period - 1),
        # the one value of a long line's window that depends on n beyond amp
        corner = amp * _pole_power(lam_a, log, period - 1)
        row = row.copy()
        row[0] = corner[0]
        row.setflags(write=False)
        return row, omega_c, key + (corner.tobytes(),)
    return row, omega_c, key


def _window(omegas, omega_cs, tol):
    """The initial states of a pass from its sections' (omega, omega_c): omega ``(S, L)``, cut after
    the last sample whose weight exceeds ``tol`` relative to the largest, and omega_c ``(S,)``."""
    length = max(len(o) for o in omegas)
    omega = np.zeros((len(omegas), length), np.complex128)
    for s, o in enumerate(omegas):
        omega[s, :len(o)] = o
    if length:
        big = np.abs(omega).max(axis=0)
        keep = np.nonzero(big > tol * max(big.max(), 1e-300))[0]
        omega = omega[:, : (keep[-1] + 1 if keep.size else 0)]
    omega_c = np.array(omega_cs, np.complex128)
    for arr in (omega, omega_c):
        arr.setflags(write=False)
    return omega, omega_c


def _invariant_window(sections, n, mode, tol):
    """omega and omega_c of a pass of shift-invariant ``sections`` on lines of ``n``: its window
    from the sections' cached weights, itself cached by their keys where no section needs the
    line's length (not ``wrap``, no line within a section's reach)."""
    weights = [_invariant_weights(complex(sec.lam), complex(sec.kap), n, mode, tol) for sec in sections]
    keys = tuple(w[2] for w in weights)
    omegas, omega_cs = [w[0] for w in weights], [w[1] for w in weights]
    if mode != "wrap" and None not in keys:
        return _windows.get((keys, tol), lambda: _window(omegas, omega_cs, tol))
    return _window(omegas, omega_cs, tol)


def invariant_window(sections, n, mode, dtype):
    """``(omega, omega_c)`` of :func:`plan_pass` for a pass of the shift-invariant ``sections``
    (any sense: the window does not depend on it) on lines of ``n``, without the plan's
    per-sample coefficients; read-only, shared between calls."""
    check_mode(mode)
    return _invariant_window(sections, int(n), mode, TOL[np.dtype(dtype)])


def _columns(sections):
    """``(S, 1)`` lam and kap of shift-invariant sections (read-only)."""
    return _columns_cached(_bits(*(z for sec in sections for z in (complex(sec.lam), complex(sec.kap)))))


@lru_cache(maxsize=256)
def _columns_cached(key):
    values = np.frombuffer(key, np.complex128).reshape(-1, 2)
    lam, kap = np.array(values[:, :1]), np.array(values[:, 1:])
    for arr in (lam, kap):
        arr.setflags(write=False)
    return lam, kap


def _invariant_plan(lp, n, mode, tol):
    """The :class:`PassPlan` of a shift-invariant pass (traversal coordinates): lam and kap
    ``(S, n)`` are read-only views of one column repeated along the line (no memory per line
    length)."""
    omega, omega_c = _invariant_window(lp.sections, n, mode, tol)
    lam, kap = _columns(lp.sections)
    S = len(lp.sections)
    return PassPlan(np.broadcast_to(lam, (S, n)), np.broadcast_to(kap, (S, n)), omega, omega_c, float(lp.tap),
                    bool(lp.reverse), True)


@lru_cache(maxsize=512)
def _plan_cached(line_pass, n, mode, dtype_str):
    tol = TOL[np.dtype(dtype_str)]
    lp = line_pass.mirrored(n)
    if lp.sections and lp.shift_invariant:
        return _invariant_plan(lp, n, mode, tol)
    positions = np.arange(n, dtype=np.float64)
    lams, kaps, omegas, omega_cs = [], [], [], []
    for sec in lp.sections:
        lam, kap = sec.coefficients(positions)
        lams.append(lam)
        kaps.append(kap)
        om, oc = _initial_weights(sec, n, mode, tol)
        omegas.append(om)
        omega_cs.append(oc)
    omega, omega_c = _window(omegas, omega_cs, tol)
    plan = PassPlan(np.array(lams), np.array(kaps), omega, omega_c, float(lp.tap), bool(lp.reverse),
                    lp.shift_invariant)
    for arr in (plan.lam, plan.kap):
        arr.setflags(write=False)
    return plan


def plan_pass(line_pass: LinePass, n: int, mode: str, dtype) -> PassPlan:
    """Build (and cache) the :class:`PassPlan` of ``line_pass`` on lines of ``n`` samples."""
    check_mode(mode)
    for sec in line_pass.sections:
        if sec.kernel is not None:
            sec.kernel.validate_line(n, line_pass.reverse)
    return _plan_cached(line_pass, int(n), mode, np.dtype(dtype).str)


def run_reference(lines, plan: PassPlan, cval=0.0, out=None, accumulate=False):
    """Executable specification of the primitive (numpy, vectorised over lines).

    ``lines`` has shape ``(n, m)``: ``m`` independent lines of ``n`` samples, in natural
    order (the plan's ``reverse`` flag is applied here).  Computation in the input's dtype
    (complex64 state for float32, complex128 for float64).
    """
    lines = np.asarray(lines)
    dtype = lines.dtype
    cdt = np.complex64 if dtype == np.float32 else np.complex128
    n = lines.shape[0]
    if out is None:
        out = np.empty_like(lines)
    src = lines[::-1] if plan.reverse else lines
    dst = out[::-1] if plan.reverse else out
    lam = plan.lam.astype(cdt)
    kap = plan.kap.astype(cdt)
    L = plan.omega.shape[1]
    state = (plan.omega.astype(cdt) @ src[:L].astype(cdt)) if L else \
        np.zeros((plan.sections, lines.shape[1]), cdt)
    state += (plan.omega_c.astype(cdt) * dtype.type(cval))[:, None]
    tap = dtype.type(plan.tap)
    tmp = np.empty_like(state)
    for k in range(n):
        v = src[k]
        y = state.real.sum(axis=0, dtype=dtype) + tap * v
        if accumulate:
            dst[k] += y
        else:
            dst[k] = y
        np.multiply(lam[:, k, None], state, out=tmp)
        tmp += kap[:, k, None] * v
        state, tmp = tmp, state
    return out


def block_powers(plan: PassPlan, block: int):
    """``(S, blocks)`` complex128: the product of each block's ``lam`` (traversal order), the
    factor that carries a state across a block of ``block`` steps."""
    lam = plan.lam
    blocks = -(-plan.n // block)
    if plan.constant:
        return np.broadcast_to(np.exp(block * np.log(lam[:, :1].astype(np.complex128))), (lam.shape[0], blocks))
    pad = np.ones((lam.shape[0], blocks * block), np.complex128)
    pad[:, :plan.n] = lam
    return pad.reshape(lam.shape[0], blocks, block).prod(axis=2)


def packed_block_powers(plan: PassPlan, block: int, dtype):
    """:func:`block_powers` as a real ``(S, blocks, 2)`` array of ``dtype`` (real, imaginary
    parts), the layout the device kernels read, as :meth:`PassPlan.packed` gives the plan's."""
    powers = block_powers(plan, block)
    return np.ascontiguousarray(np.stack([powers.real, powers.imag], axis=-1).astype(dtype))


def run_reference_blocks(lines, plan: PassPlan, block: int, cval=0.0):
    """Executable specification of block-parallel lines: :func:`run_reference` computed with
    each line cut into blocks of ``block`` steps (Nehab et al. 2011's block/carry structure).

    1. every block runs from a zero state: its end state ``E_b``; and its samples' part ``P_b``
       of the initial state (``omega`` terms, ``j < L``);
    2. per line, in traversal order: ``F_0 = omega_c cval + Σ_b P_b``, ``start_b = F``,
       ``F <- Λ_b F + E_b`` (``Λ_b``: :func:`block_powers`);
    3. every block runs again from ``start_b``, writing its outputs.

    The state is linear in the input, so this equals the sequential pass exactly in exact
    arithmetic; in floating point the two differ by rounding only.  ``lines`` ``(n, m)``
    as in :func:`run_reference`; computed in the input's dtype.
    """
    lines = np.asarray(lines)
    dtype = lines.dtype
    cdt = np.complex64 if dtype == np.float32 else np.complex128
    n, m = lines.shape
    src = lines[::-1] if plan.reverse else lines
    lam, kap = plan.lam.astype(cdt), plan.kap.astype(cdt)
    S, L = plan.sections, plan.omega.shape[1]
    blocks = -(-n // block)
    power = block_powers(plan, block).astype(cdt)
    ends = np.zeros((blocks, S, m), cdt)
    parts = np.zeros((blocks, S, m), cdt)
    for b in range(blocks):
        lo, hi = b * block, min(n, (b + 1) * block)
        if lo < L:
            parts[b] = plan.omega[:, lo:min(hi, L)].astype(cdt) @ src[lo:min(hi, L)].astype(cdt)
        state = np.zeros((S, m), cdt)
        for k in range(lo, hi):
            state = lam[:, k, None] * state + kap[:, k, None] * src[k]
        ends[b] = state
    state = parts.sum(axis=0, dtype=cdt) + (plan.omega_c.astype(cdt) * dtype.type(cval))[:, None]
    out = np.empty_like(lines)
    dst = out[::-1] if plan.reverse else out
    tap = dtype.type(plan.tap)
    for b in range(blocks):
        lo, hi = b * block, min(n, (b + 1) * block)
        f = state
        for k in range(lo, hi):
            dst[k] = f.real.sum(axis=0, dtype=dtype) + tap * src[k]
            f = lam[:, k, None] * f + kap[:, k, None] * src[k]
        state = power[:, b, None] * state + ends[b]
    return out


# --------------------------------------------------------------------------------------
# per-line plans: one shift-invariant single-section pass per line (e.g. a shear's shifts)
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LinePlans:
    """One shift-invariant, single-section pass per line, for lines of ``n`` samples.

    Line ``i`` runs ``run_reference`` with ``lam[i]``, ``kap[i]`` at every step, direct term
    ``tap[i]``, initial state ``Σ_j omega[i, j] I[j] + omega_c[i] cval`` and traversal
    reversed where ``reverse[i]``.  Lines whose pass is the identity have ``tap = 1`` and
    zero coefficients.  Used where the amount varies from line to line (the shears of
    :func:`gfgpu.motion.motion_blur`'s rotation), which one :class:`PassPlan` cannot express.
    """

    lam: np.ndarray      # (m,) complex128
    kap: np.ndarray      # (m,) complex128
    tap: np.ndarray      # (m,) float64
    reverse: np.ndarray  # (m,) bool
    omega: np.ndarray    # (m, L) complex64 for float32 plans, else complex128 (computed in complex128)
    omega_c: np.ndarray  # (m,) complex128
    n: int

    @property
    def lines(self):
        return len(self.lam)

    def packed(self, dtype):
        """Real arrays for kernels: lam, kap (m, 2), tap (m,), reverse (m,) int32,
        omega (m, L, 2), omega_c (m, 2)."""
        def split(z):
            z = np.ascontiguousarray(z)
            pairs = z.view(z.real.dtype).reshape(z.shape + (2,))      # no copy
            return pairs if pairs.dtype == dtype else pairs.astype(dtype)
        return (split(self.lam), split(self.kap), np.ascontiguousarray(self.tap, dtype),
                self.reverse.astype(np.int32), split(self.omega), split(self.omega_c))


def plan_lines(line_passes, n, mode, dtype):
    """:class:`LinePlans` from one :class:`~gfgpu._core.passes.LinePass` per line (None: identity).

    Each pass must have one shift-invariant section; boundary modes as in :func:`plan_pass`.
    The coefficients are read from the passes; the plans are built by :func:`line_plans`.
    """
    check_mode(mode)
    m = len(line_passes)
    lam = np.zeros(m, np.complex128)
    kap = np.zeros(m, np.complex128)
    tap = np.ones(m)
    reverse = np.zeros(m, bool)
    identity = np.ones(m, bool)
    for i, lp in enumerate(line_passes):
        if lp is None:
            continue
        if len(lp.sections) != 1 or not lp.sections[0].shift_invariant:
            raise ValueError("per-line plans take passes of one shift-invariant section")
        sec = lp.sections[0]
        lam[i], kap[i], tap[i], reverse[i], identity[i] = sec.lam, sec.kap, lp.tap, lp.reverse, False
    return line_plans(lam, kap, tap, reverse, n, mode, dtype, identity)


def line_plans(lam, kap, tap, reverse, n, mode, dtype, identity=None):
    """:class:`LinePlans` from per-line arrays, vectorised over the lines.

    Line ``i`` runs the single shift-invariant section ``lam[i]``, ``kap[i]`` with direct term
    ``tap[i]``, reversed where ``reverse[i]``; lines where ``identity`` is true (default: none)
    pass their input through (``tap = 1``, zero coefficients).  ``|lam| < 1`` is required.

    The initial states are the geometric series of :func:`plan_pass` summed in closed form
    over the periods of the extension (wrap: n, reflect: 2n, mirror: 2n - 2), so the cost is
    O(lines x L) array arithmetic, ``L`` being the longest initial window kept: weights below
    ``tol`` relative to a line's largest are dropped at its end, as :func:`plan_pass` does.
    """
    check_mode(mode)
    n = int(n)
    lam = np.array(lam, np.complex128).reshape(-1)
    m = len(lam)
    kap = np.array(np.broadcast_to(kap, (m,)), np.complex128)
    tap = np.array(np.broadcast_to(tap, (m,)), np.float64)
    reverse = np.array(np.broadcast_to(reverse, (m,)), bool)
    ident = np.zeros(m, bool) if identity is None else np.array(np.broadcast_to(identity, (m,)), bool)
    lam[ident], kap[ident], tap[ident], reverse[ident] = 0, 0, 1.0, False
    mag = np.abs(lam)
    if (mag >= 1).any():
        raise ValueError("per-line plans need decaying sections (|lam| < 1)")
    tol = TOL[np.dtype(dtype)]
    store = np.complex64 if np.dtype(dtype) == np.float32 else np.complex128
    omega, omega_c = _line_initial_weights(lam, kap, n, mode, tol, store)
    omega[ident], omega_c[ident] = 0, 0
    return LinePlans(lam, kap, tap, reverse, omega, omega_c, n)


def _powers(lam, k):
    """``lam[:, None] ** k[None, :]`` for integers ``k >= 0`` (``0 ** 0 = 1``), as exp(k log lam)."""
    k = np.asarray(k, np.float64)
    zero = lam == 0
    log = np.log(np.where(zero, 1.0, lam))
    out = np.exp(log[:, None] * k[None, :])
    return np.where(zero[:, None], (k == 0)[None, :].astype(np.float64), out)


_BLOCK = 64


def _geometric(lam, coef, first, count):
    """``coef[:, None] * lam[:, None] ** (first + arange(count))`` (``first`` an integer >= 0).

    The product of a table of ``lam^b`` (b < 64) and one of ``lam^(first + 64 a)``, each a
    running product of at most ``max(64, count/64)`` factors, so the relative rounding stays
    below ``(64 + count/64)`` float64 ulps whatever the exponent.
    """
    rows = len(lam)
    blocks = -(-count // _BLOCK)
    low = np.empty((rows, _BLOCK), np.complex128)
    low[:, 0] = 1.0
    low[:, 1:] = lam[:, None]
    np.cumprod(low, axis=1, out=low)
    high = np.empty((rows, blocks), np.complex128)
    high[:, 0] = coef * _powers(lam, [first])[:, 0]
    high[:, 1:] = _powers(lam, [_BLOCK])
    np.cumprod(high, axis=1, out=high)
    return (high[:, :, None] * low[:, None, :]).reshape(rows, -1)[:, :count]


def _line_initial_weights(lam, kap, n, mode, tol, store=np.complex128, chunk=64):
    """omega (lines, L) and omega_c (lines,) of single shift-invariant sections (see
    :func:`line_plans`): ``omega[i, j] = Σ_{m >= 1, e(-m) = j} kap_i lam_i^(m-1)``, summed in
    closed form over the periods of the extension.

    Line i's terms fall below ``tol`` after ``cut_i`` samples (``|lam|^m < tol``, as
    :func:`plan_pass` sums them); its window is computed to ``min(n, cut_i + 1)`` samples (wrap:
    at the end of the line, where its first terms sit) and left zero beyond, in chunks of lines
    of similar reach, so the work is about Σ_i min(n, cut_i) rather than lines x n.  Each chunk
    is computed in complex128 and stored as ``store`` (complex64 for float32 plans).
    """
    m = len(lam)
    total = kap / (1 - lam)
    if mode == "constant":
        return np.zeros((m, 0), store), total
    if mode == "nearest" or n == 1:
        return total[:, None].astype(store), np.zeros(m, np.complex128)
    mag = np.abs(lam)
    safe = np.where((mag > 0) & (mag < 1), mag, 0.5)
    cut = np.where(mag > 0, np.ceil(np.log(tol) / np.log(safe)) + 1, 1)
    reach = np.minimum(n, cut + 1).astype(np.int64)
    width = n if mode == "wrap" else int(reach.max(initial=0))
    omega = np.zeros((m, width), store)
    period = mode_period(n, mode)
    amp = kap / (1 - _powers(lam, [period])[:, 0])
    order = np.argsort(reach, kind="stable")
    for c0 in range(0, m, chunk):
        rows = order[c0:c0 + chunk]
        k = int(reach[rows].max())
        lr, ar = lam[rows], amp[rows]
        if mode == "wrap":
            # j holds m = n - j (j >= 1) or n (j = 0), plus periods: lam^(n-1-j), j >= n - k
            omega[rows, n - k:] = _geometric(lr, ar, 0, k)[:, ::-1]
            continue
        if mode == "reflect":
            # -1 -> 0, ..., -n -> n-1, -(n+1) -> n-1, ..., -2n -> 0: m = j + 1 or 2n - j
            block = _geometric(lr, ar, 0, k)
            if k == n:
                block += _geometric(lr, ar, n, n)[:, ::-1]              # lam^(2n-1-j)
        else:
            # mirror: -1 -> 1, ..., -(n-1) -> n-1, -n -> n-2, ..., -(2n-2) -> 0
            block = np.empty((len(rows), k), np.complex128)
            block[:, 0] = ar * _powers(lr, [period - 1])[:, 0]           # m = 2n - 2
            block[:, 1:] = _geometric(lr, ar, 0, k - 1)                 # m = j: lam^(j-1)
            if k == n and n > 2:
                block[:, 1:n - 1] += _geometric(lr, ar, n - 1, n - 2)[:, ::-1]   # lam^(2n-3-j)
        omega[rows, :k] = block
    return omega, np.zeros(m, np.complex128)


def run_reference_lines(lines, plans: LinePlans, cval=0.0, out=None):
    """Executable specification of the per-line primitive (numpy, vectorised over lines).

    ``lines`` has shape ``(n, m)``: line ``i`` is column ``i``, in natural order (reversed
    lines are traversed from the end).  Computation in the input's dtype.
    """
    lines = np.asarray(lines)
    dtype = lines.dtype
    cdt = np.complex64 if dtype == np.float32 else np.complex128
    n, m = lines.shape
    if out is None:
        out = np.empty_like(lines)
    rev = plans.reverse
    src = np.where(rev, lines[::-1], lines)     # traversal order per line
    L = plans.omega.shape[1]
    state = np.einsum("ij,ji->i", plans.omega.astype(cdt), src[:L].astype(cdt)) if L else np.zeros(m, cdt)
    state = state + plans.omega_c.astype(cdt) * dtype.type(cval)
    lam, kap, tap = plans.lam.astype(cdt), plans.kap.astype(cdt), plans.tap.astype(dtype)
    res = np.empty_like(lines)
    for k in range(n):
        v = src[k]
        res[k] = state.real + tap * v
        state = lam * state + kap * v
    out[...] = np.where(rev, res[::-1], res)
    return out
