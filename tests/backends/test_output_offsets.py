"""OpenCL CPU passes into a caller's ``output=`` that does not start on a cache line, and long rows.

A numpy array starts 16 bytes into a cache line.  The column kernel starts its bands where the
output's rows are vector-aligned (band 0 narrower, the last band one vector wider), and a
windowed row pass (an integer translation fused into the pass) runs a partial tile first so that
its tile stores are aligned (``tile_lead``).  Each case is checked against the float64 numpy
specification and, bit for bit, against the same call into a new (page-aligned) array, for
output arrays at several offsets within a cache line.  Long rows (``rows_as_blocks``) take the
omega terms of their first blocks from a kernel that runs no recursion (``TERMS_ONLY``).
"""

import numpy as np
import pytest

import gfgpu
from gfgpu import greens

OFFSETS = [4, 16, 36, 60]      # bytes past a cache line (0 mod 64: the aligned case, new arrays)




def at_offset(shape, dtype, offset):
    """An uninitialised array whose data start ``offset`` bytes past a 64-byte boundary."""
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    raw = np.empty(nbytes + 128, np.uint8)
    start = -raw.ctypes.data % 64 + offset
    out = raw[start:start + nbytes].view(dtype).reshape(shape)
    out[...] = np.nan           # a sample the pass does not write shows
    return out


def spec(call, x, **kw):
    return call(x.astype(np.float64), backend="numpy", **kw)


CALLS = {
    "columns": lambda x, **kw: gfgpu.green_filter(x, greens.UniformGreen(3.0), axis=0, **kw),
    "columns, anticausal": lambda x, **kw: gfgpu.green_filter(x, greens.UniformGreen(2.0), axis=0,
                                                              anticausal=True, **kw),
    "columns, two passes": lambda x, **kw: gfgpu.shift(x, (-3.5, 0), interpolation="cubic", **kw),
    "columns, translated": lambda x, **kw: gfgpu.shift(x, (2.5, 0), **kw),
    "rows, translated": lambda x, **kw: gfgpu.shift(x, (0, 2.5), **kw),
    "rows, translated back": lambda x, **kw: gfgpu.shift(x, (0, -7.5), **kw),
}


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(2100, 1024), (333, 512)])   # streamed stores; plain ones
@pytest.mark.parametrize("name", sorted(CALLS))
def test_output_at_any_offset(cpu_opencl, name, shape, dtype, rng):
    be, call = cpu_opencl, CALLS[name]
    x = rng.standard_normal(shape).astype(dtype)
    # the shifted bands need room for one more vector (nv < BAND) and rows of whole vectors
    view = be.recurse_shape((1,) + shape, 1, dtype)
    assert view.vectors < 64 and shape[1] % view.lanes == 0
    new = call(x, mode="reflect", backend=be)
    want = spec(call, x, mode="reflect")
    tol = 1e-5 if dtype == np.float32 else 1e-12
    assert np.abs(new - want).max() <= tol * np.abs(want).max()
    for offset in OFFSETS:
        if offset % np.dtype(dtype).itemsize:
            continue
        out = at_offset(shape, dtype, offset)
        got = call(x, mode="reflect", output=out, backend=be)
        assert got is out
        assert np.array_equal(out, new), f"output at {offset} bytes differs from a new array"


@pytest.mark.parametrize("mode", ["reflect", "mirror", "nearest", "constant", "wrap"])
@pytest.mark.parametrize("anticausal", [False, True])
def test_long_rows_match_the_specification(cpu_opencl, mode, anticausal, rng):
    be = cpu_opencl
    x = rng.standard_normal((3, 1 << 19)).astype(np.float32)
    assert be.recurse_shape((1,) + x.shape, 2, np.float32).rows_as_blocks
    kernel = greens.UniformGreen(3.0)
    got = gfgpu.green_filter(x, kernel, axis=1, anticausal=anticausal, mode=mode, cval=0.5, backend=be)
    want = gfgpu.green_filter(x.astype(np.float64), kernel, axis=1, anticausal=anticausal, mode=mode, cval=0.5,
                              backend="numpy")
    assert np.abs(got - want).max() <= 1e-5 * np.abs(want).max()
    out = at_offset(x.shape, np.float32, 16)
    gfgpu.green_filter(x, kernel, axis=1, anticausal=anticausal, mode=mode, cval=0.5, output=out, backend=be)
    assert np.array_equal(out, got)
