"""Argument checks and the dtype policy shared by every operator.

Every public function validates its arguments here before any work starts, so that a bad
value raises one ``TypeError``/``ValueError`` that names the argument and the allowed range.

Dtype policy: float32 and float64 are preserved; integer and boolean images are converted to
float32; float16 is computed in float32; complex and other types raise ``TypeError``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["finite_scalar", "positive", "scale", "work_dtype", "host_all_finite", "finite_cval", "flag", "integer",
           "SCALE_RANGE"]

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


def work_dtype(dtype, name="input"):
    """The dtype an array of ``dtype`` is computed in (see the module docstring)."""
    dtype = np.dtype(dtype)
    if dtype.kind == "f" and dtype.itemsize in (4, 8):
        return np.dtype(dtype.type)          # native byte order: the devices compute natively
    if dtype.kind in "biu" or dtype == np.float16:
        return np.dtype(np.float32)
    raise TypeError(f"{name} must have a real numeric dtype (float32/float64, or integer/bool "
                    f"converted to float32); got {dtype}")


def host_all_finite(arr, block=1 << 22):
    """``np.isfinite(arr).all()`` without a full-size temporary (large and memory-mapped images)."""
    if arr.dtype.kind in "biu":
        return True
    flat = arr.reshape(-1) if arr.flags.c_contiguous else None
    if flat is None:
        return bool(np.isfinite(arr).all())
    return all(np.isfinite(flat[i:i + block]).all() for i in range(0, flat.size, block))
