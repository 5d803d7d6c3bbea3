"""benchmarks/motion.py: the side-by-side run (``--quick``) goes end to end and writes every
section's rows with computed verdicts, and its supersampled rendering agrees with the exact
box exposure, so the benchmark that reports issue 27's acceptance cannot rot."""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

from oracle import box_transfer_reference

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "motion.py"
sys.path.insert(0, str(SCRIPT.parent))
try:
    import motion_refs as refs
finally:
    sys.path.remove(str(SCRIPT.parent))

SECTIONS = {"uniform, axis-aligned", "uniform, oblique", "velocity field", "spin and zoom", "accuracy, oblique",
            "accuracy, field", "accuracy, spin and zoom"}


def _run(*args, timeout=600):
    base = {k: v for k, v in os.environ.items() if k not in ("GFGPU_TEST_BACKENDS", "GFGPU_BACKEND")}
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], cwd=ROOT, env=base, capture_output=True,
                          text=True, timeout=timeout)


def test_quick_run_reports_every_section(tmp_path, require_backend):
    require_backend("opencl")
    res = _run("--quick", "--backends", "opencl", "--json", tmp_path / "motion.json")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    report = json.loads((tmp_path / "motion.json").read_text())
    rows = report["rows"]
    assert {r["section"] for r in rows} == SECTIONS
    assert "uptime" in report["meta"]["start"] and report["meta"]["wall_s"] > 0
    ours = [r for r in rows if r["method"].startswith("gfgpu") or "opencl:" in r["method"]]
    assert ours and all(r["error"] == "" for r in ours), [r for r in ours if r["error"]]
    for r in rows:
        measured = r["value"] is not None or r["timing"] is not None
        if r["target"] and measured:
            assert r["met"] in (True, False), r             # computed wherever there is a target and a figure
    speed = [r for r in ours if r["timing"] is not None]
    assert all(r["timing"]["steady"] > 0 and (r["timing"]["first"] or 0) >= 0 for r in speed)
    # a fresh shape per gfgpu row: the first call never meets a shape seen before
    fresh = [tuple(r["timing"]["first_shape"]) for r in speed if r["timing"]["calls"]]
    steady = {(r["timing"]["pixels"],) for r in speed}
    assert fresh and len(fresh) == len(set(fresh)) and len(steady) == 2      # the uniform size and its half
    for title in SECTIONS:
        assert f"### {title}" in res.stdout
    assert "| numpy.copyto (memory bound) |" in res.stdout and ("PASS" in res.stdout or "FAIL" in res.stdout)


def test_rendering_matches_the_exact_box_exposure():
    # the supersampled reference of the acceptance rows against the box along the exact direction
    # (Fourier, periodic image whose lines close): only the quadrature in time differs
    v = (7.0, 25.0)
    img = refs.texture((70, 250), seed=2)
    ref = refs.render(img, refs.translate(v), refs.time_cells("box", math.hypot(*v)), "wrap")
    exact = box_transfer_reference(img, v)
    assert refs.rel_l2(ref, exact, 16) < 1e-3


def test_quadrature_keeps_each_psf_mean():
    for psf, mean in (("box", 0.5), ("green", 1.0)):
        t, w = refs.time_cells(psf, 30.0)
        assert len(t) >= 512 and abs(w.sum() - 1) < 1e-12
        assert abs((t * w).sum() - mean) < 1e-4


def test_a_bound_above_the_copy_is_noted_and_its_verdict_kept():
    # issue 27's 1.5 x cv2 box bound at (2, 7) exceeds what a copy of the image reaches: the row says so
    import importlib.util
    spec = importlib.util.spec_from_file_location("motion_benchmark", SCRIPT)    # tests/motion is a package too
    bench = sys.modules[spec.name] = importlib.util.module_from_spec(spec)    # its dataclasses look it up
    spec.loader.exec_module(bench)
    copy = bench.Row("s", "4096²", "numpy.copyto", timing=bench.Timing(4096 * 4096, 4096 * 4096 / 2000e6, 3))
    above = bench.Row("s", "(2, 7)", "gfgpu", met=False, timing=bench.Timing(4096 * 4096, 0.08, 3))
    below = bench.Row("s", "(7, 25)", "gfgpu", met=True, timing=bench.Timing(4096 * 4096, 0.08, 3))
    bench.note_copy_bound([(above, 2400.0), (below, 246.0)], copy)
    assert "above the copy (2000 Mpix/s" in above.note and above.met is False
    assert below.note == "" and below.met is True
    bench.note_copy_bound([(below, 1e9)], bench.Row("s", "x", "numpy.copyto", error="failed"))   # no copy figure
    assert below.note == ""
