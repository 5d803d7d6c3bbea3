"""Warp kernels: the recursion primitive, the gather, the translation and the non-finite count.

Each kernel has one generic body (``typing.Any``) overloaded at the bottom of this module;
the host side is :mod:`gfgpu.backends.warp.backend` and the executable specification is
:func:`gfgpu._core.recursion.run_reference`.

:func:`recurse_lines` runs one line per thread along the last axis of a 3-D *view*
``(B, lines, n)`` of the data: the rows of a C-contiguous ``(B, N, M)`` array directly, its
columns through the transposed, strided view ``(B, M, N)`` (Warp indexes through strides, so
no copy is made).  Its body, :func:`run_line`, is generic in the sample type: for columns on
the CPU, :mod:`gfgpu.backends.warp.recurse_lanes` (a CPU-only module, so CUDA never compiles it)
runs it on vectors of adjacent columns.  On a GPU one thread per column is already coalesced.
Lines too few to fill a GPU run block-parallel (:func:`block_states`, :func:`compose`,
:func:`block_outputs`).
"""

from typing import Any

import warp as wp

# Forward kernels only (no adjoints): less code to generate and compile.
wp.set_module_options({"enable_backward": False})

#: most sections a plan may have (a pole pair: the derivative and projection passes use two)
MAX_SECTIONS = 2



@wp.func
def _coefficients(lam: wp.array3d(dtype=Any), kap: wp.array3d(dtype=Any), s: int, k: int):
    """``(Re lam, Im lam, Re kap, Im kap)`` of section ``s`` at step ``k``."""
    return wp.vector(lam[s, k, 0], lam[s, k, 1], kap[s, k, 0], kap[s, k, 1])


@wp.func
def _advance(fr: Any, fi: Any, c: Any, v: Any):
    """One step ``F <- lam F + kap v`` of a section, ``F = fr + i fi``, ``c`` from _coefficients."""
    return c[0] * fr - c[1] * fi + c[2] * v, c[0] * fi + c[1] * fr + c[3] * v


@wp.func
def _initial(src: wp.array3d(dtype=Any), b: int, i: int, first: int, step: int,
             omega: wp.array3d(dtype=Any), omega_c: wp.array2d(dtype=Any), s: int,
             init_len: int, cval: Any):
    """Initial state of section ``s``: the boundary mode, ``Σ_j omega[s, j] I[j] + omega_c[s] cval``."""
    fr = src.dtype(omega_c[s, 0] * cval)   # a real, or a vector filled with it
    fi = src.dtype(omega_c[s, 1] * cval)
    for j in range(init_len):
        v = src[b, i, first + step * j]
        fr = fr + omega[s, j, 0] * v
        fi = fi + omega[s, j, 1] * v
    return fr, fi


@wp.func
def run_line(
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
    b: int,
    i: int,
):
    """One pass over line ``src[b, i, :]`` into ``dst[b, i, :]`` (``run_reference``).

    ``lam``/``kap`` are ``(S, n, 2)``, ``omega`` ``(S, L, 2)``, ``omega_c`` ``(S, 2)``: real
    and imaginary parts of the plan in the real type; ``init_len`` is L (0: no sample term).
    Step ``k`` visits sample ``first + step * k``, from the end when ``reverse``.  The state
    is kept in the samples' precision.  ``dst`` may be ``src`` unless ``accumulate``: each
    sample is read before it is written.
    """
    n = src.shape[2]
    first = (n - 1) * reverse   # reverse is 0 or 1
    step = 1 - 2 * reverse
    # sections 0 and (when S = 2) 1, written out: their states have the sample type
    two = sections > 1
    f0r, f0i = _initial(src, b, i, first, step, omega, omega_c, 0, init_len, cval)
    f1r = src.dtype(type(cval)(0.0))
    f1i = f1r
    c0 = _coefficients(lam, kap, 0, 0)   # constant plans read their coefficients once
    c1 = c0
    if two:
        f1r, f1i = _initial(src, b, i, first, step, omega, omega_c, 1, init_len, cval)
        c1 = _coefficients(lam, kap, 1, 0)

    for k in range(n):
        x = first + step * k
        v = src[b, i, x]
        y = tap * v + f0r
        if two:
            y = y + f1r
        if accumulate != 0:
            y = y + dst[b, i, x]
        dst[b, i, x] = y
        if constant == 0:
            c0 = _coefficients(lam, kap, 0, k)
            if two:
                c1 = _coefficients(lam, kap, 1, k)
        f0r, f0i = _advance(f0r, f0i, c0, v)
        if two:
            f1r, f1i = _advance(f1r, f1i, c1, v)




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
    """:func:`run_line` on line ``(b, i)``, real samples (every device; CPU vector lanes:
    :mod:`gfgpu.backends.warp.recurse_lanes`)."""
    b, i = wp.tid()
    run_line(src, dst, lam, kap, omega, omega_c, sections, init_len, cval, tap, reverse, accumulate, constant, b, i)


@wp.kernel
def recurse_window(
    src: wp.array3d(dtype=Any),
    dst: wp.array3d(dtype=Any),
    window: wp.array(dtype=wp.int32),
    first: int,
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
):
    """A translated pass over line ``(b, i)`` read through a window index (GPU shapes): the
    recursion runs over the ``len(window)`` positions, position ``w`` reads ``src[b, i,
    window[w]]`` (``cval`` where negative) and is output sample ``w - first``, written when it
    lies on the line.  Shift-invariant sections (constant coefficients)."""
    b, i = wp.tid()
    nw = window.shape[0]
    n = src.shape[2]
    two = sections > 1
    f0r = omega_c[0, 0] * cval
    f0i = omega_c[0, 1] * cval
    f1r = f0r
    f1i = f0i
    if two:
        f1r = omega_c[1, 0] * cval
        f1i = omega_c[1, 1] * cval
    for j in range(init_len):
        w = j
        if reverse != 0:
            w = nw - 1 - j
        q = window[w]
        v = cval
        if q >= 0:
            v = src[b, i, q]
        f0r = f0r + omega[0, j, 0] * v
        f0i = f0i + omega[0, j, 1] * v
        if two:
            f1r = f1r + omega[1, j, 0] * v
            f1i = f1i + omega[1, j, 1] * v
    c0 = _coefficients(lam, kap, 0, 0)
    c1 = c0
    if two:
        c1 = _coefficients(lam, kap, 1, 0)
    for k in range(nw):
        w = k
        if reverse != 0:
            w = nw - 1 - k
        q = window[w]
        v = cval
        if q >= 0:
            v = src[b, i, q]
        x = w - first
        if x >= 0 and x < n:
            y = tap * v + f0r
            if two:
                y = y + f1r
            if accumulate != 0:
                y = y + dst[b, i, x]
            dst[b, i, x] = y
        f0r, f0i = _advance(f0r, f0i, c0, v)
        if two:
            f1r, f1i = _advance(f1r, f1i, c1, v)


@wp.func
def _initial_part(src: wp.array3d(dtype=Any), b: int, i: int, first: int, step: int,
                  omega: wp.array3d(dtype=Any), s: int, j_lo: int, j_hi: int):
    """The omega terms of traversal positions ``j_lo .. j_hi - 1`` of section ``s``."""
    fr = src.dtype(0.0)
    fi = src.dtype(0.0)
    for j in range(j_lo, j_hi):
        v = src[b, i, first + step * j]
        fr = fr + omega[s, j, 0] * v
        fi = fi + omega[s, j, 1] * v
    return fr, fi


@wp.kernel
def block_states(
    src: wp.array3d(dtype=Any),
    lam: wp.array3d(dtype=Any),
    kap: wp.array3d(dtype=Any),
    omega: wp.array3d(dtype=Any),
    sections: int,
    init_len: int,
    reverse: int,
    constant: int,
    block: int,
    check: int,
    carry: wp.array4d(dtype=Any),
    partial: wp.array4d(dtype=Any),
    flag: wp.array(dtype=wp.int32),
):
    """Block-parallel lines, phase 1: block ``blk`` of line ``src[b, i, :]`` run from a zero
    state; its end state goes to ``carry[b, blk, 2s + (0: re, 1: im), i]`` and its part of the
    initial state (the omega terms of its own samples) to ``partial`` (same layout).  With
    ``check``, ``flag[0] = 1`` if a sample it reads is NaN or infinite."""
    b, i, blk = wp.tid()
    n = src.shape[2]
    k_lo = blk * block
    k_hi = wp.min(n, k_lo + block)
    first = (n - 1) * reverse
    step = 1 - 2 * reverse
    two = sections > 1
    j_hi = wp.min(k_hi, init_len)
    p0r, p0i = _initial_part(src, b, i, first, step, omega, 0, k_lo, j_hi)
    partial[b, blk, 0, i] = p0r
    partial[b, blk, 1, i] = p0i
    if two:
        p1r, p1i = _initial_part(src, b, i, first, step, omega, 1, k_lo, j_hi)
        partial[b, blk, 2, i] = p1r
        partial[b, blk, 3, i] = p1i
    f0r = src.dtype(0.0)
    f0i = f0r
    f1r = f0r
    f1i = f0r
    c0 = _coefficients(lam, kap, 0, k_lo)
    c1 = c0
    if two:
        c1 = _coefficients(lam, kap, 1, k_lo)
    for k in range(k_lo, k_hi):
        v = src[b, i, first + step * k]
        if check != 0:
            # v * v overflows exactly at the range limit sqrt(max) (gfgpu._core.magnitude)
            if not wp.isfinite(v * v):
                flag[0] = 1     # rare: a store only where a sample is bad
        if constant == 0:
            c0 = _coefficients(lam, kap, 0, k)
            if two:
                c1 = _coefficients(lam, kap, 1, k)
        f0r, f0i = _advance(f0r, f0i, c0, v)
        if two:
            f1r, f1i = _advance(f1r, f1i, c1, v)
    carry[b, blk, 0, i] = f0r
    carry[b, blk, 1, i] = f0i
    if two:
        carry[b, blk, 2, i] = f1r
        carry[b, blk, 3, i] = f1i


@wp.kernel
def compose(
    carry: wp.array4d(dtype=Any),
    partial: wp.array4d(dtype=Any),
    omega_c: wp.array2d(dtype=Any),
    blockpow: wp.array3d(dtype=Any),
    sections: int,
    cval: Any,
):
    """Block-parallel lines, phase 2: line ``(b, i)``'s initial state is ``omega_c cval`` plus its
    blocks' ``partial`` parts; each block's start state replaces its end state in ``carry``,
    ``F <- blockpow[s, blk] F + end[blk]`` (``blockpow``: the product of the block's lam)."""
    b, i = wp.tid()
    nblocks = carry.shape[1]
    for s in range(sections):
        fr = omega_c[s, 0] * cval
        fi = omega_c[s, 1] * cval
        for blk in range(nblocks):
            fr = fr + partial[b, blk, 2 * s, i]
            fi = fi + partial[b, blk, 2 * s + 1, i]
        for blk in range(nblocks):
            er = carry[b, blk, 2 * s, i]
            ei = carry[b, blk, 2 * s + 1, i]
            carry[b, blk, 2 * s, i] = fr
            carry[b, blk, 2 * s + 1, i] = fi
            pr = blockpow[s, blk, 0]
            pi = blockpow[s, blk, 1]
            nr = pr * fr - pi * fi + er
            fi = pr * fi + pi * fr + ei
            fr = nr


@wp.kernel
def block_outputs(
    src: wp.array3d(dtype=Any),
    dst: wp.array3d(dtype=Any),
    lam: wp.array3d(dtype=Any),
    kap: wp.array3d(dtype=Any),
    sections: int,
    tap: Any,
    reverse: int,
    accumulate: int,
    constant: int,
    block: int,
    carry: wp.array4d(dtype=Any),
):
    """Block-parallel lines, phase 3: block ``blk`` of line ``(b, i)`` run from its start state
    (``carry``, after :func:`compose`), writing its outputs (``run_reference``'s step)."""
    b, i, blk = wp.tid()
    n = src.shape[2]
    k_lo = blk * block
    k_hi = wp.min(n, k_lo + block)
    first = (n - 1) * reverse
    step = 1 - 2 * reverse
    two = sections > 1
    f0r = carry[b, blk, 0, i]
    f0i = carry[b, blk, 1, i]
    f1r = f0r
    f1i = f0i
    c0 = _coefficients(lam, kap, 0, k_lo)
    c1 = c0
    if two:
        f1r = carry[b, blk, 2, i]
        f1i = carry[b, blk, 3, i]
        c1 = _coefficients(lam, kap, 1, k_lo)
    for k in range(k_lo, k_hi):
        x = first + step * k
        v = src[b, i, x]
        y = tap * v + f0r
        if two:
            y = y + f1r
        if accumulate != 0:
            y = y + dst[b, i, x]
        dst[b, i, x] = y
        if constant == 0:
            c0 = _coefficients(lam, kap, 0, k)
            if two:
                c1 = _coefficients(lam, kap, 1, k)
        f0r, f0i = _advance(f0r, f0i, c0, v)
        if two:
            f1r, f1i = _advance(f1r, f1i, c1, v)


@wp.kernel
def recurse_per_line(
    src: wp.array3d(dtype=Any),
    dst: wp.array3d(dtype=Any),
    lam: wp.array2d(dtype=Any),
    kap: wp.array2d(dtype=Any),
    tap: wp.array(dtype=Any),
    reverse: wp.array(dtype=wp.int32),
    omega: wp.array3d(dtype=Any),
    omega_c: wp.array2d(dtype=Any),
    init_len: int,
    cval: Any,
):
    """One pass over line ``src[b, i, :]`` with line ``i``'s own coefficients
    (``run_reference_lines``): ``lam``, ``kap``, ``omega_c`` ``(m, 2)``, ``tap`` and
    ``reverse`` ``(m,)``, ``omega`` ``(m, L, 2)``.  ``dst`` may be ``src``."""
    b, i = wp.tid()
    n = src.shape[2]
    rev = reverse[i]
    first = (n - 1) * rev
    step = 1 - 2 * rev
    # the per-line arrays are indexed like a plan's sections, by the line instead of s
    fr, fi = _initial(src, b, i, first, step, omega, omega_c, i, init_len, cval)
    c = wp.vector(lam[i, 0], lam[i, 1], kap[i, 0], kap[i, 1])
    t = tap[i]
    for k in range(n):
        x = first + step * k
        v = src[b, i, x]
        dst[b, i, x] = t * v + fr
        fr, fi = _advance(fr, fi, c, v)


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
def translate(src: wp.array2d(dtype=Any), index: wp.array(dtype=wp.int32), cval: Any, n: int, along_rows: int,
              check: int, dst: wp.array2d(dtype=Any), flag: wp.array(dtype=wp.int32)):
    """Integer translation of the rows ``(B*N, M)``: along rows ``dst[r, j] = src[r, index[j]]``,
    along columns row ``r = b*n + k`` of ``dst`` is row ``b*n + index[k]`` of ``src``; ``cval``
    where the index is negative.  With ``check``, ``flag[0] = 1`` if ``src[r, j]`` (each sample
    once, in the same pass) is NaN or infinite."""
    r, j = wp.tid()
    if along_rows != 0:
        i = index[j]
        if i >= 0:
            dst[r, j] = src[r, i]
        else:
            dst[r, j] = cval
    else:
        k = r % n
        i = index[k]
        if i >= 0:
            dst[r, j] = src[r - k + i, j]
        else:
            dst[r, j] = cval
    if check != 0:
        x = src[r, j]
        if not wp.isfinite(x * x):      # NaN, infinite or beyond the range limit
            flag[0] = 1


@wp.kernel
def count_nonfinite(values: wp.array(dtype=Any), count: wp.array(dtype=wp.int32)):
    """``count[0] += 1`` for every element of ``values`` that is NaN, infinite or beyond the
    range limit ``sqrt(max)`` (its square overflows: :mod:`gfgpu._core.magnitude`)."""
    t = wp.tid()
    x = values[t]
    if not wp.isfinite(x * x):
        wp.atomic_add(count, 0, 1)


for _real in (wp.float32, wp.float64):
    _plan = {"lam": wp.array3d(dtype=_real), "kap": wp.array3d(dtype=_real),
             "omega": wp.array3d(dtype=_real), "omega_c": wp.array2d(dtype=_real),
             "cval": _real, "tap": _real}
    wp.overload(recurse_per_line, {"src": wp.array3d(dtype=_real), "dst": wp.array3d(dtype=_real),
                                   "lam": wp.array2d(dtype=_real), "kap": wp.array2d(dtype=_real),
                                   "tap": wp.array(dtype=_real), "omega": wp.array3d(dtype=_real),
                                   "omega_c": wp.array2d(dtype=_real), "cval": _real})
    _blocks = {"carry": wp.array4d(dtype=_real), "partial": wp.array4d(dtype=_real)}
    wp.overload(block_states, {"src": wp.array3d(dtype=_real), "lam": wp.array3d(dtype=_real),
                               "kap": wp.array3d(dtype=_real), "omega": wp.array3d(dtype=_real), **_blocks})
    wp.overload(compose, {"omega_c": wp.array2d(dtype=_real), "blockpow": wp.array3d(dtype=_real),
                          "cval": _real, **_blocks})
    wp.overload(block_outputs, {"src": wp.array3d(dtype=_real), "dst": wp.array3d(dtype=_real),
                                "lam": wp.array3d(dtype=_real), "kap": wp.array3d(dtype=_real),
                                "tap": _real, "carry": wp.array4d(dtype=_real)})
    wp.overload(recurse_lines, {"src": wp.array3d(dtype=_real), "dst": wp.array3d(dtype=_real), **_plan})
    wp.overload(recurse_window, {"src": wp.array3d(dtype=_real), "dst": wp.array3d(dtype=_real), **_plan})
    for _index in (wp.int32, wp.int64):
        wp.overload(gather, {"src": wp.array(dtype=_real), "index": wp.array(dtype=_index),
                             "cval": _real, "out": wp.array(dtype=_real)})
    wp.overload(count_nonfinite, {"values": wp.array(dtype=_real)})
    wp.overload(translate, {"src": wp.array2d(dtype=_real), "cval": _real, "dst": wp.array2d(dtype=_real)})
del _real, _plan, _index, _blocks
