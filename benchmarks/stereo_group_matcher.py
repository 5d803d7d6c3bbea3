"""The OpenCL GPU branch of the stereo matcher, before and after issue 28 item 2, forced on the
OpenCL CPU device (PoCL): a correctness and sanity check of the work-group matcher, **not** a GPU
measurement (a CPU runs a work-group's lanes as loops and its barriers as loop splits).

- ``lines``: the previous GPU branch, rebuilt from the public per-stage launchers: int16 Hamming
  block costs (via a uint8 Hamming volume), ``sgm_line_pair`` with one work-item per path line
  into an int16 sum volume, ``select_disparity`` one work-item per row (5 bytes per sample);
- ``groups``: ``gfgpu/stereo/_opencl_groups.py`` (a work-group per line, the samples across its
  work-items; a uint8 cost and one int16 sum volume: 3 bytes per sample).

Both run on the same random census codes of a shifted pair; the maps are checked equal (and,
below ``--check-below`` samples in all, equal to the numpy specification).  Times: best of
``--repeat`` calls, the two alternated in one process, after a warm-up (builds).

With ``--motorcycle``, also ``disparity()`` on scikit-image's motorcycle pair (500 x 741, range
0..79, the defaults): the maps of the CPU band matcher, of the OpenCL GPU branch forced on the CPU
device and of Warp's forced on Warp-CPU with cooperative blocks (``wp.config.enable_cpu_blocks``),
compared bit for bit.

Usage::

    python benchmarks/stereo_group_matcher.py [--sizes 120x160 375x450] [--max-disparity 63]
                                              [--steps 2] [--paths 4] [--repeat 3] [--motorcycle]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from gfgpu.backends import resolve_backend
from gfgpu.backends.opencl.backend import OpenCLBackend
from gfgpu.stereo import _opencl, _opencl_groups
from gfgpu.stereo import spec as specs


def _codes(h, w, steps, shift, seed=0):
    rng = np.random.default_rng(seed)
    left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < 0.05).astype(np.uint64)
    return left, right


def _lines(be, cl, cr, outs, first, n, steps, block, p1, p2, paths, uniq):
    h, w = outs[0].shape
    cost = be.empty((h, w, n), np.int16)
    _opencl.launch_cost(be, cl, cr, cost, first, steps, block)
    agg = be.empty((h, w, n), np.int16)
    _opencl.launch_sgm(be, cost, agg, p1, p2, paths)
    _opencl.launch_select(be, agg, *outs, first // steps, steps, uniq)


def _groups(be, cl, cr, outs, first, n, steps, block, p1, p2, paths, uniq):
    _opencl_groups.launch_match(be, cl, cr, *outs, first, n, steps, block, p1, p2, paths, uniq)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", nargs="+", default=["120x160", "375x450"], help="HxW")
    ap.add_argument("--max-disparity", type=int, default=63)
    ap.add_argument("--steps", type=int, default=2)
    ap.add_argument("--paths", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--check-below", type=int, default=3_000_000)
    ap.add_argument("--motorcycle", action="store_true", help="also compare disparity() maps on motorcycle")
    args = ap.parse_args()
    cpu = resolve_backend("opencl")
    be = OpenCLBackend(cpu.queue)
    be.kind = "gpu"          # the GPU branch's launch shapes on the CPU device
    steps, block, p1, p2, uniq = args.steps, 3, 54, 576, 10
    n = args.max_disparity * steps + 1
    print(f"OpenCL device: {cpu.cl_device.name.strip()} ({cpu.cl_device.max_compute_units} compute units), "
          f"load average {os.getloadavg()[0]:.1f}; {n} samples, {args.paths} paths, GPU shapes forced\n")
    print("| size | samples | lines (s) | groups (s) | groups / lines | volumes lines / groups (MB) | maps |")
    print("|---|---|---|---|---|---|---|")
    for size in args.sizes:
        h, w = (int(v) for v in size.split("x"))
        left, right = _codes(h, w, steps, 7)
        cl, cr = be.asarray(left), be.asarray(right)
        outs = {k: (be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32))
                for k in ("lines", "groups")}
        best = {"lines": np.inf, "groups": np.inf}
        for rep in range(args.repeat + 1):
            for name, fn in (("lines", _lines), ("groups", _groups)):
                be.queue.finish()
                t = time.perf_counter()
                fn(be, cl, cr, outs[name], 0, n, steps, block, p1, p2, args.paths, uniq)
                be.queue.finish()
                if rep:          # the first round builds the kernels
                    best[name] = min(best[name], time.perf_counter() - t)
        got = {k: [be.to_host(a) for a in v] for k, v in outs.items()}
        same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got["lines"], got["groups"]))
        verdict = "equal" if same else "DIFFER"
        if same and h * w * n < args.check_below:
            ref = specs.semi_global_match_reference(left[0], right, 0, n, steps, block, p1, p2, args.paths, uniq)
            same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got["groups"], ref))
            verdict = "equal, = spec" if same else "equal, SPEC DIFFERS"
        mb = h * w * n / 1e6
        print(f"| {h}x{w} | {n} | {best['lines']:.3f} | {best['groups']:.3f} | "
              f"{best['groups'] / best['lines']:.2f} | {5 * mb:.0f} / {3 * mb:.0f} | {verdict} |")
    if args.motorcycle:
        _motorcycle(cpu, be)


def _motorcycle(cpu, forced_ocl):
    import skimage.data
    import warp as wp

    from gfgpu import stereo
    from gfgpu.backends.warp.backend import WarpBackend
    wp.config.enable_cpu_blocks = True       # Warp-CPU runs blocks of several threads
    forced_warp = WarpBackend(resolve_backend("warp").wp_device.alias)
    forced_warp.kind = "gpu"
    left, right, _ = skimage.data.stereo_motorcycle()
    ref = stereo.disparity(left, right, 79, backend=cpu)
    print(f"\nmotorcycle {left.shape[1]}x{left.shape[0]}, max_disparity 79, defaults; CPU band matcher: "
          f"{np.isfinite(ref).mean():.1%} valid")
    for what, be in (("OpenCL GPU branch forced", forced_ocl), ("Warp GPU branch forced", forced_warp)):
        t = time.perf_counter()
        got = stereo.disparity(left, right, 79, backend=be)
        verdict = "identical" if np.array_equal(got, ref, equal_nan=True) else "DIFFERENT"
        print(f"- {what}: {verdict} ({time.perf_counter() - t:.1f} s with builds, a CPU)")


if __name__ == "__main__":
    main()
