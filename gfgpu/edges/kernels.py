"""The fused kernels of the edge detector, registered with the backends.

``nms(be, gy, gx, out)``: interpolated non-maximum suppression of the gradient ``(gy, gx)``
(2-D device arrays), specification :func:`gfgpu.edges.spec.suppress_nonmaxima_reference`;
``nms_classes(be, gy, gx, out, low, high, strict)``: the same suppression written as uint8
hysteresis classes into ``out``, specification :func:`gfgpu.edges.spec.suppress_classes_reference`.
Launchers ``launch_nms`` and ``launch_nms_classes`` in this package's ``_numpy.py``, ``_warp.py``
and ``_opencl.py`` (with ``edges.cl``), imported on first use.
"""

from __future__ import annotations

from ..backends.fused import register
from .spec import suppress_classes_reference, suppress_nonmaxima_reference

__all__ = ["nms", "nms_classes"]

nms = register("edges.nms", suppress_nonmaxima_reference,
               **{backend: f"{__package__}._{backend}:launch_nms"
                  for backend in ("numpy", "warp", "opencl")})

nms_classes = register("edges.nms_classes", suppress_classes_reference,
                       **{backend: f"{__package__}._{backend}:launch_nms_classes"
                          for backend in ("numpy", "warp", "opencl")})
