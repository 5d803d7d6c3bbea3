"""Review of the Gauss-rule field kernel: the samples of a path it takes as inside the image read
only the image's coefficients (no window one row or column before it)."""

import numpy as np
import pytest

from gfgpu.motion import kernels, spec


def _coefficients_after_nan(be, coef):
    """``coef`` (1, H, W) on ``be`` in a sub-buffer preceded by NaN: a read before the array shows."""
    cl = pytest.importorskip("pyopencl")
    cla = pytest.importorskip("pyopencl.array")
    item = coef.dtype.itemsize
    align = max(1, be.cl_device.mem_base_addr_align // 8)
    pad = -(-max(align, 2 * coef.shape[-1] * item) // align) * align
    host = np.full(pad // item + coef.size, np.nan, coef.dtype)
    host[pad // item:] = coef.ravel()
    buf = cl.Buffer(be.context, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=host)
    return cla.Array(be.queue, coef.shape, coef.dtype, data=buf.get_sub_region(pad, coef.nbytes))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_tiny_velocity_at_row_one_reads_inside(require_backend, dtype):
    """A velocity of 1e-20 px at row 1 puts the path's end at y - t vy = 1.0 in the positions' type but
    its offset -t vy (the image's type) floors to -1: the kernel took the path as inside and read the
    window from row -1, before the coefficients (NaN here; beyond the buffer on a device).  Every PSF
    against the specification, rows and columns, and a stack (row -1 of plane 1 is plane 0)."""
    be = require_backend("opencl")
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("no float64 on this device")
    rng = np.random.default_rng(3)
    h, w = 6, 8
    coef = rng.standard_normal((1, h, w)).astype(dtype)
    field = np.zeros((2, h, w), dtype)
    field[0, 1, :] = 1e-20           # rows: tiny vy at row 1
    field[1, :, 1] = 1e-20           # columns: tiny vx at column 1
    field[0, 1, 5] = -1e-20
    field[1, 3, 1] = 1e-300 if dtype == np.float64 else 1e-40
    dcoef = _coefficients_after_nan(be, coef)
    for psf in range(4):
        out = be.empty((1, h, w), dtype)
        kernels.field_rule(be, dcoef, be.asarray(field), out, psf, "reflect", 0.0)
        ref = spec.field_rule_reference(coef, field, psf, "reflect", 0.0)
        got = be.to_host(out).reshape(ref.shape)
        tol = 2e-5 if dtype == np.float32 else 1e-12
        assert np.isfinite(got).all(), (psf, np.argwhere(~np.isfinite(got)).tolist())
        assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max()), psf


@pytest.mark.parametrize("mode", ["reflect", "mirror", "wrap", "nearest", "constant"])
def test_tiny_velocities_everywhere_match_the_spec(backend, mode):
    """Velocities of 1e-30 .. 1e-6 px of both signs at every pixel of small images and a stack (the
    inside test at its bounds), every PSF, against the specification."""
    from gfgpu import motion_blur
    rng = np.random.default_rng(4)
    for shape in [(5, 7), (4, 4), (2, 9, 6)]:
        img = rng.standard_normal(shape)
        field = np.sign(rng.standard_normal((2,) + shape[-2:])) * 10.0 ** rng.uniform(-30, -6, (2,) + shape[-2:])
        for psf in ("box", "green"):
            for dtype in (np.float32, np.float64):
                x = img.astype(dtype)
                ref = motion_blur(x, field.astype(dtype), psf=psf, mode=mode, cval=0.5, backend="numpy")
                got = motion_blur(x, field.astype(dtype), psf=psf, mode=mode, cval=0.5, backend=backend)
                tol = 2e-5 if dtype == np.float32 else 1e-10
                assert np.abs(got - ref).max() <= tol * max(1.0, np.abs(ref).max()), (shape, psf, dtype)


def test_tiny_velocities_in_gpu_launch_shapes(gpu_shaped):
    """The same tiny velocities through the GPU launch shapes (work-groups of 16 x 16 pixels)."""
    rng = np.random.default_rng(5)
    coef = rng.standard_normal((2, 9, 11)).astype(np.float32)
    field = np.sign(rng.standard_normal((2, 9, 11))) * 10.0 ** rng.uniform(-30, -6, (2, 9, 11))
    field = field.astype(np.float32)
    for psf in range(4):
        out = gpu_shaped.empty(coef.shape, np.float32)
        kernels.field_rule(gpu_shaped, gpu_shaped.asarray(coef), gpu_shaped.asarray(field), out, psf, "mirror", 0.0)
        ref = spec.field_rule_reference(coef, field, psf, "mirror", 0.0)
        got = gpu_shaped.to_host(out).reshape(ref.shape)
        assert np.abs(got - ref).max() <= 2e-5 * max(1.0, np.abs(ref).max()), psf
