"""A slow OpenCL build says why the caller waits (once per process): a first build on a machine can
take a minute with nothing on screen (a newcomer's first `gfgpu disparity --example`), while builds
served from PoCL's disk cache take milliseconds and print nothing."""

import time

import numpy as np
import pytest

pytest.importorskip("pyopencl")
import pyopencl as cl

from gfgpu._core import waiting
from gfgpu.backends.opencl import launch


@pytest.fixture
def opencl_be(opencl_cpu_device):
    import gfgpu
    return gfgpu.get_backend("opencl")


def _build(be, tag):
    # a define no other test uses: a program this process has not built
    return launch.kernel(be, "gfgpu.backends.opencl", "recurse.cl", "gather", np.float32, NOTICE_TEST=tag)


def test_a_slow_build_prints_one_notice(opencl_be, monkeypatch, capsys):
    monkeypatch.setattr(waiting, "_said", set())
    monkeypatch.setattr(launch, "BUILD_NOTICE_S", 0.05)
    build = cl.Program.build

    def slow(self, *args, **kwargs):
        time.sleep(0.3)
        return build(self, *args, **kwargs)

    monkeypatch.setattr(cl.Program, "build", slow)
    _build(opencl_be, time.monotonic_ns())
    _build(opencl_be, time.monotonic_ns() + 1)
    err = capsys.readouterr().err
    assert err.count("gfgpu: building OpenCL kernels (recurse.cl)") == 1, err
    assert "PoCL's cache" in err and "\n" == err[-1]


def test_a_quick_build_prints_nothing(opencl_be, monkeypatch, capsys):
    monkeypatch.setattr(waiting, "_said", set())
    monkeypatch.setattr(launch, "BUILD_NOTICE_S", 30.0)
    _build(opencl_be, time.monotonic_ns() + 2)
    time.sleep(0.05)
    assert capsys.readouterr().err == ""
