"""Warp's CUDA compile time per gfgpu module and per operator, measured here with NVRTC.

Warp compiles a module (every kernel and overload in it) for a device at the module's first
launch there; a GPU user waits for it at the first call of an operator (later processes load
the kernel cache).  NVRTC runs without a GPU, so this measures, for sm_90 (H100/H200), the
CUBIN build of each module that defines CUDA kernels, each in a fresh process with an empty
kernel cache, and adds up the modules each public operator needs.

Usage:  python benchmarks/warp_compile.py [--arch 90]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import device_check  # the list of modules with CUDA kernels

ONE = r"""
import importlib, json, sys, time
import warp as wp
wp.config.quiet = True
wp.init()
name, arch = sys.argv[1], int(sys.argv[2])
importlib.import_module(name)
mod = wp.get_module(name)
t = time.perf_counter()
wp.compile_aot_module(mod, arch=arch, use_ptx=False)
print("SECONDS", json.dumps(round(time.perf_counter() - t, 2)))
"""

#: the Warp modules each operator's first call compiles on a GPU (the modules a fresh process had
#: loaded after the call on Warp's CPU device, less the CPU-only ones)
OPERATORS = {
    "shift, green_filter, derivative, gradient": ["gfgpu.backends.warp.recurse"],
    "canny": ["gfgpu.backends.warp.recurse", "gfgpu.edges._warp"],
    "disparity": ["gfgpu.backends.warp.recurse", "gfgpu.stereo._warp"],
    "motion_blur, uniform or oblique, green PSF": ["gfgpu.backends.warp.recurse"],
    "motion_blur, box PSF": ["gfgpu.backends.warp.recurse", "gfgpu.motion._warp"],
    "motion_blur, velocity field (Gauss rule, paths within its tables)": [
        "gfgpu.backends.warp.recurse", "gfgpu.motion.field_kernels._warp"],
    "motion_blur, velocity field, quadrature='exact' or longer paths": [
        "gfgpu.backends.warp.recurse", "gfgpu.motion.field_kernels._warp_exact"],
    "motion_blur, rotation or zoom": ["gfgpu.backends.warp.recurse", "gfgpu.motion.polar_kernels._warp"],
}


def compile_seconds(module, arch):
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, WARP_CACHE_PATH=tmp)
        res = subprocess.run([sys.executable, "-c", ONE, module, str(arch)], capture_output=True, text=True,
                             env=env, cwd=device_check.ROOT)
    for line in res.stdout.splitlines():
        if line.startswith("SECONDS "):
            return json.loads(line[8:])
    raise RuntimeError(f"compiling {module} failed:\n{res.stderr[-2000:]}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", type=int, default=90)
    args = ap.parse_args(argv)
    seconds = {m: compile_seconds(m, args.arch) for m in device_check.warp_kernel_modules()}
    print(f"\nWarp CUDA compile (NVRTC, sm_{args.arch}, CUBIN, empty cache, {os.cpu_count()} cores)\n")
    print("| module | seconds |\n|---|---:|")
    for m, s in seconds.items():
        print(f"| `{m}` | {s:.1f} |")
    print("\n| operator: modules its first GPU call compiles | seconds | target |\n|---|---:|---:|")
    for op, mods in OPERATORS.items():
        total = sum(seconds.get(m, 0.0) for m in mods)
        print(f"| {op} | {total:.1f} | ≤ 30 |")


if __name__ == "__main__":
    main()
