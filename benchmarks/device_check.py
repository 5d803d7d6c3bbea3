"""One prepared device check: install, test on the devices, benchmark, write one report.

Run from the repository root on a fresh machine with a GPU::

    python benchmarks/device_check.py OUTDIR            # GPU devices, < 8 minutes on one GPU
    python benchmarks/device_check.py OUTDIR --cpu      # the same steps on the CPU devices
    python benchmarks/device_check.py OUTDIR --cpu --smoke   # reduced (the CI test runs this)

Steps, each in its own process with its own timeout (a step that fails or times out is
reported and the next one still runs; the whole run keeps within ``--budget`` seconds):

1. ``install`` (default on a GPU run, ``--install``/``--no-install`` to choose):
   ``pip install ".[test,bench]"`` from the working tree into this interpreter (retried without
   the ``bench`` extra, then into a fresh virtual environment under OUTDIR when the
   interpreter refuses packages, PEP 668).  PyPI's ``warp-lang`` wheel carries CUDA; PyOpenCL's
   wheel carries an ICD loader that reads ``/etc/OpenCL/vendors``.  Where the NVIDIA OpenCL
   driver (``libnvidia-opencl.so.1``) is present but no ``nvidia.icd`` names it, the check
   writes one under OUTDIR and points ``OCL_ICD_VENDORS`` there, so PyOpenCL sees the GPU.
2. ``devices``: nvidia-smi, Warp's CUDA devices, OpenCL platforms and devices, gfgpu.devices(),
   versions; this picks the devices of the later steps (``warp:cuda:0``, ``opencl:<index of the
   first GPU>``; with ``--cpu`` ``warp:cpu`` and the first OpenCL CPU device).
3. ``tests``: pytest of ``tests/`` with ``GFGPU_TEST_BACKENDS`` naming those devices (a device
   run: host-only tests skip, see tests/conftest.py); with ``--cpu`` a subset of the files.
4. ``filters``, ``stereo``, ``motion``, ``canny``: ``benchmarks/filters.py``, ``stereo.py``,
   ``motion.py`` and the timing table of ``edges_fom.py`` on those devices (small sizes with
   ``--cpu``), each printing Markdown tables with its peers measured in the same run.

Writes ``OUTDIR/report.md`` (devices, versions, each step's time and status, every step's
Markdown output), ``OUTDIR/report.json`` and one ``OUTDIR/<step>.log`` per step.  Exit status:
0 when the tests passed on the devices asked for; 1 when a test failed (or the tests did not
run to the end); 3 when no GPU was found on a GPU run (the steps then run on the CPU devices).
"""

from __future__ import annotations

import argparse
import ctypes
import datetime
import glob
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: seconds per step on a GPU run; the whole run is also capped by --budget
GPU_TIMEOUTS = {"install": 210, "devices": 90, "tests": 210, "filters": 90, "stereo": 90, "motion": 60,
                "canny": 60}
CPU_TIMEOUTS = {"install": 300, "devices": 60, "tests": 60, "filters": 30, "stereo": 30, "motion": 30,
                "canny": 25}
#: test files of a --cpu run: every backend primitive and the public calls (the whole suite takes
#: minutes on two cores); --smoke runs the first of them only
CPU_TEST_FILES = ["tests/test_shift.py", "tests/backends/test_fused.py", "tests/test_api.py"]

PROBE = r"""
import json, os, sys
info = {"python": sys.version.split()[0], "versions": {}, "warp_cuda": [], "warp_devices": [],
        "opencl": [], "gfgpu_devices": [], "errors": []}
for mod in ("numpy", "scipy", "skimage", "warp", "pyopencl", "cv2", "gfgpu"):
    try:
        m = __import__(mod)
        info["versions"][mod] = str(getattr(m, "__version__", getattr(m, "config", None) and "?"))
    except Exception as exc:
        info["versions"][mod] = f"not installed ({type(exc).__name__}: {exc})"
try:
    import warp as wp
    wp.config.quiet = True
    wp.init()
    info["warp_devices"] = [str(d) for d in wp.get_devices()]
    for d in wp.get_cuda_devices():
        info["warp_cuda"].append({"alias": d.alias, "name": d.name, "arch": getattr(d, "arch", None),
                                  "memory_GiB": round(getattr(d, "total_memory", 0) / 2**30, 1)})
except Exception as exc:
    info["errors"].append(f"warp: {type(exc).__name__}: {exc}")
try:
    import pyopencl as cl
    index = 0
    for p in cl.get_platforms():
        try:
            devs = p.get_devices()
        except cl.Error:
            devs = []
        for d in devs:
            kind = "gpu" if d.type & cl.device_type.GPU else "cpu" if d.type & cl.device_type.CPU else "other"
            info["opencl"].append({"index": index, "name": d.name.strip(), "platform": p.name.strip(),
                                   "platform_version": p.version.strip(), "driver": d.driver_version.strip(),
                                   "kind": kind, "compute_units": d.max_compute_units,
                                   "memory_GiB": round(d.global_mem_size / 2**30, 1)})
            index += 1
except Exception as exc:
    info["errors"].append(f"pyopencl: {type(exc).__name__}: {exc}")
try:
    import gfgpu
    info["gfgpu_devices"] = [str(d) for d in gfgpu.devices()]
except Exception as exc:
    info["errors"].append(f"gfgpu.devices: {type(exc).__name__}: {exc}")
print("DEVICE-PROBE " + json.dumps(info))
"""


def log(msg):
    print(f"[device_check {time.strftime('%H:%M:%S')}] {msg}", flush=True)


class Runner:
    """Runs the steps as subprocesses, each with a timeout, within one overall budget."""

    def __init__(self, outdir, budget, echo):
        self.outdir = outdir
        self.deadline = time.monotonic() + budget
        self.echo = echo
        self.steps = []
        self.env = dict(os.environ, PYTHONUNBUFFERED="1")

    def left(self):
        return self.deadline - time.monotonic()

    def run(self, name, cmd, timeout, env=None, title=None):
        """Run ``cmd``; record name, command, status, seconds and the output (also in OUTDIR/name.log)."""
        shown = [("<probe script>" if prev == "-c" else a) for prev, a in zip([""] + cmd, cmd)]
        step = {"name": name, "title": title or name, "command": " ".join(shown), "status": "skipped",
                "seconds": 0.0, "returncode": None, "output": ""}
        self.steps.append(step)
        timeout = min(timeout, self.left() - 5)
        if timeout < 10:
            step["output"] = "not run: the time budget of the check is spent"
            log(f"{name}: skipped (budget spent)")
            return step
        log(f"{name}: started (timeout {timeout:.0f} s): {step['command'][:200]}")
        path = os.path.join(self.outdir, f"{name}.log")
        t0 = time.monotonic()
        chunks = []
        with open(path, "w", encoding="utf-8") as logfile:
            try:
                proc = subprocess.Popen(cmd, cwd=ROOT, env=dict(self.env, **(env or {})), stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, errors="replace",
                                        start_new_session=True)   # its own group: a timeout ends its children too
            except OSError as exc:
                step.update(status="failed", output=f"could not start: {exc}")
                log(f"{name}: could not start: {exc}")
                return step

            def pump():
                for line in proc.stdout:
                    chunks.append(line)
                    logfile.write(line)
                    if self.echo:
                        sys.stdout.write(f"  | {line}")
                        sys.stdout.flush()

            reader = threading.Thread(target=pump, daemon=True)
            reader.start()
            try:
                proc.wait(timeout=timeout)
                status = "ok" if proc.returncode == 0 else "failed"
            except subprocess.TimeoutExpired:
                status = "timeout"
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                proc.wait()
            reader.join(timeout=10)
        step.update(status=status, seconds=round(time.monotonic() - t0, 1), returncode=proc.returncode,
                    output="".join(chunks))
        log(f"{name}: {status} in {step['seconds']:.1f} s" + (f" (exit {proc.returncode})" if status == "failed"
                                                              else ""))
        return step

    def note(self, name, status, output, seconds=0.0):
        step = {"name": name, "title": name, "command": "", "status": status, "seconds": seconds,
                "returncode": None, "output": output}
        self.steps.append(step)
        log(f"{name}: {status}: {output.splitlines()[0] if output else ''}")
        return step


# ---- install and OpenCL drivers ------------------------------------------------------------------
def install(runner, timeout):
    """pip install the working tree with its test extras; the Python to use afterwards."""
    py = sys.executable
    t_end = time.monotonic() + timeout
    step = runner.run("install", [py, "-m", "pip", "install", "--disable-pip-version-check", ".[test,bench]"],
                      timeout)
    if step["status"] == "ok":
        return py
    out = step["output"]
    if "externally-managed" in out or "externally managed" in out:
        venv = os.path.join(runner.outdir, "venv")
        log(f"install: this interpreter refuses packages (PEP 668): a virtual environment in {venv}")
        made = runner.run("install-venv", [py, "-m", "venv", venv], max(t_end - time.monotonic(), 10))
        vpy = os.path.join(venv, "bin", "python")
        if made["status"] == "ok" and os.path.exists(vpy):
            again = runner.run("install-in-venv", [vpy, "-m", "pip", "install", "--disable-pip-version-check",
                                                   ".[test,bench]"], max(t_end - time.monotonic(), 10))
            if again["status"] == "ok":
                return vpy
            py = vpy
    # opencv or matplotlib may have no wheel here: without them the peers are skipped, not the tests
    runner.run("install-test-only", [py, "-m", "pip", "install", "--disable-pip-version-check", ".[test]"],
               max(t_end - time.monotonic(), 10))
    return py


def nvidia_opencl_library():
    """Path or soname of the NVIDIA OpenCL driver if the dynamic loader finds it, else None."""
    try:
        ctypes.CDLL("libnvidia-opencl.so.1")
        return "libnvidia-opencl.so.1"
    except OSError:
        pass
    for pattern in ("/usr/lib/x86_64-linux-gnu/libnvidia-opencl.so.1", "/usr/lib64/libnvidia-opencl.so.1",
                    "/usr/local/nvidia/lib64/libnvidia-opencl.so.1",
                    "/usr/lib/aarch64-linux-gnu/libnvidia-opencl.so.1"):
        for path in glob.glob(pattern):
            return path
    return None


def prepare_opencl_icds(runner):
    """Make PyOpenCL's bundled ICD loader see the NVIDIA OpenCL driver; a line saying what was done."""
    vendor_dir = os.environ.get("OCL_ICD_VENDORS") or "/etc/OpenCL/vendors"
    icds = sorted(glob.glob(os.path.join(vendor_dir, "*.icd"))) if os.path.isdir(vendor_dir) else []
    named = []
    for path in icds:
        try:
            with open(path, encoding="utf-8", errors="replace") as f:
                named.append(f"{os.path.basename(path)}: {f.readline().strip()}")
        except OSError as exc:
            named.append(f"{os.path.basename(path)}: unreadable ({exc})")
    if any("nvidia" in line.lower() for line in named):
        return f"system ICDs in {vendor_dir}: {'; '.join(named)} (PyOpenCL's loader reads them)"
    lib = nvidia_opencl_library()
    if lib is None:
        found = f"ICDs in {vendor_dir}: {'; '.join(named)}" if named else f"no ICD in {vendor_dir}"
        return f"{found}; no NVIDIA OpenCL driver (libnvidia-opencl.so.1) found: OpenCL runs on PoCL's CPU device"
    icd_dir = os.path.join(runner.outdir, "opencl-vendors")
    os.makedirs(icd_dir, exist_ok=True)
    for path in icds:      # keep whatever the system had
        shutil.copy(path, icd_dir)
    with open(os.path.join(icd_dir, "nvidia.icd"), "w", encoding="utf-8") as f:
        f.write(lib + "\n")
    runner.env["OCL_ICD_VENDORS"] = icd_dir
    return (f"{lib} present but no nvidia.icd in {vendor_dir}: wrote {icd_dir}/nvidia.icd and set "
            f"OCL_ICD_VENDORS={icd_dir}")


# ---- devices -------------------------------------------------------------------------------------
def nvidia_smi():
    exe = shutil.which("nvidia-smi")
    if exe is None:
        return "nvidia-smi not found"
    try:
        res = subprocess.run([exe, "--query-gpu=index,name,driver_version,memory.total,compute_cap",
                              "--format=csv,noheader"], capture_output=True, text=True, timeout=30)
        return (res.stdout or res.stderr).strip() or f"nvidia-smi exit {res.returncode}"
    except (OSError, subprocess.SubprocessError) as exc:
        return f"nvidia-smi failed: {exc}"


def probe(runner, py, timeout):
    step = runner.run("devices", [py, "-c", PROBE], timeout, title="devices and versions")
    for line in step["output"].splitlines():
        if line.startswith("DEVICE-PROBE "):
            return json.loads(line[len("DEVICE-PROBE "):])
    return {"errors": [f"device probe {step['status']}"], "warp_cuda": [], "warp_devices": [], "opencl": [],
            "versions": {}, "gfgpu_devices": []}


def choose_devices(info, cpu):
    """``{backend: device}`` for the later steps: GPUs (or the CPU devices with ``cpu``)."""
    chosen = {}
    if cpu:
        if "cpu" in info.get("warp_devices", []):
            chosen["warp"] = "cpu"
        cpus = [d for d in info.get("opencl", []) if d["kind"] == "cpu"]
        if cpus:
            chosen["opencl"] = str(cpus[0]["index"])
        return chosen
    if info.get("warp_cuda"):
        chosen["warp"] = info["warp_cuda"][0]["alias"]
    gpus = [d for d in info.get("opencl", []) if d["kind"] == "gpu"]
    if gpus:
        chosen["opencl"] = str(gpus[0]["index"])
    return chosen


# ---- report --------------------------------------------------------------------------------------
def tables(output):
    """The Markdown of a benchmark's output: its tables and the lines around them."""
    keep = [line for line in output.splitlines()
            if line.startswith(("|", "#", "-", "*")) or (line.strip() and not line.startswith(("  ", "\t")))]
    return "\n".join(keep[-400:])


def pytest_summary(output):
    lines = [line for line in output.splitlines() if line.strip()]
    for line in reversed(lines):
        if (" passed" in line or " failed" in line or " error" in line or "no tests ran" in line) and " in " in line:
            return line.strip("= ").strip()
    return "no pytest summary (the run did not finish)"


def write_report(outdir, meta, info, runner):
    data = {"meta": meta, "devices": info, "steps": runner.steps}
    with open(os.path.join(outdir, "report.json"), "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2, default=str)
    md = [f"# gfgpu device check ({meta['mode']})", "",
          f"- date: {meta['date']}", f"- host: {meta['host']}, {meta['cores']} cores, Python {meta['python']}",
          f"- command: `{meta['command']}`", f"- nvidia-smi: {meta['nvidia_smi']}",
          f"- OpenCL drivers: {meta['opencl_icds']}",
          f"- devices under test: {meta['devices_under_test'] or 'none found'}",
          f"- result: **{meta['verdict']}**", "", "## Devices", ""]
    for d in info.get("warp_cuda", []):
        md.append(f"- Warp {d['alias']}: {d['name']} (sm {d.get('arch')}, {d.get('memory_GiB')} GiB)")
    md.append(f"- Warp devices: {', '.join(info.get('warp_devices', [])) or 'none'}")
    for d in info.get("opencl", []):
        md.append(f"- OpenCL {d['index']}: {d['name']} ({d['platform']}, {d['platform_version']}, driver "
                  f"{d['driver']}), {d['kind']}, {d['compute_units']} compute units, {d['memory_GiB']} GiB")
    for line in info.get("gfgpu_devices", []):
        md.append(f"- gfgpu.devices(): `{line.strip()}`")
    for err in info.get("errors", []):
        md.append(f"- probe error: {err}")
    md += ["", "## Versions", ""] + [f"- {k}: {v}" for k, v in sorted(info.get("versions", {}).items())]
    md += ["", "## Steps", "", "| step | status | seconds | command |", "|---|---|---:|---|"]
    for s in runner.steps:
        md.append(f"| {s['title']} | {s['status']} | {s['seconds']:.1f} | `{s['command'][:150]}` |")
    for s in runner.steps:
        if s["name"] in ("devices",) or s["name"].startswith("install"):
            continue
        md += ["", f"## {s['title']} ({s['status']}, {s['seconds']:.1f} s)", ""]
        if s["name"] == "tests":
            md.append(f"pytest: {pytest_summary(s['output'])}")
            bad = [line for line in s["output"].splitlines() if line.startswith(("FAILED", "ERROR"))]
            md += [""] + [f"- `{line[:300]}`" for line in bad[:60]]
        else:
            md.append(tables(s["output"]) or "(no output)")
    with open(os.path.join(outdir, "report.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(md) + "\n")


# ---- the check -----------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", help="folder for report.md, report.json and the step logs (created)")
    ap.add_argument("--cpu", action="store_true", help="run on the CPU devices (small sizes)")
    ap.add_argument("--smoke", action="store_true", help="with --cpu: the reduced variant the test suite runs")
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--install", dest="install", action="store_true", default=None,
                       help="pip install the working tree first (default on a GPU run)")
    group.add_argument("--no-install", dest="install", action="store_false")
    ap.add_argument("--budget", type=float, default=None,
                    help="seconds for the whole check (default 470 on a GPU, 115 with --cpu, 55 with --smoke)")
    ap.add_argument("--quiet", action="store_true", help="do not echo the steps' output")
    args = ap.parse_args(argv)
    if args.smoke and not args.cpu:
        ap.error("--smoke needs --cpu")
    if args.budget is not None and not args.budget > 0:
        ap.error(f"--budget must be a positive number of seconds, got {args.budget}")
    budget = args.budget or (55.0 if args.smoke else 115.0 if args.cpu else 470.0)
    install_first = (not args.cpu) if args.install is None else args.install
    outdir = os.path.abspath(args.outdir)
    os.makedirs(outdir, exist_ok=True)
    runner = Runner(outdir, budget, echo=not args.quiet)
    timeouts = CPU_TIMEOUTS if args.cpu else GPU_TIMEOUTS
    mode = "CPU devices, smoke" if args.smoke else "CPU devices" if args.cpu else "GPU devices"
    log(f"mode: {mode}; budget {budget:.0f} s; report in {outdir}")

    py = install(runner, timeouts["install"]) if install_first else sys.executable
    icds = prepare_opencl_icds(runner) if not args.cpu else "not examined (--cpu)"
    log(f"OpenCL drivers: {icds}")
    smi = nvidia_smi()
    log(f"nvidia-smi: {smi}")
    info = probe(runner, py, timeouts["devices"])
    chosen = choose_devices(info, args.cpu)
    no_gpu = not args.cpu and not chosen
    if no_gpu:
        log("NO GPU FOUND (neither Warp nor OpenCL sees one): the steps run on the CPU devices instead")
        chosen = choose_devices(info, True)
    elif not args.cpu and "opencl" not in chosen:
        log("no OpenCL GPU device: OpenCL is not tested on a GPU in this run")
    specs = [f"{name}:{dev}" for name, dev in chosen.items()]
    log(f"devices under test: {', '.join(specs) or 'none'}")
    small = args.cpu or no_gpu

    if specs:
        files = CPU_TEST_FILES[:1] if args.smoke else CPU_TEST_FILES if small else ["tests"]
        tests = runner.run("tests", [py, "-m", "pytest", *files, "-q", "-p", "no:cacheprovider", "-rfE",
                                     "--maxfail=50"], timeouts["tests"],
                           env={"GFGPU_TEST_BACKENDS": ",".join(specs)},
                           title=f"tests on {', '.join(specs)}")
    else:
        tests = runner.note("tests", "failed", "no device to test: neither Warp nor OpenCL loads")

    size = 512 if args.smoke else 1024 if small else 4096
    repeat = 2 if small else 5
    bench_specs = ",".join(specs) or "numpy"
    first = specs[0] if specs else "numpy"
    runner.run("filters", [py, "benchmarks/filters.py", "--size", str(size), "--repeat", str(repeat),
                           "--backends", bench_specs, "--no-cold", "--no-accuracy"], timeouts["filters"],
               title="filters.py (primitive, public calls, host in/out)")
    if not args.smoke:
        scenes = ["rds-steps"] if small else ["teddy", "cones", "synth-1500"]
        names = [s.split(":")[0] for s in specs] or ["numpy"]
        runner.run("stereo", [py, "benchmarks/stereo.py", "--backends", *names, "--scenes", *scenes,
                              "--repeat", "1" if small else "3", "--methods", "sgm"], timeouts["stereo"],
                   env={"GFGPU_BACKEND": first}, title="stereo.py (sgm beside OpenCV)")
        runner.run("motion", [py, "benchmarks/motion.py", "--backends", ",".join(names),
                              "--size", str(size), "--repeat", str(repeat), "--skip-accuracy"], timeouts["motion"],
                   env={"GFGPU_BACKEND": first}, title="motion.py (speed)")
    runner.run("canny", [py, "benchmarks/edges_fom.py", "--timing-only", "--timing-size", str(size),
                         "--backends", bench_specs], timeouts["canny"],
               title="canny timing (edges_fom.py) beside skimage and cv2")

    passed = tests["status"] == "ok"
    verdict = ("tests passed" if passed else f"tests {tests['status']}") + (" (NO GPU FOUND)" if no_gpu else "")
    meta = {"mode": mode, "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "host": platform.node(), "cores": os.cpu_count(), "python": platform.python_version(),
            "command": " ".join([os.path.basename(sys.executable), *sys.argv]), "nvidia_smi": smi,
            "opencl_icds": icds, "devices_under_test": ", ".join(specs), "verdict": verdict,
            "budget_s": budget, "total_s": round(budget - runner.left(), 1), "python_used": py}
    write_report(outdir, meta, info, runner)
    log(f"{verdict}; total {meta['total_s']:.0f} s; report: {os.path.join(outdir, 'report.md')}")
    if not passed:
        return 1
    return 3 if no_gpu else 0


if __name__ == "__main__":
    sys.exit(main())
