"""Input builders of the edges fused kernels (``edges.*``, gfgpu/edges/kernels.py), run on every
backend by tests/backends/test_fused.py."""
import numpy as np
from backends.builders import builds, compare


@builds("edges.nms")
def _nms(be, kernel, rng):
    for dtype in (np.float32, np.float64):
        if np.dtype(dtype) == np.float64 and not be.supports_float64:
            continue
        gy, gx = rng.standard_normal((2, 37, 53)).astype(dtype)
        gy[5, :] = 0                                    # exact zeros and axis-aligned gradients
        gx[:, 7] = 0
        for case, (a, b) in {"normal": (gy, gx), "ties": (np.round(2 * gy), np.round(2 * gx)),
                             "small": (gy[:2, :5], gx[:2, :5])}.items():
            a, b = np.ascontiguousarray(a, dtype), np.ascontiguousarray(b, dtype)
            out = be.empty(a.shape, dtype)
            kernel(be, be.asarray(a), be.asarray(b), out)
            compare(be.to_host(out), kernel.spec(a, b), f"nms {np.dtype(dtype).name} {case}")
