"""The ``backend`` fixture (tests/conftest.py): an unavailable backend is skipped, unless
``GFGPU_TEST_BACKENDS`` requests it, which turns it into a failure; unknown names are an error;
``name:device`` entries run the fixture on those devices (a device run skips host-only tests).

Checked in a separate pytest run with Warp and PyOpenCL made unimportable."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]
ROOT = TESTS.parent

PROBE = """
def test_every_backend(backend):
    assert backend.name

def test_one_backend(require_backend):
    assert require_backend("warp").name == "warp"

def test_host_only():
    pass
"""

# Warp and PyOpenCL cannot be imported in the child: both backends fail to load
RUN = ("import sys; sys.modules['warp'] = None; sys.modules['pyopencl'] = None; import pytest; "
       "sys.exit(pytest.main(['-q', '-rA', '-p', 'no:cacheprovider', 'test_probe.py']))")


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    where = tmp_path_factory.mktemp("probe")
    (where / "conftest.py").write_text((TESTS / "conftest.py").read_text(encoding="utf-8"), encoding="utf-8")
    (where / "test_probe.py").write_text(PROBE)

    def run(requested):
        env = {k: v for k, v in os.environ.items() if k != "GFGPU_TEST_BACKENDS"}
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        if requested is not None:
            env["GFGPU_TEST_BACKENDS"] = requested
        res = subprocess.run([sys.executable, "-c", RUN], cwd=where, env=env, capture_output=True, text=True)
        return res.returncode, res.stdout + res.stderr

    return run


def test_unavailable_backends_are_skipped_unless_requested(probe):
    status, out = probe(None)
    assert status == 0, out
    assert "2 passed, 3 skipped" in out, out
    assert "warp backend unavailable" in out and "opencl backend unavailable" in out, out


def test_a_requested_backend_that_does_not_load_fails(probe):
    status, out = probe(" numpy, warp ")
    assert status == 1, out
    # a fixture that fails reports its tests as errors ("ERROR at setup"): the run fails either way
    assert "1 failed, 2 passed, 1 skipped, 1 error" in out, out
    assert "ERROR test_probe.py::test_every_backend[warp]" in out, out
    assert "FAILED test_probe.py::test_one_backend" in out, out
    assert "requested by GFGPU_TEST_BACKENDS=' numpy, warp '" in out, out
    assert "SKIPPED" in out and "opencl backend unavailable" in out, out


def test_unknown_backend_names_are_an_error(probe):
    status, out = probe("numpy,bogus")
    assert status == 4, out           # pytest's usage error
    assert "GFGPU_TEST_BACKENDS='numpy,bogus' names unknown backend(s) 'bogus'" in out, out


def test_device_entries_run_only_the_named_devices(probe):
    status, out = probe("numpy:cpu")
    assert status == 0, out
    assert "PASSED test_probe.py::test_every_backend[numpy:cpu]" in out, out
    # warp is not named in a device run, and the host-only test is not a device test
    assert "1 passed, 2 skipped" in out, out
    assert "warp is not named in GFGPU_TEST_BACKENDS='numpy:cpu'" in out, out
    assert "host-only test" in out, out


def test_a_requested_device_that_does_not_exist_fails(probe):
    status, out = probe("numpy:cuda:0,warp")
    assert status == 1, out
    assert "ERROR test_probe.py::test_every_backend[numpy:cuda:0]" in out, out
    assert "numpy:cuda:0 backend unavailable: BackendUnavailable: the numpy backend runs on the host only" in out, out
    # not a device run (warp names no device): the host-only test runs
    assert "PASSED test_probe.py::test_host_only" in out, out


def test_unknown_names_with_devices_are_an_error(probe):
    status, out = probe("bogus:cuda:0")
    assert status == 4, out
    assert "names unknown backend(s) 'bogus'" in out, out
