"""numpy launcher of the edge detector's fused kernel: the specification itself, written into ``out``
(registered by :mod:`gfgpu.edges.kernels`)."""

from __future__ import annotations

from .spec import suppress_nonmaxima_reference


def launch_nms(be, gy, gx, out):
    out[...] = suppress_nonmaxima_reference(gy, gx)
    return out
