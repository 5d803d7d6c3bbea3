"""``gfgpu blur``: motion blur, zoom blur or spin blur of an image file.

Examples::

    gfgpu blur photo.png -o blurred.png --dx 25 --dy -10     # motion_blur(img, (-10, 25))
    gfgpu blur --example camera -o zoom.png --zoom 0.3 --center-x 256 --center-y 200   # center=(200, 256)
    gfgpu blur --example camera -o spin.png --rotate 10 --keep-position
    gfgpu blur photo.png -o box.png --dx 25 --psf box            # a uniform exposure (box PSF)
    gfgpu blur scan.tif -o blurred.tif --dx 8     # float or 16-bit input: a float32 or 16-bit TIFF

The output is written at the input's depth in the format of its extension (see
:func:`gfgpu.io.to_output`; float input gives a float32 TIFF); an alpha channel is kept
(filtered premultiplied).
"""

from __future__ import annotations

import time

from tqdm import tqdm

from .. import io
from ..motion import motion_blur
from .common import (
    IMAGE_OUTPUT,
    announce_backend,
    check_image_output,
    check_outputs,
    duration_text,
    join_alpha,
    note,
    size_text,
)
from .motion_args import CLI_TERMS, check_motion, motion_args, motion_input

__all__ = ["CLI_TERMS", "add_parser", "run"]


def add_parser(subparsers):
    p = subparsers.add_parser("blur", help="motion blur (--dx right, --dy down), zoom blur (--zoom U1) or "
                                           "rotation blur (--rotate DEGREES)")
    motion_args(p)          # the kinds of motion, --psf (the table of gfgpu.motion.kinds), --mode, backend
    p.add_argument("-o", "--output", required=True,
                   help="output image (.png, .tif, .jpg, .bmp: the format of the extension), at the input's depth")
    p.set_defaults(func=run)


def run(args):
    check_motion(args)
    check_outputs([args.image], [("-o", args.output, IMAGE_OUTPUT)])
    image, img, alpha, label, kw = motion_input(args)
    conversion = check_image_output("-o", args.output, image)
    be = announce_backend(args)     # after every check: a refused command never says it ran
    velocity = kw.pop("velocity")
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu blur", unit="image", disable=None, leave=False) as bar:
        out = motion_blur(img, velocity, backend=be, **kw)
        bar.update(1)
    elapsed = time.perf_counter() - t0
    io.save_image(args.output, join_alpha(out, image, alpha), image)
    note(args, conversion)
    print(f"{label}: {size_text(img.shape)} -> {args.output} ({kw['kind']}, psf {kw['psf']}, "
          f"{duration_text(elapsed)} including device start-up)")
    return 0
