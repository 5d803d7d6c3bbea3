"""numpy launchers of the polar kernels: the specifications of :mod:`gfgpu.motion.spec` themselves,
written into the outputs (registered by :mod:`gfgpu.motion.kernels`)."""

from __future__ import annotations

from .. import spec as specs


def launch_to_polar(be, coef, out, cy, cx, r0, mode, cval):
    out[...] = specs.to_polar_reference(coef, cy, cx, r0, out.shape[1], out.shape[2], mode, cval)
    return out


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None, only_band=False):
    ref = specs.from_polar_reference(pcoef, base, cy, cx, r0, r_lo, r_hi, wcoef)
    if only_band:       # the band's pixels only (what out holds elsewhere is not read)
        inside = specs.band_pixels(out.shape[1:], cy, cx, r_lo, r_hi)
        out[:, inside] = ref[:, inside]
    else:
        out[...] = ref
    return out


def launch_add_rows(be, src, dst, scale):
    dst[...] = specs.add_rows_reference(src, dst, scale)
    return dst
