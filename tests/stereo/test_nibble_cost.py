"""The CPU band matcher's 3 x 3 block costs from nibble planes of the right census codes
(``stereo.cl``'s ``census_nibbles`` and ``block_cost`` with ``-D NIBBLES``: vpshufb lookups and
saturating byte sums, PoCL on x86 with AVX2) and its selection with the right view's diagonal
minima in private memory: maps equal to the numpy specification's and to the interleaved-code
kernel's (``USE_NIBBLES = False``), on the shapes where the two differ in their own code paths:
pixels of 16 and 32 lanes past whole 32-byte vectors, sub-pixel steps 1..4, negative and shifted
ranges, ranges beyond the image's width, narrow images whose column ranges are a column or two,
bands of rows (coarse bands whose costs are recomputed)."""

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import _opencl, band_plan

from .scenes import random_dot_pair, shifted_pair, slanted, square


def _opencl_cpu():
    be = stereo.matching.resolve_backend("opencl", None)
    if be.kind != "cpu":
        pytest.skip("the band matcher (and its nibble cost) runs on OpenCL CPU devices")
    return be


def _both(monkeypatch, be, left, right, d_max, **kw):
    """The map of the nibble-plane cost and of the interleaved-code cost."""
    maps = []
    for flag in (True, False):
        monkeypatch.setattr(_opencl, "USE_NIBBLES", flag)
        maps.append(stereo.disparity(left, right, d_max, backend=be, **kw))
    return maps


CASES = [
    # (pair, max_disparity, options): samples per pixel n = (max - min) * steps + 1
    ("square", 15, {}),                                  # n = 31: one 32-lane vector
    ("square", 7, {"subpixel_steps": 1}),                # n = 8: a 16-lane pixel (NP % 32 = 16)
    ("slanted", 23, {"subpixel_steps": 2}),              # n = 47: 48 lanes, a 16-lane tail
    ("slanted", 11, {"subpixel_steps": 3}),              # n = 34
    ("square", 11, {"subpixel_steps": 4}),               # n = 45
    ("shift-9", 16, {}),                                 # an exact shift: the band with no match
    ("shift-m9", (-16, 4), {}),                          # negative disparities
    ("square", (3, 20), {}),                             # a range starting above 0
    ("square", 140, {"subpixel_steps": 1}),              # a range beyond the image's width
]


def _pair(name, shape=(64, 112)):
    if name == "square":
        return random_dot_pair(square, shape=shape)[:2]
    if name == "slanted":
        return random_dot_pair(slanted, shape=shape, seed=3)[:2]
    if name == "shift-9":
        return shifted_pair(9, shape=shape)
    left, right = shifted_pair(9, shape=shape, seed=1)
    return right, left                       # left[y, x] = right[y, x + 9]: d = -9


@pytest.mark.parametrize("name, d_max, opts", CASES)
def test_nibble_cost_equals_spec_and_interleaved(monkeypatch, name, d_max, opts):
    be = _opencl_cpu()
    if not _opencl._nibbles(be, 3):
        pytest.skip("this OpenCL device has no nibble-plane cost (PoCL on x86 with AVX2)")
    if isinstance(d_max, tuple):
        opts = {**opts, "min_disparity": d_max[0]}
        d_max = d_max[1]
    left, right = _pair(name)
    want = stereo.disparity(left, right, d_max, backend="numpy", **opts)
    nib, inter = _both(monkeypatch, be, left, right, d_max, **opts)
    np.testing.assert_array_equal(nib, want)
    np.testing.assert_array_equal(inter, want)
    assert np.isfinite(want).mean() > 0.3          # not an all-NaN comparison


@pytest.mark.parametrize("width", [3, 5, 9])
def test_nibble_cost_narrow_images(monkeypatch, width):
    # column ranges of one or two columns per work-item (4 work-items on 2 cores), the window's
    # clamped columns at both edges of every range
    be = _opencl_cpu()
    left, right = _pair("square", shape=(20, 112))
    left, right = left[:, 40:40 + width], right[:, 40:40 + width]
    for d_max in (1, 4):
        want = stereo.disparity(left, right, d_max, backend="numpy", speckle_size=0)
        for got in _both(monkeypatch, be, left, right, d_max, speckle_size=0):
            np.testing.assert_array_equal(got, want)


def test_nibble_cost_in_coarse_bands(monkeypatch):
    # the costs not kept: computed per coarse band (its nibble planes of its rows and block margin)
    # in both passes; bands of 4 rows, coarse bands of 8
    be = _opencl_cpu()
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    left, right = _pair("slanted", shape=(61, 96))
    plan = band_plan.match_plan(61, 96, 31, 4)
    assert not plan.keep and plan.coarse < 61
    want = stereo.disparity(left, right, 15, backend="numpy")
    for got in _both(monkeypatch, be, left, right, 15):
        np.testing.assert_array_equal(got, want)
