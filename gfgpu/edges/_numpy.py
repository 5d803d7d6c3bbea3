"""numpy launcher of the edge detector's fused kernel: the specifications themselves, written into ``out``
(registered by :mod:`gfgpu.edges.kernels`)."""

from __future__ import annotations

from .spec import suppress_classes_reference, suppress_nonmaxima_reference


def launch_nms(be, gy, gx, out):
    out[...] = suppress_nonmaxima_reference(gy, gx)
    return out


def launch_nms_classes(be, gy, gx, out, low, high, strict=False):
    out[...] = suppress_classes_reference(gy, gx, low, high, strict)
    return out
