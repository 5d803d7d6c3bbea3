"""Input builders of the motion fused kernels (``motion.*``, gfgpu/motion/kernels.py), run on every
backend by tests/backends/test_fused.py."""
import math

import numpy as np
from backends.builders import builds


def _close(be, got, ref, dtype, what):
    got = be.to_host(got).reshape(ref.shape)
    tol = 1e-11 if np.dtype(dtype) == np.float64 else 2e-5
    assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max()), what


def _motion_dtypes(be):
    return (np.float32, np.float64) if be.supports_float64 else (np.float32,)


@builds("motion.box_lines")
def _box_lines(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        src = rng.standard_normal((2, 7, 33)).astype(dtype)
        for axis, window, mode in ((1, (-5.3, 1.0, 0.0, 1.0), "reflect"), (2, (0.0, 1.0, 7.25, 1.0), "wrap"),
                                   (2, (-40.5, 1.0, 0.0, 1.0), "constant"), (1, (0.0, 0.8, 0.0, 1.3), "nearest")):
            dst = be.empty(src.shape, dtype)
            kernel(be, be.asarray(src), dst, axis, *window, mode, 0.7)
            _close(be, dst, kernel.spec(src, axis, *window, mode, 0.7), dtype, f"box_lines {axis} {window} {mode}")
        # whole lane groups and a partial one (vector and one-line kernels in one call), fewer lines
        # than a group, and exact groups, on both kinds of window
        for shape, axis in (((3, 5, 19), 1), ((3, 5, 19), 2), ((1, 3, 5), 2), ((1, 4, 3), 1), ((2, 4, 16), 2)):
            src = rng.standard_normal(shape).astype(dtype)
            for window in ((-2.3, 1.0, 1.7, 1.0), (-1.0, 0.9, 2.0, 1.1)):
                dst = be.empty(shape, dtype)
                kernel(be, be.asarray(src), dst, axis, *window, "mirror", 0.7)
                _close(be, dst, kernel.spec(src, axis, *window, "mirror", 0.7), dtype, f"box_lines {shape} {axis}")
        # minus less, also in place (dst is less), on the scalar and the vector kernels (8 | 2 * 8 rows)
        for shape, axis, window in (((2, 7, 33), 1, (-2.5, 1.0, 2.5, 1.0)), ((2, 8, 33), 2, (-3.25, 1.0, 0.0, 1.0)),
                                    ((2, 8, 33), 2, (0.0, 0.9, 0.0, 1.2))):
            src, less = (rng.standard_normal(shape).astype(dtype) for _ in range(2))
            ref = kernel.spec(src, axis, *window, "nearest", 0.7, less)
            dst = be.empty(shape, dtype)
            kernel(be, be.asarray(src), dst, axis, *window, "nearest", 0.7, be.asarray(less))
            _close(be, dst, ref, dtype, f"box_lines less {shape} {window}")
            same = be.asarray(less.copy())
            kernel(be, be.asarray(src), same, axis, *window, "nearest", 0.7, same)
            _close(be, same, ref, dtype, f"box_lines less in place {shape} {window}")


@builds("motion.field_blur")
def _field_blur(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        field = (rng.standard_normal((2, 20, 24)) * 4).astype(dtype)
        for psf, mode in ((0, "reflect"), (1, "wrap"), (2, "constant"), (3, "mirror")):
            out = be.empty(coef.shape, dtype)
            kernel(be, be.asarray(coef), be.asarray(field), out, psf, 2.0, mode, 0.3)
            _close(be, out, kernel.spec(coef, field, psf, 2.0, mode, 0.3), dtype, f"field_blur {psf} {mode}")


@builds("motion.field_rule")
def _field_rule(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        field = (rng.standard_normal((2, 20, 24)) * 4).astype(dtype)
        field[:, 5:9, 6:12] *= 0.2              # whole paths inside the image (the kernels' inner branch)
        field[:, 2, 3] = 0.0                    # a still pixel
        for psf, mode, most in ((0, "reflect", None), (1, "wrap", None), (2, "constant", 3), (3, "mirror", 17)):
            out = be.empty(coef.shape, dtype)
            kernel(be, be.asarray(coef), be.asarray(field), out, psf, mode, 0.3, most)
            _close(be, out, kernel.spec(coef, field, psf, mode, 0.3, most), dtype, f"field_rule {psf} {mode} {most}")


@builds("motion.to_polar")
def _to_polar(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        coef = rng.standard_normal((2, 20, 24)).astype(dtype)
        for mode, r0 in (("reflect", 0), ("constant", 0), ("nearest", 3)):
            polar = be.empty((2, 18, 64), dtype)
            kernel(be, be.asarray(coef), polar, 9.5, 11.2, r0, mode, 0.3)
            _close(be, polar, kernel.spec(coef, 9.5, 11.2, r0, 18, 64, mode, 0.3), dtype, f"to_polar {mode} {r0}")


@builds("motion.from_polar")
def _from_polar(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        pcoef = rng.standard_normal((2, 18, 64)).astype(dtype)
        base = rng.standard_normal((2, 20, 24)).astype(dtype)
        for r0, r_lo, r_hi, keep in ((0, 0.0, math.inf, None), (2, 4.5, 9.0, rng.uniform(0.2, 1.0, 18))):
            ref = kernel.spec(pcoef, base, 9.5, 11.2, r0, r_lo, r_hi, keep)
            back = be.empty((2, 20, 24), dtype)
            kernel(be, be.asarray(pcoef), be.asarray(base), back, 9.5, 11.2, r0, r_lo, r_hi, keep)
            _close(be, back, ref, dtype, f"from_polar {r0}")
            same = be.asarray(base.copy())      # in place: a band adds its change to the previous bands'
            kernel(be, be.asarray(pcoef), same, same, 9.5, 11.2, r0, r_lo, r_hi, keep)
            _close(be, same, ref, dtype, f"from_polar in place {r0}")


@builds("motion.add_rows")
def _add_rows(be, kernel, rng):
    for dtype in _motion_dtypes(be):
        src, dst = (rng.standard_normal((2, 9, 17)).astype(dtype) for _ in range(2))
        scale = rng.standard_normal(9)
        ref, ref_same = kernel.spec(src, dst, scale), kernel.spec(src, src, scale)
        out = be.asarray(dst.copy())
        kernel(be, be.asarray(src), out, scale)
        _close(be, out, ref, dtype, "add_rows")
        same = be.asarray(src.copy())       # dst is src: a scale per row in place
        kernel(be, same, same, scale)
        _close(be, same, ref_same, dtype, "add_rows in place")
