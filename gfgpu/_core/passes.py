"""What one pass of the recursion computes, independent of arrays and devices.

A :class:`Section` is one first-order complex recursion ``F[x+1] = lam(x) F[x] + kap(x) I[x]``
with output ``Re F``; a :class:`LinePass` sums sections and a direct tap along a line, causal
or anticausal.  :mod:`gfgpu.greens` builds them from the chapter's kernels;
:mod:`gfgpu._core.recursion` plans and runs them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Section", "LinePass"]


@dataclass(frozen=True)
class Section:
    """One first-order complex recursion ``F[x+1] = lam(x) F[x] + kap(x) I[x]``, ``y = Re F``.

    Either shift invariant (``lam``, ``kap`` complex scalars) or given by a kernel whose
    ``coefficients(positions)`` returns per-position arrays.  ``x_min`` is the left end of
    the kernel's domain: sources must satisfy ``x0 > x_min``.
    """

    lam: complex | None = None
    kap: complex | None = None
    kernel: object | None = None   # a gfgpu.greens.GreenKernel

    @property
    def shift_invariant(self):
        return self.kernel is None

    @property
    def x_min(self):
        return -math.inf if self.kernel is None else self.kernel.x_min

    def coefficients(self, positions):
        """(lam, kap) as complex128 arrays at integer ``positions`` (float64)."""
        positions = np.asarray(positions, dtype=np.float64)
        if self.kernel is None:
            return (np.full(positions.shape, self.lam, np.complex128),
                    np.full(positions.shape, self.kap, np.complex128))
        return self.kernel.coefficients(positions)

    def taps(self, m):
        """Impulse response ``Re(kap lam^(m-1))`` for integer offsets ``m >= 1`` (shift-invariant)."""
        m = np.asarray(m)
        out = np.real(self.kap * np.power(self.lam, np.maximum(m - 1, 0).astype(np.float64)))
        return np.where(m >= 1, out, 0.0)


@dataclass(frozen=True)
class LinePass:
    """One pass of recursions along a line: ``sections`` summed, plus ``tap * I[x]``.

    ``reverse=True`` runs it anticausally (right to left).  ``offset`` (an integer) translates
    the pass's input first: the result at ``x`` is the pass applied to the boundary mode's
    extension of the line, read at ``x - offset`` (exact index arithmetic, any magnitude;
    :mod:`gfgpu._core.translation`).  The passes of one step share one offset.
    """

    sections: tuple
    tap: float = 0.0
    reverse: bool = False
    offset: int = 0

    @property
    def is_identity(self):
        """True for a pass that only translates (no sections, unit tap)."""
        return not self.sections and self.tap == 1.0

    @property
    def shift_invariant(self):
        return all(s.shift_invariant for s in self.sections)

    def mirrored(self, n):
        """The pass in traversal coordinates of a reversed line of length ``n``."""
        if not self.reverse or self.shift_invariant:
            return self
        return LinePass(tuple(s if s.kernel is None else Section(kernel=s.kernel.mirrored(n))
                              for s in self.sections), self.tap, self.reverse, self.offset)
