"""``gfgpu frames``: motion synthesis, numbered PNGs and an animated GIF.

Example::

    gfgpu frames photo.png -o frames/ --dx 40 -n 12
    gfgpu frames photo.png -o spin/ --rotate 30 --psf box -n 8    # any kind of motion, either PSF

The PNG frames are written at the input's depth (16-bit input gives 16-bit PNGs, float input
the 8-bit conversion of :func:`gfgpu.io.to_display_8bit`, stated in a note) and keep an alpha
channel (filtered premultiplied); the GIF is 8-bit without alpha.  The output folder is created
if its parent exists.  The folder is the command's own: frames of an earlier run that this run
does not write (``frame_<digits>.png``, e.g. of a longer run) are removed once the new frames are
written, and the command says how many; nothing else in the folder is touched.
"""

from __future__ import annotations

import os
import re
import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..motion import synthesize_motion
from .common import (
    CommandError,
    announce_backend,
    check_image_output,
    check_outputs,
    duration_text,
    join_alpha,
    note,
    positive_float,
    positive_int,
    same_file,
    size_text,
)
from .motion_args import CLI_TERMS, check_motion, motion_args, motion_input

__all__ = ["CLI_TERMS", "add_parser", "run"]


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
    image, img, alpha, label, kw = motion_input(args)
    conversion = check_image_output("-o", paths[0], image)
    be = announce_backend(args)     # after every check: a refused command never says it ran
    velocity = kw.pop("velocity")
    t0 = time.perf_counter()
    with tqdm(total=args.frames, desc="gfgpu frames", unit="frame", disable=None, leave=False) as bar:
        frames = synthesize_motion(img, velocity, args.frames, progress=bar.update, backend=be, **kw)
    frames = [join_alpha(f, image, alpha) for f in frames]
    os.makedirs(folder, exist_ok=True)
    for path, frame in zip(paths, frames):
        io.save_image(path, frame, image)
    note(args, conversion)
    colour = image[..., :-1] if alpha else image      # GIF: no alpha channel
    gifs = np.stack([io.to_display_8bit(f[..., :-1] if alpha else f, colour) for f in frames])
    if gifs.ndim == 4 and gifs.shape[-1] == 1:
        gifs = gifs[..., 0]
    io.save_gif(gif, gifs, args.fps)
    stale = _remove_stale_frames(folder, paths)
    if stale:
        print(f"removed {len(stale)} frame(s) of an earlier run from {folder} ({', '.join(stale[:3])}"
              f"{', ...' if len(stale) > 3 else ''})")
    print(f"{label}: {args.frames} frames {size_text(img.shape)} -> {folder}/frame_*.png and {gif} "
          f"({duration_text(time.perf_counter() - t0)} including device start-up)")
    return 0


#: the names of the frames this command writes (any number of digits: earlier runs may have had more)
_FRAME_NAME = re.compile(r"^frame_\d+\.png$")


def _remove_stale_frames(folder, written):
    """Remove the frames of earlier runs (``frame_<digits>.png`` regular files this run did not
    write); their names, sorted.  Nothing else is touched."""
    keep = {os.path.basename(p) for p in written}
    removed = []
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        if _FRAME_NAME.match(name) and name not in keep and os.path.isfile(path) and not os.path.islink(path):
            os.unlink(path)
            removed.append(name)
    return removed
