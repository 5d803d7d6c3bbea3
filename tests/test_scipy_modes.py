"""scipy.ndimage's boundary modes under scipy's names, with scipy's meaning.

Every name scipy takes (``reflect``/``grid-mirror``, ``constant``, ``grid-constant``,
``nearest``, ``mirror``, ``wrap``, ``grid-wrap``) is accepted by every operator and the Dask
wrappers.  Filters treat the ``grid-*`` names as their plain twins (scipy's rule); ``shift``
gives them scipy's interpolation meaning, so that ``interpolation="cubic"`` is
``scipy.ndimage.shift(order=3)`` in every mode, and the Green interpolation is defined on the
same extensions (checked against direct summation of its closed-form taps).

The tests of ``TestShift`` below are adapted from scipy's own test suite
(``scipy/ndimage/tests/test_interpolation.py``, scipy 1.17, BSD-3-Clause licence, Copyright (c)
2001-2002 Enthought, Inc. 2003, SciPy Developers): run through a thin adapter
(``order=3`` -> ``interpolation="cubic"``), at order 3 only (gfgpu has no other spline order),
on real dtypes only (gfgpu refuses complex input), without ``test_shift09`` (``prefilter=False``
has no gfgpu counterpart) and ``test_shift_grid_constant_order1`` (order 1).
"""

import dask.array as da
import numpy as np
import pytest
import scipy.ndimage as ndi
from numpy.testing import assert_array_almost_equal

import gfgpu
import gfgpu.dask as gd
from gfgpu import greens
from gfgpu._core.boundary import SCIPY_MODES

#: numpy.pad's name of each extension mode (as scipy's own test module maps them)
NDIMAGE_TO_NUMPY_MODE = {"mirror": "reflect", "reflect": "symmetric", "grid-mirror": "symmetric",
                         "grid-wrap": "wrap", "nearest": "edge", "grid-constant": "constant"}


@pytest.fixture
def shift(backend):
    """scipy.ndimage.shift's signature, computed by gfgpu.shift on ``backend`` (order 3 only)."""
    def adapter(data, shift, order=3, mode="constant", cval=0.0):
        assert order == 3, "gfgpu's spline interpolation is cubic"
        data = np.asarray(data, np.float64 if backend.supports_float64 else np.float32)
        return gfgpu.shift(data, shift, mode=mode, cval=cval, interpolation="cubic", backend=backend.name)
    return adapter


def _close(backend):
    """Decimal places for scipy's assert_array_almost_equal: float32 devices hold ~6."""
    return 6 if backend.supports_float64 else 5


# --------------------------------------------------------------------------------------
# scipy's TestShift, order 3 (adapted; see the module docstring)
# --------------------------------------------------------------------------------------
class TestShift:

    def test_shift01(self, shift, backend):
        out = shift(np.asarray([1]), [1], order=3)
        assert_array_almost_equal(out, [0], _close(backend))

    def test_shift02(self, shift, backend):
        out = shift(np.ones([4]), [1], order=3)
        assert_array_almost_equal(out, [0, 1, 1, 1], _close(backend))

    def test_shift03(self, shift, backend):
        out = shift(np.ones([4]), -1, order=3)
        assert_array_almost_equal(out, [1, 1, 1, 0], _close(backend))

    def test_shift04(self, shift, backend):
        out = shift(np.asarray([4, 1, 3, 2]), 1, order=3)
        assert_array_almost_equal(out, [0, 4, 1, 3], _close(backend))

    def test_shift05(self, shift, backend):
        data = np.ones((3, 4))
        expected = np.asarray([[0, 1, 1, 1]] * 3)
        assert_array_almost_equal(shift(data, [0, 1], order=3), expected, _close(backend))

    @pytest.mark.parametrize("mode", ["constant", "grid-constant"])
    def test_shift_with_nonzero_cval(self, shift, backend, mode):
        data = np.ones((3, 4))
        expected = np.asarray([[0, 1, 1, 1]] * 3, float)
        cval = 5.0
        expected[:, 0] = cval
        out = shift(data, [0, 1], order=3, mode=mode, cval=cval)
        assert_array_almost_equal(out, expected, _close(backend))

    def test_shift06(self, shift, backend):
        data = np.asarray([[4, 1, 3, 2], [7, 6, 8, 5], [3, 5, 3, 6]])
        out = shift(data, [0, 1], order=3)
        assert_array_almost_equal(out, [[0, 4, 1, 3], [0, 7, 6, 8], [0, 3, 5, 3]], _close(backend))

    def test_shift07(self, shift, backend):
        data = np.asarray([[4, 1, 3, 2], [7, 6, 8, 5], [3, 5, 3, 6]])
        out = shift(data, [1, 0], order=3)
        assert_array_almost_equal(out, [[0, 0, 0, 0], [4, 1, 3, 2], [7, 6, 8, 5]], _close(backend))

    def test_shift08(self, shift, backend):
        data = np.asarray([[4, 1, 3, 2], [7, 6, 8, 5], [3, 5, 3, 6]])
        out = shift(data, [1, 1], order=3)
        assert_array_almost_equal(out, [[0, 0, 0, 0], [0, 4, 1, 3], [0, 7, 6, 8]], _close(backend))

    @pytest.mark.parametrize("amount", [(1, 0), (0, 1), (-1, 1), (3, -5), (2, 7)])
    def test_shift_grid_wrap(self, shift, backend, amount):
        # for mode 'grid-wrap', integer shifts match np.roll
        x = np.asarray([[0, 1], [2, 3]])
        expected = np.roll(x, amount, axis=(0, 1))
        assert_array_almost_equal(shift(x, amount, mode="grid-wrap", order=3), expected, _close(backend))

    @pytest.mark.parametrize("amount", [(1, 0), (0, 1), (-1, 1), (3, -5), (2, 7)])
    def test_shift_grid_constant1(self, shift, backend, amount):
        # for integer shifts, 'constant' and 'grid-constant' are equal
        x = np.arange(20).reshape(5, 4)
        assert_array_almost_equal(shift(x, amount, mode="grid-constant", order=3),
                                  shift(x, amount, mode="constant", order=3), _close(backend))

    def test_shift_reflect(self, shift, backend):
        # a shift by x.shape is a reflection
        x = np.asarray([[0, 1, 2], [3, 4, 5]])
        assert_array_almost_equal(shift(x, x.shape, mode="reflect", order=3), x[::-1, ::-1], _close(backend))

    def test_shift_nearest_boundary(self, shift, backend):
        # a shift of at least order // 2 beyond the end gives the edge value
        x = np.arange(16)
        assert_array_almost_equal(shift(x, 3 // 2 + 1, mode="nearest", order=3)[0], x[0], _close(backend))
        assert_array_almost_equal(shift(x, -3 // 2 - 1, mode="nearest", order=3)[-1], x[-1], _close(backend))

    @pytest.mark.parametrize("mode", ["grid-constant", "grid-wrap", "nearest", "mirror", "reflect"])
    def test_shift_vs_padded(self, shift, backend, mode):
        x = np.arange(144, dtype=float).reshape(12, 12)
        amount = (0.4, -2.3)
        # manually pad and then extract the centre to get the expected result
        npad = 32
        x_padded = np.pad(x, npad, mode=NDIMAGE_TO_NUMPY_MODE[mode])
        expected = ndi.shift(x_padded, amount, mode=mode, order=3)[npad:-npad, npad:-npad]
        rtol = 1e-7 if backend.supports_float64 else 2e-6
        np.testing.assert_allclose(shift(x, amount, mode=mode, order=3), expected, rtol=rtol, atol=rtol * 144)


# --------------------------------------------------------------------------------------
# the cases, every mode name against scipy.ndimage.shift(order=3)
# --------------------------------------------------------------------------------------
def test_the_reported_cases(backend):
    line = np.asarray([4.0, 1, 3, 2], np.float64 if backend.supports_float64 else np.float32)
    got = gfgpu.shift(line, 0.5, mode="constant", interpolation="cubic", backend=backend.name)
    np.testing.assert_allclose(got, [0, 2.625, 1.75, 2.625], atol=1e-6)
    got = gfgpu.shift(line, 1, mode="wrap", interpolation="cubic", backend=backend.name)
    np.testing.assert_allclose(got, [3, 4, 1, 3], atol=1e-6)
    got = gfgpu.shift(line, 0.5, mode="grid-constant", interpolation="cubic", backend=backend.name)
    np.testing.assert_allclose(got, ndi.shift(line.astype(float), 0.5, order=3, mode="grid-constant"), atol=1e-6)


#: shifts that cross the border by less than a sample, by several periods, and by a hair
SHIFTS_1D = [0.5, -0.3, 1.0, -2.6, 0.999999, 12.2, -20.5, 1e-16, -1e-16, 3.0]


def scipy_exact(line, s, mode, cval):
    """scipy.ndimage.shift(order=3) without its shortcuts at the border: for the modes that are an
    extension of the input, scipy on the line extended by numpy.pad far beyond the reach of the
    shift (scipy pads 'nearest' and 'grid-constant' by 12 samples only, and its 'reflect'
    prefilter truncates its initial sum: 1e-4 off on a line of 3 samples, 5e-12 on 9);
    scipy itself for the interpolation-only 'constant' and 'wrap'."""
    if mode not in NDIMAGE_TO_NUMPY_MODE:
        return ndi.shift(line, s, order=3, mode=mode, cval=cval)
    pad = int(np.ceil(np.max(np.abs(s)))) + 64
    kw = {"constant_values": cval} if mode == "grid-constant" else {}
    padded = np.pad(line, pad, mode=NDIMAGE_TO_NUMPY_MODE[mode], **kw)
    return ndi.shift(padded, s, order=3, mode=mode, cval=cval)[(slice(pad, -pad),) * line.ndim]


@pytest.mark.parametrize("mode", SCIPY_MODES)
def test_cubic_is_scipy_order_3_in_every_mode_1d(backend, mode):
    rng = np.random.default_rng(11)
    for n in (1, 3, 9):
        line = rng.random(n)
        for s in SHIFTS_1D:
            ref = scipy_exact(line, s, mode, 0.7)
            if n >= 9:       # scipy itself, where its shortcuts cost less than the tolerance
                np.testing.assert_allclose(ndi.shift(line, s, order=3, mode=mode, cval=0.7), ref, atol=1e-7)
            for dtype, tol in ((np.float64, 1e-12), (np.float32, 2e-6)):
                if dtype == np.float64 and not backend.supports_float64:
                    continue
                out = gfgpu.shift(line.astype(dtype), s, mode=mode, cval=0.7, interpolation="cubic",
                                  backend=backend.name)
                assert out.dtype == dtype
                np.testing.assert_allclose(out, ref, rtol=0, atol=tol, err_msg=f"n={n} shift={s} {dtype.__name__}")


@pytest.mark.parametrize("mode", SCIPY_MODES)
def test_cubic_is_scipy_order_3_in_every_mode_2d(backend, mode):
    img = np.random.default_rng(5).random((23, 31))
    for s in [(0.5, -1.25), (7.3, -4.6), (0, 3), (-30.5, 0.25), (1e-16, -1e-16)]:
        ref = scipy_exact(img, s, mode, 0.3)
        np.testing.assert_allclose(ndi.shift(img, s, order=3, mode=mode, cval=0.3), ref, atol=1e-7)
        dtype = np.float64 if backend.supports_float64 else np.float32
        out = gfgpu.shift(img.astype(dtype), s, mode=mode, cval=0.3, interpolation="cubic", backend=backend.name)
        tol = 1e-12 if dtype == np.float64 else 3e-6
        np.testing.assert_allclose(out, ref, rtol=0, atol=tol, err_msg=str(s))


@pytest.mark.parametrize("mode", SCIPY_MODES)
def test_colour_axes_and_device_arrays(backend, mode):
    """channel_axis, axes and a device array in: the same modes on every path."""
    rgb = np.random.default_rng(8).random((14, 17, 3))
    dtype = np.float64 if backend.supports_float64 else np.float32
    ref = np.stack([ndi.shift(rgb[..., c], (2.5, -1.25), order=3, mode=mode, cval=0.2) for c in range(3)], -1)
    out = gfgpu.shift(rgb.astype(dtype), (2.5, -1.25), channel_axis=-1, mode=mode, cval=0.2, interpolation="cubic",
                      backend=backend.name)
    np.testing.assert_allclose(out, ref, atol=3e-6)
    stack = np.moveaxis(rgb, -1, 0).astype(dtype)
    out = gfgpu.shift(stack, (2.5, -1.25), axes=(1, 2), mode=mode, cval=0.2, interpolation="cubic",
                      backend=backend.name)
    np.testing.assert_allclose(np.moveaxis(out, 0, -1), ref, atol=3e-6)
    if backend.name != "numpy":
        dev = gfgpu.shift(backend.asarray(np.ascontiguousarray(stack)), (0, 2.5, -1.25), mode=mode, cval=0.2,
                          interpolation="cubic")
        assert type(dev) is type(backend.asarray(stack))
        np.testing.assert_allclose(np.moveaxis(backend.to_host(dev), 0, -1), ref, atol=3e-6)


def test_output_dtype_is_numpys_own(backend):
    img = np.ones((6, 7), np.float32)
    for mode in ("grid-constant", "constant"):
        out = gfgpu.shift(img, 0.5, output="f", mode=mode, backend=backend.name)
        assert out.dtype is np.dtype("f")
        out = gfgpu.shift(img, 0.5, output=">f4", mode=mode, backend=backend.name)
        assert out.dtype is np.dtype(np.float32)


# --------------------------------------------------------------------------------------
# the Green interpolation on the same extensions (direct summation of its taps)
# --------------------------------------------------------------------------------------
def _green_on_mirror(line, s):
    """Green translation of ``line`` by ``s`` on its mirror extension, by direct summation."""
    n_int, f = greens.translation_split(s)
    if f == 0:
        w = {0: 1.0}
    else:
        lam, kap, tap = greens.shift_coefficients(abs(f))
        m = np.arange(1, 80)
        w = {0: tap, **{int(k) * (1 if f > 0 else -1): float(np.real(kap * lam ** (k - 1))) for k in m}}
    reach = abs(n_int) + 100
    ext = np.pad(line, reach, mode="reflect")      # whole-sample symmetric: scipy's 'mirror'
    x = np.arange(len(line))
    return sum(t * ext[reach + x - n_int - k] for k, t in w.items())


def _scipy_fold(c, n):
    """scipy's map_coordinate for 'wrap' (ni_interpolation.c): the periods k folded away."""
    k = np.zeros(c.shape, np.int64)
    k[c < 0] = -(np.trunc(-c[c < 0] / (n - 1)).astype(np.int64) + 1)
    k[c > n - 1] = np.trunc(c[c > n - 1] / (n - 1)).astype(np.int64)
    return k


@pytest.mark.parametrize("s", [0.4, -0.35, 2.5, -7.25, 13.6, 0.999])
def test_green_constant_and_wrap_are_the_mirror_interpolant_read_as_scipy_does(backend, s):
    line = np.random.default_rng(3).random(12)
    n = len(line)
    c = np.arange(n) - s
    mirror = _green_on_mirror(line, s)
    want = np.where((c >= 0) & (c <= n - 1), mirror, 0.6)
    out = gfgpu.shift(line.astype(np.float32), s, mode="constant", cval=0.6, backend=backend.name)
    np.testing.assert_allclose(out, want, atol=2e-6)
    k = _scipy_fold(c, n)
    # the mirror extension has period 2 (n - 1): an even number of folds reads c itself
    want = np.where(k % 2 == 0, mirror, _green_on_mirror(line, s + n - 1))
    out = gfgpu.shift(line.astype(np.float32), s, mode="wrap", backend=backend.name)
    np.testing.assert_allclose(out, want, atol=2e-6)
    out = gfgpu.shift(line.astype(np.float32), s, mode="mirror", backend=backend.name)
    np.testing.assert_allclose(out, mirror, atol=2e-6)


# --------------------------------------------------------------------------------------
# filters: the grid-* names are their plain twins (scipy's rule for filters)
# --------------------------------------------------------------------------------------
FILTER_TWINS = [("grid-constant", "constant"), ("grid-wrap", "wrap"), ("grid-mirror", "reflect")]

OPERATORS = {
    "green_filter": lambda img, **kw: gfgpu.green_filter(img, greens.UniformGreen(2.5), axis=0, **kw),
    "green_filter oblique": lambda img, **kw: gfgpu.green_filter(img, greens.UniformGreen(2.0), angle=0.4, **kw),
    "derivative": lambda img, **kw: gfgpu.derivative(img, 1.5, **kw),
    "projection": lambda img, **kw: gfgpu.projection(img, 1.5, **kw),
    "gradient": lambda img, **kw: np.stack(gfgpu.gradient(img, 1.5, **kw)),
}


@pytest.mark.parametrize("name", OPERATORS)
@pytest.mark.parametrize("grid, plain", FILTER_TWINS)
def test_filter_grid_names_are_their_twins(backend, name, grid, plain):
    img = np.random.default_rng(2).random((20, 26)).astype(np.float32)
    op = OPERATORS[name]
    a = op(img, mode=grid, cval=0.4, backend=backend.name)
    b = op(img, mode=plain, cval=0.4, backend=backend.name)
    np.testing.assert_array_equal(a, b)


def test_filter_constant_is_the_cval_extension():
    """For a filter scipy's 'constant' and 'grid-constant' are one mode, the cval extension:
    G_u's taps (its impulse response) summed directly over ``numpy.pad(constant_values=cval)``."""
    line = np.random.default_rng(4).random(40)
    kernel = greens.UniformGreen(2.0)
    impulse = np.zeros(241)
    impulse[120] = 1.0
    h = gfgpu.green_filter(impulse, kernel, mode="constant", backend="numpy")[120:]   # causal taps G[j]
    ext = np.pad(line, 121, mode="constant", constant_values=0.3)
    x = np.arange(len(line))
    ref = sum(h[j] * ext[121 + x - j] for j in range(len(h)))
    for mode in ("constant", "grid-constant"):
        out = gfgpu.green_filter(line, kernel, mode=mode, cval=0.3, backend="numpy")
        np.testing.assert_allclose(out, ref, atol=1e-12)


def test_every_operator_refuses_an_unknown_mode_naming_scipys_names():
    img = np.ones((8, 8))
    for call in [lambda: gfgpu.shift(img, 0.5, mode="periodic"),
                 lambda: gfgpu.green_filter(img, greens.UniformGreen(2.0), mode="grid"),
                 lambda: gfgpu.derivative(img, 1.0, mode="Wrap"),
                 lambda: gfgpu.projection(img, 1.0, mode=None),
                 lambda: gfgpu.gradient(img, 1.0, mode="edge"),
                 lambda: gd.shift(da.from_array(img), 0.5, mode="periodic"),
                 lambda: gd.green_filter(da.from_array(img), greens.UniformGreen(2.0), mode="grid")]:
        with pytest.raises(ValueError, match="mode must be one of reflect, grid-mirror, constant, grid-constant"):
            call()


# --------------------------------------------------------------------------------------
# the Dask wrappers: the same modes, exact across chunks
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", SCIPY_MODES)
@pytest.mark.parametrize("interpolation", ["green", "cubic"])
def test_dask_shift_every_mode(mode, interpolation):
    img = np.random.default_rng(6).random((21, 19))
    x = da.from_array(img, chunks=(8, 7))
    for s in [(0.5, -1.25), (12.3, -30.6)]:
        ref = gfgpu.shift(img, s, mode=mode, cval=0.3, interpolation=interpolation, backend="numpy")
        lazy = gd.shift(x, s, mode=mode, cval=0.3, interpolation=interpolation, backend="numpy")
        out = lazy.compute(scheduler="synchronous")
        assert out.dtype == ref.dtype and lazy.chunks == x.chunks
        np.testing.assert_allclose(out, ref, atol=1e-12, err_msg=str(s))
        if interpolation == "cubic":
            np.testing.assert_allclose(out, ndi.shift(img, s, order=3, mode=mode, cval=0.3), atol=1e-7)


@pytest.mark.parametrize("grid, plain", FILTER_TWINS)
def test_dask_filters_take_the_grid_names(grid, plain):
    img = np.random.default_rng(7).random((20, 22))
    x = da.from_array(img, chunks=(8, 9))
    for op in (lambda m: gd.green_filter(x, greens.UniformGreen(2.5), axis=1, mode=m, cval=0.4, backend="numpy"),
               lambda m: da.stack(gd.gradient(x, 1.5, mode=m, cval=0.4, backend="numpy"))):
        np.testing.assert_array_equal(op(grid).compute(scheduler="synchronous"),
                                      op(plain).compute(scheduler="synchronous"))
    np.testing.assert_allclose(gd.green_filter(x, greens.UniformGreen(2.5), axis=1, mode=grid, cval=0.4,
                                               backend="numpy").compute(scheduler="synchronous"),
                               gfgpu.green_filter(img, greens.UniformGreen(2.5), axis=1, mode=plain, cval=0.4,
                                                  backend="numpy"), atol=1e-12)
