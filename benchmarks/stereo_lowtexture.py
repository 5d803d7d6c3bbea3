"""Low texture (issue 28, item 4): the post-filters and options of ``disparity``, chosen on a
training split, reported on a held-out split, beside OpenCV StereoSGBM.

Split (fixed here, before any measurement; never changed after looking at held-out results):

- TRAIN: tsukuba, venus (``benchmarks/data/stereo``).  Tsukuba is the one scene of the five
  where gfgpu's mean absolute error (holes filled) was above SGBM's; venus is mostly large
  uniform planes.
- HELD-OUT: teddy, cones (``benchmarks/data/stereo``) and motorcycle
  (``skimage.data.stereo_motorcycle()``), none of which any option was chosen on.

Each scene comes in three variants, made the same way on both splits: ``clean``; ``noise5``
(Gaussian noise σ = 5 grey levels on each view, independent seeds, rounded to uint8); and
``lowcon`` (low contrast: ``96 + 0.25 (I - 96)`` plus noise σ = 2, rounded to uint8 — a quarter
of the texture against the same noise: large surfaces become effectively uniform).  The
variants of one scene are not independent data: the held-out set is 3 scenes, 9 pairs.

Metrics, over the non-occluded mask (``mask_nonocc``; motorcycle: finite ground truth):
bad-2 (% |d - gt| > 2), MAE (mean |d - gt| in px) — both with holes filled by
:func:`gfgpu.stereo.fill_holes` (the smaller of the nearest valid row neighbours) — and density
(% of the mask with an estimate before filling).  OpenCV StereoSGBM as in
``benchmarks/stereo.py`` (blockSize 5, P1 = 8·25, P2 = 32·25, uniquenessRatio 10, speckle
100/2).  gfgpu searches ``0..16k - 1`` (the smallest 16k above the ground truth's maximum),
SGBM ``16k`` disparities.

Usage::

    python benchmarks/stereo_lowtexture.py --train            # the grid on TRAIN, best settings
    python benchmarks/stereo_lowtexture.py --heldout          # CANDIDATES (below) and SGBM
    python benchmarks/stereo_lowtexture.py --heldout --confirm  # the same on fresh variants
    python benchmarks/stereo_lowtexture.py --heldout --speckle-size 100 --speckle-range 2   # one more
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from stereo import load_scene, opencv_matchers

from gfgpu.stereo import disparity, fill_holes
from gfgpu.stereo.postfilter import apply_postfilter

TRAIN = ("tsukuba", "venus")
HELDOUT = ("teddy", "cones", "motorcycle")
VARIANTS = ("clean", "noise5", "lowcon")
#: fresh variants of the HELD-OUT scenes for a confirmation run (--confirm), defined after the
#: HELD-OUT results of rules A and B had been seen and before this run: ``blur`` (both views
#: blurred, Gaussian σ = 1.5 px, then noise σ = 3) and ``gain`` (the right view scaled by 0.8 and
#: raised by 10 grey levels, noise σ = 3 on both).  The rule fixed before the run: rule B's
#: setting is turned on by default if it lowers MAE on at least 5 of these 6 pairs and does not
#: raise their mean bad-2.
CONFIRM_VARIANTS = ("blur", "gain")

#: the grid searched on TRAIN
UNIQUENESS = (5, 10, 15, 20, 30)
PATHS = (4, 8)
SPECKLE_SIZE = (0, 25, 50, 100, 200, 400)
SPECKLE_RANGE = (0.5, 1.0, 2.0)
MIN_CONFIDENCE = (0.0, 0.05, 0.1, 0.15, 0.2, 0.3)


def variant(img, kind, seed, right=False):
    img = np.asarray(img, np.float64)
    if kind == "clean":
        return np.asarray(img, np.uint8)
    rng = np.random.default_rng(seed)
    if kind == "blur":
        from scipy import ndimage
        sigma = (1.5, 1.5, 0)[:img.ndim]
        out = ndimage.gaussian_filter(img, sigma) + rng.normal(0, 3, img.shape)
    elif kind == "gain":
        out = (0.8 * img + 10 if right else img) + rng.normal(0, 3, img.shape)
    elif kind == "noise5":
        out = img + rng.normal(0, 5, img.shape)
    elif kind == "lowcon":
        out = 96 + 0.25 * (img - 96) + rng.normal(0, 2, img.shape)
    else:
        raise ValueError(kind)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def pairs(scenes, variants=VARIANTS):
    for s in scenes:
        left, right, gt, mask, top = load_scene(s)
        nd = int(16 * np.ceil((top + 1) / 16))
        for k, v in enumerate(variants):
            yield f"{s}/{v}", variant(left, v, 2 * k), variant(right, v, 2 * k + 1, right=True), gt, mask, nd


def score(disp, gt, mask):
    err = np.abs(fill_holes(disp) - gt)[mask]
    return 100 * np.mean(err > 2), float(err.mean()), 100 * np.mean(np.isfinite(disp)[mask])


class Runner:
    """Base maps (disparity + confidence) per (pair, uniqueness, paths), computed once."""

    def __init__(self, backend):
        self.backend = backend
        self.cache = {}

    def base(self, name, left, right, nd, uniqueness, paths):
        key = (name, uniqueness, paths)
        if key not in self.cache:
            # the raw map (no post-filter): the filters are applied by evaluate()
            self.cache[key] = disparity(left, right, nd - 1, uniqueness=uniqueness, paths=paths,
                                        speckle_size=0, return_confidence=True, backend=self.backend)
        return self.cache[key]


def evaluate(runner, data, setting):
    """[(bad2, mae, density)] per pair for ``setting = (uniq, paths, size, range, conf)``."""
    uniq, paths, size, rng, conf = setting
    out = []
    for name, left, right, gt, mask, nd in data:
        d, c = runner.base(name, left, right, nd, uniq, paths)
        f, _ = apply_postfilter(d, c, size, rng, conf)
        out.append(score(f, gt, mask))
    return np.array(out)


#: the matcher before this work: no post-filter (``speckle_size=0``)
DEFAULT = (10, 4, 0, 1.0, 0.0)


def _table(rows, n):
    print("| uniq | paths | speckle size | range (px) | min conf | bad-2 % | MAE px | density % | MAE < default | "
          "bad-2 <= default |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for s, b2, mae, dens, nmae, nb2 in rows:
        print(f"| {s[0]} | {s[1]} | {s[2]} | {s[3]} | {s[4]} | {b2:.2f} | {mae:.3f} | {dens:.1f} | {nmae}/{n} | "
              f"{nb2}/{n} |")


def train(args):
    """The grid on TRAIN in two stages (the matcher's options alone; then, at the default
    matcher, the post-filters), ranked by mean MAE with holes filled."""
    data = list(pairs(TRAIN))
    runner = Runner(args.backend)
    base = evaluate(runner, data, DEFAULT)

    def row(setting):
        r = evaluate(runner, data, setting)
        return (setting, r[:, 0].mean(), r[:, 1].mean(), r[:, 2].mean(),
                int(np.sum(r[:, 1] < base[:, 1])), int(np.sum(r[:, 0] <= base[:, 0])))

    print(f"TRAIN {TRAIN} x {VARIANTS}: {len(data)} pairs; default (uniq 10, 4 paths, no filters): "
          f"bad-2 {base[:, 0].mean():.2f} %, MAE {base[:, 1].mean():.3f} px, density {base[:, 2].mean():.1f} %")
    matcher = [row((u, p, 0, 1.0, 0.0)) for u, p in itertools.product(UNIQUENESS, PATHS)]
    print("\nstage 1, the matcher's options (no post-filter):")
    _table(sorted(matcher, key=lambda r: r[2]), len(data))
    filters = [row((DEFAULT[0], DEFAULT[1], size, rng, conf))
               for size, rng, conf in itertools.product(SPECKLE_SIZE, SPECKLE_RANGE, MIN_CONFIDENCE)
               if size or rng == SPECKLE_RANGE[0]]
    print("\nstage 2, post-filters at the default matcher, best 20 by mean MAE:")
    _table(sorted(filters, key=lambda r: r[2])[:20], len(data))
    print("\nstage 2, speckle filter alone:")
    _table(sorted([r for r in filters if r[0][4] == 0], key=lambda r: r[2]), len(data))
    print("\nstage 2, confidence threshold alone:")
    _table(sorted([r for r in filters if r[0][2] == 0], key=lambda r: r[2]), len(data))
    combined = [row((u, 8, size, 1.0, 0.0)) for u, size in itertools.product((10, 20), (0, 100, 200))]
    print("\nstage 3, 8 paths with the speckle filter (range 1 px):")
    _table(sorted(combined, key=lambda r: r[2]), len(data))


#: the settings taken to HELD-OUT, each picked on TRAIN by a rule stated here
CANDIDATES = {
    "before (no post-filter)": DEFAULT,
    # rule A: the lowest mean TRAIN MAE among the post-filter settings (stage 2)
    "speckle 200/1": (10, 4, 200, 1.0, 0.0),
    # rule B: the lowest mean TRAIN MAE among the post-filter settings that lower MAE and do not
    # raise bad-2 on every TRAIN pair (added after rule A's held-out result had been seen)
    # (now disparity's default: speckle_size=25, speckle_range=0.5)
    "speckle 25/0.5 (default now)": (10, 4, 25, 0.5, 0.0),
    # the matcher's options: 8 paths alone (stage 1 at the default uniqueness) and with rule A's
    # filter (best of stage 3)
    "8 paths": (10, 8, 0, 1.0, 0.0),
    "8 paths + speckle 200/1": (10, 8, 200, 1.0, 0.0),
}


def heldout(args):
    variants = CONFIRM_VARIANTS if args.confirm else VARIANTS
    data = list(pairs(HELDOUT, variants))
    runner = Runner(args.backend)
    settings = dict(CANDIDATES)
    chosen = (args.uniqueness, args.paths, args.speckle_size, args.speckle_range, args.min_confidence)
    if chosen not in settings.values():
        settings["command line"] = chosen
    results = {label: evaluate(runner, data, s) for label, s in settings.items()}
    sgbm = np.array([score(opencv_matchers(nd)["OpenCV StereoSGBM"](left, right), gt, mask)
                     for name, left, right, gt, mask, nd in data])
    names = [p[0] for p in data]
    print(f"HELD-OUT {HELDOUT} x {variants}: {len(data)} pairs, backend {args.backend}")
    print("\n| setting (uniq, paths, speckle size/range, min conf) | bad-2 % | MAE px | density % | "
          "MAE < SGBM | bad-2 < SGBM | MAE vs before (lower/higher) | worst MAE change | "
          f"MAE {' / '.join(variants)} |")
    print("|---|---|---|---|---|---|---|---|---|")
    base = results["before (no post-filter)"]
    for label, s in settings.items():
        r = results[label]
        per = " / ".join(f"{r[[i for i, n in enumerate(names) if n.endswith('/' + v)], 1].mean():.3f}"
                         for v in variants)
        print(f"| {label} ({s[0]}, {s[1]}, {s[2]}/{s[3]}, {s[4]}) | {r[:, 0].mean():.2f} | {r[:, 1].mean():.3f} | "
              f"{r[:, 2].mean():.1f} | {int(np.sum(r[:, 1] < sgbm[:, 1]))}/{len(data)} | "
              f"{int(np.sum(r[:, 0] < sgbm[:, 0]))}/{len(data)} | {int(np.sum(r[:, 1] < base[:, 1]))}/"
              f"{int(np.sum(r[:, 1] > base[:, 1]))} | {np.max(r[:, 1] - base[:, 1]):+.3f} | {per} |")
    per = " / ".join(f"{sgbm[[i for i, n in enumerate(names) if n.endswith('/' + v)], 1].mean():.3f}"
                     for v in variants)
    print(f"| OpenCV StereoSGBM | {sgbm[:, 0].mean():.2f} | {sgbm[:, 1].mean():.3f} | {sgbm[:, 2].mean():.1f} | "
          f"| | | | {per} |")
    show = [lab for lab in settings
            if lab in ("before (no post-filter)", "speckle 25/0.5 (default now)", "speckle 200/1", "command line")]
    print("\nper pair, bad-2 % / MAE px / density %:\n")
    print("| pair | " + " | ".join(show) + " | OpenCV StereoSGBM |")
    print("|---" * (len(show) + 2) + "|")
    for i, name in enumerate(names):
        cells = [f"{results[lab][i, 0]:.2f} / {results[lab][i, 1]:.3f} / {results[lab][i, 2]:.1f}" for lab in show]
        print(f"| {name} | " + " | ".join(cells) + f" | {sgbm[i, 0]:.2f} / {sgbm[i, 1]:.3f} / {sgbm[i, 2]:.1f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", action="store_true", help="search the grid on TRAIN")
    ap.add_argument("--heldout", action="store_true", help="report on HELD-OUT (default vs chosen vs SGBM)")
    ap.add_argument("--confirm", action="store_true",
                    help="with --heldout: the fresh CONFIRM_VARIANTS of the HELD-OUT scenes")
    ap.add_argument("--backend", default="opencl")
    ap.add_argument("--uniqueness", type=int, default=DEFAULT[0])
    ap.add_argument("--paths", type=int, default=DEFAULT[1])
    ap.add_argument("--speckle-size", type=int, default=DEFAULT[2])
    ap.add_argument("--speckle-range", type=float, default=DEFAULT[3])
    ap.add_argument("--min-confidence", type=float, default=DEFAULT[4])
    args = ap.parse_args()
    if args.train:
        train(args)
    if args.heldout:
        heldout(args)
    if not (args.train or args.heldout):
        ap.error("give --train and/or --heldout")


if __name__ == "__main__":
    main()
