"""Throughput of gfgpu's line operators beside peers measured in the same run.

Prints a Markdown table (Mpix/s, and the ratio to numpy.copyto of the same array, the
memory-bound) for, on a SIZE x SIZE float32 image:

* one causal G_u pass (u = 3, mode 'reflect') along rows and along columns: the raw
  primitive on device-resident arrays (``backend.recurse``) and the public
  ``green_filter`` call (which also checks the input is finite);
* ``gfgpu.shift`` by (1.5, 2.5) (two passes) and ``gfgpu.gradient`` (u = 1: 8 passes on numpy and
  Warp; on OpenCL CPU devices one two-sided row step writing both row results (P and D along the
  rows, the finite check fused), then one two-sided column step for each output);
* ``gfgpu.canny`` (u = 1, numpy in and out) beside OpenCV's GaussianBlur + Canny (uint8);
* the public ``gfgpu.shift`` by (3.25, -7.5), numpy in and numpy out, with the Green and the
  cubic fractional part, beside ``scipy.ndimage.shift`` (order 1 and 3);
* host in/out of one pass: ``gfgpu.shift(img, (0, 3))`` (an integer translation, one pass),
  numpy in and numpy out, into a given ``output=`` array (the public call, the finite check
  included) and into a new array, beside the same translation as the primitive on
  device-resident arrays (``backend.translate``) and beside ``numpy.copyto`` and
  ``img.copy()`` (a new array: its first-touch page faults are part of any numpy-out call);
* an accuracy table of ``shift`` (rel. L2 against the exact Fourier shift of a band-limited
  256 x 256 image, mode wrap) for the shifts of the core issue, every backend, beside scipy;
* peers: scipy.signal.lfilter with the same 2-pole recursion, scipy.ndimage.convolve1d with
  G_u truncated at 10u, cv2.filter2D with the same truncated kernel (if OpenCV is installed),
  numpy.copyto;

and the cold compile time of each backend (a fresh process with empty kernel caches).

Usage:  python benchmarks/filters.py [--size 4096] [--repeat 5] [--backends numpy,warp,opencl]
                                    [--no-cold] [--no-accuracy] [--no-first] [--first-only]

A backend may name its device as ``GFGPU_BACKEND`` does: ``--backends warp:cuda:0,opencl:1``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import gfgpu
from gfgpu import greens
from gfgpu._core import recursion, translation
from gfgpu.backends import get_backend

U = 3.0


def best_time(fn, repeat, sync=lambda: None):
    fn()
    sync()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - t0)
    return min(times)


def cold_compile(name, device=None):
    """Seconds for the first and the second tiny call in a fresh process with empty caches."""
    code = (
        "import time, numpy as np, gfgpu\n"
        "img = np.ones((64, 64), np.float32)\n"
        f"t0 = time.perf_counter(); gfgpu.gradient(img, 1.0, backend={name!r}, device={device!r})\n"
        "t1 = time.perf_counter()\n"
        f"gfgpu.gradient(img, 1.0, backend={name!r}, device={device!r}); t2 = time.perf_counter()\n"
        "print(t1 - t0, t2 - t1)\n")
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, WARP_CACHE_PATH=os.path.join(tmp, "warp"),
                   PYOPENCL_CACHE_DIR=os.path.join(tmp, "pyopencl"), POCL_CACHE_DIR=os.path.join(tmp, "pocl"),
                   XDG_CACHE_HOME=tmp)
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if res.returncode:
        return None, None
    first, second = (float(v) for v in res.stdout.split()[-2:])
    return first, second


def bench_backend(be, img, repeat, record):
    """Rows for one backend: the raw primitive, the public calls (device arrays in and out)."""
    n = img.shape[0]
    dev = be.asarray(img)
    out = be.empty(img.shape, np.float32)
    src3, dst3 = be.reshape(dev, (1, n, n)), be.reshape(out, (1, n, n))
    plan = recursion.plan_pass(greens.UniformGreen(U).line_pass(), n, "reflect", np.float32)
    sync = be.synchronize
    g = greens.UniformGreen(U)
    tag = f"gfgpu {be.name} ({be.device})"
    record(f"{tag}: G_u pass, rows (primitive)", best_time(lambda: be.recurse(src3, dst3, 2, plan), repeat, sync))
    record(f"{tag}: G_u pass, columns (primitive)", best_time(lambda: be.recurse(src3, dst3, 1, plan), repeat, sync))
    record(f"{tag}: green_filter, rows", best_time(
        lambda: gfgpu.green_filter(dev, g, axis=1, backend=be), repeat, sync), "device array in/out")
    record(f"{tag}: green_filter, columns", best_time(
        lambda: gfgpu.green_filter(dev, g, axis=0, backend=be), repeat, sync))
    record(f"{tag}: shift (1.5, 2.5)", best_time(
        lambda: gfgpu.shift(dev, (1.5, 2.5), backend=be), repeat, sync), "2 passes")
    record(f"{tag}: gradient u=1", best_time(
        lambda: gfgpu.gradient(dev, 1.0, backend=be), repeat, sync),
        "8 passes (OpenCL CPU: a two-output row step + 2 column steps, each two-sided), 2 outputs")
    host_out = np.empty_like(img)
    # host in/out of one pass: the integer translation (0, 3), public call and primitive
    line_axis = 2
    index = translation.window_index(n, 3, 0, "reflect")
    record(f"{tag}: shift (0, 3), translate (primitive)", best_time(
        lambda: be.translate(src3, dst3, line_axis, index, 0.0), repeat, sync), "device arrays, one pass")
    record(f"{tag}: shift (0, 3), numpy in/out, output=", best_time(
        lambda: gfgpu.shift(img, (0, 3), output=host_out, backend=be), repeat),
        "public call: finite check + pass + result on the host")
    record(f"{tag}: shift (0, 3), numpy in/out, new array", best_time(
        lambda: gfgpu.shift(img, (0, 3), backend=be), repeat), "as above, into a new array (compare img.copy())")
    record(f"{tag}: canny u=1, numpy in/out", best_time(lambda: gfgpu.canny(img, 1.0, backend=be), repeat),
           "gradient + NMS on the device, hysteresis on the host (compare cv2 GaussianBlur + Canny)")
    for interp in ("green", "cubic"):
        record(f"{tag}: shift (3.25, -7.5), {interp}, numpy in/out", best_time(
            lambda interp=interp: gfgpu.shift(img, SHIFT, interpolation=interp, output=host_out, backend=be),
            repeat), "translation: gathers + fractional passes")


def acceptance(be, img, repeat, copy_seconds):
    """Markdown rows of the engine's targets: public calls, numpy in and numpy out, as ratios to
    ``numpy.copyto`` of the same array measured in the same run (above 1: faster than a copy)."""
    g = greens.UniformGreen(U)
    out = np.empty_like(img)
    n = img.shape[0]
    dev = be.asarray(img)
    tmp = be.empty(img.shape, np.float32)
    src3, dst3 = be.reshape(dev, (1, n, n)), be.reshape(tmp, (1, n, n))
    plan = recursion.plan_pass(g.line_pass(), n, "reflect", np.float32)
    long = np.random.default_rng(1).random((4, n * n // 4), dtype=np.float32)
    long_copy = best_time(lambda: np.copyto(np.empty_like(long), long), repeat)
    cases = [
        ("green_filter(img, UniformGreen(3), axis=1)", lambda: gfgpu.green_filter(img, g, axis=1, backend=be), 0.6),
        ("  into output=", lambda: gfgpu.green_filter(img, g, axis=1, output=out, backend=be), 0.6),
        ("green_filter(img, UniformGreen(3), axis=0)", lambda: gfgpu.green_filter(img, g, axis=0, backend=be), 0.6),
        ("  into output=", lambda: gfgpu.green_filter(img, g, axis=0, output=out, backend=be), 0.6),
        ("shift(img, (0, 2.5))", lambda: gfgpu.shift(img, (0, 2.5), output=out, backend=be), 0.5),
        ("shift(img, (2.5, 0))", lambda: gfgpu.shift(img, (2.5, 0), output=out, backend=be), 0.5),
        ("shift(img, (0, 3)) (integer: a gather)", lambda: gfgpu.shift(img, (0, 3), output=out, backend=be), None),
        ("derivative(img, 1, axis=1) (P on columns, D on rows)",
         lambda: gfgpu.derivative(img, 1.0, axis=1, output=out, backend=be), 0.5),
        ("gradient(img, 1) (two outputs)", lambda: gfgpu.gradient(img, 1.0, backend=be), 0.25),
        ("one row pass, device arrays (primitive)", lambda: be.recurse(src3, dst3, 2, plan), 0.9),
        ("one column pass, device arrays (primitive)", lambda: be.recurse(src3, dst3, 1, plan), 0.9),
    ]
    lines = [f"| call ({be.name}, {n}²) | ms | × copy | target |", "|---|---:|---:|---:|"]
    for name, fn, target in cases:
        t = best_time(fn, repeat, be.synchronize)
        lines.append(f"| {name} | {t * 1e3:.1f} | {copy_seconds / t:.2f} | {f'≥ {target:.2f}' if target else '—'} |")
    t = best_time(lambda: gfgpu.green_filter(long, g, axis=1, backend=be), repeat)
    lines.append(f"| green_filter of a (4, {n * n // 4}) array, axis=1 (long lines) | {t * 1e3:.1f} | "
                 f"{long_copy / t:.2f} | ≥ 0.50 |")
    return lines


def first_calls(be, repeat):
    """Markdown rows: the first call at a new shape, in a process that has run the operator at
    another shape, beside the steady time at the new shape (target ≤ 1.5×)."""
    rng = np.random.default_rng(2)
    a = rng.random((1000, 1200), dtype=np.float32)
    b = rng.random((1100, 1300), dtype=np.float32)
    g = greens.UniformGreen(U)
    ops = [
        ("shift (2.5, -1.5)", lambda x: gfgpu.shift(x, (2.5, -1.5), backend=be)),
        ("green_filter axis=1", lambda x: gfgpu.green_filter(x, g, axis=1, backend=be)),
        ("green_filter angle=0.3", lambda x: gfgpu.green_filter(x, g, angle=0.3, backend=be)),
        ("derivative u=1", lambda x: gfgpu.derivative(x, 1.0, backend=be)),
        ("canny u=1", lambda x: gfgpu.canny(x, 1.0, backend=be)),
    ]
    lines = ["| operator (first call at 1100×1300 after 1000×1200) | first (ms) | steady (ms) | ratio |",
             "|---|---:|---:|---:|"]
    for name, fn in ops:
        fn(a)
        be.synchronize()
        t0 = time.perf_counter()
        fn(b)
        be.synchronize()
        first = time.perf_counter() - t0
        steady = best_time(lambda fn=fn: fn(b), repeat, be.synchronize)
        lines.append(f"| {name} | {first * 1e3:.1f} | {steady * 1e3:.1f} | {first / steady:.2f} |")
    return lines


SHIFT = (3.25, -7.5)
ACCURACY_SHIFTS = ((0, 10), (0, -7), (3.25, -7.5), (0, 12.5), (-20.75, 0.4), (0.5, 0.5))


def band_limited(n, seed=0, width=0.12):
    rng = np.random.default_rng(seed)
    ky = np.fft.fftfreq(n)[:, None]
    kx = np.fft.rfftfreq(n)[None, :]
    spec = rng.normal(size=(n, n // 2 + 1)) + 1j * rng.normal(size=(n, n // 2 + 1))
    img = np.fft.irfft2(spec * np.exp(-(ky**2 + kx**2) / width**2), (n, n))
    return img / img.std()


def shift_accuracy(backends):
    """Markdown rows: rel. L2 of each shift against the exact Fourier shift (mode wrap)."""
    from scipy import ndimage
    img = band_limited(256)
    ky = np.fft.fftfreq(256)[:, None]
    kx = np.fft.rfftfreq(256)[None, :]
    names = [f"gfgpu {b.name} {i}" for b in backends for i in ("green", "cubic")]
    lines = ["| shift (dy, dx) | " + " | ".join(names) + " | scipy order=1 | scipy order=3 |",
             "|---|" + "---:|" * (len(names) + 2)]
    for s in ACCURACY_SHIFTS:
        ref = np.fft.irfft2(np.fft.rfft2(img) * np.exp(-2j * np.pi * (ky * s[0] + kx * s[1])), img.shape)

        def rel(out, ref=ref):
            return np.linalg.norm(out - ref) / np.linalg.norm(ref)
        cells = [rel(gfgpu.shift(img.astype(np.float32), s, mode="wrap", interpolation=i, backend=b))
                 for b in backends for i in ("green", "cubic")]
        cells += [rel(ndimage.shift(img, s, order=o, mode="grid-wrap")) for o in (1, 3)]
        lines.append(f"| {s} | " + " | ".join(f"{c:.1e}" for c in cells) + " |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--backends", default="numpy,warp,opencl")
    ap.add_argument("--no-cold", action="store_true", help="skip the cold-compile measurement")
    ap.add_argument("--no-accuracy", action="store_true", help="skip the shift accuracy table")
    ap.add_argument("--no-first", action="store_true", help="skip the first-call-at-a-new-shape table")
    ap.add_argument("--first-only", action="store_true",
                    help="print only the first-call-at-a-new-shape table (run it in a fresh process)")
    args = ap.parse_args(argv)
    if args.first_only:
        for spec in filter(None, args.backends.split(",")):
            name, _, device = spec.partition(":")
            if name == "numpy":
                continue
            be = get_backend(name, device or None)
            print(f"\n{be.name} ({be.device}), load {os.getloadavg()[0]:.1f}\n")
            print("\n".join(first_calls(be, max(2, args.repeat // 2))))
        return

    n = args.size
    mpix = n * n / 1e6
    rng = np.random.default_rng(0)
    img = rng.random((n, n), dtype=np.float32) * 255
    rows = {}

    def record(name, seconds, note=""):
        rows[name] = (mpix / seconds, note)

    # ---- memory bound and peers ----------------------------------------------------
    dst = np.empty_like(img)
    record("numpy.copyto (memory bound)", best_time(lambda: np.copyto(dst, img), args.repeat))
    record("img.copy() (a new array)", best_time(img.copy, args.repeat), "copy + first touch of new memory")
    from scipy import ndimage, signal
    r = np.exp(-1 / U)
    b = [0.0, (2 / U) * r * np.sin(1 / U)]
    a = [1.0, -2 * r * np.cos(1 / U), r * r]
    record("scipy.signal.lfilter, rows", best_time(lambda: signal.lfilter(b, a, img, axis=1), args.repeat),
           "same recursion, float32")
    record("scipy.signal.lfilter, columns", best_time(lambda: signal.lfilter(b, a, img, axis=0), args.repeat))
    taps = greens.g_uniform(np.arange(0, int(10 * U) + 1), U)
    kernel = np.concatenate([np.zeros(len(taps) - 1), taps]).astype(np.float32)  # causal, centred
    record("scipy.ndimage.convolve1d, rows", best_time(
        lambda: ndimage.convolve1d(img, kernel, axis=1, mode="reflect"), args.repeat), f"{len(taps)} taps")
    record("scipy.ndimage.convolve1d, columns", best_time(
        lambda: ndimage.convolve1d(img, kernel, axis=0, mode="reflect"), args.repeat))
    try:
        import cv2
        k2 = kernel[::-1].reshape(1, -1)  # filter2D correlates
        record("cv2.filter2D, rows", best_time(lambda: cv2.filter2D(img, -1, k2), args.repeat),
               f"{len(taps)} taps, {cv2.getNumThreads()} threads")
        record("cv2.filter2D, columns", best_time(lambda: cv2.filter2D(img, -1, k2.T), args.repeat))
        img8 = img.astype(np.uint8)        # cv2.Canny takes 8-bit images only
        record("cv2.GaussianBlur (sigma 1) + cv2.Canny", best_time(
            lambda: cv2.Canny(cv2.GaussianBlur(img8, (0, 0), 1.0), 50, 100), args.repeat),
            "uint8, the peer of gfgpu's canny rows")
    except ImportError:
        pass
    from skimage.filters import sobel
    record("skimage.filters.sobel (gradient magnitude)", best_time(lambda: sobel(img), args.repeat))
    shifted = np.empty_like(img)
    for order in (1, 3):
        record(f"scipy.ndimage.shift {SHIFT}, order={order}", best_time(
            lambda order=order: ndimage.shift(img, SHIFT, output=shifted, order=order, mode="reflect"),
            args.repeat), "numpy in/out")

    # ---- gfgpu backends ---------------------------------------------------------------
    cold = {}
    used = []
    for spec in filter(None, args.backends.split(",")):
        name, _, device = spec.partition(":")
        try:
            be = get_backend(name, device or None)
        except Exception as exc:  # report and carry on with the others
            print(f"# {spec}: unavailable ({exc})", file=sys.stderr)
            continue
        used.append(be)
        bench_backend(be, img, args.repeat, record)
        if not args.no_cold:
            cold[spec] = cold_compile(name, device or None)

    copy = rows["numpy.copyto (memory bound)"][0]
    copy_seconds = mpix / copy
    for be in used:
        if be.name == "numpy":
            continue
        print(f"\n### Targets of the engine: {be.name} ({be.device}), numpy in / numpy out unless noted\n")
        print("\n".join(acceptance(be, img, args.repeat, copy_seconds)))
        if not args.no_first:
            print()
            print("\n".join(first_calls(be, max(2, args.repeat // 2))))
    lfilter_rows = rows["scipy.signal.lfilter, rows"][0]
    print(f"\n{n}x{n} float32, u = {U}, best of {args.repeat}; machine: {os.cpu_count()} cores\n")
    print("| operation | Mpix/s | × copyto | × lfilter (rows) | note |")
    print("|---|---:|---:|---:|---|")
    for name, (rate, note) in rows.items():
        print(f"| {name} | {rate:,.0f} | {rate / copy:.3f} | {rate / lfilter_rows:.2f} | {note} |")
    if not args.no_accuracy:
        print("\nshift accuracy: rel. L2 against the exact Fourier shift, band-limited 256x256 float32, mode wrap\n")
        print("\n".join(shift_accuracy(used)))
    if cold:
        print("\n| backend | first call, empty caches (s) | next call (s) |")
        print("|---|---:|---:|")
        for name, (first, second) in cold.items():
            print(f"| {name} | {first:.2f} | {second:.3f} |" if first is not None else f"| {name} | failed | |")


if __name__ == "__main__":
    main()
