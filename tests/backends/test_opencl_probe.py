"""The wide-vector probe of CPU OpenCL devices (gfgpu.backends.opencl.probe): a compiler that
builds a trivial kernel may still abort the process on 16-wide vectors (PyOpenCL's bundled PoCL
3.0 on an AVX-512 AMD EPYC: "LLVM ERROR: Do not know how to scalarize this operator's operand!"),
so the probe runs in a child process and keeps its verdict on disk."""

import subprocess

import pytest

pytest.importorskip("pyopencl")
from gfgpu.backends.opencl import backend as clb
from gfgpu.backends.opencl import probe


def test_a_working_device_passes_and_its_verdict_is_kept(opencl_cpu_device, tmp_path, monkeypatch):
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert probe.wide_vector_failure(dev) is None
    kept = list((tmp_path / "gfgpu" / "opencl-probe").iterdir())
    assert len(kept) == 1 and kept[0].read_text() == ""

    def no_child(*args, **kwargs):
        raise AssertionError("probed again although the verdict is kept")

    monkeypatch.setattr(subprocess, "Popen", no_child)
    assert probe.wide_vector_failure(dev) is None


def test_a_failing_kernel_is_reported_kept_and_refuses_the_device(opencl_cpu_device, tmp_path, monkeypatch):
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    # a kernel the compiler rejects stands for one that aborts the child
    monkeypatch.setattr(probe, "_KERNEL", probe._KERNEL.replace("vstore16(", "no_such_builtin(", 1))
    reason = probe.wide_vector_failure(dev)
    assert reason and "rror" in reason
    (kept,) = (tmp_path / "gfgpu" / "opencl-probe").iterdir()
    assert kept.read_text() == reason
    monkeypatch.delitem(clb._build_failures, dev.int_ptr, raising=False)
    message = clb.build_failure(dev)
    assert "16-wide vectors" in message and reason in message and "pocl-opencl-icd" in message
    monkeypatch.delitem(clb._build_failures, dev.int_ptr)


class _Hung:
    """A child that printed ``out`` and then never finishes."""

    def __init__(self, out):
        self.out, self.killed, self.returncode = out, False, None

    def communicate(self, timeout=None):
        if self.killed:
            return self.out, "warning: x\n"
        raise subprocess.TimeoutExpired("child", timeout)

    def kill(self):
        self.killed = True


def test_a_child_that_hangs_in_the_compiler_refuses_the_device_for_good(opencl_cpu_device, tmp_path, monkeypatch,
                                                                         capsys):
    """PyOpenCL's bundled PoCL on an AVX-512 EPYC with an empty kernel cache spins past any
    timeout: that verdict is kept (each later process would wait as long), and the wait is
    announced; one that hangs before the compiler is not a verdict."""
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    kept = tmp_path / "gfgpu" / "opencl-probe"
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: _Hung(""))
    assert probe.wide_vector_failure(dev, timeout=4) is None
    assert not kept.exists() or not any(kept.iterdir())
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: _Hung("compiling\n"))
    assert "did not finish within 4 s" in probe.wide_vector_failure(dev, timeout=4)
    (verdict,) = kept.iterdir()
    assert "did not finish" in verdict.read_text()
    assert "testing the OpenCL device" in capsys.readouterr().err


def test_a_dropped_kernel_is_named(opencl_cpu_device, tmp_path, monkeypatch):
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    # a program whose kernel has another name stands for one the compiler dropped
    monkeypatch.setattr(probe, "_KERNEL", probe._KERNEL.replace("gfgpu_wide(", "another_name(", 1))
    assert "without its 16-wide vector kernel" in probe.wide_vector_failure(dev)


def test_the_verdict_depends_on_the_python_and_the_probe(opencl_cpu_device, monkeypatch):
    dev = opencl_cpu_device
    before = probe._verdict_path(dev)
    monkeypatch.setattr(probe.sys, "executable", "/elsewhere/python")
    assert probe._verdict_path(dev) != before
    monkeypatch.undo()
    monkeypatch.setattr(probe, "_KERNEL", probe._KERNEL + " ")
    assert probe._verdict_path(dev) != before
