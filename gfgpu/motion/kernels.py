"""The fused kernels of motion blur, registered with the backends.

Each is a :class:`~gfgpu.backends.fused.FusedKernel`: its numpy specification is in
:mod:`gfgpu.motion.spec`, its launchers ``launch_<name>`` in this package's ``_numpy.py``,
``_warp.py`` and ``_opencl.py`` (with ``motion.cl``; the field kernel's in ``field_kernels/``, the
polar ones' in ``polar_kernels/``), imported on first use.  Call as ``kernel(backend, *args)``
with device arrays; ``mode`` is a scipy.ndimage boundary name.
"""

from __future__ import annotations

from ..backends.fused import register
from . import spec as specs

__all__ = ["fixed_width", "box_lines", "field_blur", "field_rule", "to_polar", "from_polar", "add_rows"]


def _launchers(name, package=__package__):
    return {backend: f"{package}._{backend}:launch_{name}" for backend in ("numpy", "warp", "opencl")}


def fixed_width(a0, a1, b0, b1):
    """Whether the box windows ``[a0 + a1 k, b0 + b1 k]`` keep one width, not narrower than
    :data:`~gfgpu.motion.spec.NARROW`: the launchers then run the device kernel ``box_shift`` (the
    cells' running sum telescoped to one of the coefficients, four fixed taps at each end)."""
    return a1 == 1.0 and b1 == 1.0 and b0 - a0 >= specs.NARROW


#: ``box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval, less=None)``: ``dst = box_lines_reference(src,
#: axis, a0, a1, b0, b1, mode, cval, less)`` (``src``, ``dst``, ``less`` (B, N, M); lines along ``axis`` 1 or
#: 2; ``dst`` may be ``less``)
box_lines = register("motion.box_lines", specs.box_lines_reference, **_launchers("box_lines"))

#: ``field_blur(be, coef, field, out, psf, density, mode, cval, most=0)``: ``out = field_blur_reference(coef,
#: field, psf, density, mode, cval, most)`` (``coef``, ``out`` (B, H, W); ``field`` (2, H, W), same dtype)
#: (device code of its own, ``field_kernels/``: a field call builds only field code; on Warp a module
#: apart from the default rule's too, ``_warp_exact``, since Warp builds a module whole)
field_blur = register("motion.field_blur", specs.field_blur_reference,
                      **{**_launchers("field_blur", f"{__package__}.field_kernels"),
                         "warp": f"{__package__}.field_kernels._warp_exact:launch_field_blur"})

#: ``field_rule(be, coef, field, out, psf, mode, cval, most=None, reach=None)``: ``out = field_rule_reference(coef,
#: field, psf, mode, cval, most)``: the fields' default rule, ``quadrature="gauss"`` (same shapes as ``field_blur``;
#: the launchers read the rule tables of ``spec.rule_table``; ``reach``, the field's largest component in pixels,
#: sizes OpenCL's margin of extended coefficients and changes no value)
field_rule = register("motion.field_rule", specs.field_rule_reference,
                      **_launchers("field_rule", f"{__package__}.field_kernels"))

#: the polar kernels' device code (``polar_kernels/``): a spin or zoom builds only polar code
_POLAR = f"{__package__}.polar_kernels"

#: ``to_polar(be, coef, out, cy, cx, r0, mode, cval)``: ``out = to_polar_reference(coef, cy, cx, r0,
#: *out.shape[1:], mode, cval)`` (``out`` (B, n_r, n_phi): radius ``r0 + i`` on axis 1, angle on axis 2)
to_polar = register("motion.to_polar", specs.to_polar_reference, **_launchers("to_polar", _POLAR))

#: ``from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None, only_band=False)``: ``out =
#: from_polar_reference(pcoef, base, cy, cx, r0, r_lo, r_hi, wcoef, out if only_band else None)`` (``base``, ``out``
#: (B, H, W); ``out`` may be ``base``, which each pixel reads before it is written; ``wcoef`` a host array (n_r,)
#: or None; ``only_band``: the pixels beyond the radii ``[r_lo, r_hi)`` are not written)
from_polar = register("motion.from_polar", specs.from_polar_reference, **_launchers("from_polar", _POLAR))

#: ``add_rows(be, src, dst, scale)``: ``dst = add_rows_reference(src, dst, scale)`` (``src``, ``dst`` (B, N, M),
#: ``dst`` may be ``src``; ``scale`` a host array (N,))
add_rows = register("motion.add_rows", specs.add_rows_reference, **_launchers("add_rows", _POLAR))
