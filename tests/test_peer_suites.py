"""The contracts of gfgpu's peers, ported from their own test suites, run on every backend.

gfgpu's public API follows scipy.ndimage / scikit-image conventions (README "API tour":
array-axis order, ``output=`` array or dtype, scipy's ``mode`` names and ``cval``,
``channel_axis``), its ``canny`` skimage's ``feature.canny``, its ``motion_blur`` kornia's
``filters.motion_blur`` layout ((B, C, H, W) stacks) and its stereo API OpenCV's StereoSGBM /
libSGM usage.  The tests below take the contracts those peers' suites check and that gfgpu
documents, not their numbers where gfgpu's operators differ on purpose (a Green's-function shift
is not a spline of order 3; a one-signed D is not a Gaussian + Sobel):

* scipy ``ndimage/tests/test_filters.py`` / ``test_interpolation.py`` (scipy 1.17, BSD-3-Clause):
  output dtypes and ``output=`` arrays (returned, filled, in place, any layout, refused when it
  would downcast or has another shape), every mode name, ``cval`` used only by the constant
  modes, constant images kept, axis handling (negative, out of range, repeated), 1-D and N-D
  inputs, scalar shifts, integer shifts exact, non-contiguous / Fortran / big-endian /
  read-only inputs, the input never modified;
* scikit-image ``feature/tests/test_canny.py`` and ``filters/tests/test_edges.py`` (BSD-3-Clause):
  blank images, masks, dtype scaling, quantile thresholds (``magnitude >= high``), 2-D only,
  a step's gradient has no component along it;
* kornia ``tests/filters/test_motion.py`` (Apache-2.0): (B, C, H, W) batches keep their shape
  and equal per-image calls, non-contiguous input;
* OpenCV StereoSGBM / libSGM usage: uint8 grey and BGR(A) pairs, (H, W, 1) images, negative
  ``minDisparity`` with a range of a multiple of 16, the matcher object equal to the one-shot
  call for every frame kind; the errors for 2-channel pairs, non-integer disparities, shape
  mismatches.

Where gfgpu deliberately differs (documented in README.md) the test says so: empty arrays and
NaN/inf are refused (scipy returns/propagates them), integer input gives float output, the
disparity is float32 with NaN (not OpenCV's int16 x16 with -1).

Tests marked ``xfail(strict=True, reason="bug: ...")`` are genuine bugs found by this port;
they pass (and so fail the strict xfail) once fixed.
"""

import numpy as np
import pytest
from oracle import direct_axis

import gfgpu
from gfgpu import HomogeneousGreen, UniformGreen

MODES = ["reflect", "grid-mirror", "constant", "grid-constant", "nearest", "mirror", "wrap", "grid-wrap"]
#: modes that extend a constant image by itself (the constant ones extend it by cval)
SELF_MODES = ["reflect", "grid-mirror", "nearest", "mirror", "wrap", "grid-wrap"]


# --------------------------------------------------------------------------------------
# the operators under scipy's filter contract: f(x, backend, **kw) on the last two axes
# --------------------------------------------------------------------------------------
def _green(x, be, **kw):
    return gfgpu.green_filter(x, UniformGreen(2.0), axis=-1, backend=be.name, **kw)


def _green_anti(x, be, **kw):
    return gfgpu.green_filter(x, HomogeneousGreen(1.5), axis=-2, anticausal=True, backend=be.name, **kw)


def _green_oblique(x, be, **kw):
    return gfgpu.green_filter(x, UniformGreen(2.0), angle=0.5, backend=be.name, **kw)


def _shift(x, be, **kw):
    return gfgpu.shift(x, (1.3, -2.6), axes=(-2, -1), backend=be.name, **kw)


def _shift_cubic(x, be, **kw):
    return gfgpu.shift(x, (-0.4, 3.7), axes=(-2, -1), interpolation="cubic", backend=be.name, **kw)


def _derivative(x, be, **kw):
    return gfgpu.derivative(x, 1.0, axis=-1, axes=(-2, -1), backend=be.name, **kw)


def _projection(x, be, **kw):
    return gfgpu.projection(x, 1.5, axis=-2, backend=be.name, **kw)


def _blur(x, be, **kw):
    return gfgpu.motion_blur(x, (2.0, 3.5), backend=be.name, **kw)


def _blur_box(x, be, **kw):
    return gfgpu.motion_blur(x, (-4.0, 1.5), psf="box", backend=be.name, **kw)


OPS = {"green_filter": _green, "green_filter_anticausal": _green_anti, "green_filter_oblique": _green_oblique,
       "shift": _shift, "shift_cubic": _shift_cubic, "derivative": _derivative, "projection": _projection,
       "motion_blur": _blur, "motion_blur_box": _blur_box}
#: operators that treat a 3-D array as a stack of 2-D images (the last two axes)
STACKED = ["green_filter", "green_filter_anticausal", "green_filter_oblique", "shift", "shift_cubic",
           "projection", "motion_blur", "motion_blur_box"]


@pytest.fixture(params=list(OPS))
def op(request):
    return OPS[request.param]


@pytest.fixture
def image(rng):
    return rng.random((19, 27)).astype(np.float32)


def _need_f64(be):
    if not be.supports_float64:
        pytest.skip("no float64 on this device")


# --------------------------------------------------------------------------------------
# scipy test_filters.py: dtypes and output=
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("dtype, expected", [
    (np.float32, np.float32), (np.float64, np.float64), (np.float16, np.float32), (np.uint8, np.float32),
    (np.int8, np.float32), (np.uint16, np.float32), (np.int16, np.float32), (np.bool_, np.float32),
    (np.int32, np.float64), (np.uint32, np.float64), (np.int64, np.float64), (np.uint64, np.float64)])
def test_result_dtype(backend, op, image, dtype, expected):
    """README: float32/float64 kept, integers up to 16 bits in float32, wider in float64."""
    if expected == np.float64:
        _need_f64(backend)
    x = image > 0.5 if dtype is np.bool_ else (image * 100).astype(dtype)
    out = op(x, backend)
    assert out.dtype == expected and out.shape == x.shape


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.bool_, np.float16])
def test_small_integers_equal_their_float32(backend, op, image, dtype):
    """An integer/bool image is filtered as its float32 conversion (no scaling for filters)."""
    x = image > 0.5 if dtype is np.bool_ else (image * 100).astype(dtype)
    np.testing.assert_array_equal(op(x, backend), op(x.astype(np.float32), backend))


def test_output_array_is_returned_and_filled(backend, op, image):
    """scipy: ``out = ndimage.f(x, output=arr)`` returns ``arr`` itself, holding the result."""
    ref = op(image, backend)
    out = np.full_like(image, np.nan)
    assert op(image, backend, output=out) is out
    np.testing.assert_array_equal(out, ref)


@pytest.mark.parametrize("layout", ["strided", "fortran", "reversed", "big-endian", "float64"])
def test_output_array_layouts(backend, op, image, layout):
    """scipy fills any writeable output of the right shape, whatever its strides or byte order."""
    ref = op(image, backend)
    if layout == "strided":
        out = np.full((image.shape[0], 2 * image.shape[1]), np.nan, np.float32)[:, ::2]
    elif layout == "fortran":
        out = np.full(image.shape, np.nan, np.float32, order="F")
    elif layout == "reversed":
        out = np.full(image.shape, np.nan, np.float32)[::-1, ::-1]
    elif layout == "big-endian":
        out = np.full(image.shape, np.nan, ">f4")
    else:
        _need_f64(backend)
        out = np.full(image.shape, np.nan, np.float64)
    assert op(image, backend, output=out) is out
    np.testing.assert_array_equal(out, ref)


@pytest.mark.parametrize("dtype", [np.float64, "float64", "f8", float, np.dtype(">f8")])
def test_output_dtype_argument(backend, op, image, dtype):
    """``output=`` a dtype (in any of numpy's spellings) gives a new array of that dtype."""
    _need_f64(backend)
    out = op(image, backend, output=dtype)
    assert out.dtype == np.float64
    np.testing.assert_allclose(out, op(image, backend), rtol=0, atol=1e-6)


def test_output_is_input(backend, op, image):
    """scipy allows ``output`` to be the input itself; the result is the out-of-place one."""
    ref = op(image, backend)
    x = image.copy()
    assert op(x, backend, output=x) is x
    np.testing.assert_array_equal(x, ref)


def test_output_overlapping_input(backend, op, image):
    """An output that overlaps the input in memory (not the same view) still gets the result."""
    ref = op(image, backend)
    buf = np.zeros((image.shape[0], image.shape[1] + 1), np.float32)
    buf[:, :-1] = image
    out = buf[:, 1:]
    op(buf[:, :-1], backend, output=out)
    np.testing.assert_array_equal(out, ref)


def _strip_ops():
    """Axis-aligned operators that stream strips when the image exceeds the working set (README,
    "Large images")."""
    return {
        "shift": lambda x, be, **kw: gfgpu.shift(x, (3.5, -1.0), backend=be.name, **kw),
        "shift_cols": lambda x, be, **kw: gfgpu.shift(x, (0.0, -5.5), backend=be.name, **kw),
        "green_filter_axis0": lambda x, be, **kw: gfgpu.green_filter(x, UniformGreen(3.0), axis=0,
                                                                     backend=be.name, **kw),
        "green_filter_axis1": lambda x, be, **kw: gfgpu.green_filter(x, UniformGreen(3.0), axis=1,
                                                                     backend=be.name, **kw),
        "projection_axis0": lambda x, be, **kw: gfgpu.projection(x, 1.0, axis=0, backend=be.name, **kw),
        "derivative_axis1": lambda x, be, **kw: gfgpu.derivative(x, 1.0, axis=1, backend=be.name, **kw),
        "motion_blur_rows": lambda x, be, **kw: gfgpu.motion_blur(x, (7.0, 0.0), backend=be.name, **kw),
        "motion_blur_box_rows": lambda x, be, **kw: gfgpu.motion_blur(x, (-7.0, 0.0), psf="box", backend=be.name, **kw),
    }


STRIP_OPS = _strip_ops()
@pytest.fixture
def strip_image(rng):
    """300 x 257 float32 (301 KiB): streamed in strips under a 256 KiB working set."""
    return rng.random((300, 257)).astype(np.float32)


@pytest.mark.parametrize("name", list(STRIP_OPS))
def test_streamed_equals_one_piece(backend, strip_image, name):
    """README: strips carry the recursion state exactly; the result is the one-piece call's."""
    f = STRIP_OPS[name]
    ref = f(strip_image, backend)
    with gfgpu.working_set("256K"):
        out = f(strip_image, backend)
        into = np.full((300, 514), np.nan, np.float32)[:, ::2]
        f(strip_image, backend, output=into)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-5)
    np.testing.assert_allclose(into, ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("name", list(STRIP_OPS))
def test_streamed_output_is_input(backend, strip_image, name):
    """scipy: ``output`` may be the input; the streamed call must equal the one-piece one.
    Reproducer: ``a = img.copy(); with gfgpu.working_set("256K"): gfgpu.shift(a, (3, 0), output=a)``
    differs from ``gfgpu.shift(img, (3, 0))`` on rows 51-53, 102-104, ... (the strip seams)."""
    f = STRIP_OPS[name]
    ref = f(strip_image, backend)
    x = strip_image.copy()
    with gfgpu.working_set("256K"):
        f(x, backend, output=x)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("name", list(STRIP_OPS))
@pytest.mark.parametrize("alias", ["next-row", "reversed"])
def test_streamed_output_overlapping_input(backend, strip_image, name, alias):
    """An output overlapping the input (one row further in one buffer, or the input reversed)
    gets the one-piece result, as it does below the working set (test_output_overlapping_input)."""
    f = STRIP_OPS[name]
    ref = f(strip_image, backend)
    with gfgpu.working_set("256K"):
        if alias == "next-row":
            buf = np.zeros((301, 257), np.float32)
            buf[:-1] = strip_image
            out = buf[1:]
            f(buf[:-1], backend, output=out)
        else:
            x = strip_image.copy()
            out = x[::-1]
            f(x, backend, output=out)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("dtype", [np.float16, np.uint8, np.int32, bool, int])
def test_output_dtype_refused(backend, op, image, dtype):
    """README: output dtype float32/float64 only (scipy would cast; gfgpu refuses, naming it)."""
    with pytest.raises(TypeError, match="output"):
        op(image, backend, output=dtype)


def test_output_downcast_refused(backend, op, image):
    """README: "an output that would downcast raises" (float64 input into float32)."""
    _need_f64(backend)
    with pytest.raises(TypeError, match="downcast"):
        op(image.astype(np.float64), backend, output=np.float32)
    with pytest.raises(TypeError, match="downcast"):
        op(image.astype(np.float64), backend, output=np.empty(image.shape, np.float32))


def test_output_wrong_shape_refused(backend, op, image):
    """scipy raises for an output of another shape (RuntimeError there; ValueError here)."""
    with pytest.raises(ValueError, match="output"):
        op(image, backend, output=np.empty((image.shape[0], image.shape[1] + 1), np.float32))
    with pytest.raises(ValueError, match="output"):
        op(image, backend, output=np.empty(image.T.shape, np.float32))


def test_output_read_only_refused(backend, op, image):
    out = np.empty_like(image)
    out.flags.writeable = False
    with pytest.raises(ValueError, match="read-only"):
        op(image, backend, output=out)


def test_output_not_an_array_refused(backend, op, image):
    with pytest.raises(TypeError, match="output"):
        op(image, backend, output=image.tolist())


# --------------------------------------------------------------------------------------
# scipy: inputs of any layout, never modified
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("layout", ["fortran", "strided", "reversed", "big-endian", "read-only", "list"])
def test_input_layouts(backend, op, image, layout):
    ref = op(image, backend)
    if layout == "fortran":
        x = np.asfortranarray(image)
    elif layout == "strided":
        big = np.zeros((2 * image.shape[0], 3 * image.shape[1]), np.float32)
        big[::2, ::3] = image
        x = big[::2, ::3]
    elif layout == "reversed":
        x = np.ascontiguousarray(image[::-1, ::-1])[::-1, ::-1]
    elif layout == "big-endian":
        x = image.astype(">f4")
    elif layout == "read-only":
        x = image.copy()
        x.flags.writeable = False
    else:   # array_like: a nested list of Python floats is float64
        _need_f64(backend)
        x = image.tolist()
        ref = op(image.astype(np.float64), backend)
    np.testing.assert_array_equal(op(x, backend), ref)


@pytest.mark.parametrize("dtype", [">i2", ">u2", ">i4", ">u8", ">i8"])
def test_big_endian_integer_input(backend, op, image, dtype):
    """A non-native byte order computes as its native twin (scipy reads any byte order)."""
    if np.dtype(dtype).itemsize > 2:
        _need_f64(backend)
    x = (image * 1000).astype(dtype)
    np.testing.assert_array_equal(op(x, backend), op(x.astype(x.dtype.newbyteorder("=")), backend))


def test_big_endian_float16_input(backend, op, image):
    x = image.astype(">f2")
    np.testing.assert_array_equal(op(x, backend), op(x.astype(np.float16), backend))


def test_input_not_modified(backend, op, image):
    x = image.copy()
    op(x, backend)
    np.testing.assert_array_equal(x, image)


# --------------------------------------------------------------------------------------
# scipy: modes and cval
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", MODES)
def test_every_scipy_mode_name(backend, op, image, mode):
    out = op(image, backend, mode=mode, cval=0.5)
    assert out.shape == image.shape and np.isfinite(out).all()


@pytest.mark.parametrize("mode", ["foo", "REFLECT", "symmetric", "edge", ("reflect", "wrap"), None, 3])
def test_bad_mode_refused(backend, op, image, mode):
    """An unknown name (numpy.pad's, upper case) or a per-axis sequence is a ValueError naming mode."""
    with pytest.raises((ValueError, TypeError), match="mode"):
        op(image, backend, mode=mode)


@pytest.mark.parametrize("mode", SELF_MODES)
def test_cval_ignored_outside_constant_modes(backend, op, image, mode):
    """scipy: ``cval`` is the value past the edges only for the constant modes."""
    np.testing.assert_array_equal(op(image, backend, mode=mode, cval=0.0),
                                  op(image, backend, mode=mode, cval=123.0))


@pytest.mark.parametrize("mode", ["constant", "grid-constant"])
def test_cval_used_in_constant_modes(backend, op, image, mode):
    a = op(image, backend, mode=mode, cval=0.0)
    b = op(image, backend, mode=mode, cval=5.0)
    assert np.abs(a - b).max() > 1e-3


@pytest.mark.parametrize("cval", [1, np.float32(2.5), np.int64(-3), np.array(0.25)])
def test_cval_numeric_kinds(backend, op, image, cval):
    """A Python/numpy integer, float or 0-d array is a cval, equal to the same float."""
    np.testing.assert_array_equal(op(image, backend, mode="constant", cval=cval),
                                  op(image, backend, mode="constant", cval=float(cval)))


@pytest.mark.parametrize("cval", [np.nan, np.inf, "1", 1j, True])
def test_cval_refused(backend, op, image, cval):
    with pytest.raises((ValueError, TypeError), match="cval"):
        op(image, backend, mode="constant", cval=cval)


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (2, 3)])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", ["shift", "shift_cubic", "derivative", "projection", "motion_blur", "motion_blur_box"])
def test_constant_image_kept(backend, name, shape, mode):
    """scipy's filters of unit gain keep a constant image in every mode (cval = the constant
    for the constant modes), also on axes of length 1 and 2; the derivative gives 0.
    (green_filter point-samples G_u, whose DC gain is not 1: README, Discretisation.)"""
    x = np.full(shape, 2.5, np.float32)
    out = OPS[name](x, backend, mode=mode, cval=2.5)
    expected = 0.0 if name == "derivative" else 2.5
    np.testing.assert_allclose(out, expected, rtol=0, atol=2e-5)


# --------------------------------------------------------------------------------------
# scipy: refused inputs (documented differences from scipy: empty and NaN are refused)
# --------------------------------------------------------------------------------------
def test_nan_and_inf_refused(backend, op, image):
    for bad in (np.nan, np.inf, -np.inf):
        x = image.copy()
        x[3, 4] = bad
        with pytest.raises(ValueError, match="NaN or infinite"):
            op(x, backend)


@pytest.mark.parametrize("shape", [(0, 5), (5, 0), (0, 0), (3, 0, 4)])
def test_empty_refused(backend, op, shape):
    """README: empty arrays raise ValueError (scipy would return an empty array)."""
    with pytest.raises(ValueError, match="empty"):
        op(np.zeros(shape, np.float32), backend)


@pytest.mark.parametrize("dtype", [np.complex64, np.complex128, object, "U1", "datetime64[s]", np.longdouble])
def test_non_real_dtypes_refused(backend, op, dtype):
    """scipy refuses complex input to most filters; gfgpu refuses every non-real dtype with TypeError."""
    with pytest.raises(TypeError):
        op(np.zeros((4, 5), dtype), backend)


def test_zero_dimensional_refused(backend):
    for x in (np.float32(3.0), 3.0, np.array(2.0)):
        with pytest.raises(ValueError, match="dimension"):
            gfgpu.green_filter(x, UniformGreen(2.0), backend=backend.name)
        with pytest.raises(ValueError, match="dimension"):
            gfgpu.shift(x, 0.5, backend=backend.name)


# --------------------------------------------------------------------------------------
# scipy: N-D arrays, stacks and channels
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", STACKED)
def test_stack_equals_each_image(backend, name, image):
    """(N, H, W): every image as on its own (kornia's batch contract too)."""
    f = OPS[name]
    other = np.ascontiguousarray(image[::-1] * 2.0)
    out = f(np.stack([image, other]), backend)
    np.testing.assert_allclose(out[0], f(image, backend), rtol=0, atol=1e-6)
    np.testing.assert_allclose(out[1], f(other, backend), rtol=0, atol=2e-6)


@pytest.mark.parametrize("name", ["motion_blur", "motion_blur_box", "shift", "green_filter"])
def test_kornia_bchw_batch(backend, name, rng):
    """kornia test_motion: a (B, C, H, W) batch keeps its shape and dtype, each plane as alone;
    a non-contiguous (transposed) batch gives the result of its contiguous copy."""
    f = OPS[name]
    x = rng.random((2, 3, 12, 17)).astype(np.float32)
    out = f(x, backend)
    assert out.shape == x.shape and out.dtype == x.dtype
    np.testing.assert_allclose(out[1, 2], f(np.ascontiguousarray(x[1, 2]), backend), rtol=0, atol=1e-6)
    xt = x.transpose(0, 1, 3, 2)
    np.testing.assert_array_equal(f(xt, backend), f(np.ascontiguousarray(xt), backend))


@pytest.mark.parametrize("channel_axis, build, take", [
    (-1, lambda a, b: np.dstack([a, b]), lambda r, i: r[..., i]),
    (2, lambda a, b: np.dstack([a, b]), lambda r, i: r[..., i]),
    (0, lambda a, b: np.stack([a, b]), lambda r, i: r[i]),
    (-3, lambda a, b: np.stack([a, b]), lambda r, i: r[i]),
])
@pytest.mark.parametrize("name", ["green_filter_oblique", "shift", "shift_cubic", "motion_blur", "motion_blur_box"])
def test_channel_axis(backend, name, image, channel_axis, build, take):
    """skimage: ``channel_axis`` (negative too) names the colour axis; each channel as alone."""
    f = OPS[name]
    other = image * 3.0
    x = build(image, other)
    if name.startswith("shift"):   # shift's values are per image-plane axis
        call = dict(shift=(1.3, -2.6))
        out = gfgpu.shift(x, (1.3, -2.6), channel_axis=channel_axis, backend=backend.name,
                          interpolation="cubic" if name == "shift_cubic" else "green")
        ref = [gfgpu.shift(c, call["shift"], backend=backend.name,
                           interpolation="cubic" if name == "shift_cubic" else "green") for c in (image, other)]
    else:
        out = f(x, backend, channel_axis=channel_axis)
        ref = [f(c, backend) for c in (image, other)]
    assert out.shape == x.shape
    for i in range(2):
        np.testing.assert_allclose(take(out, i), ref[i], rtol=0, atol=5e-6)


@pytest.mark.parametrize("name", ["green_filter_oblique", "shift", "motion_blur"])
def test_channel_axis_refused(backend, name, image):
    x = np.dstack([image] * 3)
    f = OPS[name] if name != "shift" else (lambda x, be, **kw: gfgpu.shift(x, (1.3, -2.6), backend=be.name, **kw))
    with pytest.raises(ValueError, match="channel_axis"):
        f(x, backend, channel_axis=3)
    with pytest.raises(ValueError, match="channel_axis"):
        f(x, backend, channel_axis=-4)
    with pytest.raises(TypeError, match="channel_axis"):
        f(x, backend, channel_axis=1.0)


def test_one_dimensional_inputs(backend, rng):
    """scipy's filters take 1-D arrays: the line filtered as the single row of an image."""
    line = rng.random(23).astype(np.float32)
    be = backend.name
    np.testing.assert_allclose(gfgpu.green_filter(line, UniformGreen(2.0), axis=0, backend=be),
                               gfgpu.green_filter(line[None], UniformGreen(2.0), axis=1, backend=be)[0],
                               rtol=0, atol=1e-6)
    np.testing.assert_allclose(gfgpu.shift(line, 1.25, backend=be),
                               gfgpu.shift(line[None], (0, 1.25), backend=be)[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(gfgpu.shift(line, [-2.5], mode="wrap", backend=be),
                               gfgpu.shift(line[None], (0, -2.5), mode="wrap", backend=be)[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(gfgpu.derivative(line, 1.0, axis=0, backend=be),
                               gfgpu.derivative(line[None], 1.0, axis=1, backend=be)[0], rtol=0, atol=1e-6)


@pytest.mark.parametrize("axis", [0, 1])
def test_negative_axis(backend, image, axis):
    """scipy: ``axis=-k`` is axis ``ndim - k``."""
    be = backend.name
    neg = axis - image.ndim
    np.testing.assert_array_equal(gfgpu.green_filter(image, UniformGreen(2.0), axis=neg, backend=be),
                                  gfgpu.green_filter(image, UniformGreen(2.0), axis=axis, backend=be))
    np.testing.assert_array_equal(gfgpu.derivative(image, 1.0, axis=neg, backend=be),
                                  gfgpu.derivative(image, 1.0, axis=axis, backend=be))
    np.testing.assert_array_equal(gfgpu.projection(image, 1.0, axis=neg, backend=be),
                                  gfgpu.projection(image, 1.0, axis=axis, backend=be))
    np.testing.assert_array_equal(gfgpu.green_filter(image, UniformGreen(2.0), axis=np.int64(axis), backend=be),
                                  gfgpu.green_filter(image, UniformGreen(2.0), axis=axis, backend=be))


def test_bad_axis_refused(backend, image):
    be = backend.name
    for axis in (2, -3):
        with pytest.raises(ValueError, match="axis"):
            gfgpu.green_filter(image, UniformGreen(2.0), axis=axis, backend=be)
        with pytest.raises(ValueError, match="axis"):
            gfgpu.derivative(image, 1.0, axis=axis, backend=be)
    for axis in (1.0, True, "0"):
        with pytest.raises(TypeError, match="axis"):
            gfgpu.green_filter(image, UniformGreen(2.0), axis=axis, backend=be)
    with pytest.raises(ValueError, match="axes"):
        gfgpu.shift(image, (1.0, 2.0), axes=(1, 1), backend=be)
    with pytest.raises(ValueError, match="axes"):
        gfgpu.shift(image, (1.0, 2.0), axes=(1, -1), backend=be)


# --------------------------------------------------------------------------------------
# scipy test_interpolation.py: shift's contract (values: tests/test_scipy_modes.py)
# --------------------------------------------------------------------------------------
def test_shift_scalar_is_every_axis(backend, image):
    """scipy: a scalar shift applies to every axis."""
    be = backend.name
    for s in (1.25, np.float64(1.25), 2):
        np.testing.assert_array_equal(gfgpu.shift(image, s, backend=be), gfgpu.shift(image, (s, s), backend=be))


def test_shift_zero_dimensional_array(backend, image):
    be = backend.name
    np.testing.assert_array_equal(gfgpu.shift(image, np.array(1.25), backend=be),
                                  gfgpu.shift(image, 1.25, backend=be))


@pytest.mark.parametrize("interpolation", ["green", "cubic"])
def test_shift_integer_is_exact(backend, image, interpolation):
    """README: integer part exact: an integer shift is np.roll in grid-wrap, a copy at 0."""
    be = backend.name
    for s in [(2, -3), (-19, 27), (40, 1)]:
        out = gfgpu.shift(image, s, mode="grid-wrap", interpolation=interpolation, backend=be)
        np.testing.assert_array_equal(out, np.roll(image, s, axis=(0, 1)))
    np.testing.assert_array_equal(gfgpu.shift(image, (0, 0), interpolation=interpolation, backend=be), image)
    out = gfgpu.shift(image, (3, 0), mode="constant", cval=-1.0, interpolation=interpolation, backend=be)
    np.testing.assert_array_equal(out[3:], image[:-3])
    np.testing.assert_array_equal(out[:3], -1.0)


@pytest.mark.parametrize("mode", ["constant", "grid-constant"])
def test_shift_beyond_the_image_is_cval(backend, image, mode):
    """scipy: a shift past the whole image leaves cval everywhere (any magnitude)."""
    for s in [(0, 27.5), (-40.25, 0), (1e12, 0.5)]:
        out = gfgpu.shift(image, s, mode=mode, cval=3.0, backend=backend.name)
        np.testing.assert_allclose(out, 3.0, rtol=0, atol=1e-5)


@pytest.mark.parametrize("shift, match", [((np.nan, 0), "finite"), ((np.inf, 0), "finite"),
                                          (("1", 0), "shift"), ((1j, 0), "shift"), ((1, 2, 3), "shift")])
def test_shift_refused(backend, image, shift, match):
    with pytest.raises((ValueError, TypeError), match=match):
        gfgpu.shift(image, shift, backend=backend.name)


@pytest.mark.parametrize("kw", [dict(order=3), dict(prefilter=False), dict(interpolation="linear")])
def test_shift_spline_options_refused(backend, image, kw):
    """scipy's ``order``/``prefilter`` have no gfgpu counterpart: refused, not ignored."""
    with pytest.raises((TypeError, ValueError)):
        gfgpu.shift(image, 1.5, backend=backend.name, **kw)


@pytest.mark.parametrize("interpolation", ["green", "cubic"])
@pytest.mark.parametrize("mode", ["grid-wrap", "reflect", "nearest", "mirror", "constant"])
def test_shift_transpose(backend, rng, interpolation, mode):
    """Array-axis order: shifting the transpose by the reversed shift is the transposed shift."""
    x = rng.random((17, 23))
    for s in [(0.4, 0.0), (2.5, -1.25), (-3.7, 6.2)]:
        a = gfgpu.shift(x, s, mode=mode, cval=0.3, interpolation=interpolation, backend=backend.name)
        b = gfgpu.shift(x.T.copy(), s[::-1], mode=mode, cval=0.3, interpolation=interpolation,
                        backend=backend.name).T
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 if x.dtype == np.float64 else 1e-6)


@pytest.mark.parametrize("shift", [(0.0, 0.4), (2.5, -1.25), (-7.75, 3.5)])
def test_shift_grid_wrap_keeps_the_mean(backend, rng, shift):
    """A periodic translation keeps the sum (G_f has unit gain: README, Discretisation)."""
    _need_f64(backend)
    x = rng.random((16, 21))
    out = gfgpu.shift(x, shift, mode="grid-wrap", backend=backend.name)
    assert abs(out.mean() - x.mean()) < 1e-12


# --------------------------------------------------------------------------------------
# green_filter / derivative / projection / gradient: symmetries and the direct-sum oracle
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["reflect", "constant", "nearest", "mirror", "wrap"])
def test_green_filter_against_direct_sum_with_output(backend, rng, mode):
    """output= into a float64 array holds the float64 result of the closed-form sum."""
    _need_f64(backend)
    x = rng.random((5, 31))
    kernel = UniformGreen(1.5)
    out = np.empty_like(x)
    gfgpu.green_filter(x, kernel, axis=1, mode=mode, cval=0.5, output=out, backend=backend.name)
    ref = direct_axis(x, kernel, 1, mode, 0.5)
    assert np.abs(out - ref).max() <= 1e-9 * np.abs(ref).max()


@pytest.mark.parametrize("kernel", [UniformGreen(2.0), HomogeneousGreen(1.5)], ids=["G_u", "H_u"])
@pytest.mark.parametrize("mode", ["reflect", "constant", "nearest", "mirror", "wrap", "grid-wrap"])
def test_anticausal_is_the_mirrored_causal(backend, rng, kernel, mode):
    """In a mirror-symmetric mode, the anticausal filter of x is the causal filter of x reversed, reversed."""
    _need_f64(backend)
    x = rng.random((9, 31))
    a = gfgpu.green_filter(x, kernel, axis=1, anticausal=True, mode=mode, cval=0.3, backend=backend.name)
    b = gfgpu.green_filter(x[:, ::-1], kernel, axis=1, mode=mode, cval=0.3, backend=backend.name)[:, ::-1]
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    c = gfgpu.green_filter(x.T.copy(), kernel, axis=0, anticausal=True, mode=mode, cval=0.3, backend=backend.name)
    np.testing.assert_allclose(a, c.T, rtol=0, atol=1e-12)


@pytest.mark.parametrize("mode", ["reflect", "constant", "nearest", "mirror", "wrap"])
def test_derivative_antisymmetric_and_gradient_transposes(backend, rng, mode):
    _need_f64(backend)
    x = rng.random((21, 26))
    be = backend.name
    a = gfgpu.derivative(x, 1.0, axis=1, mode=mode, cval=0.3, backend=be)
    b = gfgpu.derivative(x[:, ::-1], 1.0, axis=1, mode=mode, cval=0.3, backend=be)[:, ::-1]
    np.testing.assert_allclose(a, -b, rtol=0, atol=1e-12)
    gy, gx = gfgpu.gradient(x, 1.0, mode=mode, cval=0.3, backend=be)
    hy, hx = gfgpu.gradient(x.T.copy(), 1.0, mode=mode, cval=0.3, backend=be)
    np.testing.assert_allclose(gy, hx.T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gx, hy.T, rtol=0, atol=1e-12)


@pytest.mark.parametrize("u", [0.5, 1.0, 3.0])
def test_derivative_unit_ramp_response(backend, u):
    """README: derivative is normalised to unit ramp response (away from the boundary)."""
    _need_f64(backend)
    ramp = np.tile(np.arange(600.0), (3, 1))
    d = gfgpu.derivative(ramp, u, axis=1, mode="nearest", backend=backend.name)
    np.testing.assert_allclose(d[:, 250:350], 1.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("mode", ["reflect", "nearest", "mirror", "wrap"])
def test_gradient_of_a_step_has_no_component_along_it(backend, mode):
    """skimage test_edges (test_sobel_horizontal/vertical): a horizontal step has no x-derivative
    and a positive y-derivative at the step (increasing down the rows), and vice versa."""
    x = np.zeros((20, 24), np.float32)
    x[10:] = 1.0
    gy, gx = gfgpu.gradient(x, 1.0, mode=mode, backend=backend.name)
    np.testing.assert_allclose(gx, 0.0, rtol=0, atol=1e-6)
    assert gy[9:11, 5:19].min() > 0.05
    hy, hx = gfgpu.gradient(np.ascontiguousarray(x.T), 1.0, mode=mode, backend=backend.name)
    np.testing.assert_allclose(hy, 0.0, rtol=0, atol=1e-6)
    assert hx[5:19, 9:11].min() > 0.05


def test_gradient_zeros(backend):
    """skimage test_sobel_zeros: a blank image has a zero gradient."""
    for g in gfgpu.gradient(np.zeros((10, 12), np.float32), 1.0, backend=backend.name):
        assert not g.any()


@pytest.mark.parametrize("u", [np.nan, np.inf, 0.0, -1.0, 1e-9, "1", (1.0, 2.0)])
def test_scale_refused(backend, image, u):
    with pytest.raises((ValueError, TypeError), match="u "):
        gfgpu.derivative(image, u, axis=0, backend=backend.name)


# --------------------------------------------------------------------------------------
# motion_blur (kornia's motion_blur layout; gfgpu's documented path semantics)
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("psf", ["green", "box"])
def test_motion_blur_zero_velocity_is_a_copy(backend, image, psf):
    """Docstring: (0, 0) returns a copy."""
    out = gfgpu.motion_blur(image, (0, 0), psf=psf, backend=backend.name)
    np.testing.assert_array_equal(out, image)
    assert out is not image


@pytest.mark.parametrize("velocity", [(7.0, 30.0), (29.0, -13.0), (-5.5, 2.25), (0.0, -12.0)])
def test_motion_blur_impulse_centroid_is_the_velocity(backend, velocity):
    """README/docstring: G_u's mean is exactly the displacement; every pixel's impulse-response
    centroid lies within 1e-5 px of the velocity (here in float64, whole-image sums)."""
    _need_f64(backend)
    n = 1000     # G_u's tail runs to ~5 lengths: the whole response stays inside
    x = np.zeros((n, n))
    p = (n // 2 - int(2 * velocity[0]), n // 2 - int(2 * velocity[1]))
    x[p] = 1.0
    out = gfgpu.motion_blur(x, velocity, mode="constant", backend=backend.name)
    yy, xx = np.mgrid[:n, :n]
    total = out.sum()
    assert abs(total - 1.0) < 1e-6
    assert abs((out * yy).sum() / total - p[0] - velocity[0]) < 1e-5
    assert abs((out * xx).sum() / total - p[1] - velocity[1]) < 1e-5


@pytest.mark.parametrize("psf", ["green", "box"])
@pytest.mark.parametrize("mode", ["reflect", "constant", "nearest", "mirror", "grid-wrap"])
def test_motion_blur_transpose(backend, rng, psf, mode):
    """Array-axis order: the transposed image blurred by (vx, vy) is the transposed blur."""
    _need_f64(backend)
    x = rng.random((17, 23))
    for v in [(0.0, 5.5), (3.0, -2.0), (-7.3, 4.1)]:
        a = gfgpu.motion_blur(x, v, psf=psf, mode=mode, cval=0.3, backend=backend.name)
        b = gfgpu.motion_blur(x.T.copy(), v[::-1], psf=psf, mode=mode, cval=0.3, backend=backend.name).T
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)


@pytest.mark.parametrize("psf", ["green", "box"])
def test_motion_blur_grid_wrap_keeps_the_mean(backend, rng, psf):
    _need_f64(backend)
    x = rng.random((24, 31))
    for v in [(0.0, 5.5), (3.0, -2.0), (-7.3, 4.1)]:
        out = gfgpu.motion_blur(x, v, psf=psf, mode="grid-wrap", backend=backend.name)
        assert abs(out.mean() - x.mean()) < 1e-9


@pytest.mark.parametrize("velocity, kw, match", [
    (3.0, {}, "velocity"), ((1, 2, 3), {}, "velocity"), ((np.nan, 2), {}, "finite"),
    ((1, 2), dict(kind="linear"), "kind"), ((1, 2), dict(psf="gauss"), "psf"),
    (np.zeros((2, 19, 26)), {}, "shape"), (720.0, dict(kind="rotation"), "360"),
    (-1.0, dict(kind="zoom"), "u1"), (0.2, dict(kind="zoom", center=(1000, 1000)), "center")])
def test_motion_blur_refused(backend, image, velocity, kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        gfgpu.motion_blur(image, velocity, backend=backend.name, **kw)


def test_motion_blur_needs_an_image_plane(backend, rng):
    with pytest.raises(ValueError, match="2 dimension"):
        gfgpu.motion_blur(rng.random(17), (1, 2), backend=backend.name)


# --------------------------------------------------------------------------------------
# skimage test_canny.py contracts (the suite itself: tests/edges/test_skimage_suite.py)
# --------------------------------------------------------------------------------------
def test_canny_blank_and_ones(backend):
    """skimage test_00_00_zeros / test_img_all_ones: no edges in a flat image."""
    for x in (np.zeros((20, 20)), np.ones((20, 20), np.float32), np.full((20, 20), 200, np.uint8)):
        out = gfgpu.canny(x, 1.0, backend=backend.name)
        assert out.dtype == bool and out.shape == x.shape and not out.any()


def test_canny_mask_all_false_and_non_boolean(backend, image):
    be = backend.name
    assert not gfgpu.canny(image, 1.0, mask=np.zeros(image.shape, bool), backend=be).any()
    np.testing.assert_array_equal(gfgpu.canny(image, 1.0, mask=np.ones(image.shape, np.uint8), backend=be),
                                  gfgpu.canny(image, 1.0, mask=np.ones(image.shape, bool), backend=be))
    for mask in (np.full(image.shape, 2), np.full(image.shape, 0.5)):
        with pytest.raises(TypeError, match="mask"):
            gfgpu.canny(image, 1.0, mask=mask, backend=be)
    with pytest.raises(ValueError, match="mask"):
        gfgpu.canny(image, 1.0, mask=np.ones((image.shape[0] - 1, image.shape[1]), bool), backend=be)


@pytest.mark.parametrize("use_quantiles, low, high", [(False, 0.005, 0.01), (True, 0.5, 0.8)])
def test_canny_mask_outside_pixels_do_not_matter(backend, rng, use_quantiles, low, high):
    """Docstring (and skimage's masked canny): pixels outside the mask do not influence the
    result, and edges lie inside the mask eroded by one pixel (3 x 3)."""
    from scipy import ndimage
    x = ndimage.gaussian_filter(rng.random((60, 70)), 2.0).astype(np.float32)
    mask = np.zeros(x.shape, bool)
    mask[10:50, 15:60] = True
    mask[20:30, 30:40] = False
    e1 = gfgpu.canny(x, 1.0, low, high, mask=mask, use_quantiles=use_quantiles, backend=backend.name)
    y = x.copy()
    y[~mask] = rng.random(int((~mask).sum())) * 5.0
    e2 = gfgpu.canny(y, 1.0, low, high, mask=mask, use_quantiles=use_quantiles, backend=backend.name)
    assert e1.any()
    np.testing.assert_array_equal(e1, e2)
    eroded = ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=0)
    assert not (e1 & ~eroded).any()


@pytest.mark.parametrize("dtype, scale", [(np.uint8, 255), (np.uint16, 65535), (np.int16, 32767)])
def test_canny_integer_images_scaled_by_dtype_max(backend, rng, dtype, scale):
    """skimage test_dtype: an integer image is its float image divided by the dtype's maximum."""
    _need_f64(backend)
    x = (rng.random((40, 40)) * scale * 0.9).astype(dtype)
    np.testing.assert_array_equal(gfgpu.canny(x, 1.0, backend=backend.name),
                                  gfgpu.canny(x / float(scale), 1.0, backend=backend.name))


def test_canny_bool_image(backend, rng):
    x = rng.random((30, 30)) > 0.5
    np.testing.assert_array_equal(gfgpu.canny(x, 1.0, backend=backend.name),
                                  gfgpu.canny(x.astype(np.float32), 1.0, backend=backend.name))


def test_canny_scale_by_a_power_of_two(backend, rng):
    """Docstring: canny(c x, u, c lo, c hi) equals canny(x, u, lo, hi) exactly for c = 2^k."""
    x = rng.random((40, 40)).astype(np.float32)
    ref = gfgpu.canny(x, 1.0, 0.01, 0.03, backend=backend.name)
    for k in (-60, -7, 10, 90):
        c = 2.0 ** k
        np.testing.assert_array_equal(gfgpu.canny(x * np.float32(c), 1.0, 0.01 * c, 0.03 * c, backend=backend.name),
                                      ref)


def test_canny_border_never_an_edge(backend, rng):
    """Docstring: the image's outermost pixels are never edges."""
    x = rng.random((30, 34)).astype(np.float32)
    e = gfgpu.canny(x, 1.0, 0.0, 0.0, mode="constant", cval=5.0, backend=backend.name)
    assert e[1:-1, 1:-1].any()
    assert not (e[0].any() or e[-1].any() or e[:, 0].any() or e[:, -1].any())


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64, np.int64])
def test_canny_return_gradient_dtypes_and_orientation(backend, rng, dtype):
    """Magnitude/orientation in the computation dtype; orientation arctan2(gy, gx): +pi/2 down the rows."""
    if np.dtype(dtype) in (np.float64, np.int64):
        _need_f64(backend)
    x = (rng.random((30, 30)) * 100).astype(dtype)
    edges, mag, ori = gfgpu.canny(x, 1.0, return_gradient=True, backend=backend.name)
    expected = np.float64 if np.dtype(dtype) in (np.float64, np.int64) else np.float32
    assert edges.dtype == bool and mag.dtype == expected and ori.dtype == expected
    ramp = np.tile(np.arange(30.0, dtype=expected)[:, None], (1, 30))
    _, _, ori = gfgpu.canny(ramp, 1.0, return_gradient=True, backend=backend.name)
    np.testing.assert_allclose(ori[5:25, 5:25], np.pi / 2, rtol=0, atol=1e-6)


@pytest.mark.parametrize("args, match", [
    ((1.0, 0.5, 0.1), "low_threshold"), ((1.0, -0.1, 0.1), "low_threshold"), ((1.0, 0.0, np.inf), "high_threshold"),
    ((0.0,), "u "), ((np.nan,), "u ")])
def test_canny_bad_thresholds_and_scale(backend, image, args, match):
    with pytest.raises(ValueError, match=match):
        gfgpu.canny(image, *args, backend=backend.name)


@pytest.mark.parametrize("low, high", [(0.5, 1.1), (-0.1, 0.5), (0.6, 0.4)])
def test_canny_bad_quantiles(backend, image, low, high):
    """skimage test_invalid_use_quantiles."""
    with pytest.raises(ValueError):
        gfgpu.canny(image, 1.0, low, high, use_quantiles=True, backend=backend.name)


@pytest.mark.parametrize("shape", [(3, 20, 20), (20, 20, 3), (20,)])
def test_canny_image_must_be_2d(backend, shape):
    """skimage test_image_shape: canny is 2-D only (a colour image is an error, not averaged)."""
    with pytest.raises(ValueError):
        gfgpu.canny(np.zeros(shape), 1.0, backend=backend.name)


def test_canny_quantile_one_marks_the_maximum(backend):
    """skimage: ``high_mask = magnitude >= high_threshold``; with ``high_threshold=1.0`` quantile
    the threshold is the largest magnitude, so an interior maximum that NMS keeps is an edge."""
    for seed in (4, 7):
        x = np.random.default_rng(seed).random((50, 60)).astype(np.float32)
        edges, mag, _ = gfgpu.canny(x, 1.0, 1.0, 1.0, use_quantiles=True, return_gradient=True,
                                    backend=backend.name)
        i = np.unravel_index(np.argmax(mag), mag.shape)
        assert 0 < i[0] < x.shape[0] - 1 and 0 < i[1] < x.shape[1] - 1     # interior: may be an edge
        assert edges[i], f"seed {seed}: the maximum {i} is not an edge"


# --------------------------------------------------------------------------------------
# OpenCV StereoSGBM / libSGM usage patterns
# --------------------------------------------------------------------------------------
H, W, TRUE_D = 32, 80, 4


@pytest.fixture
def pair():
    right = (np.random.default_rng(0).random((H, W)) * 255).astype(np.uint8)
    return np.roll(right, TRUE_D, axis=1), right


def _frames(left, right):
    return {
        "grey uint8": (left, right),
        "BGR uint8": (np.dstack([left, left // 2, 255 - left]), np.dstack([right, right // 2, 255 - right])),
        "BGRA uint8": (np.dstack([left, left // 2, 255 - left, left]),
                       np.dstack([right, right // 2, 255 - right, right])),
        "HxWx1": (left[..., None], right[..., None]),
        "float32": (left.astype(np.float32) / 255, right.astype(np.float32) / 255),
        "uint16": (left.astype(np.uint16) * 257, right.astype(np.uint16) * 257),
        "int16": (left.astype(np.int16) * 100 - 12000, right.astype(np.int16) * 100 - 12000),
        "Fortran": (np.asfortranarray(left), np.asfortranarray(right)),
        # img[..., ::-1]: OpenCV's BGR read as RGB, a negative-stride view
        "RGB view": (np.dstack([left, left // 2, 255 - left])[..., ::-1],
                     np.dstack([right, right // 2, 255 - right])[..., ::-1]),
    }


@pytest.mark.parametrize("kind", ["grey uint8", "BGR uint8", "BGRA uint8", "HxWx1", "float32", "uint16", "int16",
                                  "Fortran", "RGB view"])
def test_stereo_opencv_frame_kinds(backend, pair, kind):
    """cv2.StereoSGBM.compute takes uint8 grey or BGR pairs; gfgpu returns float32 disparities in
    px (not OpenCV's int16 x16), NaN where no match, the known shift of an exact pair."""
    left, right = _frames(*pair)[kind]
    d = gfgpu.disparity(left, right, 16, backend=backend.name)
    assert d.dtype == np.float32 and d.shape == (H, W)
    assert np.isnan(d[:, :TRUE_D]).all()          # their matches are outside the right view
    valid = d[:, 20:]
    assert np.isfinite(valid).mean() > 0.9
    assert abs(float(np.nanmedian(valid)) - TRUE_D) < 0.05


def test_stereo_rgb_view_equals_its_copy(backend, pair):
    """A negative-stride channel view (``bgr[..., ::-1]``) is matched as its contiguous copy."""
    left, right = _frames(*pair)["RGB view"]
    np.testing.assert_array_equal(gfgpu.disparity(left, right, 16, backend=backend.name),
                                  gfgpu.disparity(np.ascontiguousarray(left), np.ascontiguousarray(right), 16,
                                                  backend=backend.name))


def test_stereo_negative_min_disparity_multiple_of_16(backend, pair):
    """StereoSGBM_create(minDisparity=-16, numDisparities=32): a range across zero; the swapped pair
    gives the negative disparity."""
    left, right = pair
    be = backend.name
    d = gfgpu.disparity(left, right, 16, min_disparity=-16, backend=be)
    assert abs(float(np.nanmedian(d[:, 20:])) - TRUE_D) < 0.05
    d = gfgpu.disparity(right, left, 0, min_disparity=-16, backend=be)
    assert abs(float(np.nanmedian(d[:, :-20])) + TRUE_D) < 0.05


def test_stereo_matcher_equals_disparity_for_every_frame_kind(backend, pair):
    """libSGM / StereoSGBM objects: one matcher of a fixed (H, W) and range, frames of any kind;
    README: compute returns exactly disparity's maps (and confidence)."""
    be = backend.name
    m = gfgpu.StereoMatcher((H, W), 24, min_disparity=-8, backend=be)
    for kind, (left, right) in _frames(*pair).items():
        d, c = m.compute(left, right, return_confidence=True)
        rd, rc = gfgpu.disparity(left, right, 24, min_disparity=-8, return_confidence=True, backend=be)
        np.testing.assert_array_equal(d, rd, err_msg=kind)
        np.testing.assert_array_equal(c, rc, err_msg=kind)


def test_stereo_same_maps_on_every_backend(backend, pair):
    """README: numpy, Warp and OpenCL give identical maps for every input dtype."""
    for kind, (left, right) in _frames(*pair).items():
        np.testing.assert_array_equal(gfgpu.disparity(left, right, 16, backend=backend.name),
                                      gfgpu.disparity(left, right, 16, backend="numpy"), err_msg=kind)


def test_stereo_power_of_two_scale_invariant(backend, pair):
    """The views are scaled by a power of two before matching (exact): the map of 2^k x is x's."""
    left, right = (a.astype(np.float32) for a in pair)
    ref = gfgpu.disparity(left, right, 16, backend=backend.name)
    for k in (-100, -8, 20, 100):
        c = np.float32(2.0 ** k)
        np.testing.assert_array_equal(gfgpu.disparity(left * c, right * c, 16, backend=backend.name), ref)


@pytest.mark.parametrize("call, exc, match", [
    (lambda l, r, be: gfgpu.disparity(l[..., None].repeat(2, -1), r[..., None].repeat(2, -1), 16, backend=be),
     ValueError, "C in 1, 3, 4"),
    (lambda l, r, be: gfgpu.disparity(l, r, 16.0, backend=be), TypeError, "max_disparity"),
    (lambda l, r, be: gfgpu.disparity(l, r, True, backend=be), TypeError, "max_disparity"),
    (lambda l, r, be: gfgpu.disparity(l, r, 0, backend=be), ValueError, "max_disparity"),
    (lambda l, r, be: gfgpu.disparity(l, r, 4097, backend=be), ValueError, "max_disparity"),
    (lambda l, r, be: gfgpu.disparity(l, r, 0, min_disparity=-16385, backend=be), ValueError, "min_disparity"),
    (lambda l, r, be: gfgpu.disparity(l, r[:, :-1], 16, backend=be), ValueError, "shape"),
    (lambda l, r, be: gfgpu.disparity(np.stack([l, l]), np.stack([r, r]), 16, backend=be), ValueError, "left"),
    (lambda l, r, be: gfgpu.disparity(l[0], r[0], 16, backend=be), ValueError, "left"),
    (lambda l, r, be: gfgpu.disparity(l[:1, :1], r[:1, :1], 1, backend=be), ValueError, "2x2"),
    (lambda l, r, be: gfgpu.disparity(l, r, 16, window=4, backend=be), ValueError, "window"),
    (lambda l, r, be: gfgpu.disparity(l, r, 16, paths=5, backend=be), ValueError, "paths"),
    (lambda l, r, be: gfgpu.disparity(l, r, 16, p1=100, p2=10, backend=be), ValueError, "p1"),
    (lambda l, r, be: gfgpu.disparity(l, r, 16, method="bm", backend=be), ValueError, "method"),
    (lambda l, r, be: gfgpu.disparity(np.where(l > 250, np.nan, l), r, 16, backend=be), ValueError, "NaN"),
    (lambda l, r, be: gfgpu.StereoMatcher((H, W, 3), 16, backend=be), ValueError, "shape"),
    (lambda l, r, be: gfgpu.StereoMatcher((32.0, 80.0), 16, backend=be), TypeError, "shape"),
    (lambda l, r, be: gfgpu.StereoMatcher((W, H), 16, backend=be).compute(l, r), ValueError, "shape"),
], ids=["2-channel", "float-max", "bool-max", "empty-range", "range>4096", "min<-16384", "shape-mismatch",
        "3D-stack", "1D", "1x1", "even-window", "paths", "p1>p2", "method", "NaN", "matcher-3-tuple",
        "matcher-float-shape", "matcher-transposed-shape"])
def test_stereo_errors(backend, pair, call, exc, match):
    with pytest.raises(exc, match=match):
        call(*pair, backend.name)


def test_stereo_confidence_contract(backend, pair):
    """Docstring: confidence in [0, 1], 0 exactly where the disparity is NaN; min_confidence
    rejects the pixels below it; speckle_size=0 turns the speckle filter off (more valid pixels)."""
    left, right = pair
    be = backend.name
    d, c = gfgpu.disparity(left, right, 16, return_confidence=True, backend=be)
    assert c.dtype == np.float32 and c.min() >= 0 and c.max() <= 1
    np.testing.assert_array_equal(c == 0, np.isnan(d))
    t = float(np.median(c[c > 0]))
    dm = gfgpu.disparity(left, right, 16, min_confidence=t, backend=be)
    assert not np.isfinite(dm[(c < t)]).any()
    no_speckle = gfgpu.disparity(left, right, 16, speckle_size=0, backend=be)
    assert np.isfinite(no_speckle).sum() >= np.isfinite(d).sum()


def test_stereo_flat_pair_has_no_match(backend):
    """Docstring: flat regions (no unique minimum) are NaN: no disparity is invented."""
    flat = np.full((H, W), 100, np.uint8)
    assert np.isnan(gfgpu.disparity(flat, flat, 16, backend=backend.name)).all()


# --------------------------------------------------------------------------------------
# README "Large images": whole-plane operators refuse an image above the working set
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["canny", "zoom", "rotation", "oblique", "shape_from_shading"])
def test_whole_plane_operators_refuse_above_the_working_set(backend, name):
    """README: "Operators that need the whole image plane — oblique directions of a 2-D image,
    zoom, canny (hysteresis is global), shape from shading, disparity — say so with a clear
    error instead of running out of memory" (a 200 x 200 float32 image, 64 KiB working set)."""
    x = np.random.default_rng(4).random((200, 200)).astype(np.float32)
    be = backend.name
    calls = {"canny": lambda: gfgpu.canny(x, backend=be),
             "zoom": lambda: gfgpu.motion_blur(x, 0.1, kind="zoom", backend=be),
             "rotation": lambda: gfgpu.motion_blur(x, 5.0, kind="rotation", backend=be),
             "oblique": lambda: gfgpu.motion_blur(x, (3.0, 4.0), backend=be),
             # an oblique light: an axis light streams its Green pass in strips (README)
             "shape_from_shading": lambda: gfgpu.shape_from_shading(x, light=(1, 1, 1), backend=be)}
    with gfgpu.working_set("64K"), pytest.raises(ValueError, match="whole image"):
        calls[name]()


def test_shape_from_shading_along_an_axis_streams(backend):
    """README: shape from shading along an axis streams its Green pass in strips: the same depth as
    in one piece under a working set far below the image."""
    yy, xx = np.mgrid[-50:50, -60:60] + 0.5
    from gfgpu.shading import lambertian_shading
    img = lambertian_shading(20 * np.exp(-(xx**2 + yy**2) / 800), (1, 0, 1)).astype(np.float32)
    ref = gfgpu.shape_from_shading(img, light=(1, 0, 1), backend=backend.name)
    with gfgpu.working_set("16K"):
        out = gfgpu.shape_from_shading(img, light=(1, 0, 1), backend=backend.name)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-5 * np.abs(ref).max())


def test_matcher_takes_a_shape_array(backend):
    """libSGM/OpenCV users pass ``numpy.array(img.shape[:2])``: a 1-D array of two integers is a shape."""
    m = gfgpu.StereoMatcher(np.array([H, W]), 16, backend=backend.name)
    assert m.shape == (H, W)
    with pytest.raises(ValueError, match=r"shape must be \(H, W\)"):
        gfgpu.StereoMatcher(np.array([[H, W]]), 16, backend=backend.name)
