"""Oblique passes: accuracy against the continuous direction, impulse centroids, throughput, plan cost.

Passes along an angle run on a sheared layout (``gfgpu._core.oblique``): integer part of the
shear by a gather, the remaining delay (2.3 to 3.3 px) by a third-order Thiran allpass along each
column (two cascaded recursions), the passes along the rows, then the mirrored allpass and a gather back.  Two other
methods run here with the same backend primitives, for comparison: the former *digital lines*
(``y = l + round(γ x)``, one pixel per column, no resampling: ``digital_lines``) and the same
shear with the moment-fitted discrete Green shift by ``|f| <= 1/2`` as the column filter
(``green_shear``).

What is printed (Markdown):

(a) accuracy: ``motion_blur`` with the velocities of the core issue, rel. L2 against the same
    Green operator applied along the continuous direction (its transfer function ``W(ω·d)``,
    d the step of one pixel along the dominant axis, applied to the spectrum), mode 'wrap', on
    shapes ``(|vy| b, |vx| b)`` whose lines close on themselves (on other shapes the wrap of a
    line onto its own start differs from the torus for any line-based method, and dominates:
    0.13 for (30, 7) on 512², before and after).  Images: the astronaut (grey, mean removed)
    and a band-limited noise (Gaussian spectrum of width 0.12 cycles/px, as benchmarks/filters.py);
(b) the blur of the two resamplings by frequency: white noise low-passed at a fraction of Nyquist;
(c) impulse centroids: one impulse in every column (row, when steep) of one period of the
    fractions of ``γ t``, mode 'constant'; error against the velocity, after accounting for
    the part of the kernel's tail beyond the plane (exactly: ``Σ m w / Σ w`` over the steps
    kept); digital lines beside;
(d) throughput on SIZE² float32, numpy in and numpy out: ``green_filter(UniformGreen(5),
    angle=0.3)`` and ``motion_blur`` (7, 30) and (40, 17) per backend, sheared beside digital lines,
    and ``cv2.filter2D`` with the motion's taps rasterised along the line (if OpenCV is installed);
(e) plan cost: gather maps and per-column plans of one oblique geometry (cached) against the
    passes they feed; the rotation's per-line plans on (SIZE/2)² against its three passes;
(f) the column filter's design: rel. L2 of the box and the Green blur (numpy, float64) against the
    exact direction by Fourier, band-limited noise (a disc up to CUT cycles/px, 0.25 and 0.1), mode
    'wrap' on shapes whose lines close, at steep, shallow and near-45° velocities, for the
    third-order allpass (now) and the former second-order one (delays 2.05 to 3.05), with the
    phase error spread of each design over its delay range at 1/8 .. 1/4 cycles/px beside.

(g) with ``--compare REV``: issue 27's oblique rows, ``motion_blur`` on OpenCL as of the git revision
    REV (extracted by ``git archive`` and imported as a package of its own) and now, in one process,
    alternated call by call (best of ``--repeat`` rounds), beside ``cv2.filter2D`` with the
    equivalent 2-D line kernels (benchmarks/motion_refs.py: the box along the segment and the
    sampled G_u) in the same rounds, per shape of ``--shapes``; the load average before and after.

Usage:  python benchmarks/oblique.py [--size 4096] [--repeat 3] [--backends numpy,warp,opencl]
        [--skip-speed] [--designs-only] [--compare REV [--shapes 4096x4096,2048x2048,1999x3001]]
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np

import gfgpu
from gfgpu import greens
from gfgpu._core import oblique
from gfgpu._core.boundary import extend_index
from gfgpu._core.lines import direction, shear_maps
from gfgpu._core.recursion import line_plans, plan_pass
from gfgpu.backends import get_backend
from gfgpu.filters import green_filter_program
from gfgpu.motion import motion_blur, rotation
from gfgpu.motion.uniform import uniform_motion_program

# The references are the tests' oracles (tests/oracle.py: the operator along the continuous
# direction by its Fourier transfer function), one definition for both. tests/ is no package:
# put it on the path, wherever this script is run from.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from oracle import box_transfer_reference, transfer_reference

VELOCITIES = [(7, 30), (17, 40), (29, -13), (30, 7), (40, 17), (-13, 29)]


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


# --------------------------------------------------------------------------------------
# the former method: digital lines
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=8)
def digital_line_maps(height, width, batch, angle, mode, margin=0):
    """Gathers laying the digital lines ``minor = l + round(γ t)`` out as rows (no resampling),
    with ``margin`` extra rows on each side."""
    steep, _, gamma = direction(angle)
    steps, across = (height, width) if steep else (width, height)
    t = np.arange(steps)
    r = np.floor(gamma * t + 0.5).astype(np.int64)
    first = -int(r.max()) - margin
    lines = across - int(r.min()) - first + margin
    minor = extend_index(first + np.arange(lines)[:, None] + r[None, :], across, mode)
    flat = np.where(minor >= 0, (t[None, :] * width + minor) if steep else (minor * width + t[None, :]), -1)
    plane = height * width
    shear = np.where(flat[None] >= 0, flat[None] + np.arange(batch)[:, None, None] * plane, -1)
    yy, xx = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    tt, mm = (yy, xx) if steep else (xx, yy)
    pos = (mm - r[tt] - first) * steps + tt
    unshear = pos[None] + np.arange(batch)[:, None, None] * (lines * steps)
    return shear.astype(np.int32).reshape(-1), unshear.astype(np.int32).reshape(-1), lines, steps


def digital_lines(image, program, mode="reflect", cval=0.0, backend="numpy"):
    """Run a program's oblique steps on digital lines (numpy in, numpy out)."""
    be = get_backend(backend)
    img = np.ascontiguousarray(image)
    dtype = img.dtype
    cur = be.asarray(img)
    h, w = img.shape[-2:]
    batch = int(np.prod(img.shape[:-2], dtype=np.int64))
    for passes, _, angle in program.steps:
        reverse = direction(angle)[1]
        shear, unshear, lines, steps = digital_line_maps(h, w, batch, float(angle), mode)
        rows_in, rows_out = be.empty((batch, lines, steps), dtype), be.empty((batch, lines, steps), dtype)
        be.gather(be.reshape(cur, (-1,)), shear, cval, be.reshape(rows_in, (-1,)))
        for i, lp in enumerate(passes):
            be.recurse(rows_in, rows_out, 2, plan_pass(replace(lp, reverse=lp.reverse != reverse), steps, mode, dtype),
                       cval, accumulate=i > 0)
        nxt = be.empty(img.shape, dtype)
        be.gather(be.reshape(rows_out, (-1,)), unshear, 0.0, be.reshape(nxt, (-1,)))
        cur = nxt
    return be.to_host(cur)


def green_shear(image, program, mode="reflect", cval=0.0, backend="numpy"):
    """The shear with the discrete Green shift as column filter: integer part round(γ t), then
    G_{-f} (|f| <= 1/2, anticausal for f > 0), the passes, G_{+f} and the gather back."""
    be = get_backend(backend)
    img = np.ascontiguousarray(image)
    dtype = img.dtype
    cur = be.asarray(img)
    h, w = img.shape[-2:]
    batch = int(np.prod(img.shape[:-2], dtype=np.int64))
    margin = 30
    for passes, _, angle in program.steps:
        steep, reverse, gamma = direction(angle)
        shear, unshear, lines, steps = digital_line_maps(h, w, batch, float(angle), mode, margin)
        t = np.arange(steps)
        f = gamma * t - np.floor(gamma * t + 0.5)
        f[np.abs(f) < 1e-12] = 0
        lam, kap, tap = greens.shift_coefficients_many(np.where(f == 0, 1.0, np.abs(f)))
        fwd = line_plans(lam, kap, tap, f > 0, lines, "nearest", dtype, f == 0)
        inv = line_plans(lam, kap, tap, f < 0, lines, "nearest", dtype, f == 0)
        rows_in, rows_out = be.empty((batch, lines, steps), dtype), be.empty((batch, lines, steps), dtype)
        be.gather(be.reshape(cur, (-1,)), shear, cval, be.reshape(rows_in, (-1,)))
        be.recurse_lines(rows_in, rows_in, 1, fwd, cval)
        for i, lp in enumerate(passes):
            be.recurse(rows_in, rows_out, 2, plan_pass(replace(lp, reverse=lp.reverse != reverse), steps, mode, dtype),
                       cval, accumulate=i > 0)
        be.recurse_lines(rows_out, rows_out, 1, inv, cval)
        nxt = be.empty(img.shape, dtype)
        be.gather(be.reshape(rows_out, (-1,)), unshear, 0.0, be.reshape(nxt, (-1,)))
        cur = nxt
    return be.to_host(cur)


def torus_shape(velocity, b=12):
    return abs(velocity[0]) * b, abs(velocity[1]) * b


def astronaut(shape):
    from skimage import data
    img = data.astronaut()[: shape[0], : shape[1]].astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    return img - img.mean()


def gaussian_noise(shape, width=0.12, seed=0):
    rng = np.random.default_rng(seed)
    ky, kx = np.fft.fftfreq(shape[0])[:, None], np.fft.fftfreq(shape[1])[None, :]
    spec = np.fft.fft2(rng.standard_normal(shape)) * np.exp(-(ky**2 + kx**2) / width**2)
    img = np.real(np.fft.ifft2(spec))
    return img / img.std()


def lowpass_noise(shape, cutoff, seed=1):
    rng = np.random.default_rng(seed)
    ky, kx = np.fft.fftfreq(shape[0])[:, None] * 2, np.fft.fftfreq(shape[1])[None, :] * 2
    return np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * (np.hypot(ky, kx) <= cutoff)))


def rel(out, ref):
    return float(np.linalg.norm(np.asarray(out, np.float64) - ref) / np.linalg.norm(ref))


def accuracy_tables(backends):
    cols = [(b, d) for b in backends for d in (np.float32, np.float64) if d == np.float32 or b.supports_float64]
    names = [f"{b.name} {np.dtype(d).name}" for b, d in cols]
    lines = ["### (a) rel. L2 against the continuous-direction operator (mode wrap, lines closing on the torus)",
             "",
             "| velocity (vy, vx) | shape | astronaut: " + " | ".join(names)
             + " | astronaut: Green-shift shear | astronaut: digital lines | band-limited: allpass shear"
             " | band-limited: Green-shift shear | band-limited: digital lines |",
             "|---|---|" + "---:|" * (len(names) + 5)]
    for v in VELOCITIES:
        shape = torus_shape(v)
        prog = uniform_motion_program(2, v)
        cells = []
        img = astronaut(shape)
        ref = transfer_reference(img, prog)
        cells += [rel(motion_blur(img.astype(d), v, mode="wrap", backend=b), ref) for b, d in cols]
        cells += [rel(green_shear(img, prog, "wrap"), ref), rel(digital_lines(img, prog, "wrap"), ref)]
        bl = gaussian_noise(shape)
        ref = transfer_reference(bl, prog)
        cells += [rel(motion_blur(bl, v, mode="wrap", backend="numpy"), ref), rel(green_shear(bl, prog, "wrap"), ref),
                  rel(digital_lines(bl, prog, "wrap"), ref)]
        lines.append(f"| {v} | {shape[0]}x{shape[1]} | " + " | ".join(f"{c:.2e}" for c in cells) + " |")
    cutoffs = (0.125, 0.25, 0.5, 0.75, 1.0)
    lines += ["", "### (b) rel. L2 by frequency: white noise below a fraction of Nyquist (numpy, float64)", "",
              "| velocity (vy, vx) | method | " + " | ".join(f"{c:g}" for c in cutoffs) + " |",
              "|---|---|" + "---:|" * len(cutoffs)]
    for v in ((7, 30), (40, 17)):
        shape = torus_shape(v)
        prog = uniform_motion_program(2, v)
        imgs = [lowpass_noise(shape, c) for c in cutoffs]
        refs = [transfer_reference(im, prog) for im in imgs]
        for label, run in (("allpass shear (gfgpu)", lambda im, v=v: motion_blur(im, v, mode="wrap", backend="numpy")),
                           ("Green-shift shear", lambda im, p=prog: green_shear(im, p, "wrap")),
                           ("digital lines (before)", lambda im, p=prog: digital_lines(im, p, "wrap"))):
            errs = [rel(run(im), r) for im, r in zip(imgs, refs)]
            lines.append(f"| {v} | {label} | " + " | ".join(f"{c:.1e}" for c in errs) + " |")
    lines += ["", "### (c) impulse centroids, every column (row, when steep) of one period: worst error (px)", "",
              "| velocity (vy, vx) | " + " | ".join(names) + " | Green-shift shear | digital lines (numpy float64) |",
              "|---|" + "---:|" * (len(names) + 2)]
    for v in VELOCITIES:
        stack, src, expect = centroid_planes(v)
        cells = [centroid_error(motion_blur(stack.astype(d), v, mode="constant", backend=b), src, expect)
                 for b, d in cols]
        prog3 = uniform_motion_program(3, v)
        cells.append(centroid_error(green_shear(stack, prog3, "constant"), src, expect))
        cells.append(centroid_error(digital_lines(stack, prog3, "constant"), src, expect))
        lines.append(f"| {v} | " + " | ".join(f"{c:.1e}" for c in cells) + " |")
    return lines


def centroid_planes(velocity):
    """A stack with one impulse per plane in each column (row) of one period of the fractions,
    and the exact centroid offset of each response (the tail beyond the plane accounted for)."""
    vy, vx = velocity
    steep = abs(vy) > abs(vx)
    length = max(abs(vy), abs(vx))
    dom_v, min_v = (vy, vx) if steep else (vx, vy)
    dom = 6 * length + length + 24
    minor = -(-dom * abs(min_v) // length) + 60
    lam, kap, tap = greens.shift_coefficients(float(length))
    m = np.arange(dom)
    w = np.concatenate([[tap], np.real(kap * lam ** (m[1:] - 1))])
    planes, src, expect = [], [], []
    for k in range(length):
        t = 12 + k if dom_v > 0 else dom - 13 - k
        m0 = 30 if min_v > 0 else minor - 31
        kept = dom - t if dom_v > 0 else t + 1
        mean = (m[:kept] * w[:kept]).sum() / w[:kept].sum()
        plane = np.zeros((dom, minor) if steep else (minor, dom))
        pos = (t, m0) if steep else (m0, t)
        plane[pos] = 1.0
        planes.append(plane)
        src.append(pos)
        expect.append((mean * vy / length, mean * vx / length))
    return np.stack(planes), np.array(src, np.float64), np.array(expect)


def centroid_error(out, src, expect):
    out = np.asarray(out, np.float64)
    yy, xx = np.mgrid[: out.shape[1], : out.shape[2]]
    mass = out.sum(axis=(1, 2))
    cy = (out * yy).sum(axis=(1, 2)) / mass - src[:, 0]
    cx = (out * xx).sum(axis=(1, 2)) / mass - src[:, 1]
    return float(max(np.abs(cy - expect[:, 0]).max(), np.abs(cx - expect[:, 1]).max()))


# --------------------------------------------------------------------------------------
# speed
# --------------------------------------------------------------------------------------
def line_kernel(velocity):
    """The motion's taps (shift by L) rasterised along the line: tap k at (k vy/L, k vx/L), split
    bilinearly between pixels, truncated where the taps fall below 1e-4 of the largest."""
    vy, vx = velocity
    length = max(abs(vy), abs(vx))
    lam, kap, tap = greens.shift_coefficients(float(length))
    k = np.arange(1, 12 * length)
    w = np.concatenate([[tap], np.real(kap * lam ** (k - 1))])
    k = np.arange(len(w))
    w, k = w[np.abs(w) > 1e-4 * np.abs(w).max()], k[np.abs(w) > 1e-4 * np.abs(w).max()]
    ys, xs = k * vy / length, k * vx / length
    r = int(np.ceil(max(np.abs(ys).max(), np.abs(xs).max()))) + 1
    ker = np.zeros((2 * r + 1, 2 * r + 1))
    y0, x0 = np.floor(ys).astype(int), np.floor(xs).astype(int)
    fy, fx = ys - y0, xs - x0
    for dy, dx, a in ((0, 0, (1 - fy) * (1 - fx)), (1, 0, fy * (1 - fx)), (0, 1, (1 - fy) * fx), (1, 1, fy * fx)):
        np.add.at(ker, (r + y0 + dy, r + x0 + dx), w * a)
    return ker.astype(np.float32)


def speed_table(size, repeat, backends):
    img = np.random.default_rng(0).random((size, size), dtype=np.float32)
    out = np.empty_like(img)
    n = size * size / 1e6
    cases = [("green_filter(UniformGreen(5), angle=0.3)",
              lambda b: gfgpu.green_filter(img, greens.UniformGreen(5.0), angle=0.3, output=out, backend=b),
              lambda b: digital_lines(img, green_filter_program(2, greens.UniformGreen(5.0), angle=0.3), backend=b)),
             ("motion_blur (7, 30)", lambda b: motion_blur(img, (7, 30), output=out, backend=b),
              lambda b: digital_lines(img, uniform_motion_program(2, (7, 30)), backend=b)),
             ("motion_blur (40, 17) (steep)", lambda b: motion_blur(img, (40, 17), output=out, backend=b),
              lambda b: digital_lines(img, uniform_motion_program(2, (40, 17)), backend=b))]
    lines = [f"### (d) throughput, {size}x{size} float32, numpy in and out (Mpix/s; ms)", "",
             "| operator | backend | sheared (now) | digital lines (before) |", "|---|---|---:|---:|"]
    for label, new, old in cases:
        for b in backends:
            tn = best_time(lambda new=new, b=b: new(b.name), repeat)
            to = best_time(lambda old=old, b=b: old(b.name), repeat)
            lines.append(f"| {label} | {b.name} | {n / tn:.0f} ({tn * 1e3:.0f} ms) | "
                         f"{n / to:.0f} ({to * 1e3:.0f} ms) |")
    try:
        import cv2
    except ImportError:
        cv2 = None
    if cv2 is not None:
        for v in ((7, 30), (40, 17)):
            ker = line_kernel(v)
            t = best_time(lambda ker=ker: cv2.filter2D(img, -1, ker, borderType=cv2.BORDER_REFLECT), repeat)
            lines.append(f"| cv2.filter2D, line kernel of motion {v} ({ker.shape[0]}x{ker.shape[1]}) | opencv | "
                         f"{n / t:.0f} ({t * 1e3:.0f} ms) | |")
    return lines


def plan_table(size, repeat, backends):
    lines = ["### (e) plan cost against the passes they feed (ms)", "",
             "| what | building (first call) | passes (per call), by backend |", "|---|---:|---|"]
    # one oblique geometry: gather maps and per-column plans (cached afterwards)
    angle = 0.3001                     # a geometry not yet in the caches
    steep, _, gamma = direction(angle)
    t0 = time.perf_counter()
    margin = oblique.column_delays(size, gamma, np.dtype(np.float32).str)[2]
    maps = shear_maps(size, size, 1, angle, "reflect", margin, steep)
    t1 = time.perf_counter()
    oblique._column_plans(size, gamma, maps.lines, np.dtype(np.float32).str)
    t2 = time.perf_counter()
    img = np.random.default_rng(0).random((size, size), dtype=np.float32)
    passes = []
    for b in backends:
        t = best_time(lambda b=b: gfgpu.green_filter(img, greens.UniformGreen(5.0), angle=angle, backend=b), repeat)
        passes.append(f"{b.name} {t * 1e3:.0f}")
    lines.append(f"| oblique {size}² (angle 0.3001): per-column plans | {(t2 - t1) * 1e3:.1f} | {', '.join(passes)} |")
    lines.append(f"| oblique {size}²: gather maps (cached per geometry) | {(t1 - t0) * 1e3:.0f} | |")
    half = size // 2
    shears = rotation.rotation_shears(10.0)
    rimg = np.random.default_rng(1).random((1, half, half), dtype=np.float32)
    for mode in ("reflect", "constant"):
        plans = [rotation._shear_plans(rate, half, half / 2 - 0.5, half, mode, np.float32) for _, rate in shears]
        tb = best_time(lambda mode=mode: [rotation._shear_plans(rate, half, half / 2 - 0.5, half, mode, np.float32)
                                          for _, rate in shears], repeat)
        passes = []
        for b in backends:
            be = get_backend(b.name)
            src, dst = be.asarray(rimg), be.empty(rimg.shape, np.float32)

            def run(be=be, src=src, dst=dst, plans=plans):
                for (axis, _), p in zip(shears, plans):
                    be.recurse_lines(src, dst, 2 if axis == -1 else 1, p, 0.0)
            t = best_time(run, repeat, be.synchronize)
            passes.append(f"{b.name} {t * 1e3:.0f} ({tb / t:.0%})")
        lines.append(f"| rotation {half}², 10°, mode {mode}: plans of the 3 shears | {tb * 1e3:.0f} | "
                     f"{', '.join(passes)} |")
    return lines



# --------------------------------------------------------------------------------------
# (f) the column filter's design
# --------------------------------------------------------------------------------------
def _thiran2_stages(d):
    """The former column filter: Thiran's second-order allpass (one stage, delays 2.05 to 3.05)."""
    d = np.asarray(d, np.float64)
    a1 = -2.0 * (d - 2.0) / (d + 1.0)
    a2 = (d - 1.0) * (d - 2.0) / ((d + 1.0) * (d + 2.0))
    h1 = a1 * (1.0 - a2)
    h2 = 1.0 - a1 * h1 - a2 * a2
    lam = 0.5 * (-a1 + 1j * np.sqrt(4.0 * a2 - a1 * a1))
    return [(lam, h1 + 1j * (h1 * lam.real - h2) / lam.imag, a2)]


def _use_design(stages, delay_min):
    from gfgpu._core import lines as core_lines
    core_lines.DELAY_MIN = delay_min
    oblique.allpass_delay = stages
    for f in (core_lines.shear_maps, oblique.column_delays, oblique._column_plans):
        f.cache_clear()


def _phase_spread(order, lo, cycles):
    """max - min over delays in [lo, lo + 1) of the allpass's phase error (rad) at ``cycles``/px."""
    w = 2 * np.pi * np.asarray(cycles)
    d = np.linspace(lo, lo + 1, 400, endpoint=False) + 1e-9
    a = oblique.thiran_denominator(d, order)
    z = np.exp(-1j * np.outer(np.arange(order + 1), w))           # (order + 1, freqs)
    resp = (a[:, ::-1] @ z) / (a @ z)
    err = np.angle(resp * np.exp(1j * np.outer(d, w)))
    return err.max(axis=0) - err.min(axis=0)


DESIGN_CASES = [((23, -9), (230, 90)), ((3, 25), (96, 800)), ((9, 23), (90, 230)), ((25, 24), (100, 96)),
                ((-7, -30), (70, 300))]


def design_table():
    current = (oblique.allpass_delay, __import__("gfgpu._core.lines", fromlist=["x"]).DELAY_MIN)
    designs = [("Thiran 3, d in [2.3, 3.3) (now)", current, (3, 2.3)),
               ("Thiran 2, d in [2.05, 3.05) (before)", (_thiran2_stages, 2.05), (2, 2.05))]
    cyc = (0.125, 0.1875, 0.25)
    lines = ["### (f) column filter: rel. L2 (%) against the exact direction (Fourier), numpy float64, mode wrap", "",
             "| design | phase spread (rad) at " + ", ".join(f"{c:g}" for c in cyc) + " cyc/px | cut | "
             + " | ".join(f"{v} box / green" for v, _ in DESIGN_CASES) + " |",
             "|---|---|---|" + "---:|" * len(DESIGN_CASES)]
    try:
        for label, (stages, dmin), (order, lo) in designs:
            _use_design(stages, dmin)
            spread = ", ".join(f"{x:.1e}" for x in _phase_spread(order, lo, cyc))
            for cut in (0.25, 0.1):
                cells = []
                for v, shape in DESIGN_CASES:
                    rng = np.random.default_rng(3)
                    ky, kx = np.fft.fftfreq(shape[0])[:, None], np.fft.fftfreq(shape[1])[None, :]
                    img = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * (np.hypot(ky, kx) < cut)))
                    box = rel(motion_blur(img, v, psf="box", mode="wrap", backend="numpy"),
                              box_transfer_reference(img, v))
                    green = rel(motion_blur(img, v, mode="wrap", backend="numpy"),
                                transfer_reference(img, uniform_motion_program(2, v)))
                    cells.append(f"{box * 100:.3f} / {green * 100:.3f}")
                lines.append(f"| {label} | {spread} | {cut} | " + " | ".join(cells) + " |")
    finally:
        _use_design(*current)
    return lines


# --------------------------------------------------------------------------------------
# (g) before and now, with OpenCV's 2-D line kernels, in one process
# --------------------------------------------------------------------------------------
#: issue 27's oblique velocities and their mirror images (vy -> -vy)
COMPARE_VELOCITIES = [(2, 7), (7, 25), (23, 101), (-2, 7), (-7, 25), (-23, 101)]
#: issue 27's acceptance (Mpix/s on OpenCL, and the ratio to cv2.filter2D)
OBLIQUE_TARGET = {"green": 150.0, "box": 100.0}
OBLIQUE_VS_CV2 = 1.5


def gfgpu_at(rev):
    """gfgpu as of git revision ``rev``, imported as the package ``gfgpu_at_<rev>`` (its modules
    import one another relatively, so it runs beside the working tree's own)."""
    root = Path(__file__).resolve().parents[1]
    sha = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", rev], check=True, capture_output=True,
                         text=True).stdout.strip()
    name = f"gfgpu_at_{sha}"
    tmp = Path(tempfile.mkdtemp(prefix="gfgpu_before_"))
    archive = subprocess.run(["git", "-C", str(root), "archive", sha, "gfgpu"], check=True,
                             capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(tmp, filter="data")
    (tmp / "gfgpu").rename(tmp / name)
    sys.path.insert(0, str(tmp))
    return __import__(name), sha


def compare_table(rev, shapes, repeat):
    """Table (g): Markdown lines."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import motion_refs as refs
    before, sha = gfgpu_at(rev)
    try:
        import cv2
    except ImportError:
        cv2 = None
    lines = [f"### (g) issue 27's oblique rows: OpenCL as of {sha} and now, one process, best of {repeat} "
             f"alternated rounds, float32, Mpix/s", "",
             f"load average before: `{os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f}`", "",
             "| shape | velocity | PSF | before | now | now / before | cv2.filter2D (kernel) | now / cv2 | "
             "issue 27 target |", "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for shape in shapes:
        img = np.random.default_rng(0).random(shape, dtype=np.float32)
        out = np.empty_like(img)
        n = img.size / 1e6
        for v in COMPARE_VELOCITIES:
            calls = {}
            for psf in ("green", "box"):
                calls["before", psf] = lambda v=v, psf=psf, img=img, out=out: before.motion.motion_blur(
                    img, v, psf=psf, output=out, backend="opencl")
                calls["now", psf] = lambda v=v, psf=psf, img=img, out=out: motion_blur(
                    img, v, psf=psf, output=out, backend="opencl")
            kernels = {}
            if cv2 is not None:
                for psf, make in (("green", refs.green_line_kernel), ("box", refs.box_line_kernel)):
                    ker, anchor = make(v)
                    kernels[psf] = ker.shape
                    calls["cv2", psf] = lambda ker=ker, anchor=anchor, img=img, out=out: cv2.filter2D(
                        img, -1, ker, dst=out, anchor=anchor, borderType=cv2.BORDER_REFLECT)
            for fn in calls.values():      # builds, plans
                fn()
            best = {k: float("inf") for k in calls}
            for _ in range(repeat):
                for k, fn in calls.items():
                    t0 = time.perf_counter()
                    fn()
                    best[k] = min(best[k], time.perf_counter() - t0)
            for psf in ("green", "box"):
                old, new = n / best["before", psf], n / best["now", psf]
                if ("cv2", psf) in best:
                    peer = n / best["cv2", psf]
                    ker = kernels[psf]
                    peer_cell, ratio = f"{peer:.0f} ({ker[0]}x{ker[1]})", f"{new / peer:.2f}"
                    need = max(OBLIQUE_TARGET[psf], OBLIQUE_VS_CV2 * peer)
                else:
                    peer_cell, ratio, need = "no OpenCV", "", OBLIQUE_TARGET[psf]
                verdict = f"{'met' if new >= need else 'NOT met'} (>= {need:.0f})"
                lines.append(f"| {shape[0]}x{shape[1]} | {v} | {psf} | {old:.0f} | {new:.0f} | {new / old:.2f} | "
                             f"{peer_cell} | {ratio} | {verdict} |")
            print(lines[-2] + "\n" + lines[-1], file=sys.stderr, flush=True)
    load = os.getloadavg()
    lines += ["", f"load average after: `{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}` (2 cores shared: absolute "
              f"figures are inflated by it, the ratios less)"]
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--backends", default="numpy,warp,opencl")
    ap.add_argument("--skip-speed", action="store_true", help="accuracy tables only")
    ap.add_argument("--designs-only", action="store_true", help="table (f) only")
    ap.add_argument("--compare", metavar="REV", help="table (g) only: OpenCL as of git revision REV against now")
    ap.add_argument("--shapes", default="4096x4096,2048x2048,1999x3001",
                    help="table (g): comma-separated HxW (default: %(default)s)")
    args = ap.parse_args(argv)
    if args.compare:
        shapes = [tuple(int(x) for x in s.split("x")) for s in args.shapes.split(",")]
        print("\n".join(compare_table(args.compare, shapes, args.repeat)), flush=True)
        return
    backends = []
    for name in args.backends.split(","):
        try:
            backends.append(get_backend(name))
        except Exception as exc:     # report and go on with the others
            print(f"<!-- backend {name} unavailable: {exc} -->")
    if args.designs_only:
        print("\n".join(design_table()), flush=True)
        return
    print("\n".join(["## Oblique passes", ""] + accuracy_tables(backends)), flush=True)
    print("\n".join([""] + design_table()), flush=True)
    if not args.skip_speed:
        print("\n".join([""] + speed_table(args.size, args.repeat, backends)), flush=True)
        print("\n".join([""] + plan_table(args.size, args.repeat, backends)), flush=True)


if __name__ == "__main__":
    main()
