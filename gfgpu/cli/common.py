"""What every ``gfgpu`` command shares: backend options, image input, the backend line, errors.

Library functions raise ``ValueError``/``TypeError``/``OSError``; :func:`gfgpu.cli.main`
turns them into one-line messages.  :class:`CommandError` is for problems only a command can
see (conflicting options, an output that would overwrite an input).
"""

from __future__ import annotations

import os

import numpy as np

from .. import io
from ..backends import resolve_backend

MODES = ("reflect", "constant", "nearest", "mirror", "wrap")


class CommandError(Exception):
    """A usage problem of one command; printed as ``gfgpu COMMAND: message``."""


def backend_args(p):
    """``--backend``, ``--device`` and ``--quiet`` (no line saying which backend ran)."""
    p.add_argument("--backend", choices=("numpy", "warp", "opencl"), help="default: automatic")
    p.add_argument("--device", help="device of the backend (e.g. cuda:0, or an OpenCL index)")
    p.add_argument("-q", "--quiet", action="store_true", help="do not print which backend and device ran")


def image_args(p, examples=io.EXAMPLES):
    """A positional IMAGE and ``--example``."""
    p.add_argument("image", nargs="?", help="input image (PNG, JPEG, TIFF, ...)")
    p.add_argument("--example", choices=examples, help="use a bundled example image instead")


def read_input(args):
    """``(array, label)`` of the command's IMAGE or ``--example``."""
    if getattr(args, "example", None):
        return io.example_image(args.example), f"{args.example} (bundled)"
    if args.image is None:
        raise CommandError(f"give an IMAGE path or --example {io.EXAMPLES[0]}")
    return io.read_image(args.image), args.image


def refuse_overwrite(inputs, outputs):
    """CommandError when an output path names an input file (inputs are never written)."""
    for out in outputs:
        for src in inputs:
            if out and src and os.path.abspath(out) == os.path.abspath(src):
                raise CommandError(f"refusing to overwrite the input {src}; choose another output")


def announce_backend(args):
    """Resolve the backend the command will run on and say so (one line, unless ``--quiet``)."""
    be = resolve_backend(getattr(args, "backend", None), getattr(args, "device", None))
    if not getattr(args, "quiet", False):
        print(f"gfgpu {args.command}: backend {be.name} on {be.device}")
    return be


def drop_alpha(image):
    """The colour channels of an image (alpha is not image content); grey stays 2-D."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[-1] in (2, 4):
        img = img[..., :-1]
    if img.ndim == 3 and img.shape[-1] == 1:
        img = img[..., 0]
    return img
