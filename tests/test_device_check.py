"""benchmarks/device_check.py and device_plan.py: the plan fits the lent GPU machine's limits, the
calls' files reassemble on the device (and a lost part is reported, not fatal), and the staged
check runs end to end on the CPU devices (``--cpu --smoke``), so the prepared GPU check cannot rot.

The full rehearsal (``--rehearse``: the plan's calls here, network cut off, about three minutes)
needs the built ``.device/`` folder; it runs with ``GFGPU_TEST_REHEARSE=1``."""
import ast
import hashlib
import json
import lzma
import os
import re
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "device_check.py"
sys.path.insert(0, str(SCRIPT.parent))
try:
    import device_check as dc
    import device_plan as dp
finally:
    sys.path.remove(str(SCRIPT.parent))


def _run(*args, timeout=240, env=None):
    base = {k: v for k, v in os.environ.items() if k not in ("GFGPU_TEST_BACKENDS", "GFGPU_BACKEND")}
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], cwd=ROOT, env=dict(base, **(env or {})),
                          capture_output=True, text=True, timeout=timeout)


RECORDED_SIZES = {**{k: v for k, v in dp.RECORDED.items() if not k.startswith("warp_lang")}, "recorded": []}


# ---- the plan and its budget ---------------------------------------------------------------------
def test_plan_dry_prints_calls_that_fit():
    res = _run("--plan", "--dry", timeout=120)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    out = res.stdout
    calls = re.findall(r"run\(command=(\".*?\"), carry=(\[.*?\]), timeout_s=(\d+)\)", out)
    assert len(calls) >= 2, out                            # the calls and the rerun
    for command, carry, timeout in calls:
        command = json.loads(command)
        assert len(command) <= dp.COMMAND_LIMIT and "--device-call" in command and '"$OUT"' in command
        assert 1 <= len(json.loads(carry)) <= 8 and int(timeout) <= 600
    sizes = re.search(r"\| MiB per call, working tree included \| ≤ 60 \| ([\d., ]+) \| ok \|", out)
    assert sizes and all(float(v) <= 60 for v in sizes.group(1).split(",")), out
    assert "OVER" not in out and "| device time, worst case, rerun included, s | ≤ 900 |" in out


def test_every_call_stays_within_the_limit_whatever_the_tree():
    # the parts of Warp's xz stream go across the calls; the small wheels and the kernel cache
    # with the last one; no call over 60 MiB with the working tree, for trees from 1 to 40 MiB
    for tree_mib in (1, 9, 20, 33, 40):
        plan = dp.layout(RECORDED_SIZES, tree_mib * dp.MIB)
        calls = plan["calls"]
        assert calls and all(c["bytes"] <= dp.CALL_LIMIT_MIB * dp.MIB for c in calls), (tree_mib, calls)
        parts = [b for c in calls for n, b, kind in c["files"] if kind == "part"]
        assert sum(parts) == RECORDED_SIZES["warp.whl.xz"]
        wholes = {n for n, _, kind in calls[-1]["files"] if kind != "part"}
        assert "warp-cache.tar.xz" in wholes and sum(n.endswith(".whl") for n in wholes) == len(dp.CARRIED) - 1
        assert all(kind == "part" for c in calls[:-1] for _, _, kind in c["files"])
    assert len(dp.layout(RECORDED_SIZES, 9 * dp.MIB)["calls"]) == 2


def test_the_budget_check_fails_what_does_not_fit(monkeypatch):
    calls = dp.runs(dp.layout(RECORDED_SIZES, 9 * dp.MIB))
    assert all(ok for *_, ok in dp.check_budget(calls))
    big = [dict(c, bytes=61 * dp.MIB) if i == 0 else c for i, c in enumerate(calls)]
    long = [dict(c, command=c["command"] + " " * 2000) for c in calls]
    assert not dict((w, ok) for w, _, _, ok in dp.check_budget(big))["MiB per call, working tree included"]
    assert not dict((w, ok) for w, _, _, ok in dp.check_budget(long))["characters per command"]
    monkeypatch.setitem(dc.STAGE_TIMEOUTS, "tests", 400)
    rows = dict((w, ok) for w, _, _, ok in dp.check_budget(dp.runs(dp.layout(RECORDED_SIZES, 9 * dp.MIB))))
    assert not rows["stage timeouts of the calls, s"] and not rows["device time, worst case, rerun included, s"]


def test_without_room_for_warp_the_plan_leaves_it_behind(monkeypatch):
    # slower transfers: Warp's extra call no longer fits with a rerun, the one-call plan does
    monkeypatch.setattr(dp, "TRANSFER_S", 55)
    plan = dp.plan_for(RECORDED_SIZES, 9 * dp.MIB)
    assert not plan["with_warp"] and len(plan["calls"]) == 1
    assert not any(kind == "part" or n == "warp-cache.tar.xz" for n, _, kind in plan["calls"][0]["files"])
    text, ok = dp.describe(plan, RECORDED_SIZES, dry=True)
    assert ok and "Warp does NOT travel" in text


def test_the_tree_is_measured_as_the_tool_counts_it(tmp_path):
    if shutil.which("git") is None:
        pytest.skip("no git here")
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    (tmp_path / ".gitignore").write_text("/ignored/\n")
    (tmp_path / "a.txt").write_bytes(b"x" * 1000)
    (tmp_path / "ignored").mkdir()
    (tmp_path / "ignored" / "big").write_bytes(b"y" * 100000)
    total, files = dp.tree_bytes(str(tmp_path))
    assert files == 2 and total == 1000 + len("/ignored/\n")       # untracked, not ignored: counted


# ---- the device side -------------------------------------------------------------------------------
def test_the_device_script_needs_only_the_standard_library():
    # it runs under the image's Python before anything is installed there
    tree = ast.parse(SCRIPT.read_text())
    top = {alias.name.split(".")[0] for node in tree.body if isinstance(node, ast.Import) for alias in node.names}
    top |= {node.module.split(".")[0] for node in tree.body if isinstance(node, ast.ImportFrom) and node.module}
    assert top - {"__future__"} <= set(sys.stdlib_module_names), top - set(sys.stdlib_module_names)


def test_the_test_selection_needs_nothing_the_device_lacks():
    # no module-level import of grimp/import-linter (tests/test_architecture.py), dask or plyfile
    # in the device tests: such a file stops the whole run at collection (a host-only test's own
    # import is skipped with the test in a device run)
    files = {n.split("::")[0] for n in dc.TEST_FILES + dc.FORCED_GPU_BRANCH}
    for name in files | {"tests/conftest.py", "conftest.py"}:
        body = ast.parse((ROOT / name).read_text()).body
        top = {a.name.split(".")[0] for node in body if isinstance(node, ast.Import) for a in node.names}
        top |= {node.module.split(".")[0] for node in body if isinstance(node, ast.ImportFrom) and node.module}
        assert not top & {"grimp", "importlinter", "dask", "distributed", "plyfile"}, (name, top)
    for node in dc.FORCED_GPU_BRANCH:
        path, test = node.split("::")
        assert path in dc.TEST_FILES and f"def {test}(" in (ROOT / path).read_text(), node
    assert "tests/test_architecture.py" not in files


def test_the_device_probe_reports_what_the_plan_carries():
    assert [d for d, _, _ in dp.CARRIED] == list(dc.CARRIED_PACKAGES)
    assert not {dp.normalize(d) for d in dc.CARRIED_PACKAGES} & {dp.normalize(n) for n in dp.IMAGE}


def test_the_kernel_modules_are_found():
    mods = dc.warp_kernel_modules()
    assert {"gfgpu.backends.warp.recurse", "gfgpu.motion._warp", "gfgpu.stereo._warp", "gfgpu.edges._warp"} <= set(mods)


def _payload(tmp_path, nparts=2):
    """A fake split payload: a small wheel, xz, cut in ``nparts``; returns (manifest, parts dir)."""
    wheel = tmp_path / "fake-1.0-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w", zipfile.ZIP_STORED) as z:
        z.writestr("fake/__init__.py", "x = 1\n" * 5000)
    packed = lzma.compress(wheel.read_bytes())
    cut = len(packed) // nparts
    send = tmp_path / "send"
    chunks = [packed[i * cut:(i + 1) * cut if i < nparts - 1 else None] for i in range(nparts)]
    files, parts = [], []
    for i, chunk in enumerate(chunks, 1):
        (send / f"call{i}").mkdir(parents=True)
        name = f"fake.whl.xz.{i:03d}"
        (send / f"call{i}" / name).write_bytes(chunk)
        files.append({"name": name, "call": i, "kind": "part", "bytes": len(chunk),
                      "sha256": hashlib.sha256(chunk).hexdigest()})
        parts.append({"name": name, "call": i})
    manifest = {"calls": nparts, "files": files, "payloads": {"warp": {
        "wheel": wheel.name, "wheel_sha256": hashlib.sha256(wheel.read_bytes()).hexdigest(), "parts": parts}}}
    return manifest, send, wheel


def test_parts_sent_in_two_calls_rebuild_the_wheel(tmp_path, monkeypatch):
    manifest, send, wheel = _payload(tmp_path)
    monkeypatch.setattr(dc, "SEND_DIR", str(send))
    root = tmp_path / "root"
    for call in (1, 2):
        lines = dc.receive(call, manifest, str(root))
        assert lines and "sha256 ok" in lines[0]
    lines, missing = dc.assemble(manifest, str(root))
    assert missing == [] and "rebuilt from 2 parts" in lines[0]
    assert (root / "wheels" / wheel.name).read_bytes() == wheel.read_bytes()
    assert "already rebuilt" in dc.assemble(manifest, str(root))[0][0]      # the rerun


def test_a_lost_part_leaves_warp_out_and_a_broken_one_stops(tmp_path, monkeypatch):
    manifest, send, wheel = _payload(tmp_path)
    monkeypatch.setattr(dc, "SEND_DIR", str(send))
    root = tmp_path / "cold"               # call 1's part never reached this machine
    dc.receive(2, manifest, str(root))
    lines, missing = dc.assemble(manifest, str(root))
    assert missing == ["warp"] and "fake.whl.xz.001" in lines[0] and "went cold" in lines[0]
    assert not (root / "wheels" / wheel.name).exists()
    (send / "call1" / "fake.whl.xz.001").write_bytes(b"broken")
    with pytest.raises(SystemExit, match="does not match its sha256"):
        dc.receive(1, manifest, str(tmp_path / "other"))


def test_resume_keeps_only_the_stages_that_passed(tmp_path):
    state = [{"name": "filters", "status": "ok", "seconds": 3.0, "title": "filters", "output": "| a | 1 |"},
             {"name": "tests", "status": "failed", "seconds": 9.0, "title": "tests", "output": ""}]
    runner = dc.Runner(str(tmp_path / "out"), str(tmp_path / "work"), 60, echo=False, state=state)
    assert runner.keep("filters")["resumed"] and runner.keep("tests") is None
    assert [s["name"] for s in runner.stages] == ["filters"]


def test_the_report_is_three_files_whatever_ran(tmp_path):
    work, out = tmp_path / "work", tmp_path / "out"
    (work / "logs").mkdir(parents=True)
    for i in range(12):                        # many stages' logs: still one archive
        (work / "logs" / f"stage{i}.log").write_text(f"log {i}\n")
    meta = {"mode": "test", "date": "now", "host": "h", "cores": 2, "python": "3", "command": "c", "notes": []}
    stages = [{"name": "filters", "title": "filters", "status": "timeout", "seconds": 35.0, "timeout": 35,
               "output": "| numpy.copyto (memory bound) | 1,940 | 1.000 |\n| gfgpu warp (cuda:0): x | 97,000 | 50 |"},
              {"name": "system", "title": "system", "status": "ok", "seconds": 1.0, "timeout": 35, "output": "",
               "info": {"copy": [{"by": "torch", "size": 4096, "seconds": 1e-4, "GB_per_s": 1342,
                                  "Mpix_per_s": 167772}]}}]
    dc.write_report(str(out), str(work), dict(meta, filters_size=4096), stages)
    assert sorted(os.listdir(out)) == sorted(dc.RESULT_FILES) and len(dc.RESULT_FILES) <= dp.RESULT_FILES_LIMIT
    with tarfile.open(out / "logs.tar.gz") as tar:
        assert len(tar.getnames()) == 12
    md = (out / "report.md").read_text()
    assert "| filters | timeout | 35.0 | 35 |" in md
    assert "| gfgpu warp (cuda:0): x | 97,000 | 0.578 |" in md          # against the device copy bound


def test_cpu_smoke_run_writes_the_report(tmp_path, require_backend):
    require_backend("opencl")
    require_backend("warp")
    res = _run(tmp_path / "out", "--cpu", "--smoke", "--quiet", "--work", tmp_path / "work")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert sorted(os.listdir(tmp_path / "out")) == sorted(dc.RESULT_FILES)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    stages = {s["name"]: s for s in report["stages"]}
    assert set(stages) == {"system", "devices", "first-call", "tests", "filters", "canny"}, stages.keys()
    for name, stage in stages.items():
        assert stage["status"] == "ok", (name, stage["output"][-2000:])
    with tarfile.open(tmp_path / "out" / "logs.tar.gz") as tar:
        assert {"logs/tests.log", "logs/filters.log", "logs/canny.log"} <= set(tar.getnames())
    specs = report["meta"]["devices_under_test"].split(", ")
    assert "warp:cpu" in specs and any(s.startswith("opencl:") for s in specs), specs
    forced = stages["tests"]["summary"]["forced_gpu_branch"]
    assert set(forced) == set(dc.FORCED_GPU_BRANCH) and set(forced.values()) == {"passed"}, forced
    assert {r["spec"] for r in stages["first-call"]["rows"]} == set(specs)
    md = (tmp_path / "out" / "report.md").read_text()
    assert "result: **tests passed**" in md and "## First call against steady state" in md
    assert "| numpy.copyto (memory bound) |" in md and "| skimage.feature.canny sigma=2 |" in md


def test_a_failing_test_stage_makes_the_check_fail(tmp_path, monkeypatch):
    # the check's exit status follows pytest's: a test run that cannot pass must fail the check
    monkeypatch.setattr(dc, "SMOKE_TEST_FILES", ["tests/does_not_exist.py"])
    monkeypatch.setattr(dc.Runner, "run", _only(dc.Runner.run, ("system", "devices", "tests")))
    monkeypatch.setattr(dc, "first_call_stage", lambda runner, py, specs, cpu: specs)
    status = dc.check([str(tmp_path / "out"), "--cpu", "--smoke", "--quiet"])
    assert status == 1
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["meta"]["verdict"] == "tests failed"


def _only(run, names):
    def wrapper(self, name, cmd, timeout, env=None, title=None, cwd=dc.ROOT):
        if name in names:
            return run(self, name, cmd, timeout, env=env, title=title, cwd=cwd)
        return self.note(name, "skipped", "not run by this test")
    return wrapper


@pytest.mark.parametrize("args, message", [
    (["out", "--smoke"], "--smoke needs --cpu"),
    (["out", "--cpu", "--budget", "-1"], "--budget must be a positive number of seconds"),
    (["--dry"], "--dry goes with --plan"),
    (["--device-call", "x", "out"], "invalid int value"),
])
def test_bad_options_are_refused(tmp_path, args, message):
    res = _run(*[tmp_path / a if a == "out" else a for a in args], timeout=60)
    assert res.returncode == 2 and message in res.stderr, res.stderr


@pytest.mark.skipif(os.environ.get("GFGPU_TEST_REHEARSE") != "1",
                    reason="the full rehearsal (minutes, needs .device/ from --plan): GFGPU_TEST_REHEARSE=1")
def test_rehearsal_passes_offline():
    res = _run("--rehearse", timeout=420)
    assert res.returncode == 0 and "rehearsal PASSED" in res.stdout, res.stdout[-5000:] + res.stderr[-3000:]
