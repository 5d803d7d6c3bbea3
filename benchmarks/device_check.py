"""The device check: gfgpu on the lent GPU machine (one H200, no network), staged, and its plan.

The lent machine (/work/.library/device/KINDS.md) has Python 3.12 with numpy, scipy,
scikit-image, OpenCV, torch and CuPy but not Warp, PyOpenCL or their dependencies, no network,
at most 64 MiB per call (working tree and carried paths), at most 8 result files per call and
15 minutes of device time for every try together.  So nothing is installed from a registry
there: ``--plan`` builds here what the check needs (benchmarks/device_plan.py) and prints the
``run`` calls that carry it; on the machine each call runs ``--device-call N``.

Here (this machine, with PyPI)::

    python benchmarks/device_check.py --plan          # build .device/, print the calls and their budget
    python benchmarks/device_check.py --plan --dry    # the same figures, nothing built or downloaded (CI)
    python benchmarks/device_check.py --rehearse      # the calls here, network cut off, CPU devices

On the device machine (what the plan's ``run`` commands call)::

    python3 benchmarks/device_check.py --device-call N "$OUT" --budget SECONDS

The staged check itself (anywhere the project's packages import)::

    python benchmarks/device_check.py OUTDIR [--cpu] [--smoke] [--work DIR] [--resume]

Stages, each a subprocess with its own timeout; after each one OUTDIR holds ``report.json``,
``report.md`` and ``logs.tar.gz`` (every stage's log), so a stage that times out, or a call
killed at its limit, still returns what ran:

* ``system`` (the first call, the image's own Python): nvidia-smi, the OpenCL ICDs (under
  ``/etc/OpenCL/vendors`` and the driver mount ``/usr/local/nvidia``), the image's packages,
  and the memory-copy bound: a device-to-device copy through torch (and CuPy) timed with CUDA
  events (on a machine without CUDA: ``numpy.copyto``);
* ``devices``: Warp's and OpenCL's devices, versions, gfgpu.devices(), and whether Warp's kernel
  cache holds the module of every gfgpu Warp kernel file for the GPU's architecture;
* ``first-call``: per backend, a fresh process times its start and the first and the steady
  call of shift, motion_blur, canny and disparity (a Warp module missing from the cache is
  compiled there: a Warp that times out here is left out of the later stages, since a killed
  compile is not cached);
* ``tests``: the forced-GPU-branch tests and a smoke subset of the device tests
  (:data:`TEST_FILES`) with ``GFGPU_TEST_BACKENDS`` naming the devices (a device run: the
  host-only tests skip, tests/conftest.py);
* ``filters``, ``stereo``, ``motion``, ``canny``: the GPU rows of benchmarks/filters.py,
  stereo.py, motion.py and edges_fom.py's timing table beside their CPU rows; the report adds
  each filters row against the device copy bound.

``--cpu`` runs the same stages on the CPU devices with small sizes (the rehearsal, and
``--cpu --smoke`` in the test suite).  Exit status: 0 when the tests passed on the devices under
test, 1 when they failed or did not run, 3 when a GPU run found no GPU.
"""

from __future__ import annotations

import argparse
import ctypes
import datetime
import glob
import hashlib
import json
import lzma
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tarfile
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: what the plan carries, one folder per call (benchmarks/device_plan.py writes it)
SEND_DIR = os.path.join(ROOT, ".device", "send")
#: where the calls leave what later calls need on the device (it lasts while the machine is warm)
DEFAULT_DEVICE_ROOT = "/root/gfgpu-device"
#: the files a check writes to OUTDIR ($OUT): at most 8 come back from a call
RESULT_FILES = ("report.json", "report.md", "logs.tar.gz")
MAX_RESULT_FILES = 8

#: seconds per stage.  The plan's budget (device_plan.py) adds these up against the calls'
#: timeouts; the CPU run (the rehearsal) keeps the same limits with smaller sizes.
SYSTEM_TIMEOUT = 35
STAGE_TIMEOUTS = {"devices": 20, "first-call": 35, "tests": 80, "filters": 30, "stereo": 30, "motion": 30,
                  "canny": 25}
#: on the CPU devices (the rehearsal): PoCL builds every OpenCL program of the tests cold on two
#: cores the first time (a minute more); the last call's budget still bounds the whole check
CPU_STAGE_TIMEOUTS = dict(STAGE_TIMEOUTS, tests=140)
#: seconds for receiving a call's files and, in the last call, reassembling and installing
RECEIVE_TIMEOUT = {"first": 10, "last": 45}
#: the check ends this many seconds before its call's timeout
CALL_MARGIN = 10

#: the device tests of the ``tests`` stage: every fused kernel against its spec (all of gfgpu's
#: Warp and OpenCL modules), the public calls, the recursion primitives, and the two tests that
#: force the OpenCL GPU branch (FORCED_GPU_BRANCH); about 250 tests, 25 s on PoCL here
TEST_FILES = ["tests/backends/test_fused.py", "tests/test_shift.py", "tests/test_api.py",
              "tests/stereo/test_kernels.py", "tests/stereo/test_matcher.py", "tests/stereo/test_disparity.py",
              "tests/stereo/test_group_matcher.py",
              "tests/motion/test_uniform.py", "tests/motion/test_rotation.py", "tests/motion/test_zoom.py",
              "tests/motion/test_box_and_field.py", "tests/edges/test_canny.py", "tests/test_robustness.py",
              "tests/shading/test_operator.py"]
FORCED_GPU_BRANCH = ["tests/stereo/test_matcher.py::test_gpu_code_path_of_the_matcher_runs_on_the_cpu_device",
                     "tests/stereo/test_kernels.py::test_opencl_line_aggregation_matches_reference"]
SMOKE_TEST_FILES = ["tests/test_shift.py", *FORCED_GPU_BRANCH]

#: image packages reported by the system stage (distribution names)
IMAGE_PACKAGES = ("numpy", "scipy", "scikit-image", "opencv-python-headless", "imageio", "tifffile", "tqdm",
                  "threadpoolctl", "pytest", "torch", "cupy-cuda13x", "typing_extensions", "pip")
CARRIED_PACKAGES = ("warp-lang", "pyopencl", "pytools", "platformdirs", "siphash24", "dask", "partd", "locket")


def log(msg):
    print(f"[device_check {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def warp_kernel_modules(root=ROOT):
    """The dotted names of gfgpu's modules that define Warp kernels (``@wp.kernel``) for a GPU,
    sorted (modules marked ``CPU_ONLY = True`` are never compiled for CUDA)."""
    names = []
    for path in sorted(glob.glob(os.path.join(root, "gfgpu", "**", "*.py"), recursive=True)):
        with open(path, encoding="utf-8") as f:
            text = f.read()
            if "@wp.kernel" not in text or "\nCPU_ONLY = True" in text:
                continue
        rel = os.path.relpath(path, root)[:-3].split(os.sep)
        names.append(".".join(rel[:-1] if rel[-1] == "__init__" else rel))
    return names


# ---- stages as subprocesses ----------------------------------------------------------------------
class Runner:
    """Runs stages as subprocesses, each with a timeout, within one overall budget; the logs go
    to ``work/logs``, and after every stage the report is written to OUTDIR."""

    def __init__(self, outdir, work, budget, echo, state=None):
        self.outdir, self.work = outdir, work
        self.logs = os.path.join(work, "logs")
        os.makedirs(self.logs, exist_ok=True)
        os.makedirs(outdir, exist_ok=True)
        self.deadline = time.monotonic() + budget
        self.echo = echo
        self.stages = []
        self.kept = {s["name"]: s for s in (state or []) if s.get("status") == "ok"}
        self.env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.flush = lambda: None
        self.timeouts = STAGE_TIMEOUTS

    def left(self):
        return self.deadline - time.monotonic()

    def keep(self, name):
        """The earlier run's record of ``name`` if it passed (``--resume``), now reported again."""
        step = self.kept.get(name)
        if step is not None:
            step = dict(step, resumed=True)
            self.stages.append(step)
            log(f"{name}: kept from the earlier run ({step['status']}, {step['seconds']:.1f} s)")
        return step

    def run(self, name, cmd, timeout, env=None, title=None, cwd=ROOT):
        """Run ``cmd``; record the stage (status, seconds, output); write the report after it."""
        shown = [("<script>" if prev == "-c" else a) for prev, a in zip([""] + cmd, cmd)]
        step = {"name": name, "title": title or name, "command": " ".join(shown), "status": "skipped",
                "seconds": 0.0, "timeout": timeout, "returncode": None, "output": ""}
        self.stages.append(step)
        limit = min(timeout, self.left() - 3)
        if limit < 3:
            step["output"] = "not run: the time budget of the check is spent"
            log(f"{name}: skipped (budget spent)")
            self.flush()
            return step
        step["timeout"] = round(limit, 1)
        log(f"{name}: started (timeout {limit:.0f} s): {step['command'][:160]}")
        t0 = time.monotonic()
        chunks = []
        with open(os.path.join(self.logs, f"{name}.log"), "w", encoding="utf-8") as logfile:
            logfile.write(f"$ {step['command']}\n")
            try:
                proc = subprocess.Popen(cmd, cwd=cwd, env=dict(self.env, **(env or {})), stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, errors="replace",
                                        start_new_session=True)   # its own group: a timeout ends its children too
            except OSError as exc:
                step.update(status="failed", output=f"could not start: {exc}")
                log(f"{name}: could not start: {exc}")
                self.flush()
                return step

            def pump():
                for line in proc.stdout:
                    chunks.append(line)
                    logfile.write(line)
                    logfile.flush()
                    if self.echo:
                        sys.stdout.write(f"  | {line}")
                        sys.stdout.flush()

            reader = threading.Thread(target=pump, daemon=True)
            reader.start()
            try:
                proc.wait(timeout=limit)
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
        self.flush()
        return step

    def note(self, name, status, output, seconds=0.0, **extra):
        step = {"name": name, "title": name, "command": "", "status": status, "seconds": seconds,
                "timeout": None, "returncode": None, "output": output, **extra}
        self.stages.append(step)
        log(f"{name}: {status}: {output.splitlines()[0] if output else ''}")
        self.flush()
        return step


def marked_json(output, marker):
    """Every JSON object printed on a line ``MARKER {...}`` of ``output``."""
    found = []
    for line in output.splitlines():
        if line.startswith(marker + " "):
            try:
                found.append(json.loads(line[len(marker) + 1:]))
            except ValueError:
                pass
    return found


# ---- the system stage: GPU, drivers, OpenCL ICDs, image packages, copy bound ----------------------
SYSTEM_PROBE = r"""
import json, os, sys, time, importlib.metadata as md
info = {"python": sys.version.split()[0], "executable": sys.executable, "packages": {}, "copy": [],
        "errors": []}
for dist in json.loads(sys.argv[1]):
    try:
        info["packages"][dist] = md.version(dist)
    except md.PackageNotFoundError:
        info["packages"][dist] = None
sizes = [int(s) for s in sys.argv[2].split(",")]
# the copy bound: read + write of a float32 array, the median of 20 copies after 3 warm-ups,
# rotating over 4 random sources (no array small enough to sit in the L2 twice in a row)
try:
    import torch
    if not torch.cuda.is_available():
        raise RuntimeError("torch sees no CUDA device")
    p = torch.cuda.get_device_properties(0)
    info["torch"] = {"version": torch.__version__, "cuda": torch.version.cuda, "name": p.name,
                     "multiprocessors": p.multi_processor_count, "memory_GiB": round(p.total_memory / 2**30, 1),
                     "l2_MB": round(getattr(p, "L2_cache_size", 0) / 1e6, 1)}
    for n in sizes:
        srcs = [torch.rand((n, n), device="cuda", dtype=torch.float32) for _ in range(4 if n <= 8192 else 1)]
        dst = torch.empty_like(srcs[0])
        for s in srcs[:3]:
            dst.copy_(s)
        torch.cuda.synchronize()
        times = []
        for i in range(20):
            a, b = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
            a.record(); dst.copy_(srcs[i % len(srcs)]); b.record(); b.synchronize()
            times.append(a.elapsed_time(b) / 1e3)
        assert torch.equal(dst, srcs[19 % len(srcs)]), "copy check failed"
        t = sorted(times)[len(times) // 2]
        info["copy"].append({"by": "torch (cuda:0, device to device)", "size": n, "seconds": t,
                             "GB_per_s": 8 * n * n / t / 1e9, "Mpix_per_s": n * n / t / 1e6})
        del srcs, dst
        torch.cuda.empty_cache()
except Exception as exc:
    info["errors"].append(f"torch copy bound: {type(exc).__name__}: {exc}")
try:
    import cupy as cp
    n = sizes[0]
    srcs = [cp.random.random((n, n), dtype=cp.float32) for _ in range(4)]
    dst = cp.empty_like(srcs[0])
    for s in srcs[:3]:
        cp.copyto(dst, s)
    cp.cuda.Device(0).synchronize()
    times = []
    for i in range(20):
        a, b = cp.cuda.Event(), cp.cuda.Event()
        a.record(); cp.copyto(dst, srcs[i % 4]); b.record(); b.synchronize()
        times.append(cp.cuda.get_elapsed_time(a, b) / 1e3)
    t = sorted(times)[len(times) // 2]
    info["copy"].append({"by": f"CuPy {cp.__version__} (device to device)", "size": n, "seconds": t,
                         "GB_per_s": 8 * n * n / t / 1e9, "Mpix_per_s": n * n / t / 1e6})
except Exception as exc:
    info["errors"].append(f"CuPy copy bound: {type(exc).__name__}: {exc}")
if not info["copy"]:
    import numpy as np
    n = sizes[0]
    src = np.random.default_rng(0).random((n, n), dtype=np.float32)
    dst = np.empty_like(src)
    np.copyto(dst, src)
    times = []
    for _ in range(5):
        t0 = time.perf_counter(); np.copyto(dst, src); times.append(time.perf_counter() - t0)
    t = sorted(times)[len(times) // 2]
    info["copy"].append({"by": "numpy.copyto (host: no CUDA device here)", "size": n, "seconds": t,
                         "GB_per_s": 8 * n * n / t / 1e9, "Mpix_per_s": n * n / t / 1e6})
print("SYSTEM-PROBE " + json.dumps(info))
"""


def nvidia_smi():
    exe = shutil.which("nvidia-smi")
    if exe is None:
        return "nvidia-smi not found"
    try:
        res = subprocess.run([exe, "--query-gpu=index,name,driver_version,memory.total,compute_cap,clocks.sm,"
                              "clocks.mem,temperature.gpu,utilization.gpu", "--format=csv,noheader"],
                             capture_output=True, text=True, timeout=20)
        return (res.stdout or res.stderr).strip() or f"nvidia-smi exit {res.returncode}"
    except (OSError, subprocess.SubprocessError) as exc:
        return f"nvidia-smi failed: {exc}"


NVIDIA_OPENCL_GLOBS = ("/usr/local/nvidia/lib64/libnvidia-opencl.so*", "/usr/local/nvidia/lib/libnvidia-opencl.so*",
                       "/usr/local/nvidia/**/libnvidia-opencl.so*", "/usr/lib/x86_64-linux-gnu/libnvidia-opencl.so*",
                       "/usr/lib64/libnvidia-opencl.so*")


def opencl_icds():
    """What an ICD loader can find: ``{vendors: {file: library}, nvidia_libraries: [...], ldconfig: bool}``."""
    vendor_dir = os.environ.get("OCL_ICD_VENDORS") or "/etc/OpenCL/vendors"
    vendors = {}
    for path in sorted(glob.glob(os.path.join(vendor_dir, "*.icd"))) if os.path.isdir(vendor_dir) else []:
        try:
            with open(path, encoding="utf-8", errors="replace") as f:
                vendors[path] = f.readline().strip()
        except OSError as exc:
            vendors[path] = f"unreadable ({exc})"
    libs = []
    for pattern in NVIDIA_OPENCL_GLOBS:
        for path in glob.glob(pattern, recursive=True):
            if path not in libs and os.path.isfile(path):
                libs.append(path)
    try:
        ctypes.CDLL("libnvidia-opencl.so.1")
        by_soname = True
    except OSError:
        by_soname = False
    return {"vendor_dir": vendor_dir, "vendors": vendors, "nvidia_libraries": libs, "loads_by_soname": by_soname}


def prepare_opencl_icds(icds, work):
    """Make PyOpenCL's bundled ICD loader see the NVIDIA OpenCL driver where the system has
    none naming it: ``(environment to add, a line saying what was done)``."""
    named = [f"{os.path.basename(k)}: {v}" for k, v in icds["vendors"].items()]
    if any("nvidia" in v.lower() for v in icds["vendors"].values()):
        return {}, f"ICDs in {icds['vendor_dir']}: {'; '.join(named)} (PyOpenCL's loader reads them)"
    lib = next((p for p in icds["nvidia_libraries"] if p.endswith(".so.1")), None) or \
        (icds["nvidia_libraries"] or [None])[0] or ("libnvidia-opencl.so.1" if icds["loads_by_soname"] else None)
    found = f"ICDs in {icds['vendor_dir']}: {'; '.join(named)}" if named else f"no ICD in {icds['vendor_dir']}"
    if lib is None:
        return {}, f"{found}; no NVIDIA OpenCL driver (libnvidia-opencl.so.1) on this machine"
    icd_dir = os.path.join(work, "opencl-vendors")
    os.makedirs(icd_dir, exist_ok=True)
    for path in icds["vendors"]:      # keep whatever the system had
        shutil.copy(path, icd_dir)
    with open(os.path.join(icd_dir, "nvidia.icd"), "w", encoding="utf-8") as f:
        f.write(lib + "\n")
    return ({"OCL_ICD_VENDORS": icd_dir},
            f"{found}; {lib} present: wrote {icd_dir}/nvidia.icd (OCL_ICD_VENDORS={icd_dir})")


def system_stage(runner, py, cpu):
    """The ``system`` stage; its record carries ``info`` (the probe's JSON) and ``icds``."""
    sizes = "1024" if cpu else "4096,16384"
    step = runner.run("system", [py, "-c", SYSTEM_PROBE, json.dumps(IMAGE_PACKAGES + CARRIED_PACKAGES), sizes],
                      SYSTEM_TIMEOUT, title="system: GPU, drivers, image packages, copy bound")
    found = marked_json(step["output"], "SYSTEM-PROBE")
    step["info"] = found[-1] if found else {"errors": [f"system probe {step['status']}"], "copy": []}
    step["info"]["nvidia_smi"] = nvidia_smi()
    step["info"]["icds"] = opencl_icds()
    step["info"]["uname"] = " ".join(platform.uname())
    runner.flush()
    return step


# ---- the devices stage -----------------------------------------------------------------------------
DEVICE_PROBE = r"""
import importlib, json, os, sys, importlib.metadata as md
info = {"python": sys.version.split()[0], "executable": sys.executable, "versions": {}, "where": {},
        "warp_cuda": [], "warp_devices": [], "warp_cache": {}, "opencl": [], "gfgpu_devices": [], "errors": []}
for dist in json.loads(sys.argv[1]):
    try:
        info["versions"][dist] = md.version(dist)
        info["where"][dist] = str(md.distribution(dist).locate_file(""))
    except md.PackageNotFoundError:
        info["versions"][dist] = None
try:
    import warp as wp
    wp.config.quiet = True
    wp.init()
    rt = wp._src.context.runtime if hasattr(wp, "_src") else None
    info["warp"] = {"version": wp.config.version, "cache": wp.config.kernel_cache_dir,
                    "toolkit": getattr(rt, "toolkit_version", None), "driver": getattr(rt, "driver_version", None),
                    "cpu_compiler": getattr(rt, "llvm", True) is not None}
    info["warp_devices"] = [str(d) for d in wp.get_devices()]
    cuda = wp.get_cuda_devices()
    for d in cuda:
        fmt = d.get_cuda_output_format() if hasattr(d, "get_cuda_output_format") else None
        info["warp_cuda"].append({"alias": d.alias, "name": d.name, "arch": d.arch, "output": fmt,
                                  "memory_GiB": round(d.total_memory / 2**30, 1)})
    for name in json.loads(sys.argv[2]):
        try:
            importlib.import_module(name)
            mod = wp.get_module(name)
            ident = mod.get_module_identifier()
            folder = os.path.join(wp.config.kernel_cache_dir, ident)
            files = sorted(os.listdir(folder)) if os.path.isdir(folder) else []
            want = [mod._get_compile_output_name(d) for d in cuda] or [f"{ident}.sm{sys.argv[3]}.cubin"]
            info["warp_cache"][name] = {"identifier": ident, "files": files, "wanted": want,
                                        "cached": all(w in files for w in want)}
        except Exception as exc:
            info["warp_cache"][name] = {"error": f"{type(exc).__name__}: {exc}", "cached": False}
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
    info["gfgpu"] = gfgpu.__version__
    info["gfgpu_devices"] = [str(d) for d in gfgpu.devices()]
except Exception as exc:
    info["errors"].append(f"gfgpu.devices: {type(exc).__name__}: {exc}")
print("DEVICE-PROBE " + json.dumps(info, default=str))
"""

#: the architecture Warp's kernels are built for ahead of time (the H200: compute capability 9.0)
CUDA_ARCH = 90


def devices_stage(runner, py):
    step = runner.keep("devices") or runner.run(
        "devices", [py, "-c", DEVICE_PROBE, json.dumps(CARRIED_PACKAGES + IMAGE_PACKAGES),
                    json.dumps(warp_kernel_modules()), str(CUDA_ARCH)],
        runner.timeouts["devices"], title="devices and versions")
    if "info" not in step:
        found = marked_json(step["output"], "DEVICE-PROBE")
        step["info"] = found[-1] if found else {"errors": [f"device probe {step['status']}"], "warp_cuda": [],
                                                "warp_devices": [], "opencl": [], "versions": {}, "warp_cache": {}}
    runner.flush()
    return step["info"]


def choose_devices(info, cpu):
    """``{backend: device}`` under test: the GPUs (or, with ``cpu``, the CPU devices)."""
    chosen = {}
    if cpu:
        if "cpu" in info.get("warp_devices", []) and info.get("warp", {}).get("cpu_compiler", True):
            chosen["warp"] = "cpu"      # not with the device's Warp: its CPU compiler is left behind
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


# ---- first call against steady state -----------------------------------------------------------------
FIRST_CALL = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
import gfgpu
from gfgpu.backends import get_backend
from gfgpu.stereo import random_dot_stereogram
name, device, size = sys.argv[1], sys.argv[2] or None, int(sys.argv[3])
be = get_backend(name, device)
be.synchronize()
print("FIRST-CALL " + json.dumps({"op": "import gfgpu + start the backend", "first_s": time.perf_counter() - t0,
                                  "steady_s": None, "device": str(be)}), flush=True)
rng = np.random.default_rng(0)
img = rng.random((size, size), dtype=np.float32)
truth = np.full((size // 4, size // 4), 5.0, np.float32)
truth[size // 16: size // 8, size // 16: size // 8] = 9.5
left, right = random_dot_stereogram(truth, seed=1)
ops = [("shift (1.5, 2.5)", lambda: gfgpu.shift(img, (1.5, 2.5), backend=be)),
       ("motion_blur (0, 25)", lambda: gfgpu.motion_blur(img, (0.0, 25.0), backend=be)),
       ("canny u=2", lambda: gfgpu.canny(img, 2.0, backend=be)),
       (f"disparity sgm {size // 4}x{size // 4}, 16 disparities", lambda: gfgpu.disparity(left, right, 15, backend=be))]
for label, fn in ops:
    t = time.perf_counter(); fn(); be.synchronize(); first = time.perf_counter() - t
    steady = []
    for _ in range(3):
        t = time.perf_counter(); fn(); be.synchronize(); steady.append(time.perf_counter() - t)
    print("FIRST-CALL " + json.dumps({"op": f"{label}, {size}x{size}" if "disparity" not in label else label,
                                      "first_s": first, "steady_s": min(steady), "device": str(be)}), flush=True)
"""


def cache_files(env):
    base = env.get("WARP_CACHE_PATH")
    if not base:
        return set()
    return {os.path.relpath(p, base) for p in glob.glob(os.path.join(base, "*", "*", "*"))
            if p.endswith((".cubin", ".ptx", ".o"))}


def first_call_stage(runner, py, specs, cpu):
    """A fresh process per backend; the Warp kernel modules it had to compile.  Returns the specs
    that may go on (a Warp that ran out of time is left out: its compile was killed)."""
    step = runner.keep("first-call")
    if step is not None:
        return step.get("keep_specs", specs)
    size = 512 if cpu else 2048
    t0 = time.monotonic()
    end = t0 + min(runner.timeouts["first-call"], runner.left() - 3)
    rows, outputs, status, keep = [], [], "ok", []
    for i, spec in enumerate(specs):
        name, _, device = spec.partition(":")
        before = cache_files(runner.env)
        # Warp first, with the most time (a cache miss compiles); at least 10 s for each one after it
        limit = end - time.monotonic() - 10 * (len(specs) - 1 - i)
        sub = runner.run(f"first-call-{name}", [py, "-c", FIRST_CALL, name, device, str(size)], limit,
                         title=f"first call on {spec}")
        runner.stages.remove(sub)
        compiled = sorted(cache_files(runner.env) - before)
        found = marked_json(sub["output"], "FIRST-CALL")
        for r in found:
            r["spec"] = spec
        rows += found
        outputs.append(f"## {spec}: {sub['status']} in {sub['seconds']:.1f} s; compiled here: "
                       f"{', '.join(compiled) or 'nothing (every module came from the cache)'}\n{sub['output']}")
        if sub["status"] != "ok":
            status = "failed" if status == "ok" else status
        if sub["status"] == "timeout" and name == "warp":
            status = "timeout"
            log(f"first-call: {spec} ran out of time (a cold compile?): left out of the later stages")
        else:
            keep.append(spec)
        rows.append({"spec": spec, "op": "(modules compiled in this process)", "compiled": compiled})
    step = runner.note("first-call", status, "\n".join(outputs), seconds=round(time.monotonic() - t0, 1),
                       rows=rows, keep_specs=keep)
    step.update(title="first call against steady state", timeout=runner.timeouts["first-call"],
                command=f"per backend: python -c <first-call script> NAME DEVICE {size}")
    return keep


# ---- tests -----------------------------------------------------------------------------------------
def junit_summary(path):
    """``{total, passed, failed, errors, skipped, failures: [...], cases: {nodeid: outcome}}`` of a JUnit file."""
    import xml.etree.ElementTree as ET
    out = {"total": 0, "passed": 0, "failed": 0, "errors": 0, "skipped": 0, "failures": [], "cases": {}}
    try:
        tree = ET.parse(path)
    except (OSError, ET.ParseError) as exc:
        out["error"] = f"no JUnit report ({exc})"
        return out
    for case in tree.iter("testcase"):
        cls, name = case.get("classname", ""), case.get("name", "")
        node = cls.replace(".", "/") + ".py::" + name
        outcome = "passed"
        for child in case:
            if child.tag in ("failure", "error"):
                outcome = "failed" if child.tag == "failure" else "errors"
                out["failures"].append(f"{node}: {(child.get('message') or '').splitlines()[0][:240]}"
                                       if child.get("message") else node)
            elif child.tag == "skipped":
                outcome = "skipped"
        out["total"] += 1
        out[outcome] += 1
        out["cases"][node] = outcome
    return out


def pytest_summary(output):
    for line in reversed([line for line in output.splitlines() if line.strip()]):
        if (" passed" in line or " failed" in line or " error" in line or "no tests ran" in line) and " in " in line:
            return line.strip("= ").strip()
    return "no pytest summary (the run did not finish)"


def tests_stage(runner, py, specs, smoke):
    step = runner.keep("tests")
    if step is not None:
        return step
    if not specs:
        return runner.note("tests", "failed", "no device to test: neither Warp nor OpenCL sees one")
    xml = os.path.join(runner.work, "tests.xml")
    files = SMOKE_TEST_FILES if smoke else TEST_FILES
    step = runner.run("tests", [py, "-m", "pytest", *files, "-q", "-p", "no:cacheprovider", "-rfE",
                                "--maxfail=30", f"--junitxml={xml}"], runner.timeouts["tests"],
                      env={"GFGPU_TEST_BACKENDS": ",".join(specs), "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"},
                      title=f"tests on {', '.join(specs)}")
    summary = junit_summary(xml)
    summary["pytest"] = pytest_summary(step["output"])
    cases = summary["cases"]
    summary["forced_gpu_branch"] = {}
    for node in FORCED_GPU_BRANCH:
        outcomes = sorted({o for n, o in cases.items() if n == node or n.startswith(node + "[")})
        summary["forced_gpu_branch"][node] = ", ".join(outcomes) or "not run"
    summary.pop("cases")
    step["summary"] = summary
    if step["status"] == "ok" and not summary["passed"]:
        step["status"] = "failed"     # nothing ran: no pass by skipping
    runner.flush()
    return step


# ---- benchmarks --------------------------------------------------------------------------------------
def benchmark_stages(runner, py, specs, cpu, smoke):
    names = [s.split(":")[0] for s in specs] or ["numpy"]
    bench = ",".join(specs) or "numpy"
    first = specs[0] if specs else "numpy"
    size = 256 if smoke else 1024 if cpu else 4096
    # best of 2 after a warm-up: the single-threaded CPU peers at 4096² (scipy) take most of the time
    repeat = "2"
    plan = [("filters", [py, "benchmarks/filters.py", "--size", str(size), "--repeat", repeat, "--backends", bench,
                         "--no-cold", "--no-accuracy"], {}, "filters.py (primitives, public calls, host in/out)")]
    if not smoke:
        plan += [("stereo", [py, "benchmarks/stereo.py", "--backends", *names, "--scenes",
                             *(["rds-steps"] if cpu else ["teddy"]), "--repeat", "1" if cpu else "2",
                             "--methods", "sgm"], {"GFGPU_BACKEND": first}, "stereo.py (sgm beside OpenCV)"),
                 ("motion", [py, "benchmarks/motion.py", "--backends", ",".join(names), "--size", str(size),
                             "--repeat", "2", "--skip-accuracy"], {"GFGPU_BACKEND": first}, "motion.py (speed)")]
    plan.append(("canny", [py, "benchmarks/edges_fom.py", "--timing-only", "--timing-size",
                           str(256 if smoke else 512 if cpu else 4096), "--backends", bench], {},
                 "canny timing (edges_fom.py) beside skimage and cv2"))
    for name, cmd, env, title in plan:
        runner.keep(name) or runner.run(name, cmd, runner.timeouts[name], env=dict(env, MPLBACKEND="Agg"),
                                        title=title)


# ---- the report --------------------------------------------------------------------------------------
def tables(output):
    """The Markdown of a benchmark's output: its tables and the lines around them."""
    keep = [line for line in output.splitlines()
            if line.startswith(("|", "#")) or (line.strip() and not line.startswith(("  ", "\t", "[", "$")))]
    return "\n".join(keep[-300:])


def against_copy(output, copy):
    """The filters table's rows with one more column: Mpix/s over the device copy's Mpix/s."""
    if not copy:
        return ""
    rows = ["| operation | Mpix/s | × device copy |", "|---|---:|---:|"]
    for line in output.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| ") and len(cells) >= 3 and re.fullmatch(r"[\d,]+(\.\d+)?", cells[1]):
            rate = float(cells[1].replace(",", ""))
            rows.append(f"| {cells[0]} | {cells[1]} | {rate / copy['Mpix_per_s']:.3f} |")
    return "\n".join(rows) if len(rows) > 2 else ""


def copy_bound(system, size):
    copies = [c for c in (system or {}).get("copy", []) if c["size"] == size] or (system or {}).get("copy", [])
    return copies[0] if copies else None


def write_report(outdir, work, meta, stages):
    """report.json, report.md and logs.tar.gz in ``outdir``, each written whole, then moved in."""
    by = {s["name"]: s for s in stages}
    system = by.get("system", {}).get("info")
    info = by.get("devices", {}).get("info", {})
    data = {"meta": meta, "stages": stages}
    md = [f"# gfgpu device check ({meta['mode']})", "",
          f"- date: {meta['date']}; host: {meta['host']}, {meta['cores']} cores, Python {meta['python']}",
          f"- command: `{meta['command']}`",
          f"- devices under test: {meta.get('devices_under_test') or 'none found'}",
          f"- result: **{meta.get('verdict', 'running')}** after {meta.get('total_s', 0):.0f} s"]
    for line in meta.get("notes", []):
        md.append(f"- {line}")
    md += ["", "## Stages", "", "| stage | status | seconds | timeout | note |", "|---|---|---:|---:|---|"]
    for s in stages:
        note = "kept from the earlier run" if s.get("resumed") else (s.get("note") or "")
        timeout = f"{s['timeout']:.0f}" if isinstance(s.get("timeout"), (int, float)) else ""
        md.append(f"| {s['title']} | {s['status']} | {s['seconds']:.1f} | {timeout} | {note} |")
    if system:
        md += ["", "## Machine", "", f"- nvidia-smi: {system.get('nvidia_smi')}", f"- uname: {system.get('uname')}",
               f"- image Python {system.get('python')} at {system.get('executable')}"]
        if system.get("torch"):
            t = system["torch"]
            md.append(f"- torch {t['version']} (CUDA {t['cuda']}): {t['name']}, {t['multiprocessors']} "
                      f"multiprocessors, {t['memory_GiB']} GiB, L2 {t['l2_MB']} MB")
        icds = system.get("icds", {})
        md.append(f"- OpenCL ICDs in {icds.get('vendor_dir')}: "
                  f"{'; '.join(f'{k}: {v}' for k, v in icds.get('vendors', {}).items()) or 'none'}; "
                  f"NVIDIA OpenCL libraries: {', '.join(icds.get('nvidia_libraries', [])) or 'none found'}"
                  f"{' (loads by soname)' if icds.get('loads_by_soname') else ''}")
        md.append("- image packages: " + ", ".join(f"{k} {v}" for k, v in system.get("packages", {}).items() if v))
        md.append("- not in the image: " + (", ".join(k for k, v in system.get("packages", {}).items() if not v)
                                            or "none of those asked"))
        for err in system.get("errors", []):
            md.append(f"- probe: {err}")
        md += ["", "### Memory-copy bound (float32, read + write)", "",
               "| by | size | median ms | GB/s | Mpix/s |", "|---|---:|---:|---:|---:|"]
        for c in system.get("copy", []):
            md.append(f"| {c['by']} | {c['size']}² | {1e3 * c['seconds']:.3f} | {c['GB_per_s']:,.0f} | "
                      f"{c['Mpix_per_s']:,.0f} |")
    if info:
        md += ["", "## Devices", ""]
        for d in info.get("warp_cuda", []):
            md.append(f"- Warp {d['alias']}: {d['name']} (sm_{d.get('arch')}, {d.get('memory_GiB')} GiB, "
                      f"kernels as {d.get('output')})")
        md.append(f"- Warp devices: {', '.join(info.get('warp_devices', [])) or 'none'}; "
                  f"Warp {info.get('warp', {}).get('version')} (toolkit {info.get('warp', {}).get('toolkit')}, "
                  f"driver {info.get('warp', {}).get('driver')})")
        for d in info.get("opencl", []):
            md.append(f"- OpenCL {d['index']}: {d['name']} ({d['platform']}, {d['platform_version']}, driver "
                      f"{d['driver']}), {d['kind']}, {d['compute_units']} compute units, {d['memory_GiB']} GiB")
        for line in info.get("gfgpu_devices", []):
            md.append(f"- gfgpu.devices(): `{line.strip()}`")
        for err in info.get("errors", []):
            md.append(f"- probe error: {err}")
        md.append("- versions: " + ", ".join(f"{k} {v}" for k, v in sorted(info.get("versions", {}).items()) if v))
        if info.get("warp_cache"):
            md += ["", "### Warp's kernel cache (built ahead of time for sm_90)", "",
                   "| module | identifier | in the cache |", "|---|---|---|"]
            for mod, c in info["warp_cache"].items():
                md.append(f"| {mod} | {c.get('identifier', c.get('error', ''))} | "
                          f"{'yes' if c.get('cached') else 'NO: ' + ', '.join(c.get('wanted', []))} |")
    fc = by.get("first-call")
    if fc and fc.get("rows"):
        md += ["", "## First call against steady state (host in, host out; fresh process per backend)", "",
               "| backend | operation | first call (s) | steady (s) |", "|---|---|---:|---:|"]
        for r in fc["rows"]:
            if "compiled" in r:
                md.append(f"| {r['spec']} | Warp modules compiled in that process | "
                          f"{len(r['compiled'])} | {', '.join(r['compiled'])} |")
            else:
                steady = "" if r.get("steady_s") is None else f"{r['steady_s']:.4f}"
                md.append(f"| {r['spec']} | {r['op']} | {r['first_s']:.3f} | {steady} |")
    t = by.get("tests")
    if t:
        md += ["", f"## Tests ({t['status']}, {t['seconds']:.1f} s)", ""]
        s = t.get("summary", {})
        if s:
            md.append(f"pytest: {s.get('pytest')}; JUnit: {s.get('passed')} passed, {s.get('failed')} failed, "
                      f"{s.get('errors')} errors, {s.get('skipped')} skipped")
            md += [""] + [f"- forced GPU branch: `{k.split('::')[1]}`: {v}" for k, v in
                          s.get("forced_gpu_branch", {}).items()]
            md += [f"- `{line[:300]}`" for line in s.get("failures", [])[:40]]
        else:
            md.append(t.get("output", "")[-2000:])
    for s in stages:
        if s["name"] in ("filters", "stereo", "motion", "canny"):
            md += ["", f"## {s['title']} ({s['status']}, {s['seconds']:.1f} s)", "",
                   tables(s["output"]) or "(no output)"]
            if s["name"] == "filters":
                size = int(meta.get("filters_size", 4096))
                extra = against_copy(s["output"], copy_bound(system, size))
                if extra:
                    c = copy_bound(system, size)
                    md += ["", f"Against the copy bound ({c['by']}, {c['size']}², {c['Mpix_per_s']:,.0f} Mpix/s):",
                           "", extra]
    md += ["", "Every stage's full output: logs.tar.gz."]
    tmp = os.path.join(work, "report.tmp")
    os.makedirs(tmp, exist_ok=True)
    with open(os.path.join(tmp, "report.json"), "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1, default=str)
    with open(os.path.join(tmp, "report.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(md) + "\n")
    with tarfile.open(os.path.join(tmp, "logs.tar.gz"), "w:gz") as tar:
        logs = os.path.join(work, "logs")
        for name in sorted(os.listdir(logs)) if os.path.isdir(logs) else []:
            tar.add(os.path.join(logs, name), arcname=f"logs/{name}")
    os.makedirs(outdir, exist_ok=True)
    for name in RESULT_FILES:
        shutil.move(os.path.join(tmp, name), os.path.join(outdir, name))


# ---- the staged check --------------------------------------------------------------------------------
def check(argv=None):
    ap = argparse.ArgumentParser(prog="device_check.py", description="the staged device check")
    ap.add_argument("outdir", help="folder for report.json, report.md and logs.tar.gz (created)")
    ap.add_argument("--cpu", action="store_true", help="run on the CPU devices (small sizes)")
    ap.add_argument("--smoke", action="store_true", help="with --cpu: the reduced variant the test suite runs")
    ap.add_argument("--work", help="folder for the logs and the state of a resumable run (default: a temporary one)")
    ap.add_argument("--resume", action="store_true", help="keep the stages that passed in the earlier run in --work")
    ap.add_argument("--preamble", help="JSON list of stage records to report first (the calls' receive, install, "
                                       "system stages)")
    ap.add_argument("--budget", type=float, default=None,
                    help=f"seconds for the whole check (default: the stage timeouts, {sum(STAGE_TIMEOUTS.values())})")
    ap.add_argument("--quiet", action="store_true", help="do not echo the stages' output")
    args = ap.parse_args(argv)
    if args.smoke and not args.cpu:
        ap.error("--smoke needs --cpu")
    if args.budget is not None and not args.budget > 0:
        ap.error(f"--budget must be a positive number of seconds, got {args.budget}")
    outdir = os.path.abspath(args.outdir)
    work = os.path.abspath(args.work) if args.work else tempfile.mkdtemp(prefix="gfgpu-device-check-")
    state_path = os.path.join(work, "state.json")
    state = []
    if args.resume and os.path.exists(state_path):
        with open(state_path, encoding="utf-8") as f:
            state = json.load(f)
    preamble = []
    if args.preamble and os.path.exists(args.preamble):
        with open(args.preamble, encoding="utf-8") as f:
            preamble = json.load(f)
    table = CPU_STAGE_TIMEOUTS if args.cpu else STAGE_TIMEOUTS
    budget = args.budget or sum(table.values()) + (SYSTEM_TIMEOUT if not preamble else 0)
    runner = Runner(outdir, work, budget, echo=not args.quiet, state=state)
    runner.timeouts = table
    mode = "CPU devices, smoke" if args.smoke else "CPU devices" if args.cpu else "GPU devices"
    t_start = time.monotonic()
    meta = {"mode": mode, "date": datetime.datetime.now().isoformat(timespec="seconds"), "host": platform.node(),
            "cores": os.cpu_count(), "python": platform.python_version(),
            "command": " ".join([os.path.basename(sys.executable), *sys.argv]), "notes": []}

    def flush():
        meta["total_s"] = round(time.monotonic() - t_start, 1)
        stages = preamble + runner.stages
        with open(state_path, "w", encoding="utf-8") as f:
            json.dump(runner.stages, f, default=str)
        write_report(outdir, work, meta, stages)

    runner.flush = flush
    py = sys.executable
    log(f"mode: {mode}; budget {budget:.0f} s; report in {outdir}; logs in {work}")
    if not any(s["name"] == "system" for s in preamble):
        runner.keep("system") or system_stage(runner, py, args.cpu)
    system = next((s for s in preamble + runner.stages if s["name"] == "system"), {}).get("info", {})
    if not args.cpu and system.get("icds"):
        env, line = prepare_opencl_icds(system["icds"], work)
        runner.env.update(env)
        meta["notes"].append(f"OpenCL drivers: {line}")
        log(f"OpenCL drivers: {line}")
    info = devices_stage(runner, py)
    chosen = choose_devices(info, args.cpu)
    no_gpu = not args.cpu and not chosen
    if no_gpu:
        meta["notes"].append("NO GPU FOUND: neither Warp nor OpenCL sees one; the CPU devices are tested instead")
        log("NO GPU FOUND (neither Warp nor OpenCL sees one): the stages run on the CPU devices instead")
        chosen = choose_devices(info, True)
    elif not args.cpu and "opencl" not in chosen:
        meta["notes"].append("no OpenCL GPU device: OpenCL is not tested on the GPU in this run")
    specs = [f"{name}:{dev}" for name, dev in chosen.items()]
    meta["devices_under_test"] = ", ".join(specs)
    log(f"devices under test: {', '.join(specs) or 'none'}")
    small = args.cpu or no_gpu
    meta["filters_size"] = 256 if args.smoke else 1024 if small else 4096
    if specs:
        kept = first_call_stage(runner, py, specs, small)
        if kept != specs:
            meta["notes"].append(f"left out of the later stages after the first call: "
                                 f"{', '.join(s for s in specs if s not in kept)}")
            specs = kept
    tests = tests_stage(runner, py, specs, args.smoke)
    benchmark_stages(runner, py, specs, small, args.smoke)
    passed = tests["status"] == "ok"
    meta["verdict"] = ("tests passed" if passed else f"tests {tests['status']}") + (" (NO GPU FOUND)" if no_gpu else "")
    flush()
    log(f"{meta['verdict']}; total {meta['total_s']:.0f} s; report: {os.path.join(outdir, 'report.md')}")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    if not passed:
        return 1
    return 3 if no_gpu else 0


# ---- on the device machine: one call of the plan -------------------------------------------------------
def device_root():
    return os.environ.get("GFGPU_DEVICE_ROOT") or DEFAULT_DEVICE_ROOT


def load_manifest(call):
    path = os.path.join(SEND_DIR, f"call{call}", "manifest.json")
    if not os.path.exists(path):
        raise SystemExit(f"device_check: {path} is missing: was .device/send/call{call} carried (carry list)?")
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def receive(call, manifest, root):
    """Copy this call's files into ``root/parts``, each checked against the manifest; the lines
    of what was received."""
    parts = os.path.join(root, "parts")
    os.makedirs(parts, exist_ok=True)
    lines = []
    for item in manifest["files"]:
        if item["call"] != call:
            continue
        src = os.path.join(SEND_DIR, f"call{call}", item["name"])
        dst = os.path.join(parts, item["name"])
        if not (os.path.exists(dst) and os.path.getsize(dst) == item["bytes"] and sha256(dst) == item["sha256"]):
            shutil.copyfile(src, dst + ".tmp")
            if sha256(dst + ".tmp") != item["sha256"]:
                raise SystemExit(f"device_check: {item['name']} does not match its sha256 (a broken transfer)")
            os.replace(dst + ".tmp", dst)
        lines.append(f"{item['name']} ({item['bytes'] / 2**20:.2f} MiB, sha256 ok)")
    return lines


def assemble(manifest, root):
    """Rebuild each split payload (parts → .xz → wheel) in ``root/wheels``; ``(lines, missing)``:
    what was rebuilt and the payloads whose parts are not all on this machine."""
    parts, wheels = os.path.join(root, "parts"), os.path.join(root, "wheels")
    os.makedirs(wheels, exist_ok=True)
    lines, missing = [], []
    for name, p in manifest["payloads"].items():
        target = os.path.join(wheels, p["wheel"])
        if os.path.exists(target) and sha256(target) == p["wheel_sha256"]:
            lines.append(f"{p['wheel']}: already rebuilt")
            continue
        absent = [q["name"] for q in p["parts"] if not os.path.exists(os.path.join(parts, q["name"]))]
        if absent:
            missing.append(name)
            lines.append(f"{name}: parts {', '.join(absent)} are not on this machine (sent by call(s) "
                         f"{', '.join(str(q['call']) for q in p['parts'] if q['name'] in absent)}; the machine "
                         f"went cold between the calls?): it is left out")
            continue
        dec = lzma.LZMADecompressor()
        h = hashlib.sha256()
        with open(target + ".tmp", "wb") as out:
            for q in p["parts"]:
                with open(os.path.join(parts, q["name"]), "rb") as f:
                    for block in iter(lambda f=f: f.read(1 << 22), b""):
                        data = dec.decompress(block)
                        h.update(data)
                        out.write(data)
        if h.hexdigest() != p["wheel_sha256"]:
            missing.append(name)
            lines.append(f"{name}: the rebuilt wheel does not match its sha256: it is left out")
            os.remove(target + ".tmp")
            continue
        os.replace(target + ".tmp", target)
        lines.append(f"{p['wheel']}: rebuilt from {len(p['parts'])} parts ({os.path.getsize(target) / 2**20:.1f} MiB, "
                     f"sha256 ok)")
    for item in manifest["files"]:
        if item["kind"] == "wheel":
            src = os.path.join(parts, item["name"])
            if os.path.exists(src):
                shutil.copyfile(src, os.path.join(wheels, item["name"]))
    return lines, missing


def image_site_dirs():
    """The image Python's own package folders (a venv made from a venv does not see them)."""
    import site
    dirs = list(site.getsitepackages())
    if site.ENABLE_USER_SITE and os.path.isdir(site.getusersitepackages()):
        dirs.append(site.getusersitepackages())
    return [d for d in dirs if os.path.isdir(d)]


def install(manifest, root, missing):
    """A venv in ``root/venv`` that sees the image's packages, the carried wheels in it
    (``pip install --no-index``); ``(venv python, lines)``."""
    venv = os.path.join(root, "venv")
    vpy = os.path.join(venv, "bin", "python")
    ready = os.path.join(venv, "gfgpu-ready.json")
    wanted = [r for r in manifest["requirements"] if r["payload"] not in missing]
    if os.path.exists(ready):
        with open(ready, encoding="utf-8") as f:
            if json.load(f) == wanted:
                return vpy, [f"venv {venv}: already installed"]
    lines = []
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", "--clear", venv],
                   check=True)
    site_dir = subprocess.run([vpy, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                              check=True, capture_output=True, text=True).stdout.strip()
    with open(os.path.join(site_dir, "_gfgpu_image_site.pth"), "w", encoding="utf-8") as f:
        for d in image_site_dirs():
            f.write(f"import site; site.addsitedir({d!r})\n")
    links = [os.path.join(root, "wheels")] + [d for d in os.environ.get("GFGPU_DEVICE_FIND_LINKS", "").split(os.pathsep)
                                              if d]
    cmd = [sys.executable, "-m", "pip", "install", "--isolated", "--no-index", "--no-deps", "--no-compile",
           "--no-cache-dir", "--disable-pip-version-check", "--upgrade", "--target", site_dir]
    for d in links:
        cmd += ["--find-links", d]
    cmd += [r["spec"] for r in wanted]
    lines.append("$ " + " ".join(cmd))
    res = subprocess.run(cmd, capture_output=True, text=True)
    lines.append((res.stdout + res.stderr).strip()[-3000:])
    if res.returncode:
        raise RuntimeError("pip install failed:\n" + "\n".join(lines))
    probe = ("import importlib, json, sys; out = {}\n"
             "for m in sys.argv[1:]:\n"
             "    try:\n        mod = importlib.import_module(m)\n"
             "        out[m] = [getattr(mod, '__version__', '?'), mod.__file__]\n"
             "    except Exception as exc:\n        out[m] = ['failed', f'{type(exc).__name__}: {exc}']\n"
             "print(json.dumps(out))")
    res = subprocess.run([vpy, "-c", probe, *[r["import"] for r in wanted], "numpy", "scipy", "pytest"],
                         capture_output=True, text=True)
    lines.append(f"imports in the venv: {res.stdout.strip() or res.stderr.strip()[-2000:]}")
    if res.returncode or '"failed"' in res.stdout:
        raise RuntimeError("the venv does not import its packages:\n" + "\n".join(lines))
    with open(ready, "w", encoding="utf-8") as f:
        json.dump(wanted, f)
    return vpy, lines


def device_call(call, out, budget):
    """One ``run`` call of the plan, on the device machine: ``budget`` seconds in all."""
    t0 = time.monotonic()
    manifest = load_manifest(call)
    root = device_root()
    os.makedirs(root, exist_ok=True)
    last = call == manifest["calls"]
    cpu = os.environ.get("GFGPU_DEVICE_CPU") == "1"      # the rehearsal: CPU devices
    log(f"call {call} of {manifest['calls']} ({'CPU rehearsal' if cpu else 'device'}); root {root}; OUT {out}")
    records = []
    try:
        lines = receive(call, manifest, root)
        status = "ok"
    except SystemExit as exc:
        lines, status = [str(exc)], "failed"
    records.append({"name": f"receive-{call}", "title": f"call {call}: receive", "command": "", "status": status,
                    "seconds": round(time.monotonic() - t0, 1),
                    "timeout": RECEIVE_TIMEOUT["last" if last else "first"], "returncode": None,
                    "output": "\n".join(lines)})
    log(f"received: {'; '.join(lines)}")
    preamble_path = os.path.join(root, "preamble.json")
    earlier = []
    if os.path.exists(preamble_path):
        with open(preamble_path, encoding="utf-8") as f:
            earlier = json.load(f)

    def merged(*new):
        """The earlier calls' records, each replaced by this call's record of the same name."""
        names = {r["name"] for group in new for r in group}
        return [r for r in earlier if r["name"] not in names] + [r for group in new for r in group]
    if not last:
        work = os.path.join(root, f"call{call}")
        runner = Runner(out, work, budget - (time.monotonic() - t0), echo=False)
        meta = {"mode": f"call {call} of {manifest['calls']}: receive + system", "notes": [],
                "date": datetime.datetime.now().isoformat(timespec="seconds"), "host": platform.node(),
                "cores": os.cpu_count(), "python": platform.python_version(),
                "command": " ".join(["python3", *sys.argv]), "verdict": "parts received"}
        runner.flush = lambda: write_report(out, work, dict(meta, total_s=time.monotonic() - t0),
                                            merged(records, runner.stages))
        if not any(r["name"] == "system" for r in earlier):
            system_stage(runner, sys.executable, cpu)
        with open(preamble_path, "w", encoding="utf-8") as f:
            json.dump(merged(records, runner.stages), f, default=str)
        runner.flush()
        log(f"call {call} done in {time.monotonic() - t0:.1f} s: send call {call + 1} now (the machine stays "
            "warm 30 s, and the parts with it)")
        return 0 if status == "ok" else 1
    # the last call: reassemble, install, run the check
    t1 = time.monotonic()
    try:
        lines, missing = assemble(manifest, root)
        cache_dir = os.path.join(root, "warp-cache")
        for cache in (i for i in manifest["files"] if i["kind"] == "warp-cache" and "warp" not in missing):
            with tarfile.open(os.path.join(root, "parts", cache["name"])) as tar:
                if hasattr(tarfile, "data_filter"):
                    tar.extractall(cache_dir, filter="data")
                else:  # pragma: no cover - Python before 3.11.4
                    tar.extractall(cache_dir)
            lines.append(f"Warp kernel cache: {cache['name']} unpacked in {cache_dir}")
        vpy, more = install(manifest, root, missing)
        lines += more
        status = "ok"
    except Exception as exc:          # report it: the check cannot run without its packages
        lines, missing, vpy, status = [f"{type(exc).__name__}: {exc}"], ["all"], None, "failed"
    records.append({"name": "install", "title": "reassemble + install (pip --no-index)", "command": "",
                    "status": status, "seconds": round(time.monotonic() - t1, 1),
                    "timeout": RECEIVE_TIMEOUT["last"], "returncode": None, "output": "\n".join(lines),
                    "note": ("WITHOUT " + ", ".join(missing)) if missing else ""})
    log(f"install: {status}" + (f"; left out: {', '.join(missing)}" if missing else ""))
    with open(preamble_path, "w", encoding="utf-8") as f:
        json.dump(merged(records), f, default=str)
    if vpy is None:
        work = os.path.join(root, "work")
        os.makedirs(os.path.join(work, "logs"), exist_ok=True)
        now = datetime.datetime.now().isoformat(timespec="seconds")
        write_report(out, work, {"mode": "install failed", "date": now,
                                 "host": platform.node(), "cores": os.cpu_count(), "python": platform.python_version(),
                                 "command": " ".join(sys.argv), "verdict": "install failed", "notes": [],
                                 "total_s": time.monotonic() - t0}, merged(records))
        return 1
    budget -= time.monotonic() - t0
    env = dict(os.environ, WARP_CACHE_PATH=os.path.join(root, "warp-cache"), PYTHONPATH=ROOT,
               PYTHONUNBUFFERED="1")
    cmd = [vpy, os.path.abspath(__file__), out, "--work", os.path.join(root, "work"), "--resume",
           "--preamble", preamble_path, "--budget", f"{budget:.0f}", "--quiet"] + (["--cpu"] if cpu else [])
    log(f"check: {' '.join(cmd)}")
    return subprocess.run(cmd, env=env).returncode


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if {"--plan", "--rehearse", "--dry"} & set(argv):
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import device_plan
        return device_plan.main(argv)
    if argv[:1] == ["--device-call"]:
        ap = argparse.ArgumentParser(prog="device_check.py --device-call",
                                     description="one run call of the plan, on the device machine")
        ap.add_argument("call", type=int, help="the call's number in the plan")
        ap.add_argument("outdir", help="$OUT: what comes back")
        ap.add_argument("--budget", type=float, required=True, help="seconds for this call (its timeout less a margin)")
        args = ap.parse_args(argv[1:])
        return device_call(args.call, os.path.abspath(args.outdir), args.budget)
    return check(argv)


if __name__ == "__main__":
    sys.exit(main())
