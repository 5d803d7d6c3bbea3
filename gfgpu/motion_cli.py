"""``gfgpu blur`` and ``gfgpu frames``: motion blur, zoom and motion synthesis on image files.

Examples::

    gfgpu blur photo.png -o blurred.png --velocity 25 -10
    gfgpu blur --example camera -o zoom.png --zoom 0.3 --center 256 200
    gfgpu blur photo.png -o zoom_out.png --zoom -0.2 --center 256 200 --mode nearest
    gfgpu blur --example camera -o spin.png --rotate 10 --keep-position
    gfgpu frames photo.png -o frames/ --velocity 40 0 -n 12

Register with ``motion_cli.add_parser(subparsers)`` in :mod:`gfgpu.cli`.
"""

from __future__ import annotations

import os
import time

import numpy as np

from .cli import _backend_args
from .files import read_image, save_png, to_display_8bit, write_atomic

EXAMPLES = ("camera",)


def _motion_args(p):
    p.add_argument("image", nargs="?", help="input image (PNG, JPEG, TIFF, ...)")
    p.add_argument("--example", choices=EXAMPLES, help="use a bundled example image instead")
    how = p.add_mutually_exclusive_group(required=True)
    how.add_argument("--velocity", nargs=2, type=float, metavar=("DX", "DY"),
                     help="uniform motion in pixels: DX toward the right, DY downward")
    how.add_argument("--zoom", type=float, metavar="U1",
                     help="zoom rate u1 in (-0.828, 2): a point at x moves to c + (x - c)(1 + u1); "
                          "u1 > 0 zooms in, u1 < 0 zooms out (reads beyond the border through --mode; "
                          "e.g. --zoom -0.2 --center 256 200 --mode nearest)")
    how.add_argument("--rotate", type=float, metavar="DEGREES",
                     help="rotation during the exposure, in [-90, 90] degrees, counter-clockwise on "
                          "screen for > 0, about --center (three Green's shears)")
    p.add_argument("--center", nargs=2, type=float, metavar=("X", "Y"),
                   help="fixed point of the zoom or rotation (default: the image centre)")
    p.add_argument("--keep-position", action="store_true",
                   help="uniform motion or rotation: blur in place instead of displacing the content")
    p.add_argument("--mode", default="reflect", choices=("reflect", "constant", "nearest", "mirror", "wrap"))
    _backend_args(p)


def add_parser(subparsers):
    """Add the ``blur`` and ``frames`` subcommands to an argparse ``subparsers`` object."""
    p = subparsers.add_parser("blur", help="motion blur (--velocity DX DY), zoom blur (--zoom U1) or "
                                           "rotation blur (--rotate DEGREES)")
    _motion_args(p)
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.set_defaults(func=run_blur)

    p = subparsers.add_parser("frames", help="motion synthesis: numbered PNGs and an animated GIF")
    _motion_args(p)
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("-n", "--frames", type=int, default=12, help="number of frames (>= 2), default 12")
    p.add_argument("--fps", type=float, default=12.0, help="GIF frame rate, default 12")
    p.set_defaults(func=run_frames)
    return subparsers


def _prepare(args):
    image, label = read_image(args.image, args.example)
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[-1] == 4:   # alpha is not image content
        img = img[..., :3]
    if img.ndim not in (2, 3):
        raise SystemExit(f"{label}: expected a grey or colour image, got shape {img.shape}")
    if args.velocity is not None:
        kw = dict(kind="uniform", velocity=tuple(args.velocity), displace=not args.keep_position)
    elif args.rotate is not None:
        kw = dict(kind="rotation", velocity=args.rotate, center=args.center, displace=not args.keep_position)
    else:
        kw = dict(kind="zoom", velocity=args.zoom, center=args.center)
    kw.update(mode=args.mode, backend=args.backend, device=args.device,
              channel_axis=-1 if img.ndim == 3 else None)
    return img, label, kw


def _same_file(a, b):
    return a is not None and os.path.abspath(a) == os.path.abspath(b)


def run_blur(args):
    from tqdm import tqdm

    from .motion import motion_blur
    if _same_file(args.image, args.output):
        raise SystemExit("refusing to overwrite the input image; choose another -o")
    img, label, kw = _prepare(args)
    velocity = kw.pop("velocity")
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu blur", unit="image", disable=None, leave=False) as bar:
        try:
            out = motion_blur(img.astype(np.float32), velocity, **kw)
        except ValueError as exc:
            raise SystemExit(f"gfgpu blur: {exc}") from None
        bar.update(1)
    elapsed = time.perf_counter() - t0
    save_png(args.output, to_display_8bit(out, img))
    print(f"{label}: {img.shape[1]}x{img.shape[0]} -> {args.output} ({kw['kind']}, {elapsed * 1e3:.0f} ms "
          f"including device start-up)")
    return 0


def run_frames(args):
    import imageio.v3 as iio
    from tqdm import tqdm

    from .motion import synthesize_motion
    if args.frames < 2:
        raise SystemExit(f"-n must be >= 2, got {args.frames}")
    if not args.fps > 0:
        raise SystemExit(f"--fps must be > 0, got {args.fps}")
    img, label, kw = _prepare(args)
    velocity = kw.pop("velocity")
    folder = args.output
    os.makedirs(folder, exist_ok=True)
    t0 = time.perf_counter()
    with tqdm(total=args.frames, desc="gfgpu frames", unit="frame", disable=None, leave=False) as bar:
        try:
            frames = synthesize_motion(img.astype(np.float32), velocity, args.frames, progress=bar.update, **kw)
        except ValueError as exc:
            raise SystemExit(f"gfgpu frames: {exc}") from None
    pngs = [to_display_8bit(f, img) for f in frames]
    width = max(3, len(str(args.frames - 1)))
    for k, png in enumerate(pngs):
        path = os.path.join(folder, f"frame_{k:0{width}d}.png")
        if _same_file(args.image, path):
            raise SystemExit(f"refusing to overwrite the input image {path}")
        save_png(path, png)
    gif = os.path.join(folder, "frames.gif")
    write_atomic(gif, lambda tmp: iio.imwrite(tmp, np.stack(pngs), extension=".gif",
                                               duration=1000.0 / args.fps, loop=0))
    print(f"{label}: {args.frames} frames {img.shape[1]}x{img.shape[0]} -> {folder}/frame_*.png and {gif} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0
