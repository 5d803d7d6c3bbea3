"""Hysteresis by linked runs against a per-pixel labelling, the NMS kernel's border and launch
shapes, the power-of-two scaling and the quantile thresholds of canny."""
import numpy as np
import pytest
from scipy import ndimage

import gfgpu
from gfgpu.edges import hysteresis
from gfgpu.edges import kernels as edge_kernels
from gfgpu.edges.canny import _DENSE_FRACTION, _components, _scale_pow2
from gfgpu.edges.spec import suppress_nonmaxima_reference


def _reference(suppressed, low, high):
    """Hysteresis by scipy's per-pixel labelling (8-connected), float64: an independent rule."""
    s = np.asarray(suppressed, np.float64)
    weak = (s >= low) & (s > 0)
    labels, count = ndimage.label(weak, np.ones((3, 3), bool))
    keep = np.zeros(count + 1, bool)
    keep[np.unique(labels[weak & (s >= high)])] = True
    keep[0] = False
    return keep[labels]


def _sparse_field(rng, shape, density):
    return rng.random(shape) * (rng.random(shape) < density)


@pytest.mark.parametrize("density", [0.0, 0.01, 0.05, 0.2, 0.6, 1.0])
def test_hysteresis_matches_a_per_pixel_labelling(rng, density):
    """Both ways of linking (runs below the dense fraction, scipy's labels above) give the
    reference's map, on shapes from one pixel to long rows and columns, one high or several."""
    for shape in [(1, 1), (1, 40), (40, 1), (2, 2), (7, 300), (300, 7), (64, 64), (129, 77)]:
        for _ in range(4):
            s = _sparse_field(rng, shape, density)
            low = rng.uniform(0, 0.5)
            highs = [low, low + 0.2, 0.9, 2.0]
            got = hysteresis(s, low, highs)
            for h, g in zip(highs, got):
                np.testing.assert_array_equal(g, _reference(s, low, h), err_msg=f"{shape} {density} {low} {h}")
            np.testing.assert_array_equal(hysteresis(s, low, highs[1]), _reference(s, low, highs[1]))


def test_both_linkings_give_the_same_components(rng):
    """The run linking and scipy's labelling agree on one mask on each side of the switch (the
    labels differ; the partition of the pixels must not)."""
    for density in (0.5 * _DENSE_FRACTION, 2 * _DENSE_FRACTION, 0.5):
        weak = rng.random((97, 131)) < density
        index = np.flatnonzero(weak)
        label, count = _components(weak, index)
        assert label.max() < count
        ref = ndimage.label(weak, np.ones((3, 3), bool))[0].reshape(-1)[index]
        # the same partition: a one-to-one map between the two labellings
        pairs = np.unique(np.stack([label, ref]), axis=1)
        assert len(np.unique(pairs[0])) == len(np.unique(pairs[1])) == pairs.shape[1]


def test_runs_link_diagonally_but_never_across_the_row_end():
    s = np.zeros((4, 30))
    s[0, 29] = 1.0         # strong, at the end of row 0
    s[1, 0] = 0.5          # next in memory, but on the other side of the image: not linked
    s[1, 28] = 0.5         # diagonal neighbour of (0, 29): linked
    s[2, 27] = 0.5         # diagonal again: linked
    s[3, 29] = 0.5         # two columns from (2, 27): not linked
    assert np.count_nonzero(s) < _DENSE_FRACTION * s.size       # linked as runs
    got = hysteresis(s, 0.4, 0.9)
    expect = np.zeros_like(got)
    expect[0, 29] = expect[1, 28] = expect[2, 27] = True
    np.testing.assert_array_equal(got, expect)
    np.testing.assert_array_equal(got, _reference(s, 0.4, 0.9))


def test_hysteresis_refuses_other_than_2d():
    with pytest.raises(ValueError, match="suppressed must be 2-D"):
        hysteresis(np.ones(5), 0.1, 0.2)


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (2, 2), (2, 70), (70, 2), (3, 3), (3, 66), (65, 3), (5, 129)])
def test_nms_kernel_writes_every_pixel_at_small_and_odd_shapes(backend, rng, shape):
    """The interior and the border (written apart on OpenCL) cover the output, in launch shapes
    that pad a work-group; every pixel equals the rule's, none is left from a stale buffer."""
    gy, gx = rng.standard_normal((2, *shape)).astype(np.float32)
    out = backend.asarray(np.full(shape, 7.0, np.float32))
    edge_kernels.nms(backend, backend.asarray(gy), backend.asarray(gx), out)
    np.testing.assert_allclose(backend.to_host(out), suppress_nonmaxima_reference(gy, gx), rtol=1e-6, atol=0)


def test_nms_kernel_on_a_disc_ties_and_axes(backend):
    """Crests whose neighbours are exactly tied (|gy| = |gx|, axis-aligned and zero gradients) in
    every octant: the selected neighbours are the rule's, pixel for pixel."""
    yy, xx = np.mgrid[:61, :67].astype(np.float64)
    r = np.hypot(yy - 30, xx - 33) + 1e-12
    prof = np.exp(-((r - 17) ** 2) / 6)
    gy, gx = (np.round(8 * (yy - 30) / r * prof) / 8).astype(np.float32), \
        (np.round(8 * (xx - 33) / r * prof) / 8).astype(np.float32)
    out = backend.empty(gy.shape, np.float32)
    edge_kernels.nms(backend, backend.asarray(gy), backend.asarray(gx), out)
    ref = suppress_nonmaxima_reference(gy, gx)
    np.testing.assert_allclose(backend.to_host(out), ref, rtol=1e-6, atol=0)
    assert (ref > 0).sum() > 50


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_scaling_by_a_power_of_two_is_ldexp(rng, dtype):
    """Bit for bit np.ldexp, also where the result is subnormal (rounded once) and where the
    factor itself is outside the normal range (the ldexp fallback)."""
    info = np.finfo(dtype)
    x = np.concatenate([rng.standard_normal(200), rng.random(50) * float(info.smallest_subnormal) * 64,
                        [0.0, -0.0, float(info.tiny), float(info.max) / 4]]).astype(dtype)
    for e in (-info.maxexp - 30, -info.maxexp, -200, -130, -126, -40, -1, 0, 1, 7, 126, 127, info.maxexp - 1,
              info.maxexp, -info.minexp + 20, info.maxexp + 30):
        with np.errstate(over="ignore"):
            got = _scale_pow2(x, e, dtype)
            expect = np.ldexp(x, e).astype(dtype, copy=False)
        assert got.dtype == dtype
        np.testing.assert_array_equal(got.view(np.uint8), expect.view(np.uint8), err_msg=str(e))


def test_quantile_thresholds_are_the_magnitudes_percentiles(backend, rng):
    """Quantiles are numpy.percentile of the returned magnitude (in its dtype), and taking them
    leaves that magnitude as the call without quantiles returns it."""
    img = (ndimage.gaussian_filter(rng.random((96, 80)), 2) * 3).astype(np.float32)
    plain = gfgpu.canny(img, 1.0, return_gradient=True, backend=backend)
    for lo, hi in ((0.7, 0.9), (0.5, 0.5), (0.0, 0.95)):
        edges, mag, ori = gfgpu.canny(img, 1.0, lo, hi, use_quantiles=True, return_gradient=True, backend=backend)
        np.testing.assert_array_equal(mag, plain[1])
        np.testing.assert_array_equal(ori, plain[2])
        tlo, thi = (float(np.percentile(mag, 100.0 * q)) for q in (lo, hi))
        np.testing.assert_array_equal(edges, gfgpu.canny(img, 1.0, tlo, thi, backend=backend))
        np.testing.assert_array_equal(edges, gfgpu.canny(img, 1.0, lo, hi, use_quantiles=True, backend=backend))


def test_canny_edges_are_the_hysteresis_of_the_reference_nms(backend):
    """canny on a textured image = reference NMS of its own gradient (float64) + the per-pixel
    labelling, up to the pixels whose magnitude rounds across a threshold."""
    from skimage import data, transform
    img = transform.resize(data.camera() / 255.0, (200, 200), anti_aliasing=True)
    img = img + 0.05 * np.sin(np.arange(200) / 1.7)[:, None] * np.cos(np.arange(200) / 2.3)[None, :]
    lo, hi = 0.004, 0.02
    edges = gfgpu.canny(img, 1.0, lo, hi, backend=backend)
    gy, gx = gfgpu.edges.edge_gradient(img, 1.0, backend="numpy")
    nms = suppress_nonmaxima_reference(gy, gx)
    ref = _reference(nms, lo, hi)
    assert ref.sum() > 1000
    assert (edges != ref).sum() <= 0.002 * ref.sum()
