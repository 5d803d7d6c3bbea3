"""``gfgpu shift``: translate an image by a sub-pixel amount.

Example::

    gfgpu shift photo.png -o shifted.png --dx 2.5 --dy -1.25
"""

from __future__ import annotations

import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..filters import shift
from .common import MODES, announce_backend, backend_args, drop_alpha, image_args, read_input, refuse_overwrite


def add_parser(subparsers):
    p = subparsers.add_parser("shift", help="translate by a sub-pixel amount (--dx right, --dy down)")
    image_args(p)
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.add_argument("--npy", help="also save the raw float32 result as .npy")
    p.add_argument("--mode", default="reflect", choices=MODES)
    p.add_argument("--dx", type=float, default=0.0, help="displacement toward the right (columns), pixels")
    p.add_argument("--dy", type=float, default=0.0, help="displacement downward (rows), pixels")
    p.add_argument("--interpolation", choices=("green", "cubic"), default="green",
                   help="fractional part: the discrete Green shift (default) or a cubic B-spline")
    backend_args(p)
    p.set_defaults(func=run)


def run(args):
    refuse_overwrite([args.image], [args.output, args.npy])
    image, label = read_input(args)
    img = drop_alpha(image)
    be = announce_backend(args)
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu shift", unit="image", disable=None, leave=False) as bar:
        # the library's array-axis order (rows, cols); colour channels are not shifted
        raw = shift(img.astype(np.float32), (args.dy, args.dx), channel_axis=-1 if img.ndim == 3 else None,
                    mode=args.mode, interpolation=args.interpolation, backend=be)
        bar.update(1)
    elapsed = time.perf_counter() - t0
    io.save_png(args.output, io.to_display_8bit(raw, img))
    if args.npy:
        io.save_npy(args.npy, raw)
    print(f"{label}: {img.shape[1]}x{img.shape[0]} -> {args.output} ({elapsed * 1e3:.0f} ms including "
          f"device start-up)")
    return 0
