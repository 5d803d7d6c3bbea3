"""The portable numpy backend: the executable specification, vectorised over lines."""

from __future__ import annotations

import numpy as np

from ..recursion import run_reference
from .base import Backend


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

    def reshape(self, array, shape):
        return array.reshape(shape)

    def all_finite(self, array):
        return bool(np.isfinite(array).all())

    def recurse(self, src, dst, axis, plan, cval=0.0, accumulate=False):
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        b, n, m = src.shape
        if axis == 2:
            # rows: step along the contiguous axis; transposing makes each step one
            # contiguous vector over all lines
            lines = np.ascontiguousarray(src.reshape(b * n, m).T)
            res = run_reference(lines, plan, cval)
            res = res.T.reshape(b, n, m)
            if accumulate:
                dst += res
            else:
                dst[...] = res
            return dst
        for i in range(b):
            run_reference(src[i], plan, cval, out=dst[i], accumulate=accumulate)
        return dst

    def gather(self, src, index, cval, out):
        flat = src.reshape(-1)
        idx = np.asarray(index)
        res = flat[np.maximum(idx, 0)]
        res[idx < 0] = cval
        out.reshape(-1)[...] = res
        return out
