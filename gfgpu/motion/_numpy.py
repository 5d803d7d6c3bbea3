"""numpy launchers of the motion-blur fused kernels: the specifications of
:mod:`gfgpu.motion.spec` themselves, written into the outputs (registered by
:mod:`gfgpu.motion.kernels`)."""

from __future__ import annotations

from . import spec as specs


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval, less=None):
    dst[...] = specs.box_lines_reference(src, axis, a0, a1, b0, b1, mode, cval, less)
    return dst
