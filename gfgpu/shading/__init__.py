"""Depth from one shading image: Green's-function shape from shading and photometric motion.

Two of the chapter's applications (§3 and §4), built on the line filters of :mod:`gfgpu.filters`:
``gsfs`` (:func:`shape_from_shading`, eqs. 30-33), ``photometric`` (:func:`photometric_motion`,
eqs. 39-40), with ``light`` (Lambertian rendering, :func:`estimate_illuminant` after Zheng &
Chellappa 1991, the depth-scale fit), ``scene`` (the tests that fix GSFS's per-line constants:
flat background, quiet border sides, Immerkær's noise estimate), ``line_fit`` (where the depth
is fixed on every line, and the fits) and ``params`` (argument checks).

Conventions (``docs/shading.md``): ``x`` is the column, ``y`` the row (downward), ``Z`` the
height toward the viewer in pixel units, ``p = ∂Z/∂x``, ``q = ∂Z/∂y``; the light
``(l1, l2, l3)`` points from the surface toward the source, ``l1`` toward +x (right), ``l2``
toward +y (down), ``l3 > 0`` toward the viewer.
"""

from .gsfs import GSFS_MIN_U_FRACTION, GSFS_U_FRACTION, ShadingGreen, shape_from_shading
from .light import estimate_illuminant, fit_depth_scale, lambertian_shading
from .params import MIN_SLANT, parse_light
from .photometric import photometric_motion
from .scene import flat_background, has_background, noise_sigma, quiet_sides

__all__ = [
    "shape_from_shading", "photometric_motion", "estimate_illuminant", "lambertian_shading",
    "parse_light", "fit_depth_scale", "flat_background", "has_background", "quiet_sides", "noise_sigma",
    "ShadingGreen", "MIN_SLANT", "GSFS_U_FRACTION", "GSFS_MIN_U_FRACTION",
]
