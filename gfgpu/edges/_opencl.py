"""OpenCL launchers of the edge detector's fused kernels (``edges.cl``), registered by
:mod:`gfgpu.edges.kernels`; specifications :func:`gfgpu.edges.spec.suppress_nonmaxima_reference`
and :func:`gfgpu.edges.spec.suppress_classes_reference`.
"""

from __future__ import annotations

import numpy as np

from ..backends.opencl import launch as ocl
from .spec import TIE_RTOL, class_thresholds

#: rows and columns (8 NV) per work-item of the CPU kernel (``suppress_nonmaxima_runs``)
BAND, NV = 8, 8


def _check(be, gy, gx, out, out_dtype):
    for arg, a in (("gy", gy), ("gx", gx), ("out", out)):
        if not be.owns(a):
            raise TypeError(f"{arg} must be a pyopencl.array.Array in the context of {be.device}, "
                            f"got {type(a).__name__}")
    if not (gy.shape == gx.shape == out.shape) or len(out.shape) != 2:
        raise ValueError(f"gy, gx and out must be 2-D arrays of one shape, got {gy.shape}, "
                         f"{gx.shape}, {out.shape}")
    if gy.dtype != gx.dtype:
        raise ValueError(f"gy and gx must have one dtype, got {gy.dtype}, {gx.dtype}")
    dtype = ocl.check_dtype(be, gy.dtype)
    if dtype not in ocl.REALS:
        raise TypeError(f"gy must be float32 or float64, got {dtype}")
    want = dtype if out_dtype is None else np.dtype(out_dtype)
    if out.dtype != want:
        raise ValueError(f"out must be {want} (gy is {dtype}), got {out.dtype}")
    return dtype


def _suppress(be, gy, gx, out, dtype, extra, defines):
    """Both kernels: the interior by the CPU or GPU shape of ``suppress_nonmaxima``, then the border."""
    h, w = out.shape
    if out.size == 0:
        return out
    # edges.cl takes plain pointers: views with an offset (or strides) go through copies
    gy, gx = (a if a.offset == 0 and a.flags.c_contiguous else a.copy() for a in (gy, gx))
    res = out if out.offset == 0 and out.flags.c_contiguous else be.empty(out.shape, out.dtype)
    if dtype == np.float64:
        defines["GFGPU_DOUBLE"] = 1
    defines["TIE_RTOL"] = repr(float(TIE_RTOL))
    group = min(ocl.GPU_GROUP, be.cl_device.max_work_group_size)
    args = (gy.data, gx.data, res.data, np.int32(h), np.int32(w)) + extra
    if h > 2 and w > 2 and be.kind == "cpu":
        # runs of 8 NV columns x BAND rows per work-item (edges.cl: three rows of magnitudes in a ring)
        runs, bands = -(-(w - 1) // (8 * NV)), -(-(h - 2) // BAND)
        lx = min(4, group)
        knl = ocl.kernel(be, __package__, "edges.cl", "suppress_nonmaxima_runs", dtype, BAND=BAND, NV=NV,
                         **defines)
        ocl.launch(be, knl, (-(-runs // lx) * lx, bands), (lx, 1), [gy, gx], [res], args)
    elif h > 2 and w > 2:     # one pixel per work-item (coalesced on a GPU); the border below
        knl = ocl.kernel(be, __package__, "edges.cl", "suppress_nonmaxima", dtype, **defines)
        ocl.launch(be, knl, (-(-(w - 2) // group) * group, h - 2), (group, 1), [gy, gx], [res], args)
    knl = ocl.kernel(be, __package__, "edges.cl", "zero_border", dtype, **defines)
    ocl.launch(be, knl, (-(-max(h, w) // group) * group,), (group,), [], [res],
               (res.data, np.int32(h), np.int32(w)) + extra)
    if res is not out:
        out.set(res.get(queue=be.queue), queue=be.queue)
    return out


def launch_nms(be, gy, gx, out):
    """Launcher of ``edges.nms`` (spec: gfgpu.edges.spec.suppress_nonmaxima_reference)."""
    dtype = _check(be, gy, gx, out, None)
    return _suppress(be, gy, gx, out, dtype, (), {})


def launch_nms_classes(be, gy, gx, out, low, high, strict=False):
    """Launcher of ``edges.nms_classes`` (spec: gfgpu.edges.spec.suppress_classes_reference):
    ``out`` a uint8 device array."""
    dtype = _check(be, gy, gx, out, np.uint8)
    lo, hi = class_thresholds(dtype, low, high)
    return _suppress(be, gy, gx, out, dtype, (lo, hi, np.int32(bool(strict))), {"CLASSES": 1})
