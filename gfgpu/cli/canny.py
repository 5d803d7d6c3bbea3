"""``gfgpu canny``: the edge map of one image (:func:`gfgpu.canny`) as a black-and-white PNG.

Example::

    gfgpu canny --example camera -o camera_edges.png -u 1.0 --low 0.8 --high 0.9

Thresholds are quantiles of the gradient magnitude, as in ``gfgpu batch canny``; without them,
:func:`gfgpu.canny`'s absolute defaults apply (slope per pixel of the image in [0, 1]).
Integer images are scaled to [0, 1] by their type's maximum, colour images averaged to grey
(alpha is not image content).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from .. import io
from ..edges import canny, check_arguments
from .common import (
    IMAGE_OUTPUT,
    MODE_HELP,
    MODES,
    CommandError,
    announce_backend,
    backend_args,
    check_outputs,
    drop_alpha,
    duration_text,
    image_args,
    positive_float,
    read_input,
    size_text,
)

__all__ = ["CLI_TERMS", "add_parser", "run"]

#: the library's argument names in messages, as this command's options
CLI_TERMS = (("low_threshold", "--low"), ("high_threshold", "--high"), ("u must", "-u must"))


def quantile(text):
    """argparse type: a number in [0, 1]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a quantile in [0, 1], got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a quantile in [0, 1], got {text!r}")
    return value


def add_parser(subparsers):
    p = subparsers.add_parser("canny", help="edge map (one-signed Green's-function gradient + Canny's steps): "
                                            "black-and-white PNG")
    image_args(p)
    p.add_argument("-o", "--output", required=True, help="output image: edges white (255) on black (0), 8-bit "
                   "grey; .png, .tif, .bmp (or .jpg, lossy)")
    p.add_argument("-u", type=positive_float, default=1.0, help="scale u of the differentiator (pixels, > 0), "
                   "default 1.0")
    p.add_argument("--low", type=quantile, metavar="Q", help="low hysteresis threshold, a quantile of the gradient "
                   "magnitude in [0, 1] (default: gfgpu.canny's absolute default)")
    p.add_argument("--high", type=quantile, metavar="Q", help="high threshold, a quantile in [0, 1] (default: "
                   "gfgpu.canny's absolute default)")
    p.add_argument("--mode", default="reflect", choices=MODES, help=MODE_HELP)
    backend_args(p)
    p.set_defaults(func=run)


def grey_image(image):
    """The float grey image canny sees: integers scaled to [0, 1] by their type's maximum (in
    float64, then float32), colour averaged over the channels, alpha dropped; float64 kept."""
    img = drop_alpha(image)
    if img.dtype.kind in "iu":
        img = (img.astype(np.float64) / np.iinfo(img.dtype).max).astype(np.float32)
    elif img.dtype != np.float64:
        img = img.astype(np.float32)
    return img.mean(axis=-1, dtype=img.dtype) if img.ndim == 3 else img


def run(args):
    check_outputs([args.image], [("-o", args.output, IMAGE_OUTPUT)])
    if (args.low is None) != (args.high is None):
        raise CommandError("give --low and --high together (quantiles), or neither (absolute defaults)")
    # every option checked before the image is read or a device started
    check_arguments(args.u, args.low, args.high, use_quantiles=True, mode=args.mode)
    image, label = read_input(args)
    img = grey_image(image)
    be = announce_backend(args)
    t0 = time.perf_counter()
    with tqdm(total=1, desc="gfgpu canny", unit="image", disable=None, leave=False) as bar:
        edges = canny(img, args.u, args.low, args.high, use_quantiles=True, mode=args.mode, backend=be)
        bar.update(1)
    elapsed = time.perf_counter() - t0
    io.write_image(args.output, edges.astype(np.uint8) * np.uint8(255))
    print(f"{label}: {size_text(img.shape)} -> {args.output}: {int(edges.sum())} edge pixels "
          f"({duration_text(elapsed)} including device start-up)")
    return 0
