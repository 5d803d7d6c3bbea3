"""The row kernel's streamed outputs and the gradient's choice of its first axis (OpenCL CPU device).

``two_sided_rows`` writes a large output (``stream``: from ``_STREAM_BYTES``) a row's whole cache
line at a time with non-temporal stores, where every output's chunks start on a cache line and the
work-item's vector of rows is full; elsewhere plain stores.  The threshold is lowered here so that
small arrays take the streamed path: its values must be those of the plain path bit for bit and of
the float64 direct sums (:func:`.test_twosided_steps.direct`, which shares no code with the
kernels); outputs at offsets that break the alignment of one output only, partial vectors of rows
and widths that are not whole cache lines fall back, and nothing beyond an output is written.

:func:`gfgpu.gradient` runs its two-output step along the rows' axis where the device takes it,
else along the other axis, else each derivative's own program: every branch against the same
direct sums.
"""

import numpy as np
import pytest

import gfgpu
from gfgpu._core.twosided import plan_two_sided
from gfgpu.backends.opencl import twosided

from .test_twosided_steps import CVALS, TOL, _as_lines, _check_outputs, _passes, direct, separable_direct

SPECS = {"D": lambda P, D: [(0, D)], "PD": lambda P, D: [(0, P), (0, D)], "DP2": lambda P, D: [(0, D), (1, P)]}


def _step(be, plan, xs, dsts, stream):
    """Run a row step with the streamed path on (threshold 0) or off; the outputs on the host."""
    saved = twosided._STREAM_BYTES
    twosided._STREAM_BYTES = 0 if stream else 1 << 62
    try:
        twosided.run_two_sided(be, [be.asarray(x) for x in xs], dsts, 2, plan, CVALS)
    finally:
        twosided._STREAM_BYTES = saved
    return [np.array(be.to_host(d)) for d in dsts]


# (B, N, M): whole vectors of rows and cache lines; a partial last vector of rows (19, 21 rows);
# widths that are not whole cache lines (45, 50); rows of one chunk
SHAPES = [(1, 16, 64), (2, 24, 160), (1, 19, 64), (3, 7, 96), (1, 17, 45), (2, 9, 50), (1, 32, 16)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("outputs", sorted(SPECS))
@pytest.mark.parametrize("shape", SHAPES)
def test_streamed_rows_equal_plain_rows_and_direct_sums(cpu_opencl, dtype, outputs, shape, rng):
    be = cpu_opencl
    P, D = _passes("chapter")
    spec = SPECS[outputs](P, D)
    plan = plan_two_sided(spec, shape[2], "reflect", dtype)
    xs = [rng.standard_normal(shape).astype(dtype) for _ in set(plan.inputs)]
    streamed = _step(be, plan, xs, [be.empty(shape, dtype) for _ in spec], True)
    plain = _step(be, plan, xs, [be.empty(shape, dtype) for _ in spec], False)
    for s, p in zip(streamed, plain):
        np.testing.assert_array_equal(s, p)
    _check_outputs(streamed, xs, spec, 2, "reflect", CVALS, dtype)


@pytest.mark.parametrize("offsets", [(0, 0), (0, 3), (5, 0), (16, 16), (1, 1)])
@pytest.mark.parametrize("shape", [(1, 136, 128), (1, 133, 128)])   # 64 KiB and more: wrapped
def test_streamed_rows_into_numpy_outputs(cpu_opencl, offsets, shape, rng):
    """Two numpy outputs (``output=``, wrapped in place) at element offsets ``offsets`` within a
    cache line: streamed where both align (offsets 0 and 16 here), else plain stores (one output
    aligned and the other not must not be streamed to a misaligned address); the guard elements
    before and after each output stay untouched."""
    be = cpu_opencl
    P, D = _passes("chapter")
    spec = [(0, P), (0, D)]
    plan = plan_two_sided(spec, shape[2], "nearest", np.float32)
    x = rng.standard_normal(shape).astype(np.float32)
    size = int(np.prod(shape))
    raws = [np.full(size + 128, 7.0, np.float32) for _ in offsets]
    starts = [32 - raw.ctypes.data % 64 // 4 + off for raw, off in zip(raws, offsets)]   # off from a line
    hosts = [raw[s:s + size].reshape(shape) for raw, s in zip(raws, starts)]
    dsts = [be.host_result(shape, np.float32, into=h) for h in hosts]
    assert all(d.gfgpu_host is h for d, h in zip(dsts, hosts))
    got = _step(be, plan, [x], dsts, True)
    for raw, s in zip(raws, starts):
        assert (raw[:s] == 7.0).all() and (raw[s + size:] == 7.0).all()
    for g in got:
        assert not np.isnan(g).any()
    ref = []
    for i, passes in spec:
        ref.append(direct(_as_lines(x, 2), passes, "nearest", CVALS[i]))
    for g, r in zip(got, ref):
        assert np.abs(_as_lines(g, 2) - r).max() <= TOL[np.float32] * max(np.abs(r).max(), 1.0)




@pytest.mark.parametrize("shape, axes, channel_axis", [
    ((40, 70), None, None),            # rows first
    ((10, 300), None, None),           # too few rows for the row kernel: columns first
    ((3, 30, 40), (1, 2), None),       # a stack: rows first
    ((30, 40, 3), None, -1),           # colour last: neither axis runs along rows
    ((3, 30, 40), None, 0),            # colour first: rows first
])
@pytest.mark.parametrize("mode", ["reflect", "constant", "wrap"])
def test_gradient_every_first_axis(cpu_opencl, shape, axes, channel_axis, mode, rng):
    from gfgpu import greens
    P, D = greens.projection_passes(1.1), greens.derivative_passes(1.1)
    cval = 0.9
    img = (rng.random(shape) * 10).astype(np.float32)
    got = gfgpu.gradient(img, 1.1, axes=axes, channel_axis=channel_axis, mode=mode, cval=cval,
                         backend=cpu_opencl)
    ax = gfgpu.filters.operated_axes(img.ndim, axes, channel_axis)
    assert len(got) == len(ax) == 2
    for g, d_axis in zip(got, ax):
        r = separable_direct(img, d_axis, ax, mode, cval, P, D)
        assert g.shape == img.shape
        assert np.abs(g - r).max() <= 4 * TOL[np.float32] * np.abs(r).max(), (d_axis, mode)
