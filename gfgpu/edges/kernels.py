"""The fused kernel of the edge detector, registered with the backends.

``nms(be, gy, gx, out)``: interpolated non-maximum suppression of the gradient ``(gy, gx)``
(2-D device arrays), specification :func:`gfgpu.edges.spec.suppress_nonmaxima_reference`;
launchers ``launch_nms`` in this package's ``_numpy.py``, ``_warp.py`` and
``_opencl.py`` (with ``edges.cl``), imported on first use.

Also registers :func:`gfgpu.edges.twosided.run_two_sided` (``twosided.cl``) with
:func:`gfgpu.filters.register_two_sided`: the derivative, projection and gradient steps on OpenCL
CPU devices.
"""

from __future__ import annotations

from ..backends.fused import register
from ..filters import register_two_sided
from . import twosided
from .spec import suppress_nonmaxima_reference

__all__ = ["nms"]

nms = register("edges.nms", suppress_nonmaxima_reference,
               **{backend: f"{__package__}._{backend}:launch_nms"
                  for backend in ("numpy", "warp", "opencl")})

# the derivative, projection and gradient's two-sided steps on OpenCL CPU devices (gfgpu.filters
# runs them through this registration: it may not import this package)
register_two_sided(twosided.runs_on, twosided.run_two_sided)
