"""``gfgpu shift``: translate an image by a sub-pixel amount.

Example::

    gfgpu shift photo.png -o shifted.png --dx 2.5 --dy -1.25

The output is written at the input's depth in the format of its extension (see
:func:`gfgpu.io.to_output`); an alpha channel is kept (filtered premultiplied).
"""

from __future__ import annotations

import time

from tqdm import tqdm

from .. import io
from ..filters import shift
from .common import (
    IMAGE_OUTPUT,
    MODE_HELP,
    MODES,
    NPY_OUTPUT,
    CommandError,
    announce_backend,
    backend_args,
    check_image_output,
    check_outputs,
    duration_text,
    finite_float,
    image_args,
    join_alpha,
    note,
    read_input,
    size_text,
    split_alpha_work,
)


def add_parser(subparsers):
    p = subparsers.add_parser("shift", help="translate by a sub-pixel amount (--dx right, --dy down)")
    image_args(p)
    p.add_argument("-o", "--output", required=True,
                   help="output image (.png, .tif, .jpg, .bmp: the format of the extension), at the input's depth")
    p.add_argument("--npy", help="also save the raw result as .npy (float32; float64 for float64 input)")
    p.add_argument("--mode", default="reflect", choices=MODES, help=MODE_HELP)
    p.add_argument("--dx", type=finite_float, default=None, help="displacement toward the right (columns), pixels")
    p.add_argument("--dy", type=finite_float, default=None, help="displacement downward (rows), pixels")
    p.add_argument("--interpolation", choices=("green", "cubic"), default="green",
                   help="fractional part: the discrete Green shift (default) or a cubic B-spline")
    backend_args(p)
    p.set_defaults(func=run)


def run(args):
    if args.dx is None and args.dy is None:
        raise CommandError("give a shift: --dx (right) and/or --dy (down), pixels")
    dx, dy = args.dx or 0.0, args.dy or 0.0
    check_outputs([args.image], [("-o", args.output, IMAGE_OUTPUT), ("--npy", args.npy, NPY_OUTPUT)])
    image, label = read_input(args)
    conversion = check_image_output("-o", args.output, image)
    be = announce_backend(args)     # after every check: a refused command never says it ran
    work, alpha = split_alpha_work(image)
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu shift", unit="image", disable=None, leave=False) as bar:
        # the library's array-axis order (rows, cols); colour channels are not shifted
        raw = shift(work, (dy, dx), channel_axis=-1 if work.ndim == 3 else None,
                    mode=args.mode, interpolation=args.interpolation, backend=be)
        bar.update(1)
    raw = join_alpha(raw, image, alpha)
    elapsed = time.perf_counter() - t0
    io.save_image(args.output, raw, image)
    note(args, conversion)
    if args.npy:
        io.save_npy(args.npy, raw)
    print(f"{label}: {size_text(work.shape)} -> {args.output} ({duration_text(elapsed)} including "
          f"device start-up)")
    return 0
