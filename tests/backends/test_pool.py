"""A new shape costs no build and no fresh memory on the CPU devices: the working arrays and numpy
results of a call come from the backend's host pool (gfgpu._core.hostpool), whose half-octave
classes a nearby shape shares, and kernels take sizes as arguments.  Counted, not timed."""

import numpy as np
import pytest

import gfgpu
from gfgpu import greens

G = greens.UniformGreen(3.0)
OPERATORS = {
    "shift": lambda x, be: gfgpu.shift(x, (2.5, -1.5), backend=be),
    "green_filter rows": lambda x, be: gfgpu.green_filter(x, G, axis=1, backend=be),
    "green_filter columns": lambda x, be: gfgpu.green_filter(x, G, axis=0, backend=be),
    "green_filter oblique": lambda x, be: gfgpu.green_filter(x, G, angle=0.3, backend=be),
    "derivative": lambda x, be: gfgpu.derivative(x, 1.0, backend=be),
}


def _builds(be):
    """Programs built so far for ``be`` (OpenCL), or None where builds are not counted here."""
    if be.name != "opencl":
        return None
    from gfgpu.backends.opencl import launch
    return sum(1 for key in launch._programs if key[0] == be.context)


def _cpu_device(backend):
    if backend.name == "numpy" or backend.kind != "cpu":
        pytest.skip("the host pool serves CPU devices")
    return backend


@pytest.mark.parametrize("name", sorted(OPERATORS))
def test_a_new_shape_reuses_pooled_memory_and_builds_nothing(backend, name, rng):
    be = _cpu_device(backend)
    op = OPERATORS[name]
    # 200 x 240 and 220 x 260 float32 (188 KiB, 223 KiB) share a half-octave class
    first, second = (rng.random(s, dtype=np.float32) for s in ((200, 240), (220, 260)))
    op(first, be)
    be.synchronize()
    fresh, builds = be._host_pool.stats["fresh"], _builds(be)
    out = op(second, be)
    be.synchronize()
    assert be._host_pool.stats["fresh"] == fresh
    assert _builds(be) == builds
    np.testing.assert_allclose(out, op(second.astype(np.float64), "numpy"), rtol=0, atol=2e-5)


@pytest.mark.parametrize("name", ["shift", "green_filter rows", "green_filter columns"])
def test_pooled_results_are_never_shared_while_alive(backend, name, rng):
    be = _cpu_device(backend)
    op = OPERATORS[name]
    x, y = (rng.random((200, 240), dtype=np.float32) for _ in range(2))
    expect_x, expect_y = op(x, "numpy"), op(y, "numpy")
    kept = op(x, be)[3:, 1:]          # a view of a result: the result's block stays in use
    other = op(y, be)
    again = op(y, be)
    assert not np.shares_memory(kept, other) and not np.shares_memory(other, again)
    np.testing.assert_allclose(kept, expect_x[3:, 1:], rtol=0, atol=2e-5)
    np.testing.assert_allclose(other, expect_y, rtol=0, atol=2e-5)
    np.testing.assert_allclose(again, expect_y, rtol=0, atol=2e-5)


def test_device_views_keep_a_pooled_buffer(require_backend, rng):
    """A view of an OpenCL array from ``empty`` (reshape, slice) shares the buffer object that holds
    the pooled memory: dropping the array keeps the memory while the view lives."""
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the host pool serves CPU devices")
    x = rng.random((200, 240), dtype=np.float32)
    arr = be.empty((200, 240), np.float32)
    be.copy(be.asarray(x), arr)
    view = arr.reshape(240, 200)
    del arr
    other = be.empty((200, 240), np.float32)      # may not take the view's memory
    be.copy(be.asarray(np.zeros_like(x)), other)
    np.testing.assert_array_equal(be.to_host(view).reshape(200, 240), x)
