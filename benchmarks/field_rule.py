"""Accuracy of the velocity fields' default rule against the exact cells and a rendering.

For each image (Gaussian-filtered noise sigma = 2 px, band-limited noise cut 0.25 and 0.1
cycles/px, the camera photograph) and each field (the benchmark's smooth field scaled to a peak
|v| from 0.3 to 30 px; a discontinuous field: two halves moving in different directions), prints
the rel. L2 and max abs error of ``motion_blur`` (numpy, float64, mode wrap, 16-px margin) under
the Gauss rule and under the exact cells against the supersampled rendering (>= 512 exactly warped
copies, benchmarks/motion_refs.py) and of the Gauss rule against the exact cells.

With ``--speed N``: instead, the speed of both rules on the benchmark's field (2, N, N), |v| <= 30 px,
float32, numpy in and out, alternated in one process (best of ``--repeat``; the exact G_u, 17 times the
samples, once on an N/4 square, its cost refusal lifted: ``motion_blur`` refuses it), with the load
average beside each row.  The process's CPU time (all its threads) is less sensitive to other jobs
than the wall time: twice the pixels per CPU second is what two idle cores would give.

With ``--speed N --compare REV``: the Gauss rule only, ``motion_blur`` as of the git revision REV
(imported beside the working tree's, as benchmarks/oblique.py does) and now, calls alternated in one
process, best of ``--repeat`` wall and CPU times, with the load average: the A/B figure a shared
machine allows.

With ``--candidates``: rules the specification does not define, measured in float64 numpy beside
today's: the box's node count from the Euclidean length |v| instead of the dominant component and
other spacings; G_u's previous rule (3-node Gauss-Legendre cells, 2 px per node) and variants of it
(Euclidean count, wider cells, cut later, cells graded along ``t``, a capped count); the rel. L2
against the rendering of the σ = 2 noise and the photograph under the smooth and the split field at
|v| <= 30 (mode wrap), and the samples per pixel on the benchmark field.

With ``--validate``: the default rule on inputs it was not chosen on (docs/motion.md): noise of
another seed, band-limited noise, six photographs of skimage.data, and rotation, zoom, shear and
random smooth fields besides the benchmark's two, mode reflect (no seam at the crops' borders).

Usage:  python benchmarks/field_rule.py [--side 128] [--copies 512] [--backend numpy] [--peaks 0.3,1,3,10,30]
        python benchmarks/field_rule.py --candidates [--side 128] [--copies 512]
        python benchmarks/field_rule.py --validate [--side 128] [--copies 512] [--mode reflect]
        python benchmarks/field_rule.py --speed 2048 [--repeat 3] [--backend opencl] [--compare REV]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from importlib import resources
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import motion_refs as refs  # noqa: E402

from gfgpu.motion import motion_blur  # noqa: E402

MARGIN = 16


def bandlimited(n, cut, seed=0):
    rng = np.random.default_rng(seed)
    f = np.fft.fft2(rng.standard_normal((n, n)))
    fy, fx = np.fft.fftfreq(n)[:, None], np.fft.fftfreq(n)[None, :]
    img = np.real(np.fft.ifft2(f * (np.hypot(fy, fx) < cut)))
    return img / img.std()


def photograph(n):
    import imageio.v3 as iio
    with resources.as_file(resources.files("gfgpu.data").joinpath("camera.png")) as p:
        cam = iio.imread(p).astype(np.float64)
    if cam.ndim == 3:
        cam = cam[..., :3].mean(-1)
    y0, x0 = (cam.shape[0] - n) // 2, (cam.shape[1] - n) // 2
    crop = cam[y0:y0 + n, x0:x0 + n]
    return (crop - crop.mean()) / crop.std()


#: photographs of skimage's data set (none used to choose the rule: the camera was)
PHOTOS = ("astronaut", "coffee", "chelsea", "rocket", "brick", "grass")


def skimage_photo(name, n):
    """The central n x n crop of skimage.data's ``name``, grey, zero mean and unit variance."""
    from skimage import data
    img = np.asarray(getattr(data, name)(), np.float64)
    if img.ndim == 3:
        img = img[..., :3].mean(-1)
    y0, x0 = (img.shape[0] - n) // 2, (img.shape[1] - n) // 2
    crop = img[y0:y0 + n, x0:x0 + n]
    return (crop - crop.mean()) / crop.std()


def shaped_field(kind, n, vmax, seed=11):
    """Fields of other shapes, peak |v| = vmax: a rotation and a zoom about the centre, a shear
    (rows moving sideways in proportion to their height, plus a third of it across), and a random
    smooth field (Gaussian-filtered noise, sigma n/10)."""
    from scipy import ndimage
    yy, xx = np.mgrid[:n, :n].astype(np.float64) - (n - 1) / 2
    if kind == "rotation":
        field = np.stack([xx, -yy])
    elif kind == "zoom":
        field = np.stack([yy, xx])
    elif kind == "shear":
        field = np.stack([yy[::-1] / 3, yy])
    else:
        rng = np.random.default_rng(seed)
        field = np.stack([ndimage.gaussian_filter(rng.standard_normal((n, n)), n / 10, mode="wrap")
                          for _ in range(2)])
    return field * (vmax / np.hypot(field[0], field[1]).max())


def split_field(n, vmax):
    """Discontinuous: the left half moves (0.6, 0.8) vmax, the right half (-0.8, 0.6) vmax, and a still square."""
    field = np.zeros((2, n, n))
    field[0, :, : n // 2], field[1, :, : n // 2] = 0.6 * vmax, 0.8 * vmax
    field[0, :, n // 2:], field[1, :, n // 2:] = -0.8 * vmax, 0.6 * vmax
    field[:, n // 4: n // 2, n // 4: n // 2] = 0.0
    return field


def exact_cells(img, field, psf, backend):
    """The exact cells without the cost refusal (``most=0``: every path its own cells of <= 1 px)."""
    from gfgpu.backends import get_backend
    from gfgpu.motion import kernels, spec
    from gfgpu.motion.spline import spline_coefficients
    be = get_backend(backend)
    shape = (1,) + img.shape
    coef = spline_coefficients(be, be.asarray(img[None]), np.float64, shape, ("wrap", "wrap"))
    out = be.empty(shape, np.float64)
    code = spec.PSF_CODES[psf, True]
    kernels.field_blur(be, coef, be.asarray(np.ascontiguousarray(field)), out, code, 1.0, "wrap", 0.0, 0)
    return be.to_host(out)[0]


def speed(n, backend, repeat):
    import gfgpu.motion.field as fields
    # the exact G_u's cells on this field (737 samples per pixel on average) exceed the budget (432) and
    # the call is refused; lifted here to time what it would cost
    fields.FIELD_TOTAL = 10**13
    print(f"load at start: {os.getloadavg()}")
    print("| psf | rule | image | best of | s per call | Mpix/s | CPU s per call | Mpix/s per 2 CPU s | load (1 min) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for psf in ("box", "green"):
        sides = {"gauss": n, "exact": n if psf == "box" else n // 4}
        data = {}
        for side in set(sides.values()):
            img = refs.texture((side, side), seed=3).astype(np.float32)
            data[side] = (img, refs.velocity_field((side, side), 30.0), np.empty_like(img))
        for rule, side in sides.items():         # builds and warms the kernels
            img, field, out = data[side]
            motion_blur(img[:64, :64], field[:, :64, :64], psf=psf, mode="wrap", backend=backend, quadrature=rule)
        best, cpu = dict.fromkeys(sides, np.inf), dict.fromkeys(sides, np.inf)
        for _ in range(repeat):
            for rule, side in sides.items():
                img, field, out = data[side]
                c0, t0 = time.process_time(), time.perf_counter()     # CPU time: every thread of the process
                motion_blur(img, field, psf=psf, mode="wrap", backend=backend, output=out, quadrature=rule)
                best[rule] = min(best[rule], time.perf_counter() - t0)
                cpu[rule] = min(cpu[rule], time.process_time() - c0)
                if rule == "exact" and psf == "green":
                    break
        for rule, side in sides.items():
            print(f"| {psf} | {rule} | {side}² | {repeat} | {best[rule]:.3f} | {side * side / best[rule] / 1e6:.2f} | "
                  f"{cpu[rule]:.3f} | {2 * side * side / cpu[rule] / 1e6:.2f} | {os.getloadavg()[0]:.1f} |", flush=True)


def compare(n, backend, repeat, rev):
    """The Gauss rule as of ``rev`` and now, alternated in one process (Markdown rows)."""
    from oblique import gfgpu_at
    before, sha = gfgpu_at(rev)
    img = refs.texture((n, n), seed=3).astype(np.float32)
    field = refs.velocity_field((n, n), 30.0)
    out = np.empty_like(img)
    calls = {(who, psf): (lambda f=f, psf=psf: f(img, field, psf=psf, mode="wrap", backend=backend, output=out))
             for who, f in (("before", before.motion.motion_blur), ("now", motion_blur)) for psf in ("box", "green")}
    for fn in calls.values():       # builds the kernels
        fn()
    load0 = os.getloadavg()
    best, cpu = dict.fromkeys(calls, np.inf), dict.fromkeys(calls, np.inf)
    for _ in range(repeat):
        for key, fn in calls.items():
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            best[key] = min(best[key], time.perf_counter() - t0)
            cpu[key] = min(cpu[key], time.process_time() - c0)
    load1 = os.getloadavg()
    print(f"(2, {n}, {n}) field, |v| <= 30, float32, {backend}, best of {repeat} alternated; load average "
          f"{load0[0]:.2f} before, {load1[0]:.2f} after")
    print(f"| psf | {sha}: Mpix/s | now: Mpix/s | now / {sha} | {sha}: Mpix/s per 2 CPU s | now: per 2 CPU s | "
          f"now / {sha} (CPU) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    px = n * n / 1e6
    for psf in ("box", "green"):
        b, w = best["before", psf], best["now", psf]
        cb, cw = cpu["before", psf], cpu["now", psf]
        print(f"| {psf} | {px / b:.2f} | {px / w:.2f} | {b / w:.2f} | {2 * px / cb:.2f} | {2 * px / cw:.2f} | "
              f"{cb / cw:.2f} |")


def _green_cells(edges, code=1):
    """G_u's cells with 3 Gauss-Legendre nodes each, weighted as spec.gauss_rule weights them."""
    from gfgpu.motion import spec
    cum = spec.psf_cdf(code, edges)
    cum[0], cum[-1] = 0.0, 1.0
    u, g = np.asarray(spec.GAUSS_NODES)[None], np.asarray(spec.GAUSS_WEIGHTS)[None]
    a, width = edges[:-1, None], np.diff(edges)[:, None]
    t = a + width * u
    quad = width * g * spec.psf_density(code, t)
    return t.ravel(), (quad + g * (np.diff(cum)[:, None] - quad.sum(1, keepdims=True))).ravel()


def candidate_green(end, cell_px, first=8, most=128, grade=0.0, euclid=True, cap=None):
    """``(count(vy, vx), rule(n))``: max(first, ceil(length end / cell_px)) cells (at most ``cap``) over
    ``[0, end]`` velocities, equal or graded (widths growing as ``e^{grade t}``)."""
    def count(vy, vx):
        length = np.hypot(vy, vx) if euclid else np.maximum(abs(vy), abs(vx))
        n = np.minimum(np.maximum(first, np.ceil(length * end / cell_px - 1e-9)), cap or most)
        return np.where(length > 0, n, 0).astype(int)

    def rule(n):
        u = np.arange(n + 1) / n
        edges = end * u if not grade else -np.log1p(-u * (1 - np.exp(-grade * end))) / grade
        edges[-1] = end
        return _green_cells(edges)
    return count, rule


def candidate_box(spacing, euclid=True):
    """``ceil(length / spacing) + 1`` Gauss-Legendre nodes over the box's support."""
    def count(vy, vx):
        length = np.hypot(vy, vx) if euclid else np.maximum(abs(vy), abs(vx))
        return np.where(length > 0, np.minimum(np.ceil(length / spacing - 1e-9) + 1, 64), 0).astype(int)

    def rule(n):
        x, g = np.polynomial.legendre.leggauss(n)
        return 0.5 * (x + 1), g / g.sum()
    return count, rule


def candidate_spec(psf):
    """The specification's own rule (spec.rule_count, spec.gauss_rule): the default of today."""
    from gfgpu.motion import spec
    code = spec.PSF_CODES[psf, True]

    def count(vy, vx):
        return spec.rule_count(code, spec.rule_length(code, vy, vx))
    return count, lambda n: spec.gauss_rule(code, n)


CANDIDATES = {
    "box": {"ceil(L/2) + 1 (now)": candidate_spec("box"), "ceil(|v|/2) + 1": candidate_box(2.0),
            "ceil(|v|/2.5) + 1": candidate_box(2.5), "ceil(|v|/3) + 1": candidate_box(3.0)},
    "green": {"graded trapezoid, 2.25-5 px, by |v| (now)": candidate_spec("green"),
              "max(8, ceil(L)) cells (the rule before)": candidate_green(6.0, 6.0, euclid=False),
              "max(8, ceil(|v|)) cells": candidate_green(6.0, 6.0),
              "cells of 7.5 px of |v|": candidate_green(6.0, 7.5), "cells of 9 px of |v|": candidate_green(6.0, 9.0),
              "cut at 9, cells of 9 px": candidate_green(9.0, 9.0),
              "cut at 9, 12 px cells graded e^(0.3 t)": candidate_green(9.0, 12.0, grade=0.3),
              "max(8, ceil(L)) capped at 16": candidate_green(6.0, 6.0, euclid=False, cap=16)},
}


def candidates(n, copies):
    """The candidate rules' accuracy and samples per pixel (Markdown rows)."""
    from scipy import ndimage

    from gfgpu.motion import spec

    def apply(coef, field, count, rule):
        vy, vx = field
        counts = count(vy, vx)
        yy, xx = np.mgrid[:n, :n].astype(np.float64)
        out = np.zeros((n, n))
        for c in np.unique(counts):
            at = counts == c
            if c == 0:
                out[at] = spec.spline_sample(coef, yy[at], xx[at], "wrap", 0.0)[0]
                continue
            for t, wt in zip(*rule(int(c))):
                out[at] += wt * spec.spline_sample(coef, yy[at] - t * vy[at], xx[at] - t * vx[at], "wrap", 0.0)[0]
        return out

    big = refs.velocity_field((512, 512), 30.0).astype(np.float64)     # the benchmark's field, any size alike
    images = {"noise": refs.texture((n, n), seed=3), "photograph": photograph(n)}
    fields = {"smooth": refs.velocity_field((n, n), 30.0).astype(np.float64), "split": split_field(n, 30.0)}
    print("| psf | rule | samples / px | noise: smooth / split | photograph: smooth / split |")
    print("|---|---|---:|---|---|")
    for psf, rules in CANDIDATES.items():
        cells = refs.time_cells(psf, 30.0, copies)
        refs_ = {(i, f): refs.render(img, lambda yy, xx, t, v=field: (yy - t * v[0], xx - t * v[1]), cells, "wrap")
                 for i, img in images.items() for f, field in fields.items()}
        for name, (count, rule) in rules.items():
            counts = count(*big)
            samples = sum(len(rule(int(c))[0]) * int((counts == c).sum()) for c in np.unique(counts) if c) / counts.size
            errs = {}
            for i, img in images.items():
                coef = ndimage.spline_filter(img, 3, mode="grid-wrap")[None]
                for f, field in fields.items():
                    errs[i, f] = 100 * errors(apply(coef, field, count, rule), refs_[i, f])[0]
            noise, photo = (f"{errs[i, 'smooth']:.2f} / {errs[i, 'split']:.2f} %" for i in images)
            print(f"| {psf} | {name} | {samples:.1f} | {noise} | {photo} |", flush=True)


def validate(n, copies, backend, mode):
    """Rel. L2 of the default rule against the rendering on inputs the rule was not chosen on
    (Markdown rows): images x fields at peak |v| = 30, each PSF, the worst and best per image."""
    images = {"noise sigma 2 (seed 3)": refs.texture((n, n), seed=3),
              "noise sigma 2 (seed 7)": refs.texture((n, n), seed=7),
              "band-limited 0.25": bandlimited(n, 0.25, 1), "band-limited 0.1": bandlimited(n, 0.1, 2),
              "camera": photograph(n), **{name: skimage_photo(name, n) for name in PHOTOS}}
    kinds = ("smooth", "split", "rotation", "zoom", "shear", "random")
    fields = {k: (refs.velocity_field((n, n), 30.0).astype(np.float64) if k == "smooth" else
                  split_field(n, 30.0) if k == "split" else shaped_field(k, n, 30.0)) for k in kinds}
    print(f"{n}², mode {mode}, {MARGIN}-px margin, peak |v| = 30, {backend} float64; rel. L2 against "
          f">= {copies} warped copies")
    print("| image | psf | " + " | ".join(kinds) + " | worst / best |")
    print("|---|---|" + "---:|" * (len(kinds) + 1))
    for name, img in images.items():
        for psf in ("box", "green"):
            cells = refs.time_cells(psf, 30.0, copies)
            errs = []
            for field in fields.values():
                ref = refs.render(img, lambda yy, xx, t, f=field: (yy - t * f[0], xx - t * f[1]), cells, mode)
                errs.append(100 * errors(motion_blur(img, field, psf=psf, mode=mode, backend=backend), ref)[0])
            print(f"| {name} | {psf} | " + " | ".join(f"{e:.2f} %" for e in errs)
                  + f" | {max(errs):.2f} / {min(errs):.2f} % |", flush=True)


def errors(out, ref):
    d, r = (out - ref)[MARGIN:-MARGIN, MARGIN:-MARGIN], ref[MARGIN:-MARGIN, MARGIN:-MARGIN]
    return float(np.linalg.norm(d) / np.linalg.norm(r)), float(np.abs(d).max())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", type=int, default=128)
    ap.add_argument("--copies", type=int, default=512)
    ap.add_argument("--backend", default="numpy")
    ap.add_argument("--peaks", default="0.3,1,3,10,30")
    ap.add_argument("--speed", type=int, metavar="N", help="time both rules on (2, N, N) instead")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--compare", metavar="REV", help="with --speed: the Gauss rule as of git revision REV and now")
    ap.add_argument("--candidates", action="store_true", help="rules the specification does not define, measured")
    ap.add_argument("--validate", action="store_true",
                    help="the default rule on photographs, noise and field shapes it was not chosen on")
    ap.add_argument("--mode", default="reflect", help="with --validate: the boundary mode (reflect: no seam)")
    opts = ap.parse_args(argv)
    if opts.candidates:
        return candidates(opts.side, opts.copies)
    if opts.validate:
        return validate(opts.side, opts.copies, opts.backend, opts.mode)
    if opts.speed and opts.compare:
        return compare(opts.speed, opts.backend, opts.repeat, opts.compare)
    if opts.speed:
        return speed(opts.speed, opts.backend, opts.repeat)
    n = opts.side
    images = {"noise sigma 2": refs.texture((n, n), seed=3), "band-limited 0.25": bandlimited(n, 0.25, 1),
              "band-limited 0.1": bandlimited(n, 0.1, 2), "photograph": photograph(n)}
    peaks = [float(p) for p in opts.peaks.split(",")]
    print("| image | field | psf | Gauss vs rendering | exact vs rendering | Gauss vs exact |")
    print("|---|---|---|---|---|---|")
    for name, img in images.items():
        for kind in ("smooth", "split"):
            for peak in peaks:
                if kind == "smooth":
                    field = refs.velocity_field((n, n), peak).astype(np.float64)
                else:
                    field = split_field(n, peak)
                for psf in ("box", "green"):
                    cells = refs.time_cells(psf, peak, opts.copies)
                    ref = refs.render(img, lambda yy, xx, t, f=field: (yy - t * f[0], xx - t * f[1]), cells, "wrap")
                    fast = motion_blur(img, field, psf=psf, mode="wrap", backend=opts.backend)
                    exact = exact_cells(img, field, psf, opts.backend)
                    cols = [errors(fast, ref), errors(exact, ref), errors(fast, exact)]
                    print(f"| {name} | {kind}, |v| <= {peak:g} | {psf} | "
                          + " | ".join(f"{100 * a:.3f} % ({b:.4f})" for a, b in cols) + " |", flush=True)


if __name__ == "__main__":
    main()
