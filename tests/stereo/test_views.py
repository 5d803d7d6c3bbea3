"""The host's matching views (``matching_views``): the right view's sub-pixel planes come from a
second-order recursion per row that must give scipy.signal.lfilter's values bit for bit (every
backend's census reads them), whatever the block of rows it runs in."""

import numpy as np
import pytest

from gfgpu.stereo import kernels, matching, spec


@pytest.mark.parametrize("amount,offset", [(0.5, 0), (-0.5, 1), (0.25, 0), (0.75, 0), (1 / 3, 0), (-0.25, 2)])
def test_rational_rows_are_lfilter_bit_for_bit(amount, offset):
    signal = pytest.importorskip("scipy.signal")
    from gfgpu import greens
    lp, = greens.translation_passes(amount)
    (sec,) = lp.sections
    lam, kap, tap = complex(sec.lam), complex(sec.kap), float(lp.tap)
    a = np.array([1.0, -2 * lam.real, abs(lam) ** 2])
    b = np.array([tap, tap * a[1] + kap.real, tap * a[2] - (kap * lam.conjugate()).real])
    rows = np.random.default_rng(7).random((13, 41)) * 200 - 20
    rows[3] = 5.0                                      # a constant row: the steady state exactly
    want = signal.lfilter(b, a, rows, axis=1, zi=signal.lfilter_zi(b, a)[None] * rows[:, :1])[0]
    np.testing.assert_array_equal(matching._rational_rows(b, a, rows), want)
    # and the whole shift against its direct evaluation with lfilter on the extended rows
    got = matching._green_shift_rows(rows, amount, offset)
    assert got.shape == rows.shape and np.isfinite(got).all()


def test_views_do_not_depend_on_the_row_blocks(monkeypatch):
    rng = np.random.default_rng(3)
    left, right = (rng.random((70, 33)).astype(np.float32) for _ in range(2))
    for steps in (1, 2, 3, 4):
        whole = matching.matching_views(left, right, steps)
        monkeypatch.setattr(matching, "_SHIFT_ROWS", 16)
        blocks = matching.matching_views(left, right, steps)
        monkeypatch.undo()
        np.testing.assert_array_equal(whole[0], blocks[0])
        np.testing.assert_array_equal(whole[1].view(np.uint32), blocks[1].view(np.uint32))


def test_subpixel_planes_on_every_backend_are_the_hosts(backend):
    # the planes the census reads (OpenCL: float64 recursions on the device, one row per
    # work-item) equal the specification's row-by-row recursion and the host's batched one bit for
    # bit: steps 1..4 (causal, anticausal and offset shifts), rows of 1 and 2 pixels, a zero run
    # long enough for the recursion's state to reach float64 subnormals (devices may flush them),
    # values that round to float32 subnormals (flushed to +0) and -0
    rng = np.random.default_rng(11)
    for shape in ((3, 1), (2, 2), (5, 37), (4, 900)):
        right = (rng.random(shape) * 1.9).astype(np.float32)
        right[:, shape[1] // 3:] = 0.0
        right[-1, : shape[1] // 2] = np.float32(2e-38)
        right[0, -1] = -0.0
        for steps in (1, 2, 3, 4):
            want = spec.subpixel_planes_reference(right, steps)
            np.testing.assert_array_equal(matching.subpixel_planes(right, steps).view(np.uint32),
                                          want.view(np.uint32))
            out = backend.empty((steps,) + shape, np.float32)
            kernels.planes(backend, backend.asarray(right), out, steps)
            got = np.asarray(backend.to_host(out))
            np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32), err_msg=f"{shape} {steps}")
