"""Warp kernels of the recursion primitive, the gather and the finiteness count.

Each kernel has one generic body (``typing.Any`` dtypes) overloaded below for float32 and
float64; the host side is :mod:`gfgpu.backends.warp_backend`.  The executable specification
is :func:`gfgpu.recursion.run_reference`.

Lines are the last axis of a 3-D array *view* ``(B, lines, n)``: the rows of a C-contiguous
``(B, N, M)`` array directly, its columns through the transposed view ``(B, M, N)`` (Warp
indexes through strides, so no copy is made and one body serves both axes).
"""

from typing import Any

import warp as wp

# Forward kernels only (no adjoints): halves code generation and compile time.
wp.set_module_options({"enable_backward": False})

#: most sections a plan may have (a pole pair: the derivative and projection passes use two)
MAX_SECTIONS = 2


@wp.kernel
def recurse_lines(
    src: wp.array3d(dtype=Any),
    dst: wp.array3d(dtype=Any),
    lam: wp.array3d(dtype=Any),
    kap: wp.array3d(dtype=Any),
    omega: wp.array3d(dtype=Any),
    omega_c: wp.array2d(dtype=Any),
    sections: int,
    init_len: int,
    cval: Any,
    tap: Any,
    reverse: int,
    accumulate: int,
    constant: int,
):
    """One line per thread: ``dst[b, i, :] = pass(src[b, i, :])`` (see ``run_reference``).

    ``lam``/``kap`` are ``(S, n, 2)``, ``omega`` ``(S, L, 2)``, ``omega_c`` ``(S, 2)``: the
    real and imaginary parts of the plan.  ``init_len`` is L (0: no sample term).  Step ``k``
    visits sample ``first + step * k`` (from the end when ``reverse``).
    """
    b, i = wp.tid()
    n = src.shape[2]
    first = int(0)
    step = int(1)
    if reverse != 0:
        first = n - 1
        step = -1

    zero = type(tap)(0.0)
    # complex state of each section as (re, im) vectors indexed by section; the section loops
    # below have a literal bound, so Warp unrolls them and the state stays in registers
    fr = wp.vector(zero, zero)
    fi = wp.vector(zero, zero)
    lr = wp.vector(zero, zero)
    li = wp.vector(zero, zero)
    kr = wp.vector(zero, zero)
    ki = wp.vector(zero, zero)

    # initial state: the boundary mode folded into omega, omega_c
    for s in range(MAX_SECTIONS):
        if s < sections:
            fr[s] = omega_c[s, 0] * cval
            fi[s] = omega_c[s, 1] * cval
            # constant plans: read the coefficients once
            lr[s] = lam[s, 0, 0]
            li[s] = lam[s, 0, 1]
            kr[s] = kap[s, 0, 0]
            ki[s] = kap[s, 0, 1]
    for j in range(init_len):
        v = src[b, i, first + step * j]
        for s in range(MAX_SECTIONS):
            if s < sections:
                fr[s] = fr[s] + omega[s, j, 0] * v
                fi[s] = fi[s] + omega[s, j, 1] * v

    for k in range(n):
        x = first + step * k
        v = src[b, i, x]
        y = tap * v
        for s in range(MAX_SECTIONS):
            if s < sections:
                y = y + fr[s]
        if accumulate != 0:
            y = y + dst[b, i, x]
        dst[b, i, x] = y
        for s in range(MAX_SECTIONS):
            if s < sections:
                if constant == 0:
                    lr[s] = lam[s, k, 0]
                    li[s] = lam[s, k, 1]
                    kr[s] = kap[s, k, 0]
                    ki[s] = kap[s, k, 1]
                re = lr[s] * fr[s] - li[s] * fi[s] + kr[s] * v
                im = lr[s] * fi[s] + li[s] * fr[s] + ki[s] * v
                fr[s] = re
                fi[s] = im


@wp.kernel
def gather(src: wp.array(dtype=Any), index: wp.array(dtype=Any), cval: Any, out: wp.array(dtype=Any)):
    """``out[t] = src[index[t]]``, or ``cval`` where ``index[t] < 0``."""
    t = wp.tid()
    j = index[t]
    if j >= type(j)(0):
        out[t] = src[j]
    else:
        out[t] = cval


@wp.kernel
def count_nonfinite(values: wp.array(dtype=Any), count: wp.array(dtype=wp.int32)):
    """``count[0] += 1`` for every NaN or infinite element of ``values``."""
    t = wp.tid()
    if not wp.isfinite(values[t]):
        wp.atomic_add(count, 0, 1)


for _real in (wp.float32, wp.float64):
    _a3 = wp.array3d(dtype=_real)
    wp.overload(recurse_lines, {"src": _a3, "dst": _a3, "lam": _a3, "kap": _a3, "omega": _a3,
                                "omega_c": wp.array2d(dtype=_real), "cval": _real, "tap": _real})
    for _index in (wp.int32, wp.int64):
        wp.overload(gather, {"src": wp.array(dtype=_real), "index": wp.array(dtype=_index),
                             "cval": _real, "out": wp.array(dtype=_real)})
    wp.overload(count_nonfinite, {"values": wp.array(dtype=_real)})
del _real, _a3, _index
