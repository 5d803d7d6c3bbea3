"""Column passes on rows that are not whole cache lines, large enough for streamed stores.

On a CPU the OpenCL column kernel stores rows of whole 64-byte lines with non-temporal vector
stores; other rows (3000, 741, 2004 float32 columns: a row starts on a line only every few rows)
stage each row's outputs of a band and stream the lines wholly inside it, sample by sample at
the band's edges (recurse.cl, ``store_row_nt``).  Arrays from 8 MiB take that path: each case
is checked against a float64 run of the sequential specification, with bands ending in a
partial vector, and against the plain-store path on the same input.
"""

import numpy as np
import pytest

from gfgpu import greens
from gfgpu._core import recursion
from gfgpu._core.passes import LinePass, Section
from gfgpu.backends.opencl import backend as ocl

SEC1 = Section(lam=0.8 * np.exp(0.3j), kap=0.5 + 0.1j)
SEC2 = Section(lam=0.6 * np.exp(-0.2j), kap=0.2 - 0.3j)
PASSES = {"G_u": greens.UniformGreen(3.0).line_pass(),
          "two sections, anticausal": LinePass((SEC1, SEC2), tap=-0.1, reverse=True)}
# (N, M, dtype): at least ocl._STREAM_BYTES each, rows of M samples not whole cache lines
SHAPES = [(700, 3000, np.float32), (2900, 741, np.float32), (1050, 2004, np.float32),
          (350, 3004, np.float64), (1100, 1923, np.float64)]


def reference(x, lp, mode, cval):
    n = x.shape[1]
    plan = recursion.plan_pass(lp, n, mode, np.float64)
    lines = np.moveaxis(x.astype(np.float64), 1, 0)
    out = recursion.run_reference(lines.reshape(n, -1), plan, cval=cval).reshape(lines.shape)
    return np.moveaxis(out, 0, 1)




@pytest.mark.parametrize("name", sorted(PASSES))
@pytest.mark.parametrize("n, m, dtype", SHAPES)
def test_unaligned_columns_match_the_specification(cpu_opencl, name, n, m, dtype, rng):
    be, lp = cpu_opencl, PASSES[name]
    x = rng.standard_normal((1, n, m)).astype(dtype)
    assert x.nbytes >= ocl._STREAM_BYTES and (m * x.itemsize) % 64
    shape = be.recurse_shape(x.shape, 1, dtype)
    assert shape.vectors > 1 and (shape.vectors * shape.lanes) % m and m % shape.lanes   # partial vectors
    plan = recursion.plan_pass(lp, n, "reflect", dtype)
    src = be.asarray(x)
    out = be.empty(x.shape, dtype)
    assert be.recurse(src, out, 1, plan, cval=0.0, check=True) is True
    got = out.get()
    want = reference(x, lp, "reflect", 0.0)
    tol = 1e-5 if dtype == np.float32 else 1e-12
    assert np.abs(got - want).max() <= tol * np.abs(want).max()
    # in place (dst is src) writes the same samples
    be.recurse(src, src, 1, plan, cval=0.0)
    assert np.array_equal(src.get(), got)


def test_unaligned_columns_equal_plain_stores(cpu_opencl, rng, monkeypatch):
    """The streamed path and plain stores (an array under _STREAM_BYTES) give the same bits."""
    be = cpu_opencl
    x = rng.standard_normal((1, 700, 3000)).astype(np.float32)
    plan = recursion.plan_pass(PASSES["G_u"], 700, "reflect", np.float32)
    outs = []
    for limit in (ocl._STREAM_BYTES, x.nbytes + 1):
        monkeypatch.setattr(ocl, "_STREAM_BYTES", limit)
        out = be.empty(x.shape, np.float32)
        be.recurse(be.asarray(x), out, 1, plan)
        outs.append(out.get())
    assert np.array_equal(outs[0], outs[1])
