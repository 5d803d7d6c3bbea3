"""Whether a CPU device's OpenCL compiler survives 16-wide vectors, probed in a child process.

A compiler may build a trivial kernel and still abort the process at gfgpu's 16-wide vector
kernels: PyOpenCL's bundled PoCL 3.0 (LLVM 14) targets an AVX-512 AMD EPYC as ``znver3`` and
stops with "LLVM ERROR: Do not know how to scalarize this operator's operand!" (an abort no
``try`` catches) or drops the kernel.  So a child process probes, once per machine: the verdict
is kept under ``XDG_CACHE_HOME`` (or ``~/.cache``) ``/gfgpu/opencl-probe/``, keyed by platform,
device, compiler target and the CPU's flags.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import threading

__all__ = ["wide_vector_failure"]

_KERNEL = """__kernel void gfgpu_wide(__global float *a, __global int *b) {
    const int i = get_global_id(0); const float16 v = vload16(i, a);
    vstore16(fma(v, (float16)(2.0f), v * 0.5f), i, a); vstore16(vload16(i, b) + (int16)(1), i, b); }"""

# the child: build and run the kernel on (platform, device) by index, check its result (version 1)
_CHILD = """import sys, numpy as np, pyopencl as cl
dev = cl.get_platforms()[int(sys.argv[1])].get_devices()[int(sys.argv[2])]
assert dev.name.strip() == sys.argv[3], "device order changed"
print("compiling", flush=True)  # what fails after this line is the compiler's (a verdict to keep)
ctx = cl.Context([dev]); q = cl.CommandQueue(ctx); mf = cl.mem_flags
a, b = np.arange(32, dtype=np.float32), np.arange(32, dtype=np.int32)
da, db = (cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=x) for x in (a, b))
prg = cl.Program(ctx, sys.argv[4]).build()
if "gfgpu_wide" not in prg.get_info(cl.program_info.KERNEL_NAMES).split(";"):
    sys.exit("error: the compiler built the program without its 16-wide vector kernel")
prg.gfgpu_wide(q, (2,), None, da, db)
cl.enqueue_copy(q, a, da); cl.enqueue_copy(q, b, db); q.finish()
assert np.array_equal(a, np.arange(32) * 2.5) and np.array_equal(b, np.arange(1, 33)), "wrong result"
print("ok")"""


def _verdict_path(device):
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((line for line in f if line.startswith("flags")), "")
    except OSError:
        flags = ""
    p = device.platform
    key = "\n".join((_KERNEL, _CHILD, p.name, p.version, device.name, device.version, device.driver_version,
                     sys.executable, flags))
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(root, "gfgpu", "opencl-probe", hashlib.sha256(key.encode()).hexdigest()[:24])


_lock = threading.Lock()     # one probe at a time in a process: a second caller reads the first's verdict


def wide_vector_failure(device, timeout=90):
    """Why the CPU ``device`` (``pyopencl.Device``) cannot run 16-wide vector kernels, or None.

    Returns the compiler's last words (e.g. ``"LLVM ERROR: ..."``), or that a child which reached
    the compiler ran past ``timeout`` seconds (a tiny kernel: seconds at most, even under load).
    A kept verdict is dropped by deleting its file (the path: :func:`_verdict_path`).
    """
    with _lock:
        return _probe(device, timeout)


def _probe(device, timeout):
    import pyopencl as cl
    path = _verdict_path(device)
    try:
        with open(path, encoding="utf-8") as f:
            return f.read().strip() or None
    except (OSError, ValueError):       # none yet, or unreadable: probed again
        pass
    where = [(p, plat.get_devices().index(device)) for p, plat in enumerate(cl.get_platforms())
             if plat.int_ptr == device.platform.int_ptr]
    try:
        child = subprocess.Popen([sys.executable, "-c", _CHILD, *map(str, where[0]), device.name.strip(), _KERNEL],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    except OSError:     # no child process here: the device is taken to work
        return None
    code = None
    try:
        out, err = child.communicate(timeout=min(3, timeout))
        code = child.returncode
    except subprocess.TimeoutExpired:
        # (a working device answers in about a second: say why the caller waits)
        print(f"gfgpu: testing the OpenCL device {device.name.strip()!r} once for this machine (up to {timeout} s)",
              file=sys.stderr, flush=True)
        try:
            out, err = child.communicate(timeout=max(0, timeout - 3))
            code = child.returncode
        except subprocess.TimeoutExpired:
            # a verdict too, kept: seen with the bundled PoCL and an empty kernel cache (its threads
            # spinning); unkept, every later process would wait as long again
            child.kill()
            out, err = child.communicate()
    out, err = out or "", err or ""
    if "compiling" not in out.split():
        return None     # the child failed before the compiler ran (its import, the device list): no verdict
    # the verdict is the compiler's words on stderr (stdout holds only the child's progress)
    lines = [line.strip() for line in err.splitlines() if line.strip()]
    errors = [line for line in lines if "LLVM ERROR" in line] or [line for line in lines if "rror" in line]
    if code is None:
        verdict = f"a 16-wide vector kernel did not finish within {timeout} s"
    elif code == 0 and "ok" in out.split():
        verdict = ""
    else:
        verdict = (errors or [f"the child stopped with exit status {code}"])[-1]
    tmp = None
    try:    # atomically: a concurrent process reads the old verdict or the new one, never half
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path))
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(verdict)
        os.replace(tmp, path)
    except OSError:     # an unwritable cache: probed again by the next process
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return verdict or None
