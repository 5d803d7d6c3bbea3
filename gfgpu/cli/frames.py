"""``gfgpu frames``: motion synthesis, numbered PNGs and an animated GIF.

Example::

    gfgpu frames photo.png -o frames/ --dx 40 -n 12
    gfgpu frames photo.png -o spin/ --rotate 30 --psf box -n 8    # any kind of motion, either PSF

The PNG frames are written at the input's depth (16-bit input gives 16-bit PNGs, float input
the 8-bit display conversion) and keep an alpha channel (filtered premultiplied); the GIF is
8-bit without alpha.  The output folder is created if its parent exists.
"""

from __future__ import annotations

import os
import time

import imageio.v3 as iio
import numpy as np
from tqdm import tqdm

from .. import io
from ..motion import synthesize_motion
from .common import CommandError, announce_backend, check_outputs, join_alpha, positive_float, positive_int, same_file
from .motion_args import check_motion, motion_args, motion_input


def add_parser(subparsers):
    p = subparsers.add_parser("frames", help="motion synthesis: numbered PNGs and an animated GIF")
    motion_args(p)
    p.add_argument("-o", "--output", required=True, help="output folder (created if its parent exists)")
    p.add_argument("-n", "--frames", type=positive_int, default=12, help="number of frames (>= 2), default 12")
    p.add_argument("--fps", type=positive_float, default=12.0, help="GIF frame rate, default 12")
    p.set_defaults(func=run)


def _check_folder(folder):
    """The output folder: an existing writable directory, or a new one in an existing folder."""
    if os.path.isdir(folder):
        check_outputs([], [("-o", os.path.join(folder, "frames.gif"), None)])
    elif os.path.lexists(folder):
        raise CommandError(f"-o {folder}: exists and is not a directory")
    else:
        check_outputs([], [("-o", folder, None)])      # its parent exists and is writable


def run(args):
    if args.frames < 2:
        raise CommandError(f"-n must be >= 2, got {args.frames}")
    check_motion(args)
    folder = args.output
    width = max(3, len(str(args.frames - 1)))
    paths = [os.path.join(folder, f"frame_{k:0{width}d}.png") for k in range(args.frames)]
    gif = os.path.join(folder, "frames.gif")
    _check_folder(folder)
    for path in paths + [gif]:
        if args.image and same_file(path, args.image):
            raise CommandError(f"-o {folder}: {path} would overwrite the input {args.image}; choose another "
                               f"folder")
    be = announce_backend(args)
    image, img, alpha, label, kw = motion_input(args)
    velocity = kw.pop("velocity")
    t0 = time.perf_counter()
    with tqdm(total=args.frames, desc="gfgpu frames", unit="frame", disable=None, leave=False) as bar:
        frames = synthesize_motion(img, velocity, args.frames, progress=bar.update, backend=be, **kw)
    frames = [join_alpha(f, image, alpha) for f in frames]
    os.makedirs(folder, exist_ok=True)
    for path, frame in zip(paths, frames):
        io.save_image(path, frame, image)
    colour = image[..., :-1] if alpha else image      # GIF: no alpha channel
    gifs = np.stack([io.to_display_8bit(f[..., :-1] if alpha else f, colour) for f in frames])
    if gifs.ndim == 4 and gifs.shape[-1] == 1:
        gifs = gifs[..., 0]
    io.write_atomic(gif, lambda tmp: iio.imwrite(tmp, gifs, extension=".gif",
                                                  duration=1000.0 / args.fps, loop=0))
    print(f"{label}: {args.frames} frames {img.shape[1]}x{img.shape[0]} -> {folder}/frame_*.png and {gif} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0
