"""Fixtures of the engine's tests."""

import pytest


@pytest.fixture
def cpu_backend(require_backend):
    """The OpenCL backend on a CPU device (its bands, tiles and streamed stores are CPU paths)."""
    be = require_backend("opencl")     # fails, not skips, where GFGPU_TEST_BACKENDS asks for OpenCL
    if be.kind != "cpu":
        pytest.skip("a CPU-device path of the OpenCL engine")
    return be
