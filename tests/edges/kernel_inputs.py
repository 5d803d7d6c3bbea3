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


def _midpoints(values, quantiles):
    """Thresholds halfway between neighbouring distinct ``values`` near the ``quantiles``: no value
    lies within rounding of them, so every backend classifies every pixel alike."""
    v = np.unique(values)
    picks = []
    for q in quantiles:
        k = min(max(int(q * (len(v) - 1)), 0), len(v) - 2)
        picks.append(0.5 * (float(v[k]) + float(v[k + 1])))
    return picks


@builds("edges.nms_classes")
def _nms_classes(be, kernel, rng):
    from gfgpu.edges.spec import suppress_nonmaxima_reference
    for dtype in (np.float32, np.float64):
        if np.dtype(dtype) == np.float64 and not be.supports_float64:
            continue
        for shape in ((37, 53), (40, 66), (2, 5)):
            gy, gx = rng.standard_normal((2, *shape)).astype(dtype)
            gy[1, :] = 0
            s = suppress_nonmaxima_reference(gy, gx)
            nonzero = s[s > 0]
            lo, hi = _midpoints(nonzero, (0.3, 0.7)) if nonzero.size > 2 else (0.5, 1.0)
            # 0 and not strict: every pixel a candidate; strict: the crests only; a high beyond
            # float32's range (infinite there): no seed
            for low, high, strict in ((lo, hi, False), (lo, hi, True), (0.0, hi, False), (0.0, hi, True),
                                      (lo, 1e300, False)):
                out = be.asarray(np.full(shape, 7, np.uint8))
                kernel(be, be.asarray(gy), be.asarray(gx), out, low, high, strict)
                compare(be.to_host(out), kernel.spec(gy, gx, low, high, strict),
                        f"nms_classes {np.dtype(dtype).name} {shape} {low} {high} {strict}")
