"""The fused kernel of the edge detector, registered with the backends.

``nms(be, gy, gx, out)``: interpolated non-maximum suppression of the gradient ``(gy, gx)``
(2-D device arrays), specification :func:`gfgpu.edges.spec.suppress_nonmaxima_reference`;
launchers ``launch_nms`` in this package's ``_numpy.py``, ``_warp.py`` and
``_opencl.py`` (with ``edges.cl``), imported on first use.
"""

from __future__ import annotations

from ..backends.fused import register
from .spec import suppress_nonmaxima_reference

__all__ = ["nms"]

nms = register("edges.nms", suppress_nonmaxima_reference,
               **{backend: f"{__package__}._{backend}:launch_nms"
                  for backend in ("numpy", "warp", "opencl")})
