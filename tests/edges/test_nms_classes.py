"""canny's device classes and its hysteresis from them: the CPU shape of the suppression kernel
against the one-pixel (GPU) shape bit for bit, the classes against the rule, the growth of seeds
through the candidates between the thresholds against a labelling of all candidates, and canny
against the suppressed magnitude's hysteresis."""
import numpy as np
import pytest
from scipy import ndimage

import gfgpu
from conftest import gpu_shaped_backend, use_backend_or_skip
from gfgpu.edges import edge_gradient, hysteresis
from gfgpu.edges import kernels as edge_kernels
from gfgpu.edges.canny import _DENSE_FRACTION, _grow
from gfgpu.edges.spec import suppress_classes_reference


def _labelled(weak, strong):
    """The 8-connected components of ``weak`` that hold a pixel of ``strong``: scipy's per-pixel
    labelling of every candidate, an independent rule."""
    labels, count = ndimage.label(weak, np.ones((3, 3), bool))
    keep = np.zeros(count + 1, bool)
    keep[labels[strong]] = True
    keep[0] = False
    return keep[labels]


@pytest.mark.parametrize("between_density", [0.0, 0.02, 0.5 * _DENSE_FRACTION, 2 * _DENSE_FRACTION, 0.5])
def test_growth_from_seeds_matches_a_labelling_of_every_candidate(rng, between_density):
    """Seeds grown through the candidates below the upper threshold (linked as runs or by scipy,
    either side of the dense fraction) keep what labelling all candidates keeps, with long chains,
    diagonal steps, row ends and seeds of every density."""
    for shape in [(3, 3), (3, 40), (40, 3), (64, 64), (97, 131), (5, 300)]:
        for seed_density in (0.0, 0.002, 0.05, 0.4):
            between = rng.random(shape) < between_density
            strong = (rng.random(shape) < seed_density) & ~between
            for m in (between, strong):
                m[[0, -1], :] = m[:, [0, -1]] = False
            got = _grow(between, strong.copy())
            np.testing.assert_array_equal(got, _labelled(between | strong, strong),
                                          err_msg=f"{shape} {between_density} {seed_density}")


def test_growth_follows_a_diagonal_chain_and_stops_at_a_gap():
    between = np.zeros((6, 12), bool)
    strong = np.zeros_like(between)
    strong[1, 10] = True                    # a seed at the end of row 1
    between[2, 1] = True                    # far from the seed: not linked
    between[2, 9] = between[3, 8] = between[3, 7] = between[4, 6] = True   # a diagonal chain
    between[4, 10] = True                   # two columns from (3, 8), two rows below (2, 9): isolated
    got = _grow(between, strong.copy())
    expect = strong.copy()
    expect[2, 9] = expect[3, 8] = expect[3, 7] = expect[4, 6] = True
    assert not got[2, 1] and not got[4, 10]
    np.testing.assert_array_equal(got & ~expect, np.zeros_like(got))
    np.testing.assert_array_equal(got, _labelled(between | strong, strong))


# rows around the band (8) and one, two bands; columns around a vector (8), a run (64) and a run
# plus a vector, with and without the last run's few columns left one at a time
@pytest.mark.parametrize("shape", [(3, 3), (3, 9), (3, 10), (9, 3), (10, 66), (11, 65), (17, 73), (20, 130),
                                   (12, 137), (40, 8), (9, 200)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_cpu_and_gpu_shapes_of_the_suppression_are_bit_identical(rng, shape, dtype):
    """The CPU kernel (a run of 64 columns x a band of 8 rows per work-item, whole vectors, the
    last run's columns left one at a time) and the one-pixel-per-work-item kernel a GPU runs give
    the same bits, for the magnitude and for the classes, at shapes across band and run ends."""
    cpu = use_backend_or_skip("opencl")
    if cpu.kind != "cpu":
        pytest.skip("the OpenCL device is not a CPU: it runs the one-pixel kernel only")
    gpu = gpu_shaped_backend("opencl")
    if np.dtype(dtype) == np.float64 and not cpu.supports_float64:
        pytest.skip("no float64")
    gy, gx = rng.standard_normal((2, *shape)).astype(dtype)
    gy[1, :] = 0
    gx[:, 2] = np.round(gx[:, 2])
    a, b = cpu.asarray(gy), cpu.asarray(gx)
    outs = []
    for be in (cpu, gpu):
        out = be.asarray(np.full(shape, 7.0, dtype))
        edge_kernels.nms(be, a, b, out)
        cls = be.asarray(np.full(shape, 7, np.uint8))
        edge_kernels.nms_classes(be, a, b, cls, 0.5, 1.5, False)
        outs.append((be.to_host(out), be.to_host(cls)))
    np.testing.assert_array_equal(outs[0][0].view(np.uint8), outs[1][0].view(np.uint8))
    np.testing.assert_array_equal(outs[0][1], outs[1][1])
    np.testing.assert_array_equal(outs[0][1], suppress_classes_reference(gy, gx, 0.5, 1.5, False))


def _disc_and_noise(rng, size=96):
    yy, xx = np.mgrid[:size, :size]
    c = (size - 1) / 2
    img = 0.7 * (((yy - c) ** 2 + (xx - c) ** 2) < 30.3 ** 2) + 0.05 * rng.standard_normal((size, size))
    return np.clip(img, 0.0, 0.99)          # peak in [0.5, 1): canny does not rescale it


@pytest.mark.parametrize("low,high", [(0.05, 0.4), (0.2, 0.2), (0.01, 0.8)])
def test_canny_is_the_hysteresis_of_the_suppressed_magnitude(backend, rng, low, high):
    """canny (classes on the device, seeds grown through the candidates) equals the linked-run
    hysteresis of the suppressed magnitude of its own gradient, on a noisy disc and on noise."""
    for img in (_disc_and_noise(rng), rng.random((80, 70)) * 0.9 + 0.05):
        img = img.astype(np.float32)
        gy, gx = edge_gradient(img, 1.0, backend=backend)
        s = backend.empty(img.shape, np.float32)
        edge_kernels.nms(backend, backend.asarray(gy), backend.asarray(gx), s)
        s = backend.to_host(s)
        lo, hi = low * float(s.max()), high * float(s.max())     # fractions of the largest crest
        expect = hysteresis(s, lo, hi)
        got = gfgpu.canny(img, 1.0, lo, hi, backend=backend)
        np.testing.assert_array_equal(got, expect)
        assert got.any()
