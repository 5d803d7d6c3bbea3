"""Line geometry (gfgpu._core.lines): axis views, axis arguments, directions, the sheared
layout of oblique directions (integer part of the shear), and the boundary extension of a line
by each mode."""
import math

import numpy as np
import pytest
from oracle import NP_PAD, pad_line

from gfgpu._core.boundary import MODES, extend_index
from gfgpu._core.lines import (
    DELAY_MIN,
    LINE_GROUP,
    axis_view_shape,
    direction,
    normalize_axis,
    shear_maps,
    shear_offsets,
)


# --------------------------------------------------------------------------------------
# axis lines
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(7,), (4, 9), (3, 5, 6), (2, 3, 4, 5), (1, 6, 1), (5, 1)])
def test_axis_view_shape_lays_out_the_lines_of_an_axis(shape):
    a = np.arange(int(np.prod(shape))).reshape(shape)
    for axis in range(len(shape)):
        (b, n, m), line_axis = axis_view_shape(shape, axis)
        assert b * n * m == a.size
        view = a.reshape(b, n, m)
        # the lines along `axis`, in C order of the other axes: (lines, samples)
        expect = np.moveaxis(a, axis, -1).reshape(-1, shape[axis])
        got = np.moveaxis(view, line_axis, -1).reshape(-1, view.shape[line_axis])
        np.testing.assert_array_equal(got, expect)
        if axis == len(shape) - 1 or int(np.prod(shape[axis + 1:])) == 1:
            assert (b, line_axis) == (1, 2) and m == shape[axis]      # contiguous lines: rows
        else:
            assert line_axis == 1 and n == shape[axis]


def test_normalize_axis():
    assert [normalize_axis(a, 3) for a in (0, 1, 2, -1, -2, -3)] == [0, 1, 2, 2, 1, 0]
    assert normalize_axis(np.int64(-1), 2) == 1
    with pytest.raises(ValueError, match=r"axis=3 is out of range for an array of 3 dimension\(s\)"):
        normalize_axis(3, 3)
    with pytest.raises(ValueError, match=r"axis=-4 is out of range"):
        normalize_axis(-4, 3)
    with pytest.raises(ValueError, match=r"channel_axis=2 is out of range for an array of 2"):
        normalize_axis(2, 2, name="channel_axis")
    for bad in ("x", None, [1]):
        with pytest.raises(TypeError, match="axis must be an integer"):
            normalize_axis(bad, 3)


# --------------------------------------------------------------------------------------
# directions
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("degrees", [0, 10, 30, 44.9, 45, 60, 90, 120, 135, 180, -30, -90, -135, 225, 300, 400])
def test_direction_steps_one_pixel_along_the_dominant_axis(degrees):
    theta = math.radians(degrees)
    steep, reverse, gamma = direction(theta)
    c, s = math.cos(theta), math.sin(theta)
    assert steep == (abs(s) > abs(c) + 1e-12)
    assert abs(gamma) <= 1 + 1e-12
    # one step: +-1 along the dominant axis, gamma along the other, in the direction (cos, sin)
    sign = -1 if reverse else 1
    step = (sign * gamma, sign * 1.0) if steep else (sign * 1.0, sign * gamma)     # (dx, dy)
    norm = math.hypot(*step)
    assert step[0] / norm == pytest.approx(c, abs=1e-12) and step[1] / norm == pytest.approx(s, abs=1e-12)


def test_direction_of_the_axes_and_diagonals():
    assert direction(0.0) == (False, False, 0.0)
    steep, reverse, gamma = direction(math.pi / 2)
    assert steep and not reverse and gamma == pytest.approx(0, abs=1e-15)
    assert direction(-math.pi / 2)[:2] == (True, True)
    assert direction(math.pi)[:2] == (False, True)
    assert direction(math.pi / 4) == (False, False, pytest.approx(1.0))     # ties go to x
    assert direction(3 * math.pi / 4) == (False, True, pytest.approx(-1.0))
    for bad, exc in ((float("nan"), ValueError), (float("inf"), ValueError), ("x", TypeError)):
        with pytest.raises(exc, match="angle"):
            direction(bad)


# --------------------------------------------------------------------------------------
# oblique directions: the sheared layout (integer part of the shear)
# --------------------------------------------------------------------------------------
SIZES = [(9, 13), (13, 9), (1, 7), (6, 1), (11, 11)]
ANGLES = [0.0, 0.3, -0.3, math.pi / 4, 1.0, math.pi / 2, 2.0, 3 * math.pi / 4, math.pi, -2.5, -math.pi / 2, 0.05]


def _pad_both(a, k, mode, cval):
    """``a`` extended by ``k`` samples on both ends of axis 0, by numpy.pad."""
    width = ((k, k),) + ((0, 0),) * (a.ndim - 1)
    if mode == "constant":
        return np.pad(a, width, mode="constant", constant_values=cval)
    if mode == "mirror" and a.shape[0] == 1:
        return np.pad(a, width, mode="edge")
    return np.pad(a, width, mode=NP_PAD[mode])


def _layout(maps, batch=1):
    """The layout as (batch, lines, steps) whatever its memory order."""
    def view(a):
        if maps.transposed:
            return a.reshape(batch, maps.steps, maps.lines).transpose(0, 2, 1)
        return a.reshape(batch, maps.lines, maps.steps)
    return view


@pytest.mark.parametrize("steps", [1, 2, 7, 30, 97])
@pytest.mark.parametrize("gamma", [0.0, 0.25, -0.25, 0.5, -0.5, 7 / 30, -13 / 29, 0.3183, 1.0, -1.0, 1e-9])
def test_shear_offsets_split_gamma_t_into_whole_pixels_and_a_delay(steps, gamma):
    r, d = shear_offsets(steps, gamma)
    t = np.arange(steps)
    assert r.dtype == np.int64 and d.dtype == np.float64
    np.testing.assert_allclose(r + d, gamma * t, rtol=0, atol=1e-12)
    whole = np.abs(gamma * t - np.round(gamma * t)) < 1e-12          # integer offsets: no resampling
    assert (d[whole] == 0).all()
    assert (d[~whole] >= DELAY_MIN - 1e-12).all() and (d[~whole] < DELAY_MIN + 1).all()


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("angle", ANGLES)
@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_every_pixel_has_one_place_in_the_sheared_layout(size, angle, transposed):
    h, w = size
    margin = 3
    steep, _, gamma = direction(angle)
    maps = shear_maps(h, w, 1, angle, "reflect", margin, transposed)
    lines, steps = maps.lines, maps.steps
    across = w if steep else h
    r, d = shear_offsets(steps, gamma)
    assert steps == (h if steep else w) and maps.transposed == transposed
    # the lines the pixels need, rounded up to whole groups of LINE_GROUP (the CPU kernels' vector
    # lanes); the extra lines lie past the last margin and are never read back
    needed = across + int(r.max() - r.min()) + 2 * margin
    assert lines % LINE_GROUP == 0 and needed <= lines < needed + LINE_GROUP
    np.testing.assert_array_equal(maps.delay, d)
    assert maps.shear.shape == (lines * steps,) and maps.unshear.shape == (h * w,)
    # each pixel has one place in the layout, and that place reads the pixel
    assert len(np.unique(maps.unshear)) == h * w
    np.testing.assert_array_equal(maps.shear[maps.unshear], np.arange(h * w))
    # the place of pixel (y, x): line m - r[t] - first at step t (x and y swap if steep), the
    # lines in order of m - r[t], with `margin` lines beyond the ones read back on each side
    yy, xx = np.mgrid[:h, :w]
    t, minor = (yy, xx) if steep else (xx, yy)
    place = np.zeros(lines * steps, np.int64)
    place[maps.unshear] = 1
    line = np.nonzero(_layout(maps)(place)[0])[0]                    # lines read back
    where = _layout(maps)(np.arange(lines * steps))[0]               # layout index of (line, step)
    inv = {int(v): (q, s) for (q, s), v in np.ndenumerate(where)}
    q_of = np.array([inv[int(u)][0] for u in maps.unshear]).reshape(h, w)
    s_of = np.array([inv[int(u)][1] for u in maps.unshear]).reshape(h, w)
    np.testing.assert_array_equal(s_of, t)
    ell = minor - r[t]
    np.testing.assert_array_equal(q_of - ell, (q_of - ell).flat[0])
    assert line.min() == margin and line.max() == needed - 1 - margin
    # a gather through both maps is the identity
    img = np.random.default_rng(0).random(h * w)
    np.testing.assert_array_equal(np.where(maps.shear >= 0, img[maps.shear], np.nan)[maps.unshear], img)


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("angle", [0.3, -0.7, 2.0, math.pi / 4, -2.5])
def test_lines_leaving_the_image_continue_through_its_extension(mode, angle, transposed):
    """Beyond the image's minor-axis edges a line reads the image extended by ``mode`` across
    that axis: what numpy.pad gives."""
    h, w = 7, 10
    margin = 4
    steep, _, gamma = direction(angle)
    img = np.random.default_rng(1).random((h, w)) + 1.0
    maps = shear_maps(h, w, 1, angle, mode, margin, transposed)
    lines, steps = maps.lines, maps.steps
    across = w if steep else h
    r, _ = shear_offsets(steps, gamma)
    first = -int(r.max()) - margin
    minor = first + np.arange(lines)[:, None] + r[None, :]          # (lines, steps)
    pad = int(np.abs(minor).max()) + across
    cval = -5.0
    plane = img.T if steep else img                                   # (minor, dominant)
    padded = _pad_both(plane, pad, mode, cval)
    expect = padded[minor + pad, np.arange(steps)[None, :]]
    got = np.where(maps.shear >= 0, img.ravel()[np.maximum(maps.shear, 0)], cval)
    np.testing.assert_array_equal(_layout(maps)(got)[0], expect)
    assert (maps.shear < 0).any() == (mode == "constant")


def test_shear_maps_for_a_batch_are_cached_and_read_only():
    h, w, batch, angle = 5, 8, 3, 0.4
    for transposed in (False, True):
        one = shear_maps(h, w, 1, angle, "wrap", 2, transposed)
        three = shear_maps(h, w, batch, angle, "wrap", 2, transposed)
        assert shear_maps(h, w, batch, angle, "wrap", 2, transposed) is three
        lines, steps = three.lines, three.steps
        assert (one.lines, one.steps) == (lines, steps)
        s1, u1 = one.shear, one.unshear
        s3, u3 = three.shear.reshape(batch, -1), three.unshear.reshape(batch, h * w)
        for b in range(batch):
            np.testing.assert_array_equal(s3[b], np.where(s1 >= 0, s1 + b * h * w, -1))
            np.testing.assert_array_equal(u3[b], u1 + b * lines * steps)
        for a in (three.shear, three.unshear, three.delay):
            assert not a.flags.writeable
        assert three.shear.dtype == three.unshear.dtype == np.int32


@pytest.mark.parametrize("angle", [0.3, 1.2, -2.6])
def test_the_transposed_layout_is_the_transpose(angle):
    a = shear_maps(9, 14, 2, angle, "mirror", 3, False)
    b = shear_maps(9, 14, 2, angle, "mirror", 3, True)
    assert (a.lines, a.steps) == (b.lines, b.steps)
    np.testing.assert_array_equal(a.shear.reshape(2, a.lines, a.steps),
                                  b.shear.reshape(2, b.steps, b.lines).transpose(0, 2, 1))
    # the same pixel, read from the same (line, step)
    la = np.stack(np.unravel_index(a.unshear, (2, a.lines, a.steps)), -1)
    lb = np.stack(np.unravel_index(b.unshear, (2, b.steps, b.lines)), -1)[:, [0, 2, 1]]
    np.testing.assert_array_equal(la, lb)


# --------------------------------------------------------------------------------------
# the extension of a line by each mode
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
@pytest.mark.parametrize("mode", MODES)
def test_extend_index_before_and_across_the_line_is_numpy_pad(mode, n):
    """Sample x0 < 0 of the extended line is sample extend_index(x0) of the line (-1: cval)."""
    line = np.arange(1.0, n + 1)
    k = 4 * n + 3                                   # several periods of every mode
    x0 = np.arange(-k, 0)
    idx = extend_index(x0, n, mode)
    assert idx.dtype == np.int64
    cval = -9.0
    got = np.where(idx >= 0, line[np.maximum(idx, 0)], cval)
    np.testing.assert_array_equal(got, pad_line(line, k, mode, cval, "left")[:k])
    # both sides, as the oblique lines extend across the image
    both = np.arange(-k, n + k)
    ext = extend_index(both, n, mode)
    got = np.where(ext >= 0, line[np.maximum(ext, 0)], cval)
    expect = _pad_both(line, k, mode, cval)
    np.testing.assert_array_equal(got, expect)


def test_extend_index_rejects_unknown_modes():
    with pytest.raises(ValueError, match="mode must be one of"):
        extend_index(np.array([-1]), 4, "symmetric")
