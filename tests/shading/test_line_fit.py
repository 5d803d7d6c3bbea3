"""The line fit of GSFS (gfgpu.shading.line_fit) against walks along the digital lines: boundary
anchors, lines without anchors, the fit of an object's runs."""
import math

import numpy as np
import pytest

from gfgpu.shading import line_fit


def _walk_neighbours(shape, angle):
    """Previous and next pixel of every pixel along its line, from (line, t) by a dictionary."""
    line, t = line_fit.line_coordinates(shape, angle)
    where = {(int(ln), int(tt)): (i, j) for (i, j), ln, tt in zip(np.ndindex(shape), line.ravel(), t.ravel())}
    return line, t, where


@pytest.mark.parametrize("angle", [0.0, math.pi / 4, 0.3, 1.9, -2.5])
def test_boundary_anchors_are_the_pixels_next_to_the_object_along_each_line(rng, angle):
    obj = rng.random((23, 31)) < 0.3
    line, t, where = _walk_neighbours(obj.shape, angle)
    expected = np.zeros_like(obj)
    for (i, j), ln, tt in zip(np.ndindex(obj.shape), line.ravel(), t.ravel()):
        if obj[i, j]:
            continue
        near = [where.get((int(ln), int(tt) + d)) for d in (-1, 1)]
        expected[i, j] = any(p is not None and obj[p] for p in near)
    np.testing.assert_array_equal(line_fit.boundary_anchors(obj, angle), expected)


def test_object_fit_puts_both_ends_of_a_bracketed_run_at_zero():
    z = np.cumsum(np.ones((3, 12)), axis=1) + 5.0   # a ramp plus a constant on every row
    obj = np.zeros(z.shape, bool)
    obj[:, 3:8] = True
    line, t = line_fit.line_coordinates(z.shape, 0.0)
    anchors = line_fit.boundary_anchors(obj, 0.0)
    out, anchored = line_fit.fix_object(z, line, t, obj, anchors)
    assert anchored.all()
    np.testing.assert_allclose(out[:, [2, 8]], 0, atol=1e-12)     # two-sided: c and a fitted
    obj[:, :3] = True                               # now cut by the left border: c only
    out, _ = line_fit.fix_object(z, line, t, obj, line_fit.boundary_anchors(obj, 0.0))
    np.testing.assert_allclose(out[:, 8], 0, atol=1e-12)
    np.testing.assert_allclose(np.diff(out, axis=1), 1.0)          # the ramp is kept
