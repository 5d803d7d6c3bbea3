"""The ``gfgpu`` command: Green's-function filters on image files.

One module per command (``gradient``, ``shift``, ``blur``, ``frames``, ``disparity``,
``depth``, ``batch``, ``devices``), each with ``add_parser(subparsers)`` and ``run(args)``.
The library never imports this package.

Examples::

    gfgpu disparity --example motorcycle -o motorcycle_disparity.png
    gfgpu gradient --example camera -o camera_gradient.png -u 1.0
    gfgpu shift photo.png -o shifted.png --dx 2.5 --dy -1.25
    gfgpu devices
"""

from __future__ import annotations

import argparse
import sys

from .._version import __version__
from ..backends import BackendUnavailable
from . import batch, blur, depth, devices, disparity, frames, gradient, shift
from .common import CommandError

__all__ = ["main", "build_parser"]

COMMANDS = (disparity, gradient, shift, blur, frames, depth, batch, devices)


def build_parser():
    parser = argparse.ArgumentParser(prog="gfgpu", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"gfgpu {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv=None):
    """Run the ``gfgpu`` command; returns the exit status (2 for a one-line error message)."""
    args = build_parser().parse_args(argv)
    name = args.command if getattr(args, "op", None) is None else f"{args.command} {args.op}"
    try:
        return args.func(args)
    except (CommandError, BackendUnavailable, OSError, ValueError, TypeError) as exc:
        print(f"gfgpu {name}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"gfgpu {name}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
