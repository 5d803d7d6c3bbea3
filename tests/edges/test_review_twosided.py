"""Review of the two-sided steps (derivative, projection, gradient on OpenCL CPU devices): the
finite check fused into the first read, outputs that alias their input, and constants beyond the
range limit, on every backend and the forced GPU launch shapes, against the numpy backend."""

import numpy as np
import pytest

import gfgpu
from conftest import gpu_shaped_backend


def _backends(backend):
    yield backend
    if backend.name != "numpy":
        yield gpu_shaped_backend(backend.name)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_non_finite_anywhere_in_a_stack_is_refused(backend, dtype):
    """inf or NaN at the first, a middle or the last sample of a line, in the first, a middle or the
    last column of a partial band, in any plane of a stack: refused, along every axis."""
    rng = np.random.default_rng(1)
    shape = (3, 33, 70)
    spots = [(0, 0, 0), (2, 32, 69), (1, 16, 69), (2, 0, 35), (0, 32, 0)]
    for be in _backends(backend):
        for ax in (0, 1, 2):
            for k, spot in enumerate(spots):
                x = rng.standard_normal(shape).astype(dtype)
                x[spot] = (np.nan, np.inf, -np.inf)[k % 3]
                for fn, kw in (("derivative", dict(axis=ax)), ("projection", dict(axis=ax)),
                               ("gradient", dict(channel_axis=ax))):
                    with pytest.raises(ValueError, match="finite"):
                        getattr(gfgpu, fn)(x, 1.3, backend=be, **kw)


@pytest.mark.parametrize("mode", ["reflect", "constant", "wrap"])
def test_output_aliasing_a_strided_input(backend, mode):
    """``output=`` the input itself, a strided view of a larger array: the view holds the result and
    the rest of the array is untouched."""
    rng = np.random.default_rng(2)
    for be in _backends(backend):
        for fn, kw in (("derivative", dict(axis=0)), ("derivative", dict(axes=(0, 1))), ("projection", {})):
            big = rng.standard_normal((60, 90)).astype(np.float32)
            keep = big.copy()
            view = big[1::2, ::3]
            ref = getattr(gfgpu, fn)(view.copy(), 2.0, backend="numpy", mode=mode, cval=0.5, **kw)
            getattr(gfgpu, fn)(view, 2.0, backend=be, mode=mode, cval=0.5, output=view, **kw)
            assert np.abs(view - ref).max() <= 3e-5 * max(1.0, np.abs(ref).max()), (fn, kw)
            mask = np.ones(big.shape, bool)
            mask[1::2, ::3] = False
            assert np.array_equal(big[mask], keep[mask])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_constants_beyond_the_range_limit(backend, dtype):
    """A cval near the dtype's largest value (the job is scaled before the fused check's launch)."""
    rng = np.random.default_rng(3)
    top = float(np.finfo(dtype).max)
    x = rng.standard_normal((20, 30)).astype(dtype)
    for be in _backends(backend):
        for cval in (top / 4, -top):
            for fn, kw in (("derivative", dict(axis=0)), ("derivative", dict(axes=(0, 1))), ("gradient", {})):
                ref = getattr(gfgpu, fn)(x, 1.0, backend="numpy", mode="constant", cval=cval, **kw)
                got = getattr(gfgpu, fn)(x, 1.0, backend=be, mode="constant", cval=cval, **kw)
                for r, g in zip(*(v if isinstance(v, tuple) else (v,) for v in (ref, got))):
                    r, g = r.astype(float), g.astype(float)
                    assert np.isfinite(g).all()
                    tol = 3e-5 if dtype == np.float32 else 1e-10
                    assert np.abs(g - r).max() <= tol * np.abs(r).max(), (fn, kw, cval)
