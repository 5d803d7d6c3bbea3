"""Whether a CPU device's OpenCL compiler survives 16-wide vectors, probed in a child process.

gfgpu's CPU kernels use 16-wide vectors (``float16`` spline windows, 16-lane byte rows).  A
compiler may build a trivial kernel and still abort the whole process on those: PoCL 3.0 as
PyOpenCL's wheels bundle it (LLVM 14) targets an AVX-512 AMD EPYC as ``znver3``, a CPU without
AVX-512, and its code generator then stops at the first ``float16`` multiply with
"LLVM ERROR: Do not know how to scalarize this operator's operand!" (an abort, which no
``try`` catches).  The probe therefore runs in a child process, once per machine: its verdict
is kept in the cache directory (``XDG_CACHE_HOME`` or ``~/.cache``, ``gfgpu/opencl-probe/``),
keyed by the platform, the device, its compiler's target and the CPU's feature flags, so a
runtime or CPU change probes again.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile

__all__ = ["wide_vector_failure"]

# bumped when the probe's kernel changes (older verdicts are then ignored)
_VERSION = "1"

_KERNEL = """
__kernel void gfgpu_wide(__global float *a, __global int *b)
{
    const int i = get_global_id(0);
    const float16 v = vload16(i, a);
    vstore16(fma(v, (float16)(2.0f), v * 0.5f), i, a);
    vstore16(vload16(i, b) + (int16)(1), i, b);
}
"""

# the child: build and run the kernel on (platform, device) by index, check its result
_CHILD = """
import sys
import numpy as np
import pyopencl as cl
p, d, name = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
dev = cl.get_platforms()[p].get_devices()[d]
if dev.name.strip() != name:
    sys.exit("device order changed")
ctx = cl.Context([dev])
queue = cl.CommandQueue(ctx)
knl = cl.Program(ctx, sys.argv[4]).build().gfgpu_wide
a = np.arange(32, dtype=np.float32)
b = np.arange(32, dtype=np.int32)
mf = cl.mem_flags
da = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=a)
db = cl.Buffer(ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=b)
knl(queue, (2,), None, da, db)
cl.enqueue_copy(queue, a, da)
cl.enqueue_copy(queue, b, db)
queue.finish()
if not (np.array_equal(a, np.arange(32) * 2.5) and np.array_equal(b, np.arange(1, 33))):
    sys.exit("wrong result of a 16-wide vector kernel")
print("ok")
"""


def _cpu_flags():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return line
    except OSError:
        pass
    return ""


def _verdict_path(device):
    plat = device.platform
    key = "\n".join((_VERSION, plat.name, plat.version, device.name, device.version, device.driver_version,
                     sys.executable, _cpu_flags()))
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(root, "gfgpu", "opencl-probe", hashlib.sha256(key.encode()).hexdigest()[:24])


def _indices(device):
    import pyopencl as cl
    for p, plat in enumerate(cl.get_platforms()):
        try:
            devs = plat.get_devices()
        except cl.Error:
            continue
        for d, dev in enumerate(devs):
            if dev.int_ptr == device.int_ptr:
                return p, d
    return None


def _keep(path, verdict):
    # written atomically: a concurrent process reads the old file or the new one, never half
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path))
        with os.fdopen(fd, "w") as f:
            f.write(verdict)
        os.replace(tmp, path)
    except OSError:     # an unwritable cache: probed again by the next process
        pass


def wide_vector_failure(device, timeout=60):
    """Why ``device`` (a CPU) cannot run 16-wide vector kernels, or None if it can.

    Parameters
    ----------
    device : pyopencl.Device
    timeout : float
        Seconds the child process may take (a tiny kernel: a few seconds at most); past it
        the device is refused in this process and probed again by the next one.

    Returns
    -------
    str or None
        The compiler's last words, e.g. ``"LLVM ERROR: Do not know how to scalarize this
        operator's operand!"``.
    """
    path = _verdict_path(device)
    try:
        with open(path) as f:
            verdict = f.read()
        return verdict or None
    except OSError:
        pass
    where = _indices(device)
    if where is None:
        return None
    try:
        res = subprocess.run([sys.executable, "-c", _CHILD, str(where[0]), str(where[1]), device.name.strip(),
                              _KERNEL], capture_output=True, text=True, timeout=timeout)
    except OSError:     # no child process here: the device is taken to work
        return None
    except subprocess.TimeoutExpired:
        # (seen: a failed PoCL build whose worker threads spin) not kept: a loaded machine may
        # be slow, and the next process probes again
        return f"a 16-wide vector kernel did not finish within {timeout} s"
    if res.returncode == 0 and res.stdout.strip().endswith("ok"):
        verdict = ""
    else:
        lines = [line.strip() for line in (res.stderr + res.stdout).splitlines() if line.strip()]
        errors = [line for line in lines if "LLVM ERROR" in line] or [line for line in lines if "rror:" in line]
        verdict = (errors or lines or [f"exit status {res.returncode}"])[0]
    _keep(path, verdict)
    return verdict or None
