"""The blocked two-sided column kernels (gfgpu/backends/opencl/twosided.cl: ``two_sided_carries``
then ``two_sided_blocks``) against the float64-free executable specification
:func:`gfgpu._core.twosided.run_two_sided_reference`, with blocks of a few rows so that every
block boundary case runs: lines shorter than a block, exactly one block, a ragged last block,
blocks of one row; and the finite check's verdict for a bad sample in the first, a middle and
the last block."""

import numpy as np
import pytest

from gfgpu import greens
from gfgpu._core.twosided import plan_two_sided, run_two_sided_reference
from gfgpu.edges import operator

TOL = {np.float32: 2e-5, np.float64: 1e-12}




def _run(be, plan, xs, cvals, check=False):
    from gfgpu.backends.opencl.twosided import run_two_sided
    dsts = [be.empty(xs[0].shape, xs[0].dtype) for _ in plan.inputs]
    verdict = run_two_sided(be, [be.asarray(x) for x in xs], dsts, 1, plan, cvals, check=check)
    return verdict, [be.to_host(d) for d in dsts]


@pytest.mark.parametrize("block", [1, 5, 16])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [1, 4, 5, 16, 23, 48])
def test_blocks_match_spec(cpu_opencl, monkeypatch, block, dtype, n, rng):
    from gfgpu.backends.opencl import twosided
    monkeypatch.setattr(twosided, "BLOCK_ROWS", block)
    be = cpu_opencl
    chapter = greens.projection_passes(1.3), greens.derivative_passes(1.3)
    one_signed = operator.projection_passes(0.9), operator.derivative_passes(0.9)
    for (P, D), outputs, mode in ((chapter, "PD", "reflect"), (one_signed, "PD", "constant"),
                                  (chapter, "D", "wrap"), (one_signed, "DP2", "mirror")):
        spec = {"PD": [(0, P), (0, D)], "D": [(0, D)], "DP2": [(0, D), (1, P)]}[outputs]
        plan = plan_two_sided(spec, n, mode, dtype)
        shape = (2, n, 37)                    # two images, a partial vector of columns
        xs = [rng.standard_normal(shape).astype(dtype) for _ in set(plan.inputs)]
        cvals = (0.6, -0.4)
        _, got = _run(be, plan, xs, cvals)
        ref = run_two_sided_reference([np.moveaxis(x, 1, 0).reshape(n, -1) for x in xs], plan, cvals)
        for g, r in zip(got, ref):
            g = np.moveaxis(g, 1, 0).reshape(n, -1)
            assert np.abs(g - r).max() <= TOL[dtype] * np.abs(r).max(), (outputs, mode)


@pytest.mark.parametrize("row", [0, 6, 12, 29])
def test_check_sees_every_block(cpu_opencl, monkeypatch, row, rng):
    """The finite check rides on the carries' sweep: a bad sample in any block is seen."""
    from gfgpu.backends.opencl import twosided
    monkeypatch.setattr(twosided, "BLOCK_ROWS", 6)
    be = cpu_opencl
    n = 30
    plan = plan_two_sided([(0, greens.projection_passes(1.0)), (0, greens.derivative_passes(1.0))], n, "reflect",
                          np.float32)
    x = rng.standard_normal((1, n, 40)).astype(np.float32)
    assert _run(be, plan, [x], (0.0, 0.0), check=True)[0]
    for bad in (np.nan, -np.inf, 2.0**70):
        y = x.copy()
        y[0, row, 33] = bad
        assert _run(be, plan, [y], (0.0, 0.0), check=True)[0] is False
