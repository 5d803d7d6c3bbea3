"""``gfgpu disparity``: a colour-mapped disparity map of a rectified stereo pair.

Examples::

    gfgpu disparity --example motorcycle -o motorcycle_disparity.png
    gfgpu disparity left.png right.png -o disp.png --max-disparity 64 --npy disp.npy --pfm disp.pfm

Registered in :mod:`gfgpu.cli` through :func:`add_parser`; runs on its own as
``python -m gfgpu.stereo_cli``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from .files import save_npy, save_png, write_atomic

EXAMPLES = ("motorcycle",)

# Turbo colour map (A. Mikhailov, Google, 2019), polynomial approximation: no matplotlib needed
_TURBO = np.array([
    [0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943],
    [0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604],
    [0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973]])


def colourise(disp, d_min, d_max):
    """(H, W, 3) uint8 Turbo image of ``disp`` scaled from ``d_min`` (blue) to ``d_max`` (red);
    NaN (rejected) pixels are black."""
    t = np.clip((np.nan_to_num(disp, nan=d_min) - d_min) / max(d_max - d_min, 1e-9), 0, 1)
    powers = t[..., None] ** np.arange(6)
    rgb = np.clip(powers @ _TURBO.T, 0, 1)
    rgb[~np.isfinite(disp)] = 0
    return (rgb * 255).round().astype(np.uint8)


def write_pfm(path, disp):
    """Write a greyscale PFM (little-endian float32, rows bottom to top; NaN kept, as Middlebury)."""
    data = np.asarray(disp, np.float32)
    with open(path, "wb") as f:
        f.write(f"Pf\n{data.shape[1]} {data.shape[0]}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(data[::-1]).astype("<f4").tobytes())


def read_pfm(path):
    """Read a greyscale PFM written by :func:`write_pfm` (or Middlebury's tools)."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"Pf":
            raise ValueError(f"{path}: not a greyscale PFM")
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(4 * w * h), "<f4" if scale < 0 else ">f4")
    return data.reshape(h, w)[::-1].astype(np.float32)


def _read_pair(args):
    import imageio.v3 as iio
    if args.example:
        from skimage import data
        left, right, _ = data.stereo_motorcycle()
        return left, right, f"{args.example} (skimage.data, Middlebury 2014)", 64
    if not (args.left and args.right):
        raise SystemExit("give LEFT and RIGHT image paths, or --example motorcycle")
    try:
        return iio.imread(args.left), iio.imread(args.right), args.left, None
    except (OSError, ValueError) as exc:
        raise SystemExit(f"cannot read the stereo pair: {exc}") from None


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
    p.add_argument("--backend", choices=("numpy", "warp", "opencl"), help="default: automatic")
    p.add_argument("--device", help="device of the backend (e.g. cuda:0, or an OpenCL index)")


def add_parser(subparsers):
    """Add the ``disparity`` subcommand to the ``gfgpu`` command's subparsers."""
    p = subparsers.add_parser("disparity", help="disparity map of a rectified stereo pair: colour PNG")
    add_arguments(p)
    p.set_defaults(func=run)
    return p


def run(args):
    """Handle ``gfgpu disparity`` (parsed ``args``); returns the exit status."""
    from tqdm import tqdm

    from .stereo import disparity, disparity_work, fill_holes

    for out in (args.output, args.npy, args.pfm):
        for src in (args.left, args.right):
            if out and src and os.path.abspath(out) == os.path.abspath(src):
                raise SystemExit(f"refusing to overwrite the input {src}")
    left, right, label, default_max = _read_pair(args)
    d_max = args.max_disparity or default_max or max(1, np.shape(left)[1] // 4)
    kw = dict(min_disparity=args.min_disparity, method=args.method)
    t0 = time.perf_counter()
    with tqdm(total=disparity_work(d_max, **kw), desc=f"gfgpu disparity ({args.method})",
              unit="step", disable=None, leave=False) as bar:
        try:
            disp = disparity(left, right, d_max, progress=bar.update, backend=args.backend,
                             device=args.device, **kw)
        except (ValueError, TypeError) as exc:
            raise SystemExit(f"gfgpu disparity: {exc}") from None
    elapsed = time.perf_counter() - t0
    if args.fill:
        disp = fill_holes(disp)
    png = colourise(disp, args.min_disparity, d_max)
    save_png(args.output, png)
    if args.npy:
        save_npy(args.npy, disp)
    if args.pfm:
        write_atomic(args.pfm, lambda tmp: write_pfm(tmp, disp))
    h, w = disp.shape
    print(f"{label}: {w}x{h}, disparities {args.min_disparity}..{d_max} -> {args.output} "
          f"({np.isnan(disp).mean():.1%} rejected, {elapsed:.2f} s including device start-up)")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="gfgpu disparity", description=__doc__.splitlines()[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
