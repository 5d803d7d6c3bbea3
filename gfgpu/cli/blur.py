"""``gfgpu blur``: motion blur, zoom blur or spin blur of an image file.

Examples::

    gfgpu blur photo.png -o blurred.png --dx 25 --dy -10     # motion_blur(img, (-10, 25))
    gfgpu blur --example camera -o zoom.png --zoom 0.3 --center-x 256 --center-y 200   # center=(200, 256)
    gfgpu blur --example camera -o spin.png --rotate 10 --keep-position
"""

from __future__ import annotations

import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..motion import motion_blur
from .common import announce_backend, refuse_overwrite
from .motion_args import motion_args, motion_input


def add_parser(subparsers):
    p = subparsers.add_parser("blur", help="motion blur (--dx right, --dy down), zoom blur (--zoom U1) or "
                                           "rotation blur (--rotate DEGREES)")
    motion_args(p)
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.set_defaults(func=run)


def run(args):
    refuse_overwrite([args.image], [args.output])
    img, label, kw = motion_input(args)
    velocity = kw.pop("velocity")
    be = announce_backend(args)
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu blur", unit="image", disable=None, leave=False) as bar:
        out = motion_blur(img.astype(np.float32), velocity, backend=be, **kw)
        bar.update(1)
    elapsed = time.perf_counter() - t0
    io.save_png(args.output, io.to_display_8bit(out, img))
    print(f"{label}: {img.shape[1]}x{img.shape[0]} -> {args.output} ({kw['kind']}, {elapsed * 1e3:.0f} ms "
          f"including device start-up)")
    return 0
