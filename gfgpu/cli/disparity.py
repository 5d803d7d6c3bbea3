"""``gfgpu disparity``: a colour-mapped disparity map of a rectified stereo pair.

Examples::

    gfgpu disparity --example motorcycle -o motorcycle_disparity.png
    gfgpu disparity left.png right.png -o disp.png --max-disparity 64 --npy disp.npy --pfm disp.pfm

"""

from __future__ import annotations

import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..stereo import disparity, disparity_work, fill_holes
from .common import CommandError, announce_backend, backend_args, refuse_overwrite

EXAMPLES = ("motorcycle",)

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
    p.add_argument("-o", "--output", required=True, help="output PNG (colour-mapped disparity)")
    p.add_argument("--max-disparity", type=int, help="largest disparity searched (px); default "
                   "64 for the example, else a quarter of the width")
    p.add_argument("--min-disparity", type=int, default=0, help="smallest disparity (px), default 0")
    p.add_argument("--method", default="sgm", choices=("sgm", "uniform", "affine"))
    p.add_argument("--npy", help="also save the raw float32 disparities (NaN = rejected) as .npy")
    p.add_argument("--pfm", help="also save them as .pfm (Middlebury's format)")
    p.add_argument("--fill", action="store_true", help="fill rejected pixels from the background")
    backend_args(p)


def add_parser(subparsers):
    """Add the ``disparity`` subcommand to the ``gfgpu`` command's subparsers."""
    p = subparsers.add_parser("disparity", help="disparity map of a rectified stereo pair: colour PNG")
    add_arguments(p)
    p.set_defaults(func=run)
    return p


def run(args):
    """Handle ``gfgpu disparity`` (parsed ``args``); returns the exit status."""
    refuse_overwrite([args.left, args.right], [args.output, args.npy, args.pfm])
    left, right, label, default_max = _read_pair(args)
    be = announce_backend(args)
    d_max = args.max_disparity or default_max or max(1, np.shape(left)[1] // 4)
    kw = dict(min_disparity=args.min_disparity, method=args.method)
    t0 = time.perf_counter()
    with tqdm(total=disparity_work(d_max, **kw), desc=f"gfgpu disparity ({args.method})",
              unit="step", disable=None, leave=False) as bar:
        disp = disparity(left, right, d_max, progress=bar.update, backend=be, **kw)
    elapsed = time.perf_counter() - t0
    if args.fill:
        disp = fill_holes(disp)
    png = io.colourise_disparity(disp, args.min_disparity, d_max)
    io.save_png(args.output, png)
    if args.npy:
        io.save_npy(args.npy, disp)
    if args.pfm:
        io.write_atomic(args.pfm, lambda tmp: io.write_pfm(tmp, disp))
    h, w = disp.shape
    print(f"{label}: {w}x{h}, disparities {args.min_disparity}..{d_max} -> {args.output} "
          f"({np.isnan(disp).mean():.1%} rejected, {elapsed:.2f} s including device start-up)")
    return 0
