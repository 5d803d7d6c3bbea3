"""Host memory that a CPU device's queued kernels still write is never freed (gfgpu._core.hostpool).

A block goes back to the pool when Python drops its last array; an OpenCL kernel queued on it may
not have run yet.  The pool used to free blocks beyond its limit at that moment: the quick start's
``gfgpu disparity --example motorcycle`` (500 x 741, 64 disparities, OpenCL on PoCL) crashed
with a segmentation fault in the cost kernel.  Each case runs in a child process, so a crash
fails one test with its exit status instead of ending the run.
"""

import os
import subprocess
import sys

import pytest

SCRIPT = r"""
import sys
import numpy as np
import gfgpu

backend = gfgpu.get_backend(sys.argv[1], None if sys.argv[2] == "-" else sys.argv[2])
rng = np.random.default_rng(0)
left = rng.random((500, 741)).astype(np.float32)
right = np.roll(left, -5, axis=1)
disp = gfgpu.disparity(left, right, max_disparity=64, backend=backend)
assert abs(np.nanmedian(disp) - 5) < 0.01, np.nanmedian(disp)
# many shapes in a row: released blocks are freed while later passes are queued
for n in range(300, 700, 37):
    image = rng.random((n, n + 11)).astype(np.float32)
    out = gfgpu.shift(image, (1.5, -2.25), backend=backend)
    ref = gfgpu.shift(image, (1.5, -2.25), backend="numpy")
    assert np.allclose(out, ref, atol=1e-4), n
    gfgpu.green_filter(image, gfgpu.UniformGreen(3.0), axis=0, backend=backend)
    gfgpu.derivative(image, 1.5, axis=1, backend=backend)
print("ok")
"""


@pytest.mark.parametrize("limit", [None, "1"])
def test_released_blocks_are_not_freed_under_queued_kernels(backend, limit):
    env = dict(os.environ)
    env.pop("GFGPU_HOST_POOL", None)
    if limit is not None:
        env["GFGPU_HOST_POOL"] = limit        # hold nothing: every release frees at the next request
    name, device = backend.spec
    run = subprocess.run([sys.executable, "-c", SCRIPT, name, "-" if device is None else str(device)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0 and run.stdout.strip().endswith("ok"), (run.returncode, run.stderr[-2000:])
