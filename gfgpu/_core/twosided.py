"""Two-sided steps: the causal and anticausal passes of one step, with shared states, as one sweep pair.

A step of a line operator sums passes along one axis (:class:`~gfgpu._core.passes.LinePass`): for
the chapter's derivative D and projection P a causal and an anticausal pass of complex sections
that share their poles (both are built from ``h_v`` at the same scales v).  Since a section's state
is linear in its ``kap``, every such section is the *unit* section ``F[x+1] = lam F[x] + I[x]``
(``kap = 1``) read out as ``Re(kap F)``; sections of equal ``lam`` share one unit state.  A
:class:`TwoSidedPlan` holds, for up to two inputs and two outputs along the same lines:

* ``lam[i, s]``: the poles of input ``i`` (its distinct ``lam`` over every pass that reads it);
* ``causal[o, s]``, ``anticausal[o, s]``: output ``o``'s weights on the causal and anticausal
  unit states of its input (``inputs[o]``), and ``tap[o]``, its direct term;
* ``omega[i, d, s, j]``, ``omega_c[i, d, s]``: the unit states' initial values (the boundary
  mode, exactly as :func:`gfgpu._core.recursion.plan_pass` folds it), ``d = 0`` causal (``j``
  from the start of the line), ``d = 1`` anticausal (``j`` from its end).

So one step reads each input and writes each output for both passes (on an OpenCL CPU device
one kernel: a backward sweep storing its states every few rows, then blocks that restart it and
run the forward sweep, each output written once): the gradient's two column passes (P and D of
the same image) are one step.  :func:`run_two_sided_reference` is the
executable specification; it equals the sum of the passes by
:func:`~gfgpu._core.recursion.run_reference` up to rounding.
"""

from __future__ import annotations

import struct
import threading
from collections import OrderedDict
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .passes import LinePass, Section
from .recursion import check_mode, invariant_window

__all__ = ["TwoSidedPlan", "plan_two_sided", "run_two_sided_reference", "MAX_SECTIONS"]

#: most distinct poles per input: complex sections (the chapter's D and P at two scales, P at
#: its own scale), real ones (the one-signed D of :mod:`gfgpu.edges.operator`: two per scale)
MAX_SECTIONS = {False: 4, True: 8}


@dataclass(frozen=True, eq=False)
class TwoSidedPlan:
    lam: np.ndarray        # (NIN, S) complex128
    causal: np.ndarray     # (NOUT, S) complex128
    anticausal: np.ndarray  # (NOUT, S) complex128
    tap: np.ndarray        # (NOUT,) float64
    inputs: tuple          # the input each output reads
    omega: np.ndarray      # (NIN, 2, S, L) complex128
    omega_c: np.ndarray    # (NIN, 2, S) complex128
    n: int

    @property
    def sections(self):
        return self.lam.shape[1]

    @property
    def real(self):
        """True when every pole and weight is real: the states are real (a quarter of the work)."""
        return not (self.lam.imag.any() or self.causal.imag.any() or self.anticausal.imag.any()
                    or self.omega.imag.any() or self.omega_c.imag.any())

    def packed(self, dtype):
        """``(coef, omega)`` as real arrays of ``dtype``, the layout of ``twosided.cl``: coef holds
        lam (NIN, S, 2), causal and anticausal (NOUT, S, 2), tap (NOUT,), omega_c (NIN, 2, S, 2);
        omega is (NIN, 2, S, L, 2) (at least 2 values: no empty buffers)."""
        def split(z):
            return np.stack([z.real, z.imag], axis=-1).reshape(-1)
        coef = np.concatenate([split(self.lam), split(self.causal), split(self.anticausal), self.tap,
                               split(self.omega_c)]).astype(dtype)
        omega = split(self.omega).astype(dtype)
        if omega.size < 2:
            omega = np.zeros(2, dtype)
        return np.ascontiguousarray(coef), np.ascontiguousarray(omega)


def _fusable(lp):
    return isinstance(lp, LinePass) and lp.offset == 0 and all(s.shift_invariant for s in lp.sections)


def plan_two_sided(outputs, n, mode, dtype):
    """The :class:`TwoSidedPlan` of a step, or None where one cannot express it.

    Parameters
    ----------
    outputs : sequence of (int, sequence of LinePass)
        Per output (one or two): the input it reads (0, or 1 with two inputs) and the passes
        summed into it (shift-invariant sections, no translation).
    n : int
        Samples per line.
    mode : str
        Boundary mode.
    dtype : numpy dtype
        The work dtype (the tolerance of the initial states, as :func:`plan_pass`).

    Returns
    -------
    TwoSidedPlan or None
        None when a pass translates or has shift-variant sections, or an input has more
        distinct poles than :data:`MAX_SECTIONS`.
    """
    check_mode(mode)
    key = tuple((int(i), tuple(passes)) for i, passes in outputs)
    if not key or len(key) > 2 or not all(_fusable(lp) for _, ps in key for lp in ps):
        return None
    return _plan_cached(key, int(n), mode, np.dtype(dtype).str)


@lru_cache(maxsize=128)
def _plan_cached(key, n, mode, dtype_str):
    head = _weights(key)
    if head is None:
        return None
    poles, lam, causal, anticausal, tap = head
    nin, S = lam.shape
    # the unit sections' initial weights, in traversal order of each direction (a shift-invariant
    # pass's window does not depend on its sense: both directions hold the same one)
    windows = [[invariant_window((Section(lam=lam[i, s], kap=1.0 + 0j),), n, mode, dtype_str)
                if s < len(poles[i]) else None for s in range(S)] for i in range(nin)]
    omega, omega_c = _states(windows)
    return TwoSidedPlan(lam, causal, anticausal, tap, tuple(i for i, _ in key), omega, omega_c, n)


def _weights(key):
    """The part of a step's plan that does not depend on the lines: ``(poles, lam, causal,
    anticausal, tap)``, or None where no plan expresses the step (read-only arrays); cached by the
    values' bits too (passes compare equal across -0.0 and 0.0)."""
    values = [complex(x) for _, passes in key for lp in passes
              for x in (lp.tap, *(z for sec in lp.sections for z in (sec.lam, sec.kap)))]
    return _weights_cached(key, struct.pack(f"<{2 * len(values)}d", *(v for z in values for v in (z.real, z.imag))))


@lru_cache(maxsize=64)
def _weights_cached(key, bits):
    nin = max(i for i, _ in key) + 1
    if nin > 2 or sorted({i for i, _ in key}) != list(range(nin)):
        return None
    poles = [[] for _ in range(nin)]
    for i, passes in key:
        for lp in passes:
            for sec in lp.sections:
                lam = complex(sec.lam)
                if lam not in poles[i]:
                    poles[i].append(lam)
    S = max(1, max(len(p) for p in poles))
    real = all(p.imag == 0 for ps in poles for p in ps) and all(
        complex(sec.kap).imag == 0 for _, ps in key for lp in ps for sec in lp.sections)
    if S > MAX_SECTIONS[real]:
        return None
    nout = len(key)
    lam = np.zeros((nin, S), np.complex128)
    causal = np.zeros((nout, S), np.complex128)
    anticausal = np.zeros((nout, S), np.complex128)
    tap = np.zeros(nout)
    for i, ps in enumerate(poles):
        lam[i, :len(ps)] = ps
    for o, (i, passes) in enumerate(key):
        for lp in passes:
            tap[o] += lp.tap
            weights = anticausal if lp.reverse else causal
            for sec in lp.sections:
                weights[o, poles[i].index(complex(sec.lam))] += complex(sec.kap)
    for arr in (lam, causal, anticausal, tap):
        arr.setflags(write=False)
    return poles, lam, causal, anticausal, tap


_STATES_CACHE_SIZE = 64
_states_cache = OrderedDict()    # ids of the unit windows -> (windows, omega, omega_c)
_states_lock = threading.Lock()


def _states(windows):
    """``omega (NIN, 2, S, L)`` and ``omega_c (NIN, 2, S)`` from the unit sections' windows
    (None: no such section), cached by the windows' identities (the windows of a line length
    beyond their reach are shared, :func:`~gfgpu._core.recursion.invariant_window`; the entry
    keeps them, so their ids stay theirs)."""
    key = tuple(None if w is None else (id(w[0]), id(w[1])) for row in windows for w in row)
    with _states_lock:
        hit = _states_cache.get(key)
        if hit is not None:
            _states_cache.move_to_end(key)
            return hit[1], hit[2]
    nin, S = len(windows), len(windows[0])
    L = max(0 if w is None else w[0].shape[1] for row in windows for w in row)
    omega = np.zeros((nin, 2, S, L), np.complex128)
    omega_c = np.zeros((nin, 2, S), np.complex128)
    for i, row in enumerate(windows):
        for s, w in enumerate(row):
            if w is not None:
                omega[i, :, s, :w[0].shape[1]] = w[0][0]
                omega_c[i, :, s] = w[1][0]
    for arr in (omega, omega_c):
        arr.setflags(write=False)
    with _states_lock:
        _states_cache[key] = (windows, omega, omega_c)
        if len(_states_cache) > _STATES_CACHE_SIZE:
            _states_cache.popitem(last=False)
    return omega, omega_c


def run_two_sided_reference(inputs, plan, cvals=(0.0, 0.0)):
    """Executable specification of a two-sided step (numpy, vectorised over lines).

    ``inputs`` are arrays ``(n, m)`` (``m`` lines of ``n`` samples, natural order), one per input
    of ``plan``, of one real dtype; ``cvals`` the constant of each input's extension.  Returns the
    list of outputs ``(n, m)``, computed in the inputs' dtype (complex64 states for float32).
    """
    inputs = [np.asarray(x) for x in inputs]
    dtype = inputs[0].dtype
    cdt = np.complex64 if dtype == np.float32 else np.complex128
    n = plan.n
    L = plan.omega.shape[-1]
    outs = [np.zeros_like(inputs[i]) for i in plan.inputs]
    for o, i in enumerate(plan.inputs):
        x = inputs[i]
        outs[o] += dtype.type(plan.tap[o]) * x
    for d in range(2):
        for i, x in enumerate(inputs):
            src = x[::-1] if d else x
            lam = plan.lam[i].astype(cdt)[:, None]
            state = (plan.omega[i, d].astype(cdt) @ src[:L].astype(cdt)) if L else \
                np.zeros((plan.sections, x.shape[1]), cdt)
            state = state + (plan.omega_c[i, d].astype(cdt) * dtype.type(cvals[i]))[:, None]
            readers = [o for o, j in enumerate(plan.inputs) if j == i]
            weights = {o: (plan.anticausal if d else plan.causal)[o].astype(cdt)[:, None] for o in readers}
            views = {o: (outs[o][::-1] if d else outs[o]) for o in readers}
            for k in range(n):
                for o in readers:
                    views[o][k] += (weights[o] * state).real.sum(axis=0, dtype=dtype)
                state = lam * state + src[k].astype(cdt)
    return outs
