"""The box-window kernel of the uniform, spin and zoom box blurs (``motion.box_lines``: motion.cl's
box_lines, box_vec and box_shift) against its float64 specification (gfgpu.motion.spec), on the
shapes that pick each device branch.  On a CPU device: rows in groups of one cache line of lanes
(16 float32, 8 float64), box_shift loading tiles of that many steps (whole tiles, a partial one at a
line's end, tiles reaching beyond either end, lines shorter than a tile) and box_vec gathering;
columns in bands of vectors with a partial band; the lines no group holds in the one-line kernels
(box_shift_lines for a window of fixed width, box_lines otherwise).  The same calls in the GPU
launch shapes (one line per work-item), forced on the CPU devices."""
import numpy as np
import pytest

from conftest import gpu_shaped_backend
from gfgpu.motion import kernels

#: float32 results within this of the float64 specification (relative to the largest value)
TOL32 = 2e-5
TOL64 = 1e-11

#: windows [a0 + a1 k, b0 + b1 k]: trailing, leading and centred boxes (box_shift), windows wholly
#: beyond the left or the right end and one longer than the lines (tiles outside the line), a
#: growing window (box_vec) and a narrow one (the spline's value); box_vec slides four coefficients
#: at each end in registers: the zoom-in's window [k / 1.1, k] (narrower than NARROW at first, the
#: spline's value, while its ends slide on), a zoom-out's [k, 1.25 k] and ends that cross up to
#: three cells per step from beyond the line's start
WINDOWS = [(-5.3, 1.0, 0.0, 1.0), (0.0, 1.0, 7.25, 1.0), (-2.5, 1.0, 2.5, 1.0), (-40.5, 1.0, -30.0, 1.0),
           (30.25, 1.0, 61.0, 1.0), (-60.5, 1.0, 60.5, 1.0), (-1.0, 0.9, 2.0, 1.1), (0.3, 1.0, 0.3, 1.0),
           (0.0, 1 / 1.1, 0.0, 1.0), (0.0, 1.0, 0.0, 1.25), (-40.0, 1.7, -5.0, 2.3)]


def _dtypes(be):
    return (np.float32, np.float64) if be.supports_float64 else (np.float32,)


def _close(be, got, ref, dtype, what):
    got = be.to_host(got).reshape(ref.shape)
    tol = TOL64 if np.dtype(dtype) == np.float64 else TOL32
    err = np.abs(got - ref).max() / max(1.0, np.abs(ref).max())
    assert err <= tol, (what, err)


def _backends(backend):
    """``backend`` as the tests get it, and, for a device backend on its CPU, forced into GPU shapes."""
    if backend.name == "numpy":
        return [backend]
    return [backend, gpu_shaped_backend(backend.name)]


def _check_all(be, src, axis, mode, rng):
    dtype = src.dtype
    less = rng.standard_normal(src.shape).astype(dtype)
    for window in WINDOWS:
        what = f"{src.shape} axis {axis} {window} {mode} {dtype.name}"
        dst = be.empty(src.shape, dtype)
        kernels.box_lines(be, be.asarray(src), dst, axis, *window, mode, 0.7)
        _close(be, dst, kernels.box_lines.spec(src, axis, *window, mode, 0.7), dtype, what)
        # minus less, and in place (dst is less: each element read before it is written)
        ref = kernels.box_lines.spec(src, axis, *window, mode, 0.7, less)
        dst = be.empty(src.shape, dtype)
        kernels.box_lines(be, be.asarray(src), dst, axis, *window, mode, 0.7, be.asarray(less))
        _close(be, dst, ref, dtype, what + " less")
        same = be.asarray(less.copy())
        kernels.box_lines(be, be.asarray(src), same, axis, *window, mode, 0.7, same)
        _close(be, same, ref, dtype, what + " less in place")


@pytest.mark.parametrize("mode", ["constant", "nearest", "reflect", "mirror", "wrap"])
@pytest.mark.parametrize("shape", [(2, 17, 45), (1, 16, 16), (3, 8, 5), (1, 32, 1)])
def test_box_lines_along_rows_on_every_launch_shape(backend, rng, mode, shape):
    # (2, 17, 45): 34 rows, two groups of 16 (four of 8) and 2 (none) left to the one-line kernel,
    # whole tiles then a partial one of 13 (5) steps; (1, 16, 16): one group, one whole tile;
    # (3, 8, 5): lines shorter than a tile; (1, 32, 1): one sample per line
    for be in _backends(backend):
        for dtype in _dtypes(be):
            _check_all(be, rng.standard_normal(shape).astype(dtype), 2, mode, rng)


@pytest.mark.parametrize("mode", ["constant", "nearest", "reflect", "mirror", "wrap"])
@pytest.mark.parametrize("shape", [(2, 45, 53), (1, 20, 128), (2, 9, 16), (1, 3, 40), "bands"])
def test_box_lines_along_columns_on_every_launch_shape(backend, rng, mode, shape):
    # float32 (float64): (2, 45, 53): 3 (6) vectors and 5 columns left to the one-line kernel;
    # (1, 20, 128): 8 (16) vectors; (2, 9, 16): one vector; (1, 3, 40): lines shorter than the
    # window's taps.  On a CPU device box_shift takes vectors in bands of up to 4 where every
    # compute unit still gets two bands: "bands" is wide enough for bands of 4 on this device,
    # with a partial band of 2 vectors (float32) and 5 scalar columns
    if shape == "bands":
        units = int(backend.cl_device.max_compute_units) if backend.name == "opencl" else 2
        shape = (1, 5, 16 * (8 * units + 2) + 5)
    for be in _backends(backend):
        for dtype in _dtypes(be):
            _check_all(be, rng.standard_normal(shape).astype(dtype), 1, mode, rng)
