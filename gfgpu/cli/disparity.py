"""``gfgpu disparity``: a colour-mapped disparity map of a rectified stereo pair.

Examples::

    gfgpu disparity --example motorcycle -o motorcycle_disparity.png
    gfgpu disparity left.png right.png -o disp.png --max-disparity 64 --npy disp.npy --pfm disp.pfm
    gfgpu disparity left.png right.png -o disp.png --png16 disp16.png \\
        --ply cloud.ply --focal 3740 --baseline 0.16

"""

from __future__ import annotations

import sys
import time

import numpy as np
from tqdm import tqdm

from .. import io
from .common import (
    IMAGE_OUTPUT,
    NPY_OUTPUT,
    CommandError,
    announce_backend,
    backend_args,
    check_outputs,
    duration_text,
    finite_float,
    positive_int,
    size_text,
)

EXAMPLES = ("motorcycle",)

#: the library's argument names in its messages -> this command's options
CLI_TERMS = (("max_disparity", "--max-disparity"), ("min_disparity", "--min-disparity"),
             ("focal_px", "--focal"), ("baseline", "--baseline"))

#: the largest disparity a KITTI 16-bit PNG holds: round(d * 256) <= 65535
PNG16_MAX = 65535 / 256


def disparity(*args, **kwargs):
    """:func:`gfgpu.stereo.disparity`, imported on first call (``gfgpu --help`` does not load the matcher;
    a module attribute, so that tests can replace the matching)."""
    from ..stereo import disparity as compute
    return compute(*args, **kwargs)


def _read_pair(args):
    if args.example:
        from skimage import data
        left, right, _ = data.stereo_motorcycle()
        return left, right, f"{args.example} (skimage.data, Middlebury 2014)", 64
    if not (args.left and args.right):
        raise CommandError("give LEFT and RIGHT image paths, or --example motorcycle")
    return io.read_image(args.left), io.read_image(args.right), args.left, None


def add_arguments(p):
    p.add_argument("left", nargs="?", help="left image of a rectified pair")
    p.add_argument("right", nargs="?", help="right image of the pair")
    p.add_argument("--example", choices=EXAMPLES, help="use a bundled pair instead (no download)")
    p.add_argument("-o", "--output", required=True, help="output PNG (colour-mapped disparity with a colour bar)")
    p.add_argument("--max-disparity", type=positive_int, help="largest disparity searched (px); default 64 for "
                   "the example, else estimated by a coarse pass at 1/4 size (its 99.5th percentile "
                   "+ 8 px, rounded up to 16k-1)")
    p.add_argument("--min-disparity", type=int, default=0, help="smallest disparity (px), default 0")
    p.add_argument("--method", default="sgm", choices=("sgm", "uniform", "affine"))
    p.add_argument("--npy", help="also save the raw float32 disparities (NaN = rejected; never filled) as .npy")
    p.add_argument("--pfm", help="also save them as .pfm (Middlebury's format; never filled)")
    p.add_argument("--png16", help="also save them as a 16-bit PNG, KITTI convention (d*256, 0 = invalid; never "
                   "filled); holds disparities 0 < d < 256 only, so --max-disparity must be <= 255 and "
                   "--min-disparity >= 0")
    p.add_argument("--confidence", help="also save the confidence per pixel (float32 .npy, 0..1)")
    p.add_argument("--ply", help="also save the point cloud (PLY, left view's colours); needs "
                   "--focal and --baseline, or --q")
    p.add_argument("--focal", type=finite_float, help="focal length (px) for --ply")
    p.add_argument("--baseline", type=finite_float, help="baseline for --ply (the points' unit)")
    p.add_argument("--q", help="4x4 reprojection matrix (OpenCV's Q) as a text or .npy file, for --ply")
    p.add_argument("--no-colour-bar", action="store_true", help="omit the colour bar on the PNG")
    p.add_argument("--fill", action="store_true", help="fill rejected pixels of the colour PNG (-o) from the "
                   "background (the bands at the image's edges by a smooth average, not streaks); the data "
                   "outputs (--npy, --pfm, --png16, --ply) stay raw")
    backend_args(p)


def add_parser(subparsers):
    """Add the ``disparity`` subcommand to the ``gfgpu`` command's subparsers."""
    p = subparsers.add_parser("disparity", help="disparity map of a rectified stereo pair: colour PNG")
    add_arguments(p)
    p.set_defaults(func=run)
    return p


def _q_matrix(args, shape):
    if args.q is not None and (args.focal is not None or args.baseline is not None):
        raise CommandError("--ply takes --q or --focal and --baseline, not both")
    if args.q:
        try:
            q = np.load(args.q) if args.q.endswith(".npy") else np.loadtxt(args.q)
        except (OSError, ValueError) as exc:
            raise CommandError(f"--q {args.q}: cannot read a 4x4 matrix ({exc})") from None
        if np.shape(q) != (4, 4):
            raise CommandError(f"--q {args.q}: expected a 4x4 matrix, got shape {np.shape(q)}")
        return q
    if args.focal is None or args.baseline is None:
        raise CommandError("--ply needs --focal and --baseline, or --q")
    from ..stereo import stereo_q
    h, w = shape
    return stereo_q(args.focal, args.baseline, ((h - 1) / 2, (w - 1) / 2))


def _check_png16(args, d_max):
    """--png16 cannot hold disparities >= 256 or <= 0 (they would become 0 = invalid): refused before
    the matching runs."""
    if not args.png16:
        return
    if d_max > PNG16_MAX:
        raise CommandError(f"--png16 {args.png16}: a KITTI 16-bit PNG holds disparities below 256 (d x 256 <= "
                           f"65535) and --max-disparity is {d_max}; use --max-disparity 255 or less, or --npy / "
                           f"--pfm, which keep every value")
    if args.min_disparity < 0:
        raise CommandError(f"--png16 {args.png16}: a KITTI 16-bit PNG holds disparities > 0 only (0 = invalid) "
                           f"and --min-disparity is {args.min_disparity}; use --npy or --pfm for negative ones")


def run(args):
    """Handle ``gfgpu disparity`` (parsed ``args``); returns the exit status."""
    from ..stereo import disparity_work, estimate_max_disparity, fill_holes, reproject_to_3d

    check_outputs([args.left, args.right], [
        ("-o", args.output, IMAGE_OUTPUT), ("--npy", args.npy, NPY_OUTPUT), ("--pfm", args.pfm, (".pfm",)),
        ("--png16", args.png16, (".png",)), ("--confidence", args.confidence, NPY_OUTPUT),
        ("--ply", args.ply, (".ply",))])
    if args.ply is None and (args.focal is not None or args.baseline is not None or args.q):
        raise CommandError("--focal, --baseline and --q are for --ply")
    if args.max_disparity is not None:
        _check_png16(args, args.max_disparity)
    left, right, label, default_max = _read_pair(args)
    if np.shape(left)[:2] != np.shape(right)[:2]:      # before the backend starts (and says it runs)
        (hl, wl), (hr, wr) = np.shape(left)[:2], np.shape(right)[:2]
        raise CommandError(f"LEFT and RIGHT must have one size, got {hl} x {wl} and {hr} x {wr} (rows x cols)")
    q = _q_matrix(args, np.shape(left)[:2]) if args.ply else None      # before any work or file
    be = announce_backend(args)
    t0 = time.perf_counter()
    d_max = args.max_disparity or default_max
    if d_max is None:
        d_max = estimate_max_disparity(left, right, min_disparity=args.min_disparity, backend=be)
        print(f"max disparity {d_max} (estimated by a coarse pass; set --max-disparity to override)")
    _check_png16(args, d_max)
    kw = dict(min_disparity=args.min_disparity, method=args.method)
    with tqdm(total=disparity_work(d_max, **kw), desc=f"gfgpu disparity ({args.method})",
              unit="step", disable=None, leave=False) as bar:
        disp, conf = disparity(left, right, d_max, progress=bar.update, backend=be,
                               return_confidence=True, **kw)
    elapsed = time.perf_counter() - t0
    raw = disp
    if args.fill:
        disp = fill_holes(disp, edges="smooth")
    png = io.colourise_disparity(disp, args.min_disparity, d_max)
    if not args.no_colour_bar:
        bar_img = io.colour_bar(png.shape[0], args.min_disparity, d_max, width=64)
        png = np.concatenate([png, np.zeros((png.shape[0], 4, 3), np.uint8), bar_img], axis=1)
    io.write_image(args.output, png)
    if args.npy:
        io.save_npy(args.npy, raw)                 # raw: NaN = rejected, whatever --fill does to the PNG
    if args.pfm:
        io.write_atomic(args.pfm, lambda tmp: io.write_pfm(tmp, raw))
    if args.png16:
        lost = int(np.count_nonzero(np.isfinite(raw) & ((raw * 256 >= 65535.5) | (raw * 256 < 0.5))))
        io.save_png(args.png16, io.disparity_to_png16(raw))
        if lost:     # sub-pixel refinement can pass d_max a little, values near 0 round to 0
            print(f"gfgpu disparity: warning: --png16 {args.png16}: {lost} finite disparities outside "
                  f"[1/512, 255.998] written as 0 (invalid); --npy and --pfm keep them", file=sys.stderr)
    if args.confidence:
        io.save_npy(args.confidence, conf)
    if args.ply:
        pts = reproject_to_3d(raw, q)     # rejected pixels are no points
        colours = np.asarray(left)
        if colours.dtype != np.uint8:
            top = float(colours.max()) or 1.0
            colours = np.clip(colours / top * 255, 0, 255).astype(np.uint8)
        n = io.write_ply(args.ply, pts, colours[..., :3] if colours.ndim == 3 else colours)
        print(f"{n} points -> {args.ply}")
    print(f"{label}: {size_text(disp.shape)}, disparities {args.min_disparity}..{d_max} -> {args.output} "
          f"({np.isnan(raw).mean():.1%} rejected, {duration_text(elapsed)} including device start-up)")
    return 0
