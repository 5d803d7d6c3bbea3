"""Stereo benchmark: gfgpu.disparity beside OpenCV StereoBM and StereoSGBM, same run.

Scenes: the four Middlebury pairs in ``benchmarks/data/stereo/`` (tsukuba, venus, teddy, cones;
non-occluded masks; conventions and terms of use in its README.md) and
``skimage.data.stereo_motorcycle()`` (pixels with finite ground truth), plus random-dot
stereograms with piecewise-constant and slanted disparities (the chapter's Fig. 8), and a
camera-size synthetic pair (``synth-1500``: 1000 x 1500, 192 disparities, a smooth random texture
shifted by a smooth disparity field between 30 and 180 px).  Metrics:
bad-1 / bad-2 = % of evaluated pixels with |d - gt| > 1 / 2 px, with rejected pixels (holes)
filled by :func:`gfgpu.stereo.fill_holes` (the smaller of the nearest valid left/right
neighbours, as that README prescribes) for every method; the share of holes before filling
is printed too.  Times are per pair, steady state (the best of
``--repeat`` runs after one warm-up, which also compiles the kernels).  Each (scene, method)
runs in a fresh process (``multiprocessing`` spawn), so its peak resident memory (``ru_maxrss``)
is its own: the table gives the peak and the peak above the process's RSS before the first call
(imports and the images loaded).

OpenCV settings (from ``benchmarks/data/stereo/README.md``): StereoBM blockSize 15, StereoSGBM
blockSize 5, P1 = 8·bs², P2 = 32·bs², uniquenessRatio 10, speckle filter 100/2,
numDisparities = next multiple of 16 above the ground truth's maximum; SGBM in its default mode
(5 directions in one pass) and in full 8-path mode (``MODE_HH``).  gfgpu searches the same range.

Usage::

    python benchmarks/stereo.py [--backends opencl warp] [--methods sgm uniform affine]
                                [--repeat 3] [--figure docs/stereo_scenes.png]
                                [--scenes tsukuba venus teddy cones motorcycle synth-1500]
    python benchmarks/stereo.py --stages teddy [--backends opencl]   # per-stage times only
    python benchmarks/stereo.py --stream teddy [--frames 20]          # StereoMatcher vs disparity()
    python benchmarks/stereo.py --windows 1 3 5 7 9 11 13 15 --scenes tsukuba venus teddy cones motorcycle
    python benchmarks/stereo.py --compare REV --scenes teddy synth-1500 [--repeat 7]  # REV and now, one process
    python benchmarks/stereo.py --compare REV --kernels synth-1500 [--repeat 5]    # per kernel, REV and now
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import resource
import time

import numpy as np

from gfgpu.stereo import disparity, fill_holes, random_dot_stereogram
from gfgpu.stereo import kernels as stereo_kernels

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "stereo")
SCENES = ("tsukuba", "venus", "teddy", "cones")


def load_middlebury(scene):
    import imageio.v3 as iio
    folder = os.path.join(DATA, scene)
    meta = json.load(open(os.path.join(folder, "meta.json")))
    left = iio.imread(os.path.join(folder, "left.png"))
    right = iio.imread(os.path.join(folder, "right.png"))
    gt = iio.imread(os.path.join(folder, meta["gt_disparity_left"])).astype(np.float64)
    if gt.ndim == 3:
        gt = gt[..., 0]
    mask = iio.imread(os.path.join(folder, "mask_nonocc.png"))
    if mask.ndim == 3:
        mask = mask[..., 0]
    mask = (mask > 128) & (gt > 0)
    return left, right, gt / meta["gt_scale"], mask, float(meta["gt_max_disparity_px"])


def load_motorcycle():
    from skimage import data
    left, right, gt = data.stereo_motorcycle()
    gt = np.asarray(gt, np.float64)
    mask = np.isfinite(gt)
    return left, right, np.where(mask, gt, 0), mask, float(gt[mask].max())


def random_dots(kind, shape=(240, 320), seed=0):
    """Random-dot pair (gfgpu.stereo.random_dot_stereogram) with a known disparity map."""
    from scipy import ndimage
    h, w = shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    if kind == "rds-steps":      # piecewise constant: background, two raised squares (sub-pixel)
        gt = np.full((h, w), 6.0)
        gt[60:180, 60:150] = 14.5
        gt[90:200, 190:290] = 23.25
    else:                        # slanted plane
        gt = 4.0 + 0.04 * xx + 0.02 * yy
    left, right = random_dot_stereogram(gt, seed)
    mask = np.zeros((h, w), bool)
    mask[:, 32:] = True          # left margin: no right pixel to match
    jumps = (np.abs(np.diff(gt, axis=1, append=gt[:, -1:])) > 1) | \
        (np.abs(np.diff(gt, axis=0, append=gt[-1:])) > 1)
    mask &= ~ndimage.binary_dilation(jumps, iterations=3)   # occlusions and discontinuities
    return left.astype(np.uint8), right.astype(np.uint8), gt, mask, float(gt.max())


def synthetic(shape=(1000, 1500), seed=0, top=180.0):
    """Camera-size pair: a smooth random texture (``random_dot_stereogram``) shifted by a smooth
    disparity field (a sum of broad Gaussians, 30..``top`` px); 192 disparities searched
    (``synth-3000``: 2000 x 3000, 30..240 px, 256 disparities)."""
    from scipy import ndimage
    h, w = shape
    rng = np.random.default_rng(seed + 1)
    field = ndimage.gaussian_filter(rng.standard_normal((h // 50, w // 50)), 2.0)
    field = ndimage.zoom(field, (h / field.shape[0], w / field.shape[1]), order=3)[:h, :w]
    gt = 30 + (top - 30) * (field - field.min()) / np.ptp(field)
    left, right = random_dot_stereogram(gt, seed)
    xx = np.arange(w)[None]
    mask = (xx - gt >= 8) & (xx < w - 8)       # the match inside the right view
    return left.astype(np.uint8), right.astype(np.uint8), gt, mask, 16 * np.ceil((top + 12) / 16) - 2


def load_scene(scene):
    if scene in SCENES:
        return load_middlebury(scene)
    if scene == "motorcycle":
        return load_motorcycle()
    if scene == "synth-1500":
        return synthetic()
    if scene == "synth-3000":
        return synthetic((2000, 3000), top=240.0)
    return random_dots(scene)


def grey(img):
    img = np.asarray(img)
    if img.ndim == 3:
        img = img[..., :3].astype(np.float32).mean(axis=-1)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def opencv_matchers(num_disp):
    import cv2
    bm = cv2.StereoBM_create(numDisparities=num_disp, blockSize=15)
    bm.setUniquenessRatio(10)
    bm.setSpeckleWindowSize(100)
    bm.setSpeckleRange(2)
    bs = 5
    sgbm, sgbm_hh = (cv2.StereoSGBM_create(minDisparity=0, numDisparities=num_disp, blockSize=bs,
                                           P1=8 * bs * bs, P2=32 * bs * bs, uniquenessRatio=10,
                                           speckleWindowSize=100, speckleRange=2, mode=mode)
                     for mode in (cv2.STEREO_SGBM_MODE_SGBM, cv2.STEREO_SGBM_MODE_HH))

    def run(matcher):
        def match(left, right):
            raw = matcher.compute(grey(left), grey(right)).astype(np.float32) / 16
            raw[raw < 0] = np.nan
            return raw
        return match
    return {"OpenCV StereoBM": run(bm), "OpenCV StereoSGBM": run(sgbm), "OpenCV SGBM 8-path": run(sgbm_hh)}


def timed(fn, repeat):
    out = fn()   # warm-up (kernel compilation, caches)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def stage_times(scene_images, d_max, backend, repeat, steps=2, paths=4):
    """Steady-state seconds of each stage of ``disparity(..., method="sgm")`` on ``backend``:
    census (with the Green shifts of the right view when ``steps > 1``), the fused matcher
    (cost, aggregation and selection; on CPUs streamed in bands of rows), and the whole call
    (which adds the host's grey conversion and left-right check)."""
    from gfgpu import stereo
    from gfgpu.backends import resolve_backend
    be = resolve_backend(backend, None)
    left, right = (stereo.matching.grey_image(img, name) for img, name in zip(scene_images, ("left", "right")))
    h, w = left.shape
    radius, block = 3, 3
    n = d_max * steps + 1
    state = {}

    def census():
        # the views as disparity() prepares them: scaled, the right view's sub-pixel planes
        # Green-shifted on the host (float64), then the census on the device
        lft, planes = stereo.matching.matching_views(left, right, steps)
        state["cl"] = be.empty((1, h, w), np.uint64)
        stereo_kernels.census(be, be.asarray(lft), state["cl"], 0, radius)
        state["cr"] = be.empty((steps, h, w), np.uint64)
        for f in range(steps):
            stereo_kernels.census(be, be.asarray(planes[f]), state["cr"], f, radius)

    def match():
        outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
        stereo_kernels.match(be, state["cl"], state["cr"], *outs, 0, n, steps, block,
                             *stereo.default_penalties(block, paths), paths, 10, stereo.matching._budget(be))

    times = {}
    for name, fn in (("census" + (" + Green shifts (host)" if steps > 1 else ""), census),
                     (f"cost + {paths}-path aggregation + selection", match)):
        best = np.inf
        for _ in range(repeat + 1):        # the first run compiles
            t0 = time.perf_counter()
            fn()
            be.synchronize()
            best = min(best, time.perf_counter() - t0)
        times[name] = best
    _, times["disparity() total"] = timed(lambda: stereo.disparity(*scene_images, d_max, subpixel_steps=steps,
                                                                   paths=paths, backend=be), repeat)
    return times


def kernel_profile(scene_images, d_max, repeat, steps=2, paths=4, package=None):
    """Seconds per OpenCL kernel and per host step of one steady ``disparity`` call (the best of
    ``repeat`` after a warm-up): every launch is waited for and timed by its kernel's name (so the
    kernels do not overlap, as they do not in the band matcher's queue), and the host's
    grey conversion, view preparation (scaling; Green-shifted planes where the host makes them) and
    speckle filter are timed around their functions.  ``package``: the gfgpu package to profile
    (default: this one; ``--compare`` passes an older revision's).  Returns ({name: seconds},
    whole call seconds)."""
    if package is None:
        import gfgpu as package
    import importlib
    stereo = importlib.import_module(package.__name__ + ".stereo")
    ocl = importlib.import_module(package.__name__ + ".backends.opencl.launch")
    matching = importlib.import_module(package.__name__ + ".stereo.matching")
    post = importlib.import_module(package.__name__ + ".stereo.postfilter")
    be_name = "opencl"
    acc = {}
    real_launch, real_views, real_grey = ocl.launch, matching.matching_views, matching.grey_image
    real_preset, real_copy = ocl.PresetLaunch.__call__, ocl.copy_bytes
    real_post = post.apply_postfilter
    # the views' scaling and flush (older revisions have no _scale2; the host-made planes' flush
    # is inside matching_views' time)
    real_scaled = {name: getattr(matching, name) for name in ("_scaled_views", "_scale2", "_flush")
                   if hasattr(matching, name)}

    def add(name, t0):
        acc[name] = acc.get(name, 0.0) + time.perf_counter() - t0

    def launch(be, knl, *a):
        t0 = time.perf_counter()
        evt = real_launch(be, knl, *a)
        evt.wait()
        add("kernel " + knl.function_name, t0)
        return evt

    def preset(self, *a):        # the band loop's launches with their arguments set once
        t0 = time.perf_counter()
        evt = real_preset(self, *a)
        evt.wait()
        add("kernel " + self.function_name, t0)
        return evt

    def copy(*a, **k):          # device copies (the right view into its plane 0)
        t0 = time.perf_counter()
        evt = real_copy(*a, **k)
        evt.wait()
        add("device copies", t0)
        return evt

    def views(*a):
        t0 = time.perf_counter()
        out = real_views(*a)
        add("host: matching_views (scale, Green-shifted planes)", t0)
        return out

    def grey(*a):
        t0 = time.perf_counter()
        out = real_grey(*a)
        add("host: grey_image", t0)
        return out

    def speckles(*a):
        t0 = time.perf_counter()
        out = real_post(*a)
        add("host: speckle filter (apply_postfilter)", t0)
        return out

    depth = [0]

    def timed_scaling(fn):
        def scaled(*a):
            depth[0] += 1          # (_scaled_views calls _scale2 and _flush: timed once)
            t0 = time.perf_counter()
            try:
                return fn(*a)
            finally:
                depth[0] -= 1
                if depth[0] == 0:
                    add("host: scaled views", t0)
        return scaled

    ocl.launch, matching.matching_views, matching.grey_image = launch, views, grey
    ocl.PresetLaunch.__call__, ocl.copy_bytes = preset, copy
    post.apply_postfilter = speckles
    for name, fn in real_scaled.items():
        setattr(matching, name, timed_scaling(fn))
    try:
        best, best_total = None, np.inf
        for _ in range(repeat + 1):
            acc.clear()
            t0 = time.perf_counter()
            stereo.disparity(*scene_images, d_max, subpixel_steps=steps, paths=paths, backend=be_name)
            total = time.perf_counter() - t0
            if total < best_total:
                best, best_total = dict(acc), total
    finally:
        ocl.launch, matching.matching_views, matching.grey_image = real_launch, real_views, real_grey
        ocl.PresetLaunch.__call__, ocl.copy_bytes = real_preset, real_copy
        post.apply_postfilter = real_post
        for name, fn in real_scaled.items():
            setattr(matching, name, fn)
    return best, best_total


def _programs(be):
    """Programs built so far in this process (OpenCL; Warp builds its module once, not per size)."""
    if be.name != "opencl":
        return 0
    from gfgpu.backends.opencl import launch
    return len(launch._programs)


def stream_times(scene, backend, frames=20):
    """``StereoMatcher.compute`` on ``frames`` pairs of ``scene`` (each with its own seeded noise,
    σ = 1 grey level, so that every frame differs) against ``disparity()`` on the same frames,
    interleaved in this process (one compute, then one disparity call, per frame) so that both see
    the same machine load.  Returns the first frame's seconds, the median and largest of frames
    2..N, disparity's median (steady: after a warm-up call), and the programs built at the first
    frame and after it."""
    from gfgpu import stereo
    from gfgpu.backends import resolve_backend
    be = resolve_backend(backend, None)
    left, right, _, _, top = load_scene(scene)
    d_max = 16 * int(np.ceil((top + 1) / 16)) - 1
    rng = np.random.default_rng(0)
    pairs = [(np.clip(left + rng.normal(0, 1, left.shape), 0, 255).astype(np.float32),
              np.clip(right + rng.normal(0, 1, right.shape), 0, 255).astype(np.float32)) for _ in range(frames)]
    matcher = stereo.StereoMatcher(pairs[0][0].shape[:2], d_max, backend=be)
    built0 = _programs(be)
    t0 = time.perf_counter()
    matcher.compute(*pairs[0])
    first = time.perf_counter() - t0
    built1 = _programs(be)
    stereo.disparity(*pairs[0], d_max, backend=be)            # warm-up of the one-shot call
    per_frame, one_shot = [], []
    for lft, rgt in pairs[1:]:
        t0 = time.perf_counter()
        got = matcher.compute(lft, rgt)
        per_frame.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        want = stereo.disparity(lft, rgt, d_max, backend=be)
        one_shot.append(time.perf_counter() - t0)
        if not np.array_equal(got, want, equal_nan=True):
            raise AssertionError("StereoMatcher.compute differs from disparity()")
    return {"shape": pairs[0][0].shape[:2], "d_max": d_max, "first": first, "median": float(np.median(per_frame)),
            "max": max(per_frame), "disparity": float(np.median(one_shot)), "built_first": built1 - built0,
            "built_after": _programs(be) - built1}


def compare(rev, scenes, backend, repeat):
    """The default ``disparity`` as of git revision ``rev`` and now (the working tree), and OpenCV
    StereoSGBM, alternated in one process on each scene (each warmed up first; best of ``repeat``
    rounds, wall and this process's CPU time): Markdown rows, with whether the two maps are
    identical and the load average before and after each scene."""
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from oblique import gfgpu_at
    before, sha = gfgpu_at(rev)
    print(f"default sgm ({backend}) as of {sha} and now, StereoSGBM ({SGBM_SETTINGS}), one process, best of "
          f"{repeat} alternated rounds\n")
    print(f"| scene | {sha} (ms) | now (ms) | SGBM (ms) | {sha} / SGBM | now / SGBM | now / {sha} | CPU {sha} (ms) | "
          f"CPU now (ms) | CPU SGBM (ms) | maps identical | load |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|")
    for scene in scenes:
        calls = _compared_calls(scene, before.stereo.disparity, sha, backend)
        maps = {who: fn() for who, fn in calls.items()}       # builds the kernels
        load0 = os.getloadavg()[0]
        wall, cpu = dict.fromkeys(calls, np.inf), dict.fromkeys(calls, np.inf)
        for _ in range(repeat):
            for who, fn in calls.items():
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                wall[who] = min(wall[who], time.perf_counter() - t0)
                cpu[who] = min(cpu[who], time.process_time() - c0)
        same = np.array_equal(maps[sha], maps["now"], equal_nan=True)
        ms = {who: 1e3 * t for who, t in wall.items()}
        print(f"| {scene} | {ms[sha]:.1f} | {ms['now']:.1f} | {ms['SGBM']:.1f} | {wall[sha] / wall['SGBM']:.2f}x | "
              f"{wall['now'] / wall['SGBM']:.2f}x | {wall['now'] / wall[sha]:.2f} | {1e3 * cpu[sha]:.1f} | "
              f"{1e3 * cpu['now']:.1f} | {1e3 * cpu['SGBM']:.1f} | {same} | {load0:.1f}-{os.getloadavg()[0]:.1f} |",
              flush=True)


def compare_kernels(rev, scene, repeat):
    """:func:`kernel_profile` of the default ``disparity`` (OpenCL) as of git revision ``rev`` and
    now, alternated in one process for ``repeat`` rounds (each warmed up first): the least seconds
    of each kernel and host step over the rounds, as a Markdown table."""
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from oblique import gfgpu_at
    before, sha = gfgpu_at(rev)
    import gfgpu
    left, right, _, _, top = load_scene(scene)
    d_max = 16 * int(np.ceil((top + 1) / 16)) - 1
    best = {sha: {}, "now": {}}
    load0 = os.getloadavg()[0]
    for _ in range(repeat):
        for who, pkg in ((sha, before), ("now", gfgpu)):
            parts, total = kernel_profile((left, right), d_max, 1, package=pkg)
            parts["whole call"] = total
            for name, sec in parts.items():
                best[who][name] = min(best[who].get(name, np.inf), sec)
    print(f"{scene}, {left.shape[1]}x{left.shape[0]}, d = 0..{d_max}, opencl, as of {sha} and now, one process, "
          f"least of {repeat} alternated rounds (each launch waited for), load {load0:.1f}-{os.getloadavg()[0]:.1f}\n")
    print(f"| step | {sha} (ms) | now (ms) | now / {sha} |\n|---|---:|---:|---:|")
    names = sorted(set(best[sha]) | set(best["now"]), key=lambda k: -max(best[sha].get(k, 0), best["now"].get(k, 0)))
    for name in names:
        a, b = best[sha].get(name), best["now"].get(name)
        ratio = f"{b / a:.2f}" if a and b else "-"
        fmt = lambda v: "-" if v is None else f"{v * 1e3:.1f}"
        print(f"| {name} | {fmt(a)} | {fmt(b)} | {ratio} |")


def _compared_calls(scene, disparity_before, sha, backend):
    """{who: call} of :func:`compare` on ``scene``."""
    left, right, _, _, top = load_scene(scene)
    num_disp = 16 * int(np.ceil((top + 1) / 16))
    sgbm = opencv_matchers(num_disp)["OpenCV StereoSGBM"]
    return {sha: lambda: disparity_before(left, right, num_disp - 1, backend=backend),
            "now": lambda: disparity(left, right, num_disp - 1, backend=backend),
            "SGBM": lambda: sgbm(left, right)}


#: OpenCV's settings, as :func:`opencv_matchers` makes them (for the tables' captions)
SGBM_SETTINGS = "blockSize 5, P1 8*25, P2 32*25, uniquenessRatio 10, speckle 100/2"


def _rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _run_isolated(scene, name, backends, sweep_backend, repeat):
    """One (scene, method) in this (fresh) process: (disparity, seconds, peak RSS MB, RSS MB
    before the first call)."""
    left, right, gt, mask, top = load_scene(scene)
    num_disp = 16 * int(np.ceil((top + 1) / 16))
    d_max = num_disp - 1
    if name.startswith("OpenCV"):
        fn = lambda: opencv_matchers(num_disp)[name](left, right)
    else:
        method, be = name.split()[1], name.split("(")[1].rstrip(")")
        # "sgm": the defaults (half-pixel cost samples from the Green-shifted right view);
        # "sgm-fast": whole-pixel samples (subpixel_steps=1)
        options = {"method": "sgm", "subpixel_steps": 1} if method == "sgm-fast" else {"method": method}
        fn = lambda: disparity(left, right, d_max, backend=be, **options)
    base = _rss_mb()
    disp, seconds = timed(fn, repeat)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return disp, seconds, peak, base


def scores(disp, gt, mask):
    filled = fill_holes(disp)
    err = np.abs(filled - gt)[mask]
    return 100 * np.mean(err > 1), 100 * np.mean(err > 2), 100 * np.mean(~np.isfinite(disp)[mask])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backends", nargs="+", default=["opencl"])
    ap.add_argument("--methods", nargs="+", default=["sgm", "sgm-fast", "uniform", "affine"],
                    help="sgm: the defaults; sgm-fast: subpixel_steps=1; uniform, affine: the chapter's sweeps")
    ap.add_argument("--sweep-backend", default="opencl", help="backend of the uniform/affine rows")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES) + ["motorcycle", "rds-steps", "rds-slant"])
    ap.add_argument("--figure", help="write a figure (left, ground truth, gfgpu, SGBM) here")
    ap.add_argument("--stages", metavar="SCENE", help="print per-stage times of sgm on this Middlebury "
                    "scene (and SGBM's time) instead of the scene table")
    ap.add_argument("--stream", metavar="SCENE", help="StereoMatcher.compute on --frames noisy copies of this "
                    "scene's pair against disparity() on the same frames, instead of the scene table")
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--kernels", metavar="SCENE", help="print the time of each OpenCL kernel and host step of "
                    "the default sgm on this scene (each launch waited for)")
    ap.add_argument("--windows", nargs="+", type=int, metavar="W", help="bad-2 of the default sgm with each "
                    "block side W (default penalties) on --scenes, instead of the scene table")
    ap.add_argument("--compare", metavar="REV", help="the default sgm as of git revision REV and now, with "
                    "StereoSGBM, alternated in one process on --scenes (first backend), instead of the scene table")
    args = ap.parse_args()
    if args.compare and args.kernels:
        compare_kernels(args.compare, args.kernels, args.repeat)
        return
    if args.compare:
        compare(args.compare, args.scenes, args.backends[0], args.repeat)
        return
    if args.windows:
        print("| scene | " + " | ".join(f"window {w}" for w in args.windows) + " |")
        print("|---|" + "---|" * len(args.windows))
        for scene in args.scenes:
            left, right, gt, mask, top = load_scene(scene)
            d_max = 16 * int(np.ceil((top + 1) / 16)) - 1
            row = [scores(disparity(left, right, d_max, window=w, backend=args.backends[0]), gt, mask)[1]
                   for w in args.windows]
            print(f"| {scene} | " + " | ".join(f"{v:.2f}" for v in row) + " |", flush=True)
        return
    if args.stream:
        for be in args.backends:
            r = stream_times(args.stream, be, args.frames)
            print(f"{args.stream} {r['shape'][1]}x{r['shape'][0]}, d = 0..{r['d_max']}, {be}, {args.frames} frames: "
                  f"StereoMatcher.compute first {r['first'] * 1e3:.1f} ms ({r['built_first']} programs built), "
                  f"then median {r['median'] * 1e3:.1f} ms (max {r['max'] * 1e3:.1f}; {r['built_after']} built); "
                  f"disparity() steady median {r['disparity'] * 1e3:.1f} ms: "
                  f"{r['median'] / r['disparity']:.2f}x", flush=True)
        return
    if args.kernels:
        left, right, _, _, top = load_scene(args.kernels)
        num_disp = 16 * int(np.ceil((top + 1) / 16))
        parts, total = kernel_profile((left, right), num_disp - 1, max(args.repeat, 3))
        print(f"\n{args.kernels}, {left.shape[1]}x{left.shape[0]}, d = 0..{num_disp - 1}, opencl, "
              f"load {os.getloadavg()[0]:.1f}\n")
        print("| step | ms | share |\n|---|---|---|")
        for name, sec in sorted(parts.items(), key=lambda kv: -kv[1]):
            print(f"| {name} | {sec * 1e3:.1f} | {sec / total:.0%} |")
        print(f"| rest (host: checks, buffers, launches, read-back) | "
              f"{(total - sum(parts.values())) * 1e3:.1f} | {1 - sum(parts.values()) / total:.0%} |")
        print(f"| whole call | {total * 1e3:.1f} | |")
        return
    if args.stages:
        left, right, _, _, top = load_scene(args.stages)
        num_disp = 16 * int(np.ceil((top + 1) / 16))
        cols = {be: stage_times((left, right), num_disp - 1, be, max(args.repeat, 5)) for be in args.backends}
        print(f"\n{args.stages}, {left.shape[1]}x{left.shape[0]}, d = 0..{num_disp - 1} ({num_disp} samples)\n")
        print("| stage | " + " | ".join(f"{be} (ms)" for be in cols) + " |")
        print("|---|" + "---|" * len(cols))
        for stage in next(iter(cols.values())):
            print(f"| {stage} | " + " | ".join(f"{cols[be][stage] * 1e3:.1f}" for be in cols) + " |")
        try:
            _, sgbm = timed(lambda: opencv_matchers(num_disp)["OpenCV StereoSGBM"](left, right), max(args.repeat, 5))
            print("| OpenCV StereoSGBM (whole) | " + " | ".join(f"{sgbm * 1e3:.1f}" for _ in cols) + " |")
        except ImportError:
            print("OpenCV (cv2) not installed: SGBM skipped")
        return

    rows, shown = [], {}
    ctx = multiprocessing.get_context("spawn")
    for scene in args.scenes:
        if scene in SCENES and not os.path.isdir(os.path.join(DATA, scene)):
            print(f"skipping {scene}: {DATA} not found")
            continue
        left, right, gt, mask, top = load_scene(scene)
        big = left.shape[0] * left.shape[1] > 10**6
        names = [f"gfgpu {m} ({be})" for m in args.methods if m.startswith("sgm")
                 for be in args.backends if not (big and be in ("numpy", "warp"))]
        names += [f"gfgpu {m} ({args.sweep_backend})" for m in args.methods
                  if not m.startswith("sgm") and not big]
        try:
            import cv2  # noqa: F401
            names += ["OpenCV StereoBM", "OpenCV StereoSGBM", "OpenCV SGBM 8-path"]
        except ImportError:
            print("OpenCV (cv2) not installed: peers skipped")
        for name in names:
            repeat = 1 if ("uniform" in name or "affine" in name or "numpy" in name or big) else args.repeat
            with ctx.Pool(1) as pool:
                disp, seconds, peak, base = pool.apply(_run_isolated, (scene, name, args.backends,
                                                                      args.sweep_backend, repeat))
            b1, b2, holes = scores(disp, gt, mask)
            rows.append((scene, name, b1, b2, holes, seconds, peak, peak - base))
            shown[(scene, name)] = disp
            print(f"{scene:10s} {name:28s} bad-1 {b1:5.1f}  bad-2 {b2:5.1f}  holes {holes:4.1f}%  "
                  f"{seconds:6.3f} s  peak RSS {peak:7.0f} MB (+{peak - base:.0f})  load {os.getloadavg()[0]:.1f}",
                  flush=True)
        shown[(scene, "left")], shown[(scene, "gt")] = left, np.where(mask | (gt > 0), gt, np.nan)

    print("\n| scene | method | bad-1 % | bad-2 % | holes % | time (s) | time / SGBM | peak RSS (MB) | "
          "above start (MB) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for scene, name, b1, b2, holes, seconds, peak, extra in rows:
        ref = [r[5] for r in rows if r[0] == scene and r[1] == "OpenCV StereoSGBM"]
        ratio = f"{seconds / ref[0]:.1f}x" if ref else "-"
        print(f"| {scene} | {name} | {b1:.1f} | {b2:.1f} | {holes:.1f} | {seconds:.3f} | {ratio} | "
              f"{peak:.0f} | {extra:.0f} |")
    if args.figure:
        figure(shown, [s for s in args.scenes if (s, "left") in shown], args.backends[0], args.figure)


def figure(shown, scenes, backend, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cols = ("left", "gt", f"gfgpu sgm ({backend})", "OpenCV StereoSGBM")
    titles = ("left image", "ground truth", "gfgpu (sgm, holes filled)", "OpenCV SGBM (holes filled)")
    fig, axes = plt.subplots(len(scenes), 4, figsize=(13, 2.7 * len(scenes)))
    axes = np.atleast_2d(axes)
    for i, scene in enumerate(scenes):
        gt = shown[(scene, "gt")]
        lo, hi = np.nanmin(gt), np.nanmax(gt)
        for j, key in enumerate(cols):
            ax = axes[i, j]
            img = shown.get((scene, key))
            if img is None:
                ax.axis("off")
                continue
            if key == "left":
                ax.imshow(img if np.ndim(img) == 3 else img, cmap="gray")
            else:
                ax.imshow(fill_holes(img) if key != "gt" else img, cmap="turbo", vmin=lo, vmax=hi)
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(titles[j])
        axes[i, 0].set_ylabel(scene)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    print(f"figure written to {path}")


if __name__ == "__main__":
    main()
