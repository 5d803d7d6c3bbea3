"""benchmarks/device_check.py runs end to end on the CPU devices (``--cpu --smoke``: the full
``--cpu`` run takes about two minutes on two cores), so the prepared GPU check cannot rot."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "device_check.py"


def _run(*args, timeout=240):
    env = {k: v for k, v in os.environ.items() if k not in ("GFGPU_TEST_BACKENDS", "GFGPU_BACKEND")}
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_cpu_smoke_run_writes_the_report(tmp_path, require_backend):
    require_backend("opencl")
    require_backend("warp")
    res = _run(tmp_path / "out", "--cpu", "--smoke", "--quiet")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    steps = {s["name"]: s for s in report["steps"]}
    assert set(steps) >= {"devices", "tests", "filters", "canny"}, steps.keys()
    assert "install" not in steps                 # --cpu does not install by default
    for name in ("devices", "tests", "filters", "canny"):
        assert steps[name]["status"] == "ok", (name, steps[name]["output"][-2000:])
        assert (tmp_path / "out" / f"{name}.log").exists()
    specs = report["meta"]["devices_under_test"].split(", ")
    assert "warp:cpu" in specs and any(s.startswith("opencl:") for s in specs), specs
    assert report["devices"]["opencl"] and report["devices"]["versions"]["numpy"]
    md = (tmp_path / "out" / "report.md").read_text()
    assert "result: **tests passed**" in md
    assert "| numpy.copyto (memory bound) |" in md           # the filters table with its bound
    assert "shift (0, 3), numpy in/out, output=" in md
    assert "| skimage.feature.canny sigma=2 |" in md
    assert "passed" in md and "warp:cpu" in md


def test_a_failing_test_step_makes_the_check_fail(tmp_path, monkeypatch):
    # the check's exit status follows pytest's: a test run that cannot pass must fail the check
    sys.path.insert(0, str(SCRIPT.parent))
    try:
        import device_check
    finally:
        sys.path.remove(str(SCRIPT.parent))
    monkeypatch.setattr(device_check, "CPU_TEST_FILES", ["tests/does_not_exist.py"])
    monkeypatch.setattr(device_check.Runner, "run", _only_tests(device_check.Runner.run))
    status = device_check.main([str(tmp_path / "out"), "--cpu", "--smoke", "--quiet"])
    assert status == 1
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["meta"]["verdict"] == "tests failed"


def _only_tests(run):
    # the device probe and the test step run; the benchmarks are not needed here
    def wrapper(self, name, cmd, timeout, env=None, title=None):
        if name in ("devices", "tests"):
            return run(self, name, cmd, timeout, env=env, title=title)
        return self.note(name, "skipped", "not run by this test")
    return wrapper


@pytest.mark.parametrize("args, message", [
    (["--smoke"], "--smoke needs --cpu"),
    (["--cpu", "--budget", "-1"], "--budget must be a positive number of seconds"),
])
def test_bad_options_are_refused(tmp_path, args, message):
    res = _run(tmp_path / "out", *args, timeout=60)
    assert res.returncode == 2 and message in res.stderr, res.stderr
