"""``gfgpu gradient``: the Green's-function gradient of an image as a colour-coded PNG.

Example::

    gfgpu gradient --example camera -o camera_gradient.png -u 1.0
"""

from __future__ import annotations

import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..filters import gradient
from .common import (
    IMAGE_OUTPUT,
    MODE_HELP,
    MODES,
    NPY_OUTPUT,
    announce_backend,
    backend_args,
    check_outputs,
    drop_alpha,
    duration_text,
    image_args,
    positive_float,
    read_input,
    size_text,
    working_dtype,
)


def add_parser(subparsers):
    p = subparsers.add_parser("gradient", help="Green's-function gradient (D across, P along): colour PNG")
    image_args(p)
    p.add_argument("-o", "--output", required=True, help="output image, 8-bit colour (hue = orientation, value = "
                   "magnitude); .png, .tif, .jpg or .bmp")
    p.add_argument("--npy", help="also save the raw (gy, gx) as .npy, shape (2, rows, cols) (float32; "
                   "float64 for float64 input)")
    p.add_argument("--mode", default="reflect", choices=MODES, help=MODE_HELP)
    p.add_argument("-u", type=positive_float, default=1.0, help="scale u of D (pixels, > 0), default 1.0")
    backend_args(p)
    p.set_defaults(func=run)


def run(args):
    check_outputs([args.image], [("-o", args.output, IMAGE_OUTPUT), ("--npy", args.npy, NPY_OUTPUT)])
    image, label = read_input(args)
    be = announce_backend(args)
    img = drop_alpha(image).astype(working_dtype(image))
    if img.ndim == 3:
        img = img.mean(axis=-1)   # luminance-like average: one gradient per pixel
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu gradient", unit="image", disable=None, leave=False) as bar:
        gy, gx = gradient(img, args.u, mode=args.mode, backend=be)
        bar.update(1)
    elapsed = time.perf_counter() - t0
    io.write_image(args.output, io.gradient_to_rgb(gy, gx))
    if args.npy:
        io.save_npy(args.npy, np.stack([gy, gx]))
    print(f"{label}: {size_text(img.shape)} -> {args.output} ({duration_text(elapsed)} including "
          f"device start-up)")
    return 0
