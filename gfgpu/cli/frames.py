"""``gfgpu frames``: motion synthesis, numbered PNGs and an animated GIF.

Example::

    gfgpu frames photo.png -o frames/ --dx 40 -n 12
"""

from __future__ import annotations

import os
import time

import imageio.v3 as iio
import numpy as np
from tqdm import tqdm

from .. import io
from ..motion import synthesize_motion
from .common import CommandError, announce_backend, refuse_overwrite
from .motion_args import motion_args, motion_input


def add_parser(subparsers):
    p = subparsers.add_parser("frames", help="motion synthesis: numbered PNGs and an animated GIF")
    motion_args(p)
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("-n", "--frames", type=int, default=12, help="number of frames (>= 2), default 12")
    p.add_argument("--fps", type=float, default=12.0, help="GIF frame rate, default 12")
    p.set_defaults(func=run)


def run(args):
    if args.frames < 2:
        raise CommandError(f"-n must be >= 2, got {args.frames}")
    if not args.fps > 0:
        raise CommandError(f"--fps must be > 0, got {args.fps}")
    img, label, kw = motion_input(args)
    velocity = kw.pop("velocity")
    folder = args.output
    width = max(3, len(str(args.frames - 1)))
    paths = [os.path.join(folder, f"frame_{k:0{width}d}.png") for k in range(args.frames)]
    gif = os.path.join(folder, "frames.gif")
    refuse_overwrite([args.image], paths + [gif])
    be = announce_backend(args)
    os.makedirs(folder, exist_ok=True)
    t0 = time.perf_counter()
    with tqdm(total=args.frames, desc="gfgpu frames", unit="frame", disable=None, leave=False) as bar:
        frames = synthesize_motion(img.astype(np.float32), velocity, args.frames, progress=bar.update,
                                   backend=be, **kw)
    pngs = [io.to_display_8bit(f, img) for f in frames]
    for path, png in zip(paths, pngs):
        io.save_png(path, png)
    io.write_atomic(gif, lambda tmp: iio.imwrite(tmp, np.stack(pngs), extension=".gif",
                                                  duration=1000.0 / args.fps, loop=0))
    print(f"{label}: {args.frames} frames {img.shape[1]}x{img.shape[0]} -> {folder}/frame_*.png and {gif} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0
