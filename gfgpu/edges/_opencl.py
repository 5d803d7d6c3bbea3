"""OpenCL launcher of the edge detector's fused kernel (``edges.cl``), registered by
:mod:`gfgpu.edges.kernels`; specification :func:`gfgpu.edges.spec.suppress_nonmaxima_reference`.
"""

from __future__ import annotations

import numpy as np

from ..backends.opencl import launch as ocl
from .spec import TIE_RTOL


def launch_nms(be, gy, gx, out):
    """Launcher of ``edges.nms`` (spec: gfgpu.edges.spec.suppress_nonmaxima_reference)."""
    for arg, a in (("gy", gy), ("gx", gx), ("out", out)):
        if not be.owns(a):
            raise TypeError(f"{arg} must be a pyopencl.array.Array in the context of {be.device}, "
                            f"got {type(a).__name__}")
    if not (gy.shape == gx.shape == out.shape) or len(out.shape) != 2:
        raise ValueError(f"gy, gx and out must be 2-D arrays of one shape, got {gy.shape}, "
                         f"{gx.shape}, {out.shape}")
    if not (gy.dtype == gx.dtype == out.dtype):
        raise ValueError(f"gy, gx and out must have one dtype, got {gy.dtype}, {gx.dtype}, {out.dtype}")
    dtype = ocl.check_dtype(be, out.dtype)
    if dtype not in ocl.REALS:
        raise TypeError(f"gy must be float32 or float64, got {dtype}")
    h, w = out.shape
    if out.size == 0:
        return out
    # edges.cl takes plain pointers: views with an offset (or strides) go through copies
    gy, gx = (a if a.offset == 0 and a.flags.c_contiguous else a.copy() for a in (gy, gx))
    res = out if out.offset == 0 and out.flags.c_contiguous else be.empty(out.shape, dtype)
    defines = {"GFGPU_DOUBLE": 1} if dtype == np.float64 else {}
    defines["TIE_RTOL"] = repr(float(TIE_RTOL))
    group = min(ocl.GPU_GROUP, be.cl_device.max_work_group_size)   # PoCL vectorises a group on CPUs
    if h > 2 and w > 2:     # the interior; the border below
        knl = ocl.kernel(be, __package__, "edges.cl", "suppress_nonmaxima", dtype, **defines)
        ocl.launch(be, knl, (-(-(w - 2) // group) * group, h - 2), (group, 1), [gy, gx], [res],
                   (gy.data, gx.data, res.data, np.int32(h), np.int32(w)))
    knl = ocl.kernel(be, __package__, "edges.cl", "zero_border", dtype, **defines)
    ocl.launch(be, knl, (-(-max(h, w) // group) * group,), (group,), [], [res],
               (res.data, np.int32(h), np.int32(w)))
    if res is not out:
        out.set(res.get(queue=be.queue), queue=be.queue)
    return out
