"""The portable numpy backend: float64, vectorised over lines.

Constant-coefficient passes (G_u, H_u, shift, D, P) use an exact *blocked* form of the
recursion: within a block of ``T`` steps the response to the block's own samples is a fixed
``T x T`` lower-triangular Toeplitz matrix and the response to the state entering the block is
``lam^j``, so one block of all lines is two small matrix products (BLAS), and only the ``N/T``
block carries run sequentially.  This is the same linear map as :func:`run_reference` (no
truncation), rounded differently.  Per-position passes (the affine kernels) step through
:func:`gfgpu._core.recursion.run_reference`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from threadpoolctl import ThreadpoolController

from ..._core.magnitude import host_in_range
from ..._core.recursion import run_reference, run_reference_lines
from ..base import Backend, check_line_plans

_BLOCK = 64


@lru_cache(maxsize=64)
def _block_matrices(plan, block):
    """Matrices of one block for a constant-coefficient plan (float64).

    ``out_in`` (T, T): output at step j from input at step i (Σ_s Re(kap λ^(j-1-i)) for i < j,
    plus the tap on the diagonal); ``out_state`` (T, 2S): output from the entering state's real
    and imaginary parts; ``carry_in`` (2S, T) and ``carry_state`` (2S, 2S): the state leaving
    the block.
    """
    lam = plan.lam[:, 0]
    kap = plan.kap[:, 0]
    S = len(lam)
    j = np.arange(block)
    diff = j[:, None] - j[None, :] - 1
    powers = np.power(lam[:, None, None], np.maximum(diff, 0)[None].astype(np.float64))
    resp = np.where(diff[None] >= 0, kap[:, None, None] * powers, 0)            # (S, T, T) complex
    out_in = resp.real.sum(axis=0) + plan.tap * np.eye(block)
    lam_j = np.power(lam[:, None], j[None].astype(np.float64))                  # (S, T)
    # Re(lam^j F) = Re(lam^j) Re F - Im(lam^j) Im F
    out_state = np.concatenate([lam_j.real.T, -lam_j.imag.T], axis=1)          # (T, 2S)
    tail = kap[:, None] * np.power(lam[:, None], (block - 1 - j)[None].astype(np.float64))  # (S, T)
    carry_in = np.concatenate([tail.real, tail.imag], axis=0)                   # (2S, T)
    lt = lam**block
    carry_state = np.zeros((2 * S, 2 * S))
    for s in range(S):
        carry_state[s, s], carry_state[s, S + s] = lt[s].real, -lt[s].imag
        carry_state[S + s, s], carry_state[S + s, S + s] = lt[s].imag, lt[s].real
    return out_in, out_state, carry_in, carry_state


@lru_cache(maxsize=1)
def _blas_controller():
    # inspecting the loaded libraries is the costly part (0.4 ms per call); do it once
    return ThreadpoolController()


def _blocked(lines, plan, cval, steps_last=False):
    """Blocked evaluation of a constant plan, float64, on ``lines`` in traversal order.

    ``lines`` is ``(n, m)`` (step k is row k, one column per line) or, with ``steps_last``,
    ``(m, n)`` (one row per line): the same products with the matrices transposed instead of
    the data.  The block products are small (T x T times T x m): BLAS runs them on one
    thread, since a multi-threaded BLAS spins and slows several-fold when the cores are
    shared (measured 5x on 2 busy cores).
    """
    # errstate: a non-finite sample is refused by the finite check that reads this pass's
    # input or result; numpy's RuntimeWarning would come before that one error
    with _blas_controller().limit(limits=1, user_api="blas"), np.errstate(invalid="ignore", over="ignore"):
        if steps_last:
            return _blocked_products(lines.T, plan, cval, transposed=True).T
        return _blocked_products(lines, plan, cval)


def _blocked_products(lines, plan, cval, transposed=False):
    """``lines`` (n, m) view; with ``transposed`` it is the transpose of a row-major (m, n)
    array and the products are evaluated as ``x.T @ M.T`` to stream the rows."""
    n, m = lines.shape
    S = plan.sections
    L = plan.omega.shape[1]
    state = plan.omega @ lines[:L] if L else np.zeros((S, m), np.complex128)
    state = state + (plan.omega_c * cval)[:, None]
    state = np.concatenate([state.real, state.imag], axis=0)                    # (2S, m)
    out_in, out_state, carry_in, carry_state = _block_matrices(plan, _BLOCK)
    if transposed:
        out = np.empty((m, n), np.float64)
        rows = lines.T                                                          # (m, n)
        st = np.ascontiguousarray(state.T)                                      # (m, 2S)
        for k0 in range(0, n, _BLOCK):
            x = rows[:, k0:k0 + _BLOCK]
            t = x.shape[1]
            out[:, k0:k0 + t] = x @ out_in[:t, :t].T + st @ out_state[:t].T
            if t == _BLOCK:
                st = x @ carry_in.T + st @ carry_state.T
        return out.T
    out = np.empty((n, m), np.float64)
    for k0 in range(0, n, _BLOCK):
        x = lines[k0:k0 + _BLOCK]
        t = x.shape[0]
        if t == _BLOCK:
            out[k0:k0 + t] = out_in @ x + out_state @ state
            state = carry_in @ x + carry_state @ state
        else:   # last, partial block: the leading t x t corner of the same matrices
            out[k0:] = out_in[:t, :t] @ x + out_state[:t] @ state
    return out


class NumpyBackend(Backend):
    name = "numpy"
    device = "host"
    supports_float64 = True

    def owns(self, array):
        return isinstance(array, np.ndarray)

    def asarray(self, host):
        return np.ascontiguousarray(host)

    def to_host(self, array):
        return np.asarray(array)

    def empty(self, shape, dtype):
        return np.empty(shape, dtype)

    def host_result(self, shape, dtype, into=None):
        return np.empty(shape, dtype) if into is None else into

    def copy(self, src, dst):
        np.copyto(dst, src)
        return dst

    def is_contiguous(self, array):
        return bool(array.flags.c_contiguous)

    def contiguous(self, array):
        return np.ascontiguousarray(array)

    def may_share_memory(self, a, b):
        return bool(np.may_share_memory(a, b))

    def reshape(self, array, shape):
        return array.reshape(shape)

    def all_finite(self, array):
        return host_in_range(array)

    def _pass(self, lines, plan, cval, steps_last=False):
        """Result of one pass, float64: ``lines`` (n, m) steps along axis 0, or (m, n)."""
        if not plan.constant:
            if steps_last:
                return run_reference(lines.T.astype(np.float64), plan, cval).T
            return run_reference(lines.astype(np.float64), plan, cval)
        flip = (slice(None), slice(None, None, -1)) if steps_last else slice(None, None, -1)
        src = lines[flip] if plan.reverse else lines
        res = _blocked(np.asarray(src, np.float64), plan, float(cval), steps_last)
        return res[flip] if plan.reverse else res

    def recurse_lines(self, src, dst, axis, plans, cval=0.0):
        check_line_plans(src, dst, axis, plans)
        for i in range(src.shape[0]):
            lines = src[i] if axis == 1 else src[i].T          # (n, m): one column per line
            res = run_reference_lines(lines.astype(np.float64), plans, cval)
            if axis == 1:
                dst[i] = res
            else:
                dst[i] = res.T
        return dst

    def recurse(self, src, dst, axis, plan, cval=0.0, accumulate=False, check=False):
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        if check:
            finite = self.all_finite(src)
            self.recurse(src, dst, axis, plan, cval, accumulate)
            return finite
        b, n, m = src.shape
        if axis == 2:
            # rows: one row per line, streamed block by block (no transposed copies)
            res = self._pass(src.reshape(b * n, m), plan, cval, steps_last=True).reshape(b, n, m)
            if accumulate:
                dst += res
            else:
                dst[...] = res
            return dst
        for i in range(b):
            res = self._pass(src[i], plan, cval)
            if accumulate:
                dst[i] += res
            else:
                dst[i] = res
        return dst

    def gather(self, src, index, cval, out):
        flat = src.reshape(-1)
        idx = np.asarray(index)
        res = flat[np.maximum(idx, 0)]
        res[idx < 0] = cval
        out.reshape(-1)[...] = res
        return out

    def translate(self, src, dst, axis, index, cval=0.0, check=False):
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        if src.ndim != 3 or src.shape != dst.shape:
            raise ValueError(f"src and dst must be 3-D arrays of one shape, got {src.shape} and {dst.shape}")
        if np.may_share_memory(src, dst):
            raise ValueError("dst may not overlap src")
        idx = np.asarray(index).reshape(-1)
        if idx.size != src.shape[axis]:
            raise ValueError(f"index has {idx.size} elements, axis {axis} has {src.shape[axis]}")
        finite = host_in_range(src) if check else None
        np.take(src, np.maximum(idx, 0), axis=axis, out=dst)
        outside = [slice(None)] * 3
        outside[axis] = idx < 0
        dst[tuple(outside)] = cval
        return finite
