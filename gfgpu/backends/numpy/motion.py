"""numpy launchers of the motion-blur fused kernels: the specifications of
:mod:`gfgpu.backends.specs_motion` themselves, written into the outputs (registered by
:mod:`gfgpu.motion.kernels`)."""

from __future__ import annotations

from .. import specs_motion as specs


def launch_box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval):
    dst[...] = specs.box_lines_reference(src, axis, a0, a1, b0, b1, mode, cval)
    return dst


def launch_field_blur(be, coef, field, out, psf, density, mode, cval):
    out[...] = specs.field_blur_reference(coef, field, psf, density, mode, cval)
    return out


def launch_to_polar(be, coef, out, cy, cx, mode, cval):
    out[...] = specs.to_polar_reference(coef, cy, cx, out.shape[1], out.shape[2], mode, cval)
    return out


def launch_from_polar(be, pcoef, out, cy, cx):
    out[...] = specs.from_polar_reference(pcoef, cy, cx, out.shape[1], out.shape[2])
    return out
