"""The fused kernel of the edge detector, registered with the backends.

``nms(be, gy, gx, out)``: interpolated non-maximum suppression of the gradient ``(gy, gx)``
(2-D device arrays), specification
:func:`gfgpu.backends.specs.suppress_nonmaxima_reference`; device code in
``backends/warp/edges.py`` and ``backends/opencl/edges.cl``.
"""

from __future__ import annotations

from ..backends import specs
from ..backends.fused import register

__all__ = ["nms"]

nms = register("edges.nms", specs.suppress_nonmaxima_reference,
               numpy="gfgpu.backends.numpy.fused:launch_suppress_nonmaxima",
               warp="gfgpu.backends.warp.edges:launch_suppress_nonmaxima",
               opencl="gfgpu.backends.opencl.edges:launch_suppress_nonmaxima")
