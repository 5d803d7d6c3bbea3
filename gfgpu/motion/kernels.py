"""The fused kernels of motion blur, registered with the backends.

Each is a :class:`~gfgpu.backends.fused.FusedKernel`: its numpy specification lives in
:mod:`gfgpu.backends.specs_motion`, its device code beside each backend
(``backends/warp/motion.py``, ``backends/opencl/motion.cl``).  Call as ``kernel(backend, *args)``
with device arrays; ``mode`` is a scipy.ndimage boundary name.
"""

from __future__ import annotations

from ..backends import specs_motion as specs
from ..backends.fused import register

__all__ = ["box_lines", "field_blur", "to_polar", "from_polar"]


def _launchers(name):
    return {"numpy": f"gfgpu.backends.numpy.motion:launch_{name}",
            "warp": f"gfgpu.backends.warp.motion:launch_{name}",
            "opencl": f"gfgpu.backends.opencl.motion:launch_{name}"}


#: ``box_lines(be, src, dst, axis, a0, a1, b0, b1, mode, cval)``: ``dst = box_lines_reference(src, axis,
#: a0, a1, b0, b1, mode, cval)`` (``src``, ``dst`` (B, N, M); lines along ``axis`` 1 or 2)
box_lines = register("motion.box_lines", specs.box_lines_reference, **_launchers("box_lines"))

#: ``field_blur(be, coef, field, out, psf, density, mode, cval)``: ``out = field_blur_reference(coef,
#: field, psf, density, mode, cval)`` (``coef``, ``out`` (B, H, W); ``field`` (2, H, W), same dtype)
field_blur = register("motion.field_blur", specs.field_blur_reference, **_launchers("field_blur"))

#: ``to_polar(be, coef, out, cy, cx, mode, cval)``: ``out = to_polar_reference(coef, cy, cx, *out.shape[1:],
#: mode, cval)`` (``out`` (B, n_phi, n_r): angle on axis 1, radius on axis 2)
to_polar = register("motion.to_polar", specs.to_polar_reference, **_launchers("to_polar"))

#: ``from_polar(be, pcoef, out, cy, cx)``: ``out = from_polar_reference(pcoef, cy, cx, *out.shape[1:])``
from_polar = register("motion.from_polar", specs.from_polar_reference, **_launchers("from_polar"))
