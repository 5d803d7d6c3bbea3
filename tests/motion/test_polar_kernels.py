"""The polar resampling kernels of the spin and zoom blurs (gfgpu/motion/polar_kernels) against their
float64 specifications (gfgpu.motion.spec), on the shapes that pick each device branch: on a CPU device
the explicit-vector kernels (whole vectors of angles and blocks of rings, whole vectors of pixels plus
the scalar kernel for a box's last columns, rows of 64 elements with a tail), and the same calls in the
GPU launch shapes (one sample per work-item), forced on the CPU devices."""
import math

import numpy as np
import pytest

from conftest import gpu_shaped_backend
from gfgpu.motion import kernels, polar

#: float32 results within this of the float64 specification (relative to the largest value)
TOL32 = 2e-5
TOL64 = 1e-11


def _dtypes(be):
    return (np.float32, np.float64) if be.supports_float64 else (np.float32,)


def _close(be, got, ref, dtype):
    got = be.to_host(got).reshape(ref.shape)
    tol = TOL64 if np.dtype(dtype) == np.float64 else TOL32
    err = np.abs(got - ref).max() / max(1.0, np.abs(ref).max())
    assert err <= tol, err


def _backends(backend):
    """``backend`` as the tests get it, and, for a device backend on its CPU, forced into GPU shapes."""
    if backend.name == "numpy":
        return [backend]
    return [backend, gpu_shaped_backend(backend.name)]


@pytest.mark.parametrize("mode", ["reflect", "wrap", "constant", "mirror"])
@pytest.mark.parametrize("n_r, n_phi", [(16, 64), (24, 48), (13, 40)])
def test_to_polar_on_every_launch_shape(backend, rng, mode, n_r, n_phi):
    # (16, 64), (24, 48): whole vectors and ring blocks (the CPU's vector kernel); (13, 40): rings
    # that no block divides (the scalar kernel)
    for be in _backends(backend):
        for dtype in _dtypes(be):
            coef = rng.standard_normal((2, 37, 45)).astype(dtype)
            for cy, cx, r0 in ((18.3, 21.6, 0), (12.0, 30.25, 5)):
                ref = kernels.to_polar.spec(coef, cy, cx, r0, n_r, n_phi, mode, 0.3)
                out = be.empty((2, n_r, n_phi), dtype)
                kernels.to_polar(be, be.asarray(coef), out, cy, cx, r0, mode, 0.3)
                _close(be, out, ref, dtype)


@pytest.mark.parametrize("width", [40, 45, 7])
def test_from_polar_on_every_launch_shape(backend, rng, width):
    # 40 columns: whole vectors only; 45: whole vectors and 5 scalar columns; 7: the scalar kernel only;
    # in place, the band's box starts at a column that no vector width divides
    for be in _backends(backend):
        for dtype in _dtypes(be):
            pcoef = rng.standard_normal((2, 32, 96)).astype(dtype)
            base = rng.standard_normal((2, 33, width)).astype(dtype)
            cy, cx = 16.37, width / 2.0 - 0.29     # no pixel at exactly r_lo or r_hi (a tie either way)
            for r0, r_lo, r_hi, keep in ((0, 0.0, math.inf, None), (3, 5.5, 13.0, rng.uniform(0.2, 1.0, 32))):
                ref = kernels.from_polar.spec(pcoef, base, cy, cx, r0, r_lo, r_hi, keep)
                back = be.empty(base.shape, dtype)
                kernels.from_polar(be, be.asarray(pcoef), be.asarray(base), back, cy, cx, r0, r_lo, r_hi, keep)
                _close(be, back, ref, dtype)
                same = be.asarray(base.copy())
                kernels.from_polar(be, be.asarray(pcoef), same, same, cy, cx, r0, r_lo, r_hi, keep)
                _close(be, same, ref, dtype)


@pytest.mark.parametrize("width", [40, 45, 7])
def test_from_polar_only_band_leaves_every_other_pixel_alone(backend, rng, width):
    """``only_band``: the band's pixels from ``base`` (not the output), every other pixel of the output
    untouched, including those that share a vector of 8 with the band's (the spin's bands each write their
    own radii into one output, in any order)."""
    for be in _backends(backend):
        for dtype in _dtypes(be):
            pcoef = rng.standard_normal((2, 32, 96)).astype(dtype)
            base = rng.standard_normal((2, 33, width)).astype(dtype)
            held = rng.standard_normal((2, 33, width)).astype(dtype)
            cy, cx = 16.37, width / 2.0 - 0.29
            for r0, r_lo, r_hi, keep in ((0, 0.0, 6.5, None), (3, 5.5, 13.0, rng.uniform(0.2, 1.0, 32)),
                                         (2, 9.0, math.inf, rng.uniform(0.2, 1.0, 32))):
                ref = kernels.from_polar.spec(pcoef, base, cy, cx, r0, r_lo, r_hi, keep, held)
                out = be.asarray(held.copy())
                kernels.from_polar(be, be.asarray(pcoef), be.asarray(base), out, cy, cx, r0, r_lo, r_hi, keep,
                                   only_band=True)
                _close(be, out, ref, dtype)
                yy, xx = np.mgrid[:33, :width]
                beyond = ~((np.hypot(yy - cy, xx - cx) >= r_lo) & (np.hypot(yy - cy, xx - cx) < r_hi))
                assert np.array_equal(be.to_host(out).reshape(held.shape)[:, beyond], held[:, beyond])


@pytest.mark.parametrize("shape, center", [((300, 300), None), ((211, 333), (20.5, 300.2))])
@pytest.mark.parametrize("psf", ["green", "box"])
def test_spin_bands_write_every_pixel_once(backend, shape, center, psf):
    """The bands of a spin each write their own radii into the output (:func:`gfgpu.motion.polar._run_polar`):
    together every pixel, whatever the output held (NaN here), and the same values as into a fresh result
    or into the image itself."""
    import gfgpu
    img = np.random.default_rng(4).random(shape).astype(np.float32)
    kw = {} if center is None else {"center": center}
    cy, cx = ((shape[0] - 1) / 2, (shape[1] - 1) / 2) if center is None else center
    assert len(polar.polar_bands(*shape, cy, cx, split=True)) > 1
    ref = gfgpu.motion_blur(img, 10.0, kind="rotation", psf=psf, backend=backend.name, **kw)
    held = np.full(shape, np.nan, np.float32)
    got = gfgpu.motion_blur(img, 10.0, kind="rotation", psf=psf, backend=backend.name, output=held, **kw)
    assert np.isfinite(got).all() and np.array_equal(got, ref)
    same = img.copy()
    got = gfgpu.motion_blur(same, 10.0, kind="rotation", psf=psf, backend=backend.name, output=same, **kw)
    assert np.array_equal(got, ref)


@pytest.mark.parametrize("m", [64, 200, 9])
def test_add_rows_on_every_launch_shape(backend, rng, m):
    for be in _backends(backend):
        for dtype in _dtypes(be):
            src, dst = (rng.standard_normal((2, 5, m)).astype(dtype) for _ in range(2))
            scale = rng.standard_normal(5)
            out = be.asarray(dst.copy())
            kernels.add_rows(be, be.asarray(src), out, scale)
            _close(be, out, kernels.add_rows.spec(src, dst, scale), dtype)


@pytest.mark.parametrize("kind, value", [("rotation", 10.0), ("zoom", 0.1), ("zoom", -0.1)])
@pytest.mark.parametrize("psf", ["green", "box"])
def test_spin_and_zoom_equal_numpy_on_every_launch_shape(backend, rng, kind, value, psf):
    """The whole blur (several bands for the spin, widths that no vector divides) as numpy's float64."""
    import gfgpu
    img = rng.standard_normal((200, 231))
    ref = gfgpu.motion_blur(img, value, kind=kind, psf=psf, center=(60.3, 91.7), backend="numpy")
    assert len(polar.polar_bands(200, 231, 60.3, 91.7, split=True)) > 1
    for be in _backends(backend):
        got = gfgpu.motion_blur(img.astype(np.float32), value, kind=kind, psf=psf, center=(60.3, 91.7), backend=be)
        err = np.abs(got - ref).max() / np.abs(ref).max()
        assert err <= 1e-4, err
