"""Passes along an image-plane direction that is not an array axis."""

from __future__ import annotations

import numpy as np

from .lines import direction, oblique_maps
from .passes import LinePass
from .recursion import plan_pass

__all__ = ["run_oblique_passes"]


def run_oblique_passes(be, src, dst, dtype, passes, mode, cval, angle, plane):
    """Apply ``passes`` (summed) along the image-plane direction ``angle`` (radians from +x toward +y)
    in the plane ``plane`` = (row axis, column axis), the last two axes of ``src``.

    ``src`` and ``dst`` are distinct device arrays of the same shape; ``src`` is not modified.
    """
    shape = tuple(src.shape)
    ya, xa = plane
    if (ya, xa) != (len(shape) - 2, len(shape) - 1):
        raise ValueError("oblique filtering needs the image plane on the last two axes of the "
                         "working array")
    height, width = shape[-2], shape[-1]
    batch = int(np.prod(shape[:-2], dtype=np.int64))
    _, reverse, _ = direction(angle)
    shear, unshear, lines, steps = oblique_maps(height, width, batch, float(angle), mode)
    rows_in = be.empty((batch, lines, steps), dtype)
    rows_out = be.empty((batch, lines, steps), dtype)
    be.gather(be.reshape(src, (-1,)), shear, cval, be.reshape(rows_in, (-1,)))
    for i, lp in enumerate(passes):
        lp = LinePass(lp.sections, lp.tap, lp.reverse != reverse)
        be.recurse(rows_in, rows_out, 2, plan_pass(lp, steps, mode, dtype), cval, accumulate=i > 0)
    be.gather(be.reshape(rows_out, (-1,)), unshear, 0.0, be.reshape(dst, (-1,)))
    return dst
