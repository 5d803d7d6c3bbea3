"""``gfgpu batch``: wall time of a batch run here (sequential) and on a Dask LocalCluster.

Writes COUNT random-texture PNGs of SIZE x SIZE into a temporary folder, then times the whole
batch (planning, cluster start-up and shut-down included, as a user sees it) for each backend:
in this process one file after another (the peer), and with ``--workers N`` for each N given.
The median time per file (read + filter + write, measured inside the task) separates the
per-file cost from the cluster's start-up and scheduling overhead.

Usage:  python benchmarks/batch.py [--count 16] [--size 1024] [--op canny] [--workers 1,2]
                                   [--backends numpy,warp,opencl] [--repeat 2]
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time

import numpy as np

from gfgpu import batch

# the gfgpu.batch parameters; pairs in array-axis order: shift=(dy, dx), velocity=(vy, vx)
PARAMS = {"shift": {"shift": (-1.25, 2.5)}, "gradient": {"u": 1.0}, "canny": {"u": 1.0, "low": 0.8, "high": 0.9},
          "blur": {"velocity": (-10.0, 25.0)}}


def make_images(folder, count, size):
    import imageio.v3 as iio
    from scipy.ndimage import gaussian_filter
    rng = np.random.default_rng(1)
    for i in range(count):
        img = gaussian_filter(rng.random((size, size)), 2.0)
        img = 255 * (img - img.min()) / (img.max() - img.min())
        iio.imwrite(os.path.join(folder, f"img{i:03d}.png"), img.astype(np.uint8))


def time_batch(inputs, outdir, op, backend, workers, repeat):
    walls, per_file = [], []
    for _ in range(repeat):
        shutil.rmtree(outdir, ignore_errors=True)
        jobs = batch.plan_jobs(inputs, outdir, op, PARAMS[op], fmt="npy", backend=backend)
        t0 = time.perf_counter()
        results = batch.run_batch(jobs, workers=workers, progress=False)
        walls.append(time.perf_counter() - t0)
        if any(r.status != "ok" for r in results):
            raise RuntimeError(f"{op} on {backend}: {[r.message for r in results if r.status != 'ok'][:3]}")
        per_file.append(float(np.median([r.seconds for r in results])))
    return walls, per_file


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=16)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--op", choices=tuple(PARAMS), default="canny")
    ap.add_argument("--workers", default="1,2", help="comma-separated LocalCluster sizes")
    ap.add_argument("--backends", default="numpy,warp,opencl")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gfgpu-batch-bench-") as tmp:
        src = os.path.join(tmp, "in")
        os.makedirs(src)
        make_images(src, args.count, args.size)
        inputs = batch.discover_inputs([src])
        print(f"{args.count} PNGs of {args.size}x{args.size}, `gfgpu batch {args.op}`, .npy outputs; "
              f"{os.cpu_count()} CPU cores; wall time of the whole batch (min-max of {args.repeat} runs)\n")
        print("| backend | run | wall (s) | files/s | speed-up vs sequential | median s/file in the task |")
        print("|---|---|---|---|---|---|")
        for workers in [int(w) for w in args.workers.split(",")]:
            t0 = time.perf_counter()
            batch.run_batch([], workers=workers, progress=False)
            print(f"| - | --workers {workers}, no files: cluster start-up + shut-down | {time.perf_counter() - t0:.1f} "
                  f"| - | - | - |", flush=True)
        for backend in args.backends.split(","):
            base = None
            for workers in [None] + [int(w) for w in args.workers.split(",")]:
                walls, per = time_batch(inputs, os.path.join(tmp, "out"), args.op, backend, workers, args.repeat)
                best = min(walls)
                base = best if workers is None else base
                label = "sequential (here)" if workers is None else f"--workers {workers}"
                print(f"| {backend} | {label} | {min(walls):.1f}-{max(walls):.1f} | {args.count / best:.1f} | "
                      f"{base / best:.2f}x | {min(per):.2f}-{max(per):.2f} |", flush=True)


if __name__ == "__main__":
    main()
