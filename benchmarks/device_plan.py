"""The device check's plan: what travels to the lent GPU machine, in which calls, within which budget.

Run through benchmarks/device_check.py (``--plan``, ``--plan --dry``, ``--rehearse``); this
machine builds everything under ``.device/`` (ignored by git):

* ``.device/wheels``: ``pip download --python-version 3.12 --only-binary=:all: --platform
  manylinux_2_28_x86_64 ...`` of what the device image lacks for the check (:data:`CARRIED`:
  warp-lang, pyopencl and its dependencies pytools, platformdirs, siphash24, and dask with partd
  and locket, since tests/backends/test_fused.py imports gfgpu.dask; the image has numpy,
  typing_extensions and dask's other dependencies; plyfile, distributed and import-linter are
  not needed: nothing in the check imports them);
* ``.device/build``: warp-lang's wheel rewritten without what a CUDA run never loads
  (:data:`SLIM_DROP`: ``warp/bin/warp-clang.so``, the CPU compiler, and Warp's own tests and
  examples), its members stored uncompressed so that xz packs it (149 MB → about 80 MiB), and
  Warp's kernel cache of every gfgpu Warp module for sm_90 (CUBIN and PTX, built here by NVRTC
  with ``wp.compile_aot_module``: no GPU needed), packed;
* ``.device/send/callN``: one folder per ``run`` call (its ``carry``), the xz stream cut into
  parts so that each call, working tree included, stays within :data:`CALL_LIMIT_MIB`;
  the last call holds the small wheels and the kernel cache too (it can run alone, without Warp);
* ``.device/rehearse``: what the rehearsal adds for this machine (cp311 builds of pyopencl and
  siphash24; stand-ins for image packages the local Python lacks; PoCL as the OpenCL driver).

The budget figures are checked every time a plan is printed; ``--plan --dry`` computes them
from the files when present, else from :data:`RECORDED` (the sizes of the last build here).
"""

from __future__ import annotations

import glob
import importlib.metadata as md
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import time
import zipfile

import device_check as dc

ROOT = dc.ROOT
DEVICE = os.path.join(ROOT, ".device")
WHEELS = os.path.join(DEVICE, "wheels")
BUILD = os.path.join(DEVICE, "build")
CACHE = os.path.join(DEVICE, "warp-cache")
SEND = dc.SEND_DIR
REHEARSE = os.path.join(DEVICE, "rehearse")

MIB = 2**20
#: limits of the device tool (/work/.library/device/README.md) and of the issue
CALL_LIMIT_MIB = 60            # per call, working tree included (the tool's own limit is 64 MiB)
COMMAND_LIMIT = 2000           # characters per command
STAGE_SUM_LIMIT = 540          # seconds: every stage timeout of every call together
RESULT_FILES_LIMIT = 8         # files back from $OUT per call
DEVICE_TIME_LIMIT = 900        # seconds of device time for every try together
#: what the budget assumes (not measured here: the tool says "a minute or more" for a start)
START_S = 120                  # a machine's start, transfers of the first call not included
TRANSFER_S = 20                # sending one call (≤ 60 MiB) and taking its results back
GAP_S = 30                     # between calls: the machine stays warm 30 s, the parts with it

DEVICE_PYTHON = "3.12"
PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64")
#: (distribution, import name, version when this interpreter has none installed) the image lacks
#: dask (with partd and locket): tests/backends/test_fused.py imports every gfgpu module, gfgpu.dask too
CARRIED = (("warp-lang", "warp", "1.19.0"), ("pyopencl", "pyopencl", "2026.1.4"), ("pytools", "pytools", "2026.1.1"),
           ("platformdirs", "platformdirs", "4.14.9"), ("siphash24", "siphash24", "1.9"), ("dask", "dask", "2026.8.0"),
           ("partd", "partd", "1.4.2"), ("locket", "locket", "1.0.0"))
#: the Python packages of the device image, as KINDS.md lists them (read 2026-11-17)
IMAGE = set("""absl-py accelerate aiofiles aiohappyeyeballs aiohttp aiosignal annotated-doc anyio attrs botorch build
certifi charset-normalizer chex click cloudpickle cmake colorama contourpy coverage cuda-bindings cuda-core
cuda-pathfinder cuda-toolkit cupy-cuda13x cycler cython diffrax e3nn einops equinox etils execnet filelock flatbuffers
flax fonttools formulaic frozenlist fsspec gpytorch grpcio h11 h5py hf-xet httpcore httpx huggingface-hub humanize
hypothesis idna imageio iniconfig interface-meta jax jax-cuda13-pjrt jax-cuda13-plugin jaxlib jaxtyping jinja2 joblib
kiwisolver lazy-loader lightning lightning-utilities linear-operator lineax llvmlite lxml markdown markdown-it-py
markupsafe matplotlib mdurl meson ml-dtypes mpi4py mpmath msgpack multidict multipledispatch mypy-extensions nanobind
narwhals networkx ninja numba numba-cuda numpy numpyro nvidia-cublas nvidia-cuda-cupti nvidia-cuda-nvrtc
nvidia-cuda-runtime nvidia-cudnn-cu13 nvidia-cufft nvidia-cufile nvidia-curand nvidia-cusolver nvidia-cusparse
nvidia-cusparselt-cu13 nvidia-ml-py nvidia-nccl-cu13 nvidia-nvjitlink nvidia-nvshmem-cu13 nvidia-nvtx onnx onnx-ir
onnxruntime onnxscript opencv-python-headless optax opt-einsum opt-einsum-fx optimistix orbax-checkpoint packaging
pandas pathspec patsy peft pillow pip pluggy portalocker prometheus-client propcache protobuf psutil pyarrow pybind11
py-cpuinfo pygments pyparsing pyproject-hooks pyre-extensions pytest pytest-benchmark pytest-cov pytest-mock
pytest-timeout pytest-xdist python-dateutil pytorch-lightning pyyaml regex requests rich sacrebleu safetensors
scikit-build-core scikit-image scikit-learn scipy seaborn sentencepiece sentence-transformers setuptools shellingham
simplejson six sortedcontainers statsmodels sympy tabulate tensorboard tensorboard-data-server tensorstore
threadpoolctl tifffile tiktoken timm tokenizers toolz torch torchaudio torchdiffeq torch-geometric torchmetrics
torchvision tqdm transformers treescope triton typer typing-extensions typing-inspect urllib3 uvloop wadler-lindig
werkzeug wheel wrapt xarray xxhash yarl zipp""".split())
#: warp-lang members a CUDA run never loads: the CPU compiler (LLVM/Clang) and Warp's tests
SLIM_DROP = ("warp/bin/warp-clang.so", "warp/tests/", "warp/examples/")
#: the rehearsal's stand-ins for image packages its base Python lacks, and PoCL for a CPU OpenCL
STAND_INS = (("scikit-image", "0.26.0"), ("imageio", "2.38.2"), ("tifffile", "2026.3.3"), ("tqdm", "4.70.1"),
             ("threadpoolctl", "3.8.0"), ("pillow", "13.0.0"), ("lazy-loader", "0.6"),
             ("opencv-python-headless", None), ("toolz", "1.2.0"), ("fsspec", "2026.9.0"), ("cloudpickle", "3.1.3"),
             ("importlib-metadata", "10.2.0"), ("lazy-importer", "0.1.0"), ("zipp", "4.1.2"),
             ("pocl-binary-distribution", "3.0"))
REHEARSE_COMPILED = ("pyopencl", "siphash24")   # the carried wheels built per Python version

#: sizes of the last ``--plan`` here (bytes), for ``--plan --dry`` where .device/ is absent (CI)
RECORDED = {
    "warp_lang-1.19.0-py3-none-manylinux_2_28_x86_64.whl": 149277474,
    "warp.whl.xz": 82511800,
    "pyopencl-2026.1.4-cp312-cp312-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl": 759116,
    "pytools-2026.1.1-py3-none-any.whl": 99212,
    "platformdirs-4.14.9-py3-none-any.whl": 94272,
    "siphash24-1.9-cp312-cp312-manylinux2014_x86_64.manylinux_2_17_x86_64.manylinux_2_28_x86_64.whl": 102370,
    "dask-2026.8.0-py3-none-any.whl": 1492182,
    "partd-1.4.2-py3-none-any.whl": 18905,
    "locket-1.0.0-py2.py3-none-any.whl": 4398,
    "warp-cache.tar.xz": 325076,
}


def mib(n):
    return n / MIB


def sha256(path):
    return dc.sha256(path)


def installed_version(dist, default):
    try:
        return md.version(dist)
    except md.PackageNotFoundError:
        return default


def requirements():
    """``[{spec, import, payload, dist, version}]`` of the carried packages, at this machine's
    versions (the ones the test suite ran with here)."""
    return [{"dist": d, "import": i, "version": installed_version(d, v), "payload": i,
             "spec": f"{d}=={installed_version(d, v)}"} for d, i, v in CARRIED]


# ---- the working tree that travels with every call -----------------------------------------------
def tree_bytes(root=ROOT):
    """``(bytes, files)`` of what the tool sends: tracked and untracked-not-ignored files (and shared/)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=root,
                             capture_output=True, check=True).stdout
        names = [n for n in out.decode("utf-8", "surrogateescape").split("\0") if n]
    except (OSError, subprocess.CalledProcessError):      # no git: every file but the usual ignored ones
        names = []
        for base, dirs, files in os.walk(root):
            dirs[:] = [d for d in dirs if d not in (".git", ".venv", ".device", "__pycache__", "build", "dist")
                       and not d.endswith(".egg-info")]
            names += [os.path.relpath(os.path.join(base, f), root) for f in files]
    shared = os.path.join(root, "shared")
    if os.path.isdir(shared):
        names += [os.path.relpath(os.path.join(b, f), root) for b, _, fs in os.walk(shared) for f in fs]
    total = 0
    for name in set(names):
        try:
            total += os.lstat(os.path.join(root, name)).st_size
        except OSError:
            pass            # deleted in the working tree, still in the index
    return total, len(set(names))


# ---- building ------------------------------------------------------------------------------------
def pip_download(dest, specs, python_version, platforms=PLATFORMS, deps=False):
    os.makedirs(dest, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "-q", "--only-binary=:all:",
           "--python-version", python_version, "--implementation", "cp", "-d", dest]
    for p in platforms:
        cmd += ["--platform", p]
    if not deps:
        cmd.append("--no-deps")
    print(f"$ {' '.join(cmd)} {' '.join(specs)}", flush=True)
    subprocess.run(cmd + list(specs), check=True)


def wheel_for(folder, dist, version):
    def key(name):
        return re.sub(r"[-_.]+", "_", name).lower()
    found = sorted(f for f in (os.listdir(folder) if os.path.isdir(folder) else []) if f.endswith(".whl")
                   and key(f.split("-")[0]) == key(dist) and f.split("-")[1] == version)
    return os.path.join(folder, found[0]) if found else None


def slim_wheel(src, dst):
    """warp-lang's wheel without :data:`SLIM_DROP`, members stored (xz compresses it); RECORD
    lists what is left.  Deterministic: same input, same bytes."""
    dropped = 0
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst + ".tmp", "w", zipfile.ZIP_STORED) as zout:
        keep = [i for i in zin.infolist() if not i.filename.startswith(SLIM_DROP)]
        dropped = sum(i.file_size for i in zin.infolist()) - sum(i.file_size for i in keep)
        for info in keep:
            data = zin.read(info)
            if info.filename.endswith(".dist-info/RECORD"):
                lines = data.decode().splitlines()
                kept = [line for line in lines if not line.split(",")[0].startswith(SLIM_DROP)]
                data = ("\n".join(kept) + "\n").encode()
            out = zipfile.ZipInfo(info.filename, info.date_time)
            out.external_attr, out.compress_type = info.external_attr, zipfile.ZIP_STORED
            zout.writestr(out, data)
    os.replace(dst + ".tmp", dst)
    return dropped


def xz(src, dst):
    """xz of ``src`` (the xz program, both cores, else Python's lzma: either one decodes with lzma)."""
    exe = shutil.which("xz")
    if exe:
        with open(dst + ".tmp", "wb") as out:
            subprocess.run(["nice", "-n", "10", exe, "-6", "-T2", "-c", src] if shutil.which("nice")
                           else [exe, "-6", "-T2", "-c", src], stdout=out, check=True)
    else:
        import lzma
        with open(src, "rb") as f, lzma.open(dst + ".tmp", "wb", preset=6) as out:
            shutil.copyfileobj(f, out, 1 << 22)
    os.replace(dst + ".tmp", dst)


AOT = r"""
import importlib, json, sys, time
import warp as wp
wp.config.quiet = True
wp.init()
arch = int(sys.argv[1])
for name in sys.argv[2:]:
    importlib.import_module(name)
    mod = wp.get_module(name)
    ident = mod.get_module_identifier()
    t = time.perf_counter()
    paths = []
    for ptx in (False, True):
        paths += [str(p) for p in wp.compile_aot_module(mod, arch=arch, use_ptx=ptx)]
    print("AOT " + json.dumps({"module": name, "identifier": ident, "seconds": round(time.perf_counter() - t, 1),
                               "paths": paths}), flush=True)
"""


def warp_version():
    return installed_version("warp-lang", dict((d, v) for d, _, v in CARRIED)["warp-lang"])


def build_kernel_cache(python=sys.executable):
    """Warp's kernel cache for sm_90 (CUBIN and PTX) of every gfgpu Warp module, built here by
    NVRTC (no GPU needed) into .device/warp-cache; ``[{module, identifier, seconds}]``."""
    modules = dc.warp_kernel_modules()
    env = dict(os.environ, WARP_CACHE_PATH=CACHE, PYTHONPATH=ROOT)
    res = subprocess.run([python, "-c", AOT, str(dc.CUDA_ARCH), *modules], env=env, cwd=ROOT,
                         capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError(f"Warp's ahead-of-time build failed:\n{res.stdout[-3000:]}\n{res.stderr[-3000:]}")
    return dc.marked_json(res.stdout, "AOT")


def pack_kernel_cache(built, dst):
    """tar.xz of the current modules' .cubin, .ptx and .meta (stale modules left out)."""
    version = warp_version()
    with tarfile.open(dst + ".tmp", "w:xz") as tar:
        for m in built:
            folder = os.path.join(CACHE, version, m["identifier"])
            for path in sorted(glob.glob(os.path.join(folder, "*"))):
                if path.endswith((".cubin", ".ptx", ".meta")):
                    info = tar.gettarinfo(path, arcname=os.path.relpath(path, CACHE))
                    info.mtime, info.uid, info.gid, info.uname, info.gname = 0, 0, 0, "", ""
                    with open(path, "rb") as f:
                        tar.addfile(info, f)
    os.replace(dst + ".tmp", dst)


def build(log=print):
    """Everything under .device/ the plan sends and the rehearsal uses; returns the build record."""
    t0 = time.monotonic()
    reqs = requirements()
    pip_download(WHEELS, [r["spec"] for r in reqs], DEVICE_PYTHON)
    os.makedirs(BUILD, exist_ok=True)
    warp = next(r for r in reqs if r["import"] == "warp")
    src = wheel_for(WHEELS, warp["dist"], warp["version"])
    stamp_path = os.path.join(BUILD, "slim.json")
    stamp = {"source": os.path.basename(src), "source_sha256": sha256(src), "drop": list(SLIM_DROP)}
    slim = os.path.join(BUILD, "slim", os.path.basename(src))
    packed = os.path.join(BUILD, "warp.whl.xz")
    old = json.load(open(stamp_path)) if os.path.exists(stamp_path) else None
    if not (old and {k: old.get(k) for k in stamp} == stamp and os.path.exists(packed) and os.path.exists(slim)):
        os.makedirs(os.path.dirname(slim), exist_ok=True)
        log(f"slimming {os.path.basename(src)} (without {', '.join(SLIM_DROP)}), members stored ...")
        stamp["dropped_bytes"] = slim_wheel(src, slim)
        stamp["slim_sha256"] = sha256(slim)
        log(f"xz of the slim wheel ({mib(os.path.getsize(slim)):.0f} MiB; a few minutes on two cores) ...")
        xz(slim, packed)
        stamp["xz_sha256"] = sha256(packed)
        with open(stamp_path, "w") as f:
            json.dump(stamp, f, indent=1)
    else:
        stamp = old
    log("Warp's kernel cache for sm_90 (NVRTC here, no GPU) ...")
    built = build_kernel_cache()
    pack_kernel_cache(built, os.path.join(BUILD, "warp-cache.tar.xz"))
    for m in built:
        log(f"  {m['module']}: {m['identifier']} ({m['seconds']:.1f} s)")
    log("the rehearsal's wheels for this machine's Python ...")
    vi = f"{sys.version_info.major}.{sys.version_info.minor}"
    rehearse_wheels = os.path.join(REHEARSE, f"wheels-cp{vi.replace('.', '')}")
    pip_download(rehearse_wheels, [r["spec"] for r in reqs if r["dist"] in REHEARSE_COMPILED]
                 + [f"{d}=={v}" if v else d for d, v in STAND_INS], vi)
    plan = layout(sizes_from_files(), tree_bytes()[0])
    write_send(plan, stamp, built)
    log(f"built in {time.monotonic() - t0:.0f} s")
    return plan


def normalize(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def unmet_requirements(wheels, python_version=DEVICE_PYTHON):
    """The requirements of ``wheels`` (their markers for Linux x86-64 and ``python_version``, no
    extras) that the plan does not carry and the image does not have; ``None`` without packaging."""
    try:
        from packaging.requirements import Requirement
    except ImportError:          # pragma: no cover - pip's own environment has it
        return None
    env = {"python_version": python_version, "python_full_version": python_version + ".0", "sys_platform": "linux",
           "platform_system": "Linux", "platform_machine": "x86_64", "os_name": "posix",
           "implementation_name": "cpython", "platform_python_implementation": "CPython", "extra": ""}
    have = {normalize(d) for d, _, _ in CARRIED} | {normalize(n) for n in IMAGE}
    unmet = []
    for path in wheels:
        with zipfile.ZipFile(path) as z:
            meta = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
            for line in z.read(meta).decode("utf-8", "replace").splitlines():
                if line.startswith("Requires-Dist:"):
                    req = Requirement(line.split(":", 1)[1].strip())
                    if (req.marker is None or req.marker.evaluate(env)) and normalize(req.name) not in have:
                        unmet.append(f"{os.path.basename(path).split('-')[0]} needs {req}")
    return unmet


# ---- the calls -------------------------------------------------------------------------------------
def small_wheels():
    reqs = [r for r in requirements() if r["import"] != "warp"]
    return [(r, wheel_for(WHEELS, r["dist"], r["version"])) for r in reqs]


def recorded_name(r):
    """The wheel name :data:`RECORDED` holds for requirement ``r``."""
    stem = f"{r['dist'].replace('-', '_')}-{r['version']}-"
    return next((k for k in RECORDED if k.startswith(stem)), stem + "(unknown).whl")


def sizes_from_files():
    """``{name: bytes}`` of what the plan sends, from .device/ where built, else :data:`RECORDED`
    (those names listed under the key ``"recorded"``)."""
    entries = [("warp.whl.xz", os.path.join(BUILD, "warp.whl.xz")),
               ("warp-cache.tar.xz", os.path.join(BUILD, "warp-cache.tar.xz"))]
    for r, path in small_wheels():
        entries.append((os.path.basename(path) if path else recorded_name(r), path))
    sizes, recorded = {}, []
    for name, path in entries:
        if path and os.path.exists(path):
            sizes[name] = os.path.getsize(path)
        else:
            sizes[name] = RECORDED.get(name, 0)
            recorded.append(name)
    sizes["recorded"] = recorded
    return sizes


def layout(sizes, tree, with_warp=True):
    """The calls: ``[{call, files: [(name, bytes, kind)], bytes}]``.  The small wheels and the
    kernel cache go with the last call (it can run alone); the xz stream of Warp's wheel is cut
    so that every call carries about the same (each within :data:`CALL_LIMIT_MIB` with the tree)."""
    reserve = 64 * 1024                     # the manifest in each call's folder
    cap = CALL_LIMIT_MIB * MIB - tree - reserve
    wholes = [(n, b, "wheel") for n, b in sizes.items() if isinstance(b, int) and n.endswith(".whl")]
    if with_warp:
        wholes.append(("warp-cache.tar.xz", sizes["warp-cache.tar.xz"], "warp-cache"))
    split = sizes["warp.whl.xz"] if with_warp else 0
    total = split + sum(b for _, b, _ in wholes)
    calls = max(1, -(-total // cap)) if cap > 0 else 0
    plan = {"tree": tree, "cap": cap, "calls": [], "with_warp": with_warp, "total": total}
    if not calls:
        return plan
    per = -(-total // calls)
    left = split
    for n in range(1, calls + 1):
        files = [] if n < calls else list(wholes)
        room = per - sum(b for _, b, _ in files) if n < calls else left
        take = min(left, max(room, 0))
        if take:
            files.insert(0, (f"warp.whl.xz.{n:03d}", take, "part"))
            left -= take
        plan["calls"].append({"call": n, "files": files, "bytes": tree + reserve + sum(b for _, b, _ in files)})
    return plan


def call_timeouts(calls):
    """``(timeouts, stage lists)``: each call's timeout and the stages whose timeouts make it up."""
    checks = sum(dc.STAGE_TIMEOUTS.values())
    out, stages = [], []
    for n in range(1, calls + 1):
        last = n == calls
        st = [("receive", dc.RECEIVE_TIMEOUT["last" if last else "first"])]
        if n == 1:
            st.append(("system", dc.SYSTEM_TIMEOUT))
        if last:
            st += list(dc.STAGE_TIMEOUTS.items())
        stages.append(st)
        out.append(sum(t for _, t in st) + dc.CALL_MARGIN)
    # the rerun: the last call again on the warm machine (receive and install find their work done)
    rerun = [("receive", dc.RECEIVE_TIMEOUT["first"])] + list(dc.STAGE_TIMEOUTS.items())
    stages.append(rerun)
    out.append(sum(t for _, t in rerun) + dc.CALL_MARGIN)
    assert checks == sum(t for n, t in rerun[1:])
    return out, stages


def command(call, timeout):
    return (f'PYTHONUNBUFFERED=1 python3 benchmarks/device_check.py --device-call {call} "$OUT" '
            f"--budget {timeout - dc.CALL_MARGIN // 2}")


def runs(plan):
    """The ``run`` calls: ``[{label, command, carry, timeout_s, bytes, stages}]``, the rerun last."""
    n = len(plan["calls"])
    timeouts, stages = call_timeouts(n)
    out = []
    for c, t, st in zip(plan["calls"], timeouts, stages):
        out.append({"label": f"call {c['call']} of {n}", "call": c["call"], "command": command(c["call"], t),
                    "carry": [f".device/send/call{c['call']}"], "timeout_s": t, "bytes": c["bytes"], "stages": st,
                    "files": c["files"]})
    last = plan["calls"][-1]
    out.append({"label": "rerun (only if needed: the last call again, within 30 s)", "call": last["call"],
                "command": command(last["call"], timeouts[-1]), "carry": [f".device/send/call{last['call']}"],
                "timeout_s": timeouts[-1], "bytes": last["bytes"], "stages": stages[-1], "files": last["files"],
                "rerun": True})
    return out


def device_time(calls):
    """Worst-case device seconds of the calls (every timeout spent), a start and the gaps included."""
    return START_S + sum(TRANSFER_S + c["timeout_s"] for c in calls) + GAP_S * (len(calls) - 1)


def check_budget(calls):
    """``[(what, limit, figures, ok)]`` for every limit of the plan."""
    firsts = [c for c in calls if not c.get("rerun")]
    stage_sum = sum(t for c in firsts for _, t in c["stages"])
    rows = [
        ("MiB per call, working tree included", f"≤ {CALL_LIMIT_MIB}",
         ", ".join(f"{mib(c['bytes']):.1f}" for c in firsts), all(c["bytes"] <= CALL_LIMIT_MIB * MIB for c in calls)),
        ("characters per command", f"≤ {COMMAND_LIMIT}", ", ".join(str(len(c["command"])) for c in calls),
         all(len(c["command"]) <= COMMAND_LIMIT for c in calls)),
        ("stage timeouts of the calls, s", f"≤ {STAGE_SUM_LIMIT}", f"{stage_sum}", stage_sum <= STAGE_SUM_LIMIT),
        ("stages within each call's timeout, s", "sum + margin ≤ timeout",
         ", ".join(f"{sum(t for _, t in c['stages'])}+{dc.CALL_MARGIN}≤{c['timeout_s']}" for c in calls),
         all(sum(t for _, t in c["stages"]) + dc.CALL_MARGIN <= c["timeout_s"] for c in calls)),
        ("each command's timeout, s", "≤ 600", ", ".join(str(c["timeout_s"]) for c in calls),
         all(c["timeout_s"] <= 600 for c in calls)),
        ("result files per call", f"≤ {RESULT_FILES_LIMIT}", f"{len(dc.RESULT_FILES)} ({', '.join(dc.RESULT_FILES)})",
         len(dc.RESULT_FILES) <= RESULT_FILES_LIMIT),
        ("carried paths per call", "≤ 8", ", ".join(str(len(c["carry"])) for c in calls),
         all(len(c["carry"]) <= 8 for c in calls)),
        ("device time, worst case, rerun included, s", f"≤ {DEVICE_TIME_LIMIT}", f"{device_time(calls)}",
         device_time(calls) <= DEVICE_TIME_LIMIT),
    ]
    return rows


def write_send(plan, stamp, built):
    """The call folders .device/send/callN: the parts, the small wheels, the kernel cache, the manifest."""
    if os.path.isdir(SEND):
        shutil.rmtree(SEND)
    reqs = requirements()
    packed = os.path.join(BUILD, "warp.whl.xz")
    files, parts = [], []
    offset = 0
    with open(packed, "rb") as src:
        for c in plan["calls"]:
            folder = os.path.join(SEND, f"call{c['call']}")
            os.makedirs(folder)
            for name, size, kind in c["files"]:
                path = os.path.join(folder, name)
                if kind == "part":
                    with open(path, "wb") as out:
                        out.write(src.read(size))
                    offset += size
                    parts.append({"name": name, "call": c["call"]})
                elif kind == "wheel":
                    shutil.copyfile(os.path.join(WHEELS, name), path)
                else:
                    shutil.copyfile(os.path.join(BUILD, name), path)
                files.append({"name": name, "call": c["call"], "kind": kind, "bytes": os.path.getsize(path),
                              "sha256": sha256(path)})
        assert not src.read(1), "the xz stream was not sent whole"
    warp = next(r for r in reqs if r["import"] == "warp")
    manifest = {"calls": len(plan["calls"]), "python": DEVICE_PYTHON, "cuda_arch": dc.CUDA_ARCH,
                "payloads": {"warp": {"wheel": stamp["source"], "wheel_sha256": stamp["slim_sha256"],
                                      "xz_sha256": stamp["xz_sha256"], "parts": parts, "dropped": stamp["drop"]}},
                "files": files, "requirements": reqs, "warp_modules": {m["module"]: m["identifier"] for m in built},
                "warp_version": warp["version"]}
    for c in plan["calls"]:
        with open(os.path.join(SEND, f"call{c['call']}", "manifest.json"), "w") as f:
            json.dump(manifest, f, indent=1)


def sent_plan():
    """The plan as .device/send holds it (``None`` where it was not built)."""
    path = os.path.join(SEND, "call1", "manifest.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        manifest = json.load(f)
    tree = tree_bytes()[0]
    calls = []
    for n in range(1, manifest["calls"] + 1):
        folder = os.path.join(SEND, f"call{n}")
        files = [(i["name"], i["bytes"], i["kind"]) for i in manifest["files"] if i["call"] == n]
        size = sum(os.path.getsize(p) for p in glob.glob(os.path.join(folder, "*")))
        calls.append({"call": n, "files": files, "bytes": tree + size})
    return {"tree": tree, "calls": calls, "with_warp": True, "manifest": manifest}


def warp_wheel_bytes():
    r = next(r for r in requirements() if r["import"] == "warp")
    path = wheel_for(WHEELS, r["dist"], r["version"])
    return os.path.getsize(path) if path else RECORDED.get(recorded_name(r), 0)


# ---- printing -------------------------------------------------------------------------------------
def describe(plan, sizes, dry):
    calls = runs(plan)
    rows = check_budget(calls)
    tree, nfiles = tree_bytes()
    reqs = requirements()
    recorded = sizes.get("recorded", [])
    mark = lambda name: " (recorded size)" if name in recorded else ""
    out = ["# gfgpu device check: the plan (built here; nothing of it has run on a GPU)", "",
           f"Working tree with every call: {mib(tree):.2f} MiB ({nfiles} files: tracked + untracked-not-ignored, "
           "as the tool counts them)",
           "Carried (the image lacks them): " + ", ".join(r["spec"] for r in reqs),
           f"  warp-lang: the {mib(warp_wheel_bytes()):.1f} MiB wheel "
           f"less {', '.join(SLIM_DROP)}, stored, xz: {mib(sizes['warp.whl.xz']):.1f} MiB{mark('warp.whl.xz')}",
           f"  Warp's kernel cache for sm_{dc.CUDA_ARCH} (CUBIN + PTX, NVRTC here): "
           f"{', '.join(dc.warp_kernel_modules())}: {mib(sizes['warp-cache.tar.xz']):.2f} MiB"
           f"{mark('warp-cache.tar.xz')}",
           "  dask, partd, locket: tests/backends/test_fused.py imports every gfgpu module, gfgpu.dask too",
           "Not carried: what the image has (numpy, typing_extensions, click, cloudpickle, fsspec, pyyaml, toolz, "
           "...); plyfile, distributed, import-linter/grimp (nothing in the check imports them: tests/test_dask.py, "
           "test_batch.py, test_io.py and test_architecture.py are not in its selection)"]
    present = [w for _, w in [(None, wheel_for(WHEELS, r["dist"], r["version"])) for r in reqs] if w]
    unmet = unmet_requirements(present) if len(present) == len(reqs) else None
    closed = unmet is None or not unmet
    out.append("Dependencies of the carried wheels: " + (
        "not checked (no wheelhouse here: --plan builds it)" if unmet is None else
        "closed: each one is carried or in the image (KINDS.md's list)" if not unmet else
        "NOT CLOSED: " + "; ".join(unmet)))
    out.append("")
    if recorded:
        out.append(f"Sizes of {len(recorded)} files from the recorded manifest (RECORDED: no .device/ here): "
                   + ", ".join(recorded))
        out.append("")
    out.append(f"The run calls ({'sizes only: --dry' if dry else 'files in .device/send'}):")
    for c in calls:
        out += ["", f"{c['label']}: {mib(c['bytes']):.1f} MiB with the tree; stages "
                    + " + ".join(f"{n} {t}" for n, t in c["stages"]) + f" + margin {dc.CALL_MARGIN} s",
                "  files: " + ", ".join(f"{n} ({mib(b):.2f} MiB)" for n, b, _ in c["files"]),
                f"  run(command={json.dumps(c['command'])}, carry={json.dumps(c['carry'])}, "
                f"timeout_s={c['timeout_s']})"]
    out += ["", "On the device: call 1 copies its part to /root/gfgpu-device/parts and runs the system stage "
                "(nvidia-smi, OpenCL ICDs, image packages, the torch/CuPy copy bound); the next call must follow "
                "within 30 s (the machine stays warm 30 s; then /root is gone). The last call checks every part's "
                "sha256, rebuilds the wheel (lzma), unpacks the kernel cache, makes /root/gfgpu-device/venv "
                "(--system-site-packages, plus a .pth with the image Python's own site folders: that Python is "
                "itself a venv), pip install --isolated --no-index --no-deps --find-links, then the staged check "
                "(WARP_CACHE_PATH=the carried cache). If call 1's part is missing (the machine went cold), the "
                "last call runs the check without Warp.", ""]
    out += ["Budget:", "", "| limit | allowed | this plan | |", "|---|---|---|---|"]
    out += [f"| {what} | {lim} | {fig} | {'ok' if ok else 'OVER'} |" for what, lim, fig, ok in rows]
    out += ["", f"Device time, worst case: start {START_S} s (assumed: 'a minute or more') + "
                + " + ".join(f"({TRANSFER_S} transfer + {c['timeout_s']})" for c in calls)
                + f" + {GAP_S} s × {len(calls) - 1} gaps = {device_time(calls)} s of {DEVICE_TIME_LIMIT}; "
                  f"without the rerun {device_time(calls[:-1])} s."]
    alone = layout(sizes, tree, with_warp=False)
    alone_calls = runs(alone)
    out += [f"Decision: Warp travels ({len(plan['calls'])} calls, {device_time(calls)} s worst case with a rerun); "
            f"without Warp the check would take {len(alone['calls'])} call(s), {device_time(alone_calls)} s "
            "(OpenCL on NVIDIA's ICD if present, else numpy and the copy bound only)."
            if plan["with_warp"] else
            "Decision: Warp does NOT travel: its parts do not fit the budget; the check runs with OpenCL on "
            "NVIDIA's ICD if present, else numpy and the copy bound only."]
    return "\n".join(out), closed and all(ok for *_, ok in rows)


def plan_for(sizes, tree):
    plan = layout(sizes, tree)
    if not plan["calls"] or not all(ok for *_, ok in check_budget(runs(plan))):
        plan = layout(sizes, tree, with_warp=False)
    return plan


# ---- the rehearsal ---------------------------------------------------------------------------------
def base_python():
    """A Python of this machine with numpy, scipy and pytest but neither Warp nor PyOpenCL
    (the image's part of the rehearsal): $GFGPU_REHEARSE_PYTHON, else this venv's base."""
    probe = ("import importlib.util as u; import sys; "
             "sys.exit(0 if all(u.find_spec(m) for m in ('numpy', 'scipy', 'pytest')) and "
             "not any(u.find_spec(m) for m in ('warp', 'pyopencl', 'gfgpu')) else 1)")
    for cand in filter(None, [os.environ.get("GFGPU_REHEARSE_PYTHON"), getattr(sys, "_base_executable", None),
                              shutil.which("python3")]):
        if subprocess.run([cand, "-I", "-c", probe]).returncode == 0:
            return cand
    raise SystemExit("rehearse: no Python with numpy, scipy and pytest but without warp/pyopencl/gfgpu here "
                     "(set GFGPU_REHEARSE_PYTHON)")


def offline_prefix():
    """A command prefix that cuts the network off (a new network namespace), or [] with the reason."""
    exe = shutil.which("unshare")
    if exe and subprocess.run([exe, "-rn", "true"], capture_output=True).returncode == 0:
        return [exe, "-rn"], "network cut off: every call ran in a new network namespace (unshare -rn)"
    return [], "unshare -rn is not available here: the calls ran with pip --no-index --isolated only"


def image_python(base, wheels, prefix):
    """The rehearsal's image: a venv of ``base`` with the stand-ins (offline, from ``wheels``)."""
    image = os.path.join(REHEARSE, "image")
    py = os.path.join(image, "bin", "python3")
    specs = []
    for dist, version in STAND_INS:
        version = version or next((m.group(1) for m in [re.match(rf"{dist.replace('-', '_')}-([^-]+)-", f)
                                                        for f in sorted(os.listdir(wheels))] if m), None)
        specs.append(f"{dist}=={version}")
    stamp = os.path.join(image, "stand-ins.json")
    if os.path.exists(stamp) and json.load(open(stamp)) == specs and os.path.exists(py):
        return py, specs
    shutil.rmtree(image, ignore_errors=True)
    subprocess.run([base, "-m", "venv", "--system-site-packages", "--without-pip", image], check=True)
    site_dir = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"], check=True,
                              capture_output=True, text=True).stdout.strip()
    subprocess.run(prefix + [base, "-m", "pip", "install", "--isolated", "--no-index", "--no-deps", "--no-compile",
                             "-q", "--disable-pip-version-check", "--target", site_dir, "--find-links", wheels, *specs],
                   check=True)
    with open(stamp, "w") as f:
        json.dump(specs, f)
    return py, specs


def check_out(out):
    """Problems with what a call leaves in $OUT (what the tool would bring back)."""
    problems, files = [], []
    for base, _, names in os.walk(out):
        for name in names:
            rel = os.path.relpath(os.path.join(base, name), out)
            files.append(rel)
            if rel.count(os.sep) > 2:
                problems.append(f"{rel}: more than 2 folders down")
            if not re.fullmatch(r"[A-Za-z0-9._-]+", name):
                problems.append(f"{rel}: a name the tool does not bring back")
            if os.path.getsize(os.path.join(base, name)) > 16 * MIB:
                problems.append(f"{rel}: over 16 MiB")
    if len(files) > RESULT_FILES_LIMIT:
        problems.append(f"{len(files)} files (at most {RESULT_FILES_LIMIT} come back)")
    return files, problems


def rehearse(log=print):
    """The plan's calls here, offline, on the CPU devices; returns 0 when every check held."""
    t0 = time.monotonic()
    plan = sent_plan()
    if plan is None:
        raise SystemExit("rehearse: .device/send is not built: run `python benchmarks/device_check.py --plan` "
                         "first (it needs PyPI)")
    vi = f"{sys.version_info.major}.{sys.version_info.minor}"
    base = base_python()
    bv = subprocess.run([base, "-c", "import sys; print(f'{sys.version_info[0]}.{sys.version_info[1]}')"],
                        capture_output=True, text=True).stdout.strip()
    wheels = os.path.join(REHEARSE, f"wheels-cp{bv.replace('.', '')}")
    if not os.path.isdir(wheels):
        raise SystemExit(f"rehearse: {wheels} is missing: run --plan with Python {bv} (this one is {vi})")
    calls = runs(plan)
    failures = []
    rows = check_budget(calls)
    failures += [f"budget: {what}: {fig} (allowed {lim})" for what, lim, fig, ok in rows if not ok]
    prefix, net = offline_prefix()
    log(f"rehearsal: {net}; image = {base} + stand-ins")
    py, specs = image_python(base, wheels, prefix)
    run_dir = os.path.join(REHEARSE, "run")
    shutil.rmtree(run_dir, ignore_errors=True)
    bindir = os.path.join(run_dir, "bin")
    os.makedirs(bindir)
    with open(os.path.join(bindir, "python3"), "w") as f:     # not a link: a venv is found by its own path
        f.write(f'#!/bin/sh\nexec "{py}" "$@"\n')
    os.chmod(os.path.join(bindir, "python3"), 0o755)
    # PoCL, the OpenCL driver of the rehearsal, found by the ICD loader as the NVIDIA one would be
    pocl = glob.glob(os.path.join(os.path.dirname(os.path.dirname(py)), "lib", "python*",
                                  "site-packages", "pyopencl", ".libs", "libpocl*.so"))
    vendors = os.path.join(run_dir, "vendors")
    os.makedirs(vendors)
    if pocl:
        with open(os.path.join(vendors, "pocl.icd"), "w") as f:
            f.write(pocl[0] + "\n")
    else:
        failures.append("no PoCL library among the stand-ins: the rehearsal has no OpenCL device")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PIP_", "GFGPU_", "WARP_", "VIRTUAL_ENV",
                                                                      "PYTHON"))}
    env.update(PATH=bindir + os.pathsep + env.get("PATH", ""), GFGPU_DEVICE_ROOT=os.path.join(run_dir, "root"),
               GFGPU_DEVICE_FIND_LINKS=wheels, GFGPU_DEVICE_CPU="1", OCL_ICD_VENDORS=vendors)
    table = []
    # the plan's calls, the rerun, then the last call alone on a "cold machine" (call 1's part lost)
    cold = dict(calls[len(plan["calls"]) - 1], label="last call alone (a cold machine: call 1's part lost)",
                root=os.path.join(run_dir, "cold-root"))
    for i, c in enumerate(calls + [cold]):
        out = os.path.join(run_dir, f"out{i + 1}")
        os.makedirs(out)
        t = time.monotonic()
        try:
            res = subprocess.run(prefix + ["bash", "-c", c["command"]], cwd=ROOT,
                                 env=dict(env, OUT=out, GFGPU_DEVICE_ROOT=c.get("root", env["GFGPU_DEVICE_ROOT"])),
                                 capture_output=True, text=True, timeout=c["timeout_s"])
            rc, text = res.returncode, res.stdout + res.stderr
        except subprocess.TimeoutExpired as exc:
            rc, text = "timeout", (exc.stdout or b"").decode() + (exc.stderr or b"").decode()
        wall = time.monotonic() - t
        with open(os.path.join(run_dir, f"call{i + 1}.log"), "w") as f:
            f.write(text)
        files, problems = check_out(out)
        failures += [f"{c['label']}: {p}" for p in problems]
        report = {}
        if os.path.exists(os.path.join(out, "report.json")):
            report = json.load(open(os.path.join(out, "report.json")))
        stages = {s["name"]: s for s in report.get("stages", [])}
        bad = [f"{n} {s['status']}" for n, s in stages.items() if s["status"] != "ok"]
        if rc != 0:
            failures.append(f"{c['label']}: exit {rc} (log: {os.path.relpath(run_dir, ROOT)}/call{i + 1}.log)")
        if bad:
            failures.append(f"{c['label']}: stages not ok: {', '.join(bad)}")
        if not report:
            failures.append(f"{c['label']}: no report.json")
        table.append((c, rc, wall, files, stages))
        done = ", ".join(f"{n} {s['status']}" + (" (kept)" if s.get("resumed") else "") for n, s in stages.items())
        log(f"{c['label']}: exit {rc} in {wall:.1f} s (timeout {c['timeout_s']} s); {len(files)} result files; "
            f"stages: {done}")
    # what the last call must have shown
    last = table[len(plan["calls"]) - 1][4]
    info = last.get("devices", {}).get("info", {})
    where = info.get("where", {})
    for r in requirements():
        loc = where.get(r["dist"]) or ""
        if not loc.startswith(os.path.join(run_dir, "root", "venv")):
            failures.append(f"{r['dist']} does not come from the plan's venv (found at {loc or 'nowhere'})")
        if info.get("versions", {}).get(r["dist"]) != r["version"]:
            failures.append(f"{r['dist']}: version {info.get('versions', {}).get(r['dist'])}, the plan carries "
                            f"{r['version']}")
    cache = info.get("warp_cache", {})
    if set(cache) != set(dc.warp_kernel_modules()) or not all(v.get("cached") for v in cache.values()):
        failures.append(f"Warp's carried kernel cache does not hold every module for sm_{dc.CUDA_ARCH}: {cache}")
    if "install" in last and last["install"].get("note"):
        failures.append(f"the install left something out: {last['install']['note']}")
    rerun = table[len(plan["calls"])][4]
    again = [n for n, s in rerun.items() if n in dc.STAGE_TIMEOUTS and last.get(n, {}).get("status") == "ok"
             and not s.get("resumed")]
    kept = [n for n, s in rerun.items() if n in dc.STAGE_TIMEOUTS and last.get(n, {}).get("status") != "ok"
            and s.get("resumed")]
    if again or kept:
        failures.append(f"the rerun ran again what had passed ({', '.join(again) or 'nothing'}) or kept what had "
                        f"not ({', '.join(kept) or 'nothing'})")
    if len(table) > len(plan["calls"]) + 1:         # the last call alone on a cold machine
        cold = table[-1][4]
        note = cold.get("install", {}).get("note", "")
        if "WITHOUT warp" not in note or cold.get("system", {}).get("status") != "ok":
            failures.append(f"the last call alone did not run without Warp (install note {note!r})")
        if cold.get("devices", {}).get("info", {}).get("warp"):
            failures.append("the last call alone still found Warp")
    total = time.monotonic() - t0
    if total > 300:
        failures.append(f"the rehearsal took {total:.0f} s (at most 300)")
    log("")
    log("| call | MiB | command chars | timeout s | wall s | result files | stages |")
    log("|---|---:|---:|---:|---:|---|---|")
    for c, _, wall, files, stages in table:
        log(f"| {c['label']} | {mib(c['bytes']):.1f} | {len(c['command'])} | {c['timeout_s']} | {wall:.1f} | "
            f"{len(files)}: {', '.join(sorted(files))} | {sum(s['status'] == 'ok' for s in stages.values())}/"
            f"{len(stages)} ok |")
    log("")
    log(f"rehearsal {'PASSED' if not failures else 'FAILED'} in {total:.0f} s; {net}; stand-ins: {', '.join(specs)}; "
        f"reports in {os.path.relpath(run_dir, ROOT)}/out*")
    for f in failures:
        log(f"  FAIL: {f}")
    return 0 if not failures else 1


def main(argv):
    import argparse
    ap = argparse.ArgumentParser(prog="device_check.py", description="the device check's plan and rehearsal")
    ap.add_argument("--plan", action="store_true", help="build .device/ and print the run calls with their budget")
    ap.add_argument("--dry", action="store_true", help="with --plan: build nothing, download nothing")
    ap.add_argument("--rehearse", action="store_true", help="run the plan's calls here, offline, on the CPU devices")
    args = ap.parse_args(argv)
    if args.dry and not args.plan:
        ap.error("--dry goes with --plan")
    if args.plan == args.rehearse:
        ap.error("one of --plan or --rehearse")
    if args.rehearse:
        return rehearse()
    if not args.dry:
        build()
    sizes = sizes_from_files()
    tree = tree_bytes()[0]
    plan = (sent_plan() if not args.dry else None) or plan_for(sizes, tree)
    text, ok = describe(plan, sizes, args.dry)
    print(text)
    if not ok:
        print("\nTHE PLAN DOES NOT FIT ITS BUDGET (OVER above)")
    return 0 if ok else 1
