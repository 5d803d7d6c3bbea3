"""The range the passes compute in: images near the limits of their dtype, brought in by a power of two.

A recursion's state, a pair of passes' sum or a box's running sum can exceed the largest value
of the dtype (float32: 3.4e38) where the result does not: a float32 image of values near 1e38
then comes back as inf or NaN where the float64 specification gives the finite result.  Every
input check of the backends (the finite check fused into the first pass, the device checks and
the host checks) therefore tests that each sample is finite **and** below :func:`range_limit`,
the square root of the dtype's largest value (float32 2**64, float64 2**512): below it, any
gain of the passes up to that factor again stays in range.  An input the check refuses is
settled by :func:`settle_peak`: a non-finite sample is an error; otherwise the input is scaled
by the power of two :func:`scale_exponent` that brings its peak to [0.5, 1), the passes run on
it, and the result is scaled back (both exact, :func:`numpy.ldexp`).  Images in range, almost
all, pay nothing: the test rides on the read of the input that the finite check already makes.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["range_limit", "host_in_range", "host_peak", "scale_exponent", "within_range"]


def range_limit(dtype):
    """The largest magnitude (exclusive) an input sample of ``dtype`` is computed at unscaled:
    2**64 for float32, 2**512 for float64 (``sqrt`` of the dtype's largest value).  Device
    kernels test it as ``isfinite(x * x)``, or as ``x * 2**(emax/2)`` being finite."""
    return float(2.0 ** (np.finfo(np.dtype(dtype)).maxexp // 2))


def host_in_range(arr, block=1 << 22):
    """True if every sample of the host array ``arr`` is finite and below
    :func:`range_limit` of its dtype (integers: always), without a full-size temporary."""
    arr = np.asarray(arr)
    if arr.dtype.kind in "biu":
        return True
    return host_peak(arr, block) < range_limit(arr.dtype)


def host_peak(arr, block=1 << 22):
    """``max |arr|`` as a Python float (inf, or NaN, if a sample is not finite), block by block:
    the max and min of each block, no ``|arr|`` temporary."""
    arr = np.asarray(arr)
    if arr.size == 0:
        return 0.0
    flat = arr.reshape(-1) if arr.flags.c_contiguous else None
    chunks = [arr] if flat is None else (flat[i:i + block] for i in range(0, flat.size, block))
    peak = 0.0
    for c in chunks:
        hi, lo = float(np.max(c)), float(np.min(c))
        if math.isnan(hi) or math.isnan(lo):
            return math.nan
        peak = max(peak, hi, -lo)
    return peak


def scale_exponent(peak, dtype):
    """The exponent ``e`` such that ``ldexp(x, e)`` brings an input of peak ``max|x|`` into the
    range the passes compute in: 0 for a peak below :func:`range_limit`, else ``-exponent``
    of the peak (the scaled peak lies in [0.5, 1))."""
    if not peak < range_limit(dtype):
        return -math.frexp(peak)[1]
    return 0


def within_range(host, cval, dtype):
    """``(ldexp(host, e), ldexp(cval, e), e)`` for a finite host block whose lines all lie in it
    (a Dask task), ``e`` from its own peak (:func:`scale_exponent`; 0 almost always, and then
    ``host`` itself); one read of the block, which is also its finite check (``ValueError``)."""
    peak = max(host_peak(host), abs(float(cval)))
    if not math.isfinite(peak):
        raise ValueError("input contains NaN or infinite values")
    exp = scale_exponent(peak, dtype)
    if exp == 0:
        return host, cval, 0
    return np.ldexp(host, exp, dtype=dtype), float(np.ldexp(cval, exp)), exp
