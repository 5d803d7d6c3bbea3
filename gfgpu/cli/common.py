"""What every ``gfgpu`` command shares: backend options, option types, image input and output,
the backend line, errors.

Library functions raise ``ValueError``/``TypeError``/``OSError``; :func:`gfgpu.cli.main`
turns them into one-line messages.  :class:`CommandError` is for problems only a command can
see (conflicting options, an output that would overwrite an input).  Every command checks its
options, inputs and outputs before any work (:func:`check_outputs`); see :mod:`gfgpu.cli` for
the exit statuses.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

from .. import io
from .._core.boundary import SCIPY_MODES
from ..backends import BackendUnavailable, resolve_backend

MODES = SCIPY_MODES
#: help of --mode (scipy.ndimage's names and meanings)
MODE_HELP = ("how the image continues beyond its border (scipy.ndimage's modes and meanings: for a shift "
             "'wrap' has period n - 1 and 'constant' fills beyond [0, n - 1]; grid-wrap / grid-constant are "
             "the periodic and padded ones; default reflect)")


class CommandError(Exception):
    """A usage problem of one command; printed as ``gfgpu COMMAND: message``."""


def in_cli_terms(message, terms):
    """A library message in the command line's terms: each ``(api, cli)`` of ``terms`` replaced,
    in order (a command's ``CLI_TERMS``, e.g. ``("max_disparity", "--max-disparity")``), so that
    errors name the option and its unit, not the function argument."""
    for api, cli in terms:
        message = message.replace(api, cli)
    return message


def finite_float(text):
    """argparse type: a finite float (``nan``, ``inf`` and values that overflow are refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def positive_float(text):
    """argparse type: a finite float > 0."""
    value = finite_float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def positive_int(text):
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return value


def backend_args(p):
    """``--backend``, ``--device`` and ``--quiet`` (no line saying which backend ran)."""
    p.add_argument("--backend", choices=("numpy", "warp", "opencl"), help="default: automatic")
    p.add_argument("--device", help="device of the backend (e.g. cuda:0, or an OpenCL index)")
    p.add_argument("-q", "--quiet", action="store_true", help="do not print which backend and device ran")


def image_args(p, examples=io.EXAMPLES):
    """A positional IMAGE and ``--example``."""
    p.add_argument("image", nargs="?", help="input image (PNG, JPEG, TIFF, ...)")
    p.add_argument("--example", choices=examples, help="use a bundled example image instead")


#: the positional input arguments a command may have, in the order they are named in messages
INPUT_ARGUMENTS = ("image", "left", "right")


def check_source(args):
    """An input file and ``--example`` together are an error (the file would be ignored), and so is
    an input file that does not exist or is not a regular file (a directory, a FIFO).

    :func:`gfgpu.cli.main` calls it for every command before anything runs; CommandError names the
    argument and the path."""
    example = getattr(args, "example", None)
    files = [getattr(args, name) for name in INPUT_ARGUMENTS if getattr(args, name, None)]
    if example and files:
        raise CommandError(f"give input file(s) or --example {example}, not both (got {' '.join(files)} and "
                           f"--example {example})")
    for name in INPUT_ARGUMENTS:        # a missing input is a usage error before anything runs
        path = getattr(args, name, None)
        if path and not os.path.exists(path):
            raise CommandError(f"{name.upper()} {path}: no such file")
        problem = io.regular_file_problem(path) if path else None
        if problem is not None:
            raise CommandError(f"{name.upper()} {path}: {problem}, not an image file")


def read_input(args):
    """``(array, label)`` of the command's IMAGE or ``--example`` (never both: :func:`check_source`)."""
    check_source(args)
    if getattr(args, "example", None):
        return io.example_image(args.example), f"{args.example} (bundled)"
    if args.image is None:
        raise CommandError(f"give an IMAGE path or --example {io.EXAMPLES[0]}")
    return io.read_image(args.image), args.image


def size_text(shape):
    """An image's size as every message gives it, the library's order: ``"480 x 640 (rows x cols)"``."""
    return f"{shape[0]} x {shape[1]} (rows x cols)"


def duration_text(seconds):
    """A wall time as every command prints it: milliseconds below a second, else seconds
    (``"840 ms"``, ``"2.5 s"``, ``"116 s"``).

    Examples
    --------
    >>> duration_text(0.8404), duration_text(2.54), duration_text(115.9)
    ('840 ms', '2.5 s', '116 s')
    """
    if seconds < 1:
        return f"{seconds * 1e3:.0f} ms"
    return f"{seconds:.1f} s" if seconds < 100 else f"{seconds:.0f} s"


def check_image_output(option, path, image):
    """Before any work: refuse an output format that would lose the input's depth or alpha
    (:func:`gfgpu.io.check_keeps`, a CommandError naming ``option``); returns the one-line note of
    any stated conversion (:func:`gfgpu.io.conversion_note`), or None."""
    if not path:
        return None
    try:
        io.check_keeps(image, path, option)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    return io.conversion_note(image, path)


def note(args, text):
    """Print a conversion note (``gfgpu COMMAND: note: ...``) on stderr (also with ``--quiet``, which
    silences the backend line only: what was done to the values is never silent)."""
    if text:
        print(f"gfgpu {args.command}: note: {text}", file=sys.stderr)


def working_dtype(image):
    """The float type a command filters ``image`` in: float64 stays float64 (never cast down: a
    float64 TIFF beyond float32's range must not overflow), everything else float32."""
    return np.float64 if np.asarray(image).dtype == np.float64 else np.float32


#: extensions an image output (``-o``) may have; its format follows the extension
IMAGE_OUTPUT = tuple(io.IMAGE_FORMATS)
#: the extension of a ``--npy`` output
NPY_OUTPUT = (".npy",)


def same_file(a, b):
    """Whether paths ``a`` and ``b`` name one file: the same path, a symbolic link to it (also a
    dangling link that points there) or a hard link (``os.path.samefile`` where both exist)."""
    if os.path.abspath(a) == os.path.abspath(b) or os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_outputs(inputs, outputs):
    """Before any work: refuse outputs that cannot or must not be written (CommandError).

    ``outputs`` are ``(option, path, extensions)`` (``path`` None: not asked for;
    ``extensions`` None: any).  Each must have one of its extensions, lie in an existing
    writable folder (:func:`gfgpu.io.check_output`; nothing is created), not be an input file
    (also through a symbolic or hard link: inputs are never written) and not be another
    output.  The message names the option.
    """
    inputs = [p for p in inputs if p]
    seen = []
    for option, path, extensions in outputs:
        if not path:
            continue
        for src in inputs:
            if same_file(path, src):
                raise CommandError(f"{option} {path}: refusing to overwrite the input {src}; choose another "
                                   f"output")
        for other_option, other in seen:
            if same_file(path, other):
                raise CommandError(f"{option} and {other_option} name the same file {path}")
        try:
            io.check_output(path, name=option, extensions=extensions)
        except (OSError, ValueError) as exc:
            raise CommandError(str(exc)) from None
        seen.append((option, path))


def refuse_overwrite(inputs, outputs):
    """:func:`check_outputs` for outputs of any extension (named "output" in messages)."""
    check_outputs(inputs, [("output", out, None) for out in outputs])


def announce_backend(args):
    """Resolve the backend the command will run on and say so (one line, unless ``--quiet``).

    A bad ``--backend``/``--device`` is a CommandError naming the option."""
    if hasattr(args, "image") and args.image is None and not getattr(args, "example", None):
        # a usage error before the backend starts (and says it runs): no input at all
        raise CommandError(f"give an IMAGE path or --example {io.EXAMPLES[0]}")
    backend, device = getattr(args, "backend", None), getattr(args, "device", None)
    if device is not None and backend is None:
        raise CommandError(f"--device {device}: needs --backend as well (e.g. --backend warp --device cuda:0)")
    try:
        be = resolve_backend(backend, device)
    except (BackendUnavailable, ValueError, TypeError) as exc:
        option = f"--device {device}" if device is not None else f"--backend {backend}" if backend else "backend"
        raise CommandError(f"{option}: {exc}") from None
    if not getattr(args, "quiet", False):
        print(f"gfgpu {args.command}: backend {be.name} on {be.device}")
    return be


def split_alpha_work(image):
    """``(work, has_alpha)``: the float array a colour filter runs on (:func:`working_dtype`).  With alpha, colour x
    alpha and alpha (premultiplied, :func:`gfgpu.io.premultiply`), all filtered alike, so edges
    get no dark fringes; :func:`join_alpha` undoes it."""
    img = np.asarray(image)
    if io.has_alpha(img):
        return io.premultiply(img, working_dtype(img)), True
    if img.ndim == 3 and img.shape[-1] == 1:
        img = img[..., 0]
    return img.astype(working_dtype(img)), False


def join_alpha(result, image, has_alpha):
    """The filtered premultiplied ``result`` back to colour and alpha (see :func:`split_alpha_work`)."""
    return io.unpremultiply(result, np.asarray(image).dtype) if has_alpha else result


def drop_alpha(image):
    """The colour channels of an image (alpha is not image content); grey stays 2-D."""
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[-1] in (2, 4):
        img = img[..., :-1]
    if img.ndim == 3 and img.shape[-1] == 1:
        img = img[..., 0]
    return img
