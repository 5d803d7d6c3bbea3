"""The ``gfgpu`` command: Green's-function filters on image files.

Examples::

    gfgpu gradient --example camera -o camera_gradient.png -u 1.0
    gfgpu shift photo.png -o shifted.png --by 2.5 -1.25
    gfgpu devices
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from .files import EXAMPLES, read_image, save_npy, save_png, to_display_8bit


def _gradient_png(gy, gx):
    """Colour-coded gradient: hue = orientation, value = magnitude (robustly normalised)."""
    from skimage.color import hsv2rgb
    mag = np.hypot(gx, gy)
    top = np.percentile(mag, 99.5) or 1.0
    hsv = np.stack([(np.arctan2(gy, gx) / (2 * np.pi)) % 1.0, np.full(mag.shape, 0.8),
                    np.clip(mag / top, 0, 1)], axis=-1)
    return (hsv2rgb(hsv) * 255).round().astype(np.uint8)


def _backend_args(p):
    p.add_argument("--backend", choices=("numpy", "warp", "opencl"), help="default: automatic")
    p.add_argument("--device", help="device of the backend (e.g. cuda:0, or an OpenCL index)")


def _io_args(p):
    p.add_argument("image", nargs="?", help="input image (PNG, JPEG, TIFF, ...)")
    p.add_argument("--example", choices=EXAMPLES, help="use a bundled example image instead")
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.add_argument("--npy", help="also save the raw float result as .npy")
    p.add_argument("--mode", default="reflect",
                   choices=("reflect", "constant", "nearest", "mirror", "wrap"))


def build_parser():
    parser = argparse.ArgumentParser(prog="gfgpu", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("gradient", help="Green's-function gradient (D across, P along): colour PNG")
    _io_args(p)
    p.add_argument("-u", type=float, default=1.0, help="scale u of D (pixels, > 0), default 1.0")
    _backend_args(p)

    p = sub.add_parser("shift", help="sub-pixel shift through G_u")
    _io_args(p)
    p.add_argument("--by", nargs=2, type=float, metavar=("DX", "DY"), required=True,
                   help="displacement in pixels: DX toward the right, DY downward")
    _backend_args(p)

    sub.add_parser("devices", help="list backends and devices, usable or not (and why)")
    # applications register their own subcommands (each sets func= on its parser)
    from . import batch_cli, motion_cli, shading_cli, stereo_cli
    stereo_cli.add_parser(sub)
    motion_cli.add_parser(sub)
    shading_cli.add_parser(sub)
    batch_cli.add_parser(sub)
    return parser


def _grey_or_channels(image):
    """(float image, axes of the image plane): colour images are filtered per channel."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[-1] == 4:   # drop alpha: it is not image content
        img = img[..., :3]
    axes = (0, 1)
    return img, axes


def main(argv=None):
    args = build_parser().parse_args(argv)
    if hasattr(args, "func"):
        return args.func(args)
    if args.command == "devices":
        import gfgpu
        for d in gfgpu.devices():
            print(d)
        return 0

    from tqdm import tqdm

    import gfgpu

    image, label = read_image(args.image, args.example)
    img, axes = _grey_or_channels(image)
    kw = dict(mode=args.mode, backend=args.backend, device=args.device)
    t0 = time.perf_counter()
    with tqdm(total=2, desc=f"gfgpu {args.command}", unit="step", disable=None, leave=False) as bar:
        if args.command == "gradient":
            if img.ndim == 3:
                img = img.mean(axis=-1)   # luminance-like average: one gradient per pixel
            bar.update(1)
            gy, gx = gfgpu.gradient(img.astype(np.float32), args.u, **kw)
            bar.update(1)
            raw = np.stack([gy, gx])
            png = _gradient_png(gy, gx)
        else:
            dx, dy = args.by
            bar.update(1)
            shift = (dy, dx) + (0.0,) * (img.ndim - 2)
            raw = gfgpu.shift(img.astype(np.float32), shift, **kw)
            bar.update(1)
            png = to_display_8bit(raw, img)
    elapsed = time.perf_counter() - t0
    save_png(args.output, png)
    if args.npy:
        save_npy(args.npy, raw)
    print(f"{label}: {img.shape[1]}x{img.shape[0]} -> {args.output} "
          f"({args.command}, {elapsed * 1e3:.0f} ms including device start-up)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
