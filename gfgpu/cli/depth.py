"""``gfgpu depth``: depth from one shading image (GSFS or photometric motion).

Examples::

    gfgpu depth vase.png -o vase_depth.png --light 1 0 1
    gfgpu depth face.png -o depth.png --method photometric-motion --relief relief.png --npy depth.npy
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from tqdm import tqdm

from .. import io
from .._core.validation import SCALE_RANGE
from .common import (
    IMAGE_OUTPUT,
    NPY_OUTPUT,
    CommandError,
    announce_backend,
    backend_args,
    check_outputs,
    duration_text,
    finite_float,
    positive_float,
    size_text,
    working_dtype,
)

#: the library's argument names in its messages -> this command's options and units
CLI_TERMS = (
    ("Pass direction= (radians)", "Pass --direction DEGREES"),
    ("or use photometric_motion", "or use --method photometric-motion"),
    ("direction= (radians)", "--direction (degrees)"),
    # the light estimate's refusals (the command has no mask option: that advice is the library's)
    ("pass light= explicitly, or mask= the object on its background", "pass --light L1 L2 L3 (or TILT SLANT)"),
    ("pass light= explicitly", "pass --light L1 L2 L3 (or TILT SLANT)"),
    ("pass light=", "pass --light L1 L2 L3 (or TILT SLANT)"),
    ("u must be at least", "-u must be at least"),
)


def gsfs_u(text):
    """argparse type of ``-u``: pixels in (0, 1e9], the library's range of a kernel scale (as ``gfgpu
    gradient -u``; beyond, the result no longer changes: the integrator limit).  The lower limit, a
    quarter of the image's line along the light, is the library's check once the light is known."""
    value = positive_float(text)
    if value > SCALE_RANGE[1]:
        raise argparse.ArgumentTypeError(f"must lie in (0, {SCALE_RANGE[1]:g}] pixels (at least a quarter of the "
                                         f"image's line along the light), got {text!r}")
    return value


def add_parser(subparsers):
    """Add the ``depth`` subcommand to an argparse ``subparsers`` object."""
    p = subparsers.add_parser("depth", help="depth map from one shading image (GSFS / photometric motion)")
    p.add_argument("image", help="input shading image (grey; colour is averaged)")
    p.add_argument("-o", "--output", required=True,
                   help="output depth image, 8-bit (near = bright); .png, .tif, .jpg or .bmp")
    p.add_argument("--method", choices=("gsfs", "photometric-motion"), default="gsfs")
    p.add_argument("--light", nargs="+", type=finite_float, metavar="L",
                   help="light as L1 L2 L3 (x right, y down, z toward the viewer) or TILT SLANT in "
                        "degrees; default: estimated from an object on a flat frontal background (its "
                        "brightest point against the background's level; gfgpu.estimate_illuminant's "
                        "'background' method), refused with the reason when the image has none")
    p.add_argument("-u", type=gsfs_u, default=None, help="GSFS matching constant in pixels, from a quarter of "
                   "the image's line along the light to 1e9 (default: one line)")
    p.add_argument("--boundary", choices=("auto", "background", "free"), default="auto",
                   help="GSFS line constants: an object on a flat background, a textured surface "
                        "filling the frame, or chosen from the image border (default)")
    p.add_argument("--direction", type=finite_float, default=None,
                   help="matching/motion direction in degrees from +x toward +y (default: light tilt)")
    p.add_argument("--relief", help="also write a shaded-relief rendering of the depth (8-bit image)")
    p.add_argument("--npy", help="also write the raw float depth (.npy)")
    backend_args(p)
    p.set_defaults(func=run)
    return p


def _light(values):
    if values is None:
        return None
    if len(values) == 2:
        return (math.radians(values[0]), math.radians(values[1]))
    if len(values) == 3:
        return tuple(values)
    raise CommandError(f"--light takes 3 values (L1 L2 L3) or 2 (TILT SLANT in degrees), got {len(values)}")


def _to_png(values):
    lo, hi = np.percentile(values, [0.5, 99.5])
    scale = 255.0 / (hi - lo) if hi > lo else 0.0
    return np.clip(np.rint((values - lo) * scale), 0, 255).astype(np.uint8)


def run(args):
    # imported here: gfgpu --help does not load the shading package (and scipy.optimize)
    from ..shading import lambertian_shading, photometric_motion, shape_from_shading

    light = _light(args.light)
    check_outputs([args.image], [("-o", args.output, IMAGE_OUTPUT), ("--relief", args.relief, IMAGE_OUTPUT),
                                 ("--npy", args.npy, NPY_OUTPUT)])
    image = io.read_image(args.image)
    img = np.asarray(image)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=-1) if img.shape[-1] >= 3 else img[..., 0]
    img = img.astype(working_dtype(image))
    if image.dtype == np.uint8:
        img /= 255.0
    elif image.dtype == np.uint16:
        img /= 65535.0
    be = announce_backend(args)     # after the input is read: a refused command never says it ran
    kw = dict(light=light, backend=be)
    direction = None if args.direction is None else math.radians(args.direction)
    t0 = time.perf_counter()
    with tqdm(total=3, desc=f"gfgpu depth ({args.method})", unit="step", disable=None, leave=False) as bar:
        bar.update(1)
        if args.method == "gsfs":
            depth = shape_from_shading(img, u=args.u, direction=direction, boundary=args.boundary, **kw)
        else:
            depth = photometric_motion(img, direction=direction, **kw)
        bar.update(1)
        io.write_image(args.output, _to_png(depth))
        if args.relief:
            relief = lambertian_shading(depth, (math.radians(-135), math.radians(45)))  # light from top-left
            io.write_image(args.relief, _to_png(relief))
        if args.npy:
            io.save_npy(args.npy, depth)
        bar.update(1)
    written = ", ".join(p for p in (args.output, args.relief, args.npy) if p)
    print(f"{args.image}: {size_text(img.shape)} -> {written} ({args.method}, "
          f"{duration_text(time.perf_counter() - t0)} including device start-up)")
    return 0
