"""Argument checks and the dtype policy shared by every operator.

Every public function validates its arguments here before any work starts, so that a bad
value raises one ``TypeError``/``ValueError`` that names the argument and the allowed range.

Dtype policy: float32 and float64 are preserved; boolean images and integers of up to 16 bits
(which float32 holds exactly) are converted to float32; wider integers (int32, uint32, int64,
uint64) are computed in float64, since float32 rounds integers above 2**24 (a backend without
float64 refuses them unless ``output=numpy.float32`` asks for float32); float16 is computed in
float32; complex and other types raise ``TypeError``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["finite_scalar", "positive", "scale", "work_dtype", "wide_integer", "float_dtype", "host_all_finite",
           "finite_cval", "flag", "integer", "SCALE_RANGE"]

#: the scales (pixels) a Green's-function kernel can take: below, exp(-1/u) underflows and the
#: sampled kernel is a delta (its normalisations divide by zero); above, exp(-1/u) lies within
#: float64 rounding of 1 and the recursion cannot resolve the kernel
SCALE_RANGE = (0.002, 1e9)


def finite_scalar(name, value):
    """``value`` as a finite Python float; ``TypeError``/``ValueError`` naming ``name`` otherwise."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a real number, got the string {value!r}")
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def flag(name, value):
    """``value`` as a bool; only ``True``/``False`` (and numpy bools) are accepted, so that a
    string such as ``"False"`` is an error instead of a true value."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name} must be True or False, got {value!r}")


def integer(name, value):
    """``value`` as an int; floats (even integral ones), strings and bools are errors."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    return int(value)


def positive(name, value):
    """``value`` as a finite float > 0."""
    v = finite_scalar(name, value)
    if v <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return v


def scale(name, value):
    """A kernel scale ``u`` (or σ) in pixels, within :data:`SCALE_RANGE`."""
    v = positive(name, value)
    lo, hi = SCALE_RANGE
    if not lo <= v <= hi:
        raise ValueError(f"{name} must lie in [{lo:g}, {hi:g}] pixels, got {value!r} (below, the sampled kernel "
                         f"is a delta; above, float64 cannot resolve its decay)")
    return v


def finite_cval(cval):
    """The constant of ``mode='constant'``."""
    return finite_scalar("cval", cval)


def wide_integer(dtype):
    """True for an integer dtype float32 cannot hold exactly (wider than 16 bits)."""
    dtype = np.dtype(dtype)
    return dtype.kind in "iu" and dtype.itemsize > 2


def work_dtype(dtype, name="input"):
    """The dtype an array of ``dtype`` is computed in (see the module docstring)."""
    dtype = np.dtype(dtype)
    if dtype.kind == "f" and dtype.itemsize in (4, 8):
        return np.dtype(dtype.type)          # native byte order: the devices compute natively
    if wide_integer(dtype):
        return np.dtype(np.float64)          # float32 rounds integers above 2**24
    if dtype.kind in "biu" or (dtype.kind == "f" and dtype.itemsize == 2):     # float16 of either byte order
        return np.dtype(np.float32)
    raise TypeError(f"{name} must have a real numeric dtype (float32/float64, or integer/bool: up to 16 "
                    f"bits converted to float32, wider integers to float64); got {dtype}")


def float_dtype(name, value):
    """``value`` (a dtype, type or name) as float32 or float64; ``TypeError`` naming ``name``
    for anything else (an unknown name such as ``'bogus'`` included)."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be float32 or float64, got {value!r}")
    try:
        dtype = np.dtype(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be float32 or float64 (a numpy dtype or its name), got {value!r}") from None
    if dtype.kind != "f" or dtype.itemsize not in (4, 8):
        raise TypeError(f"{name} must be float32 or float64, got {dtype}")
    return np.dtype(dtype.type)


def host_all_finite(arr, block=1 << 22):
    """``np.isfinite(arr).all()`` without a full-size temporary (large and memory-mapped images)."""
    if arr.dtype.kind in "biu":
        return True
    flat = arr.reshape(-1) if arr.flags.c_contiguous else None
    if flat is None:
        return bool(np.isfinite(arr).all())
    return all(np.isfinite(flat[i:i + block]).all() for i in range(0, flat.size, block))
