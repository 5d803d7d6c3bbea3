"""numpy launcher of the field kernel: the specification itself, written into the output."""

from __future__ import annotations

from .. import spec as specs


def launch_field_blur(be, coef, field, out, psf, density, mode, cval, most=0):
    out[...] = specs.field_blur_reference(coef, field, psf, density, mode, cval, most)
    return out


def launch_field_rule(be, coef, field, out, psf, mode, cval, most=None, reach=None):
    # reach (the field's largest component) sizes the OpenCL kernel's margin only: no effect on the result
    out[...] = specs.field_rule_reference(coef, field, psf, mode, cval, most)
    return out
