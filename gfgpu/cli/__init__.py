"""The ``gfgpu`` command: Green's-function filters on image files.

One module per command (``gradient``, ``canny``, ``shift``, ``blur``, ``frames``, ``disparity``,
``depth``, ``batch``, ``devices``), each with ``add_parser(subparsers)`` and ``run(args)``.
The library never imports this package.

Examples::

    gfgpu disparity --example motorcycle -o motorcycle_disparity.png
    gfgpu gradient --example camera -o camera_gradient.png -u 1.0
    gfgpu shift photo.png -o shifted.png --dx 2.5 --dy -1.25
    gfgpu devices

Every command checks its options, inputs and outputs before any work, and an error is one line
``gfgpu COMMAND: message`` on stderr naming the option or the file.  Exit status:

- 0: done;
- 2: a usage error, found before any work: a bad option or option value (``-u 0``, ``--dx nan``,
  an unknown ``--device``), an input that cannot be read (missing, not a regular file, corrupt,
  empty, an animation or multi-page file, complex samples, a decompression bomb), an output
  that must not or cannot be written (an input file, a wrong extension, a missing, read-only or
  non-directory folder: nothing is created);
- 1: the work failed: an output could not be written after computing (a full disk, an I/O
  error: :class:`gfgpu.io.OutputError`), or in ``gfgpu batch`` at least one file failed;
- 130: interrupted (Ctrl-C).
"""

from __future__ import annotations

import sys

from .._version import __version__

__all__ = ["main", "build_parser"]


def commands():
    """The command modules, in the order ``gfgpu --help`` lists them.

    Imported here, not at the top: ``from gfgpu.cli import main`` (the ``gfgpu`` script's first
    line) then loads next to nothing, so a Ctrl-C during start-up reaches :func:`main`'s handler
    (exit status 130, one line) instead of printing a traceback."""
    from . import batch, blur, canny, depth, devices, disparity, frames, gradient, shift
    return (disparity, gradient, canny, shift, blur, frames, depth, batch, devices)


#: the command's one-line description (not read from the docstring, which ``python -OO`` drops)
DESCRIPTION = "The gfgpu command: Green's-function filters on image files."


def build_parser():
    """The ``gfgpu`` command's argparse parser, every command's subparser added."""
    # imported here, like the commands (see commands())
    import argparse

    class _Parser(argparse.ArgumentParser):
        """Usage errors as one line, ``gfgpu COMMAND: message`` (exit status 2), like every other error."""

        def error(self, message):
            self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")

    parser = _Parser(prog="gfgpu", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"gfgpu {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in commands():
        command.add_parser(sub)
    return parser


def main(argv=None):
    """Run the ``gfgpu`` command; returns the exit status (2: usage error, 1: the work failed,
    130: interrupted; see the module's documentation)."""
    name, args = "gfgpu", None
    try:
        # inside the try: a Ctrl-C while the commands are imported is an interruption like any other
        from .common import check_source
        parser = build_parser()
        args, extra = parser.parse_known_args(argv)
        name = args.command if getattr(args, "op", None) is None else f"{args.command} {args.op}"
        if extra:
            # the command's parser reports them (argparse's top level would say "gfgpu: ...")
            _command_parser(parser, args).error(f"unrecognized arguments: {' '.join(extra)}" + _hint(args, extra))
        check_source(args)
        return args.func(args)
    except KeyboardInterrupt:
        print(f"{'gfgpu ' if name != 'gfgpu' else ''}{name}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        status = _report(exc, name, args)
        if status is None:
            raise
        return status


def _command_parser(parser, args):
    """The parser of the command (and sub-command, ``gfgpu batch canny``) that ``args`` ran."""
    import argparse
    for key in ("command", "op"):
        actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not actions or getattr(args, key, None) is None:
            break
        parser = actions[0].choices[getattr(args, key)]
    return parser


def _hint(args, extra):
    if "--example" in extra or any(e.startswith("--example=") for e in extra):
        return (" (gfgpu depth needs a shading image of your own: there is no bundled example)"
                if args.command == "depth" else "")
    return ""


def _report(exc, name, args):
    """The exit status of a failed command, its one-line message printed; None for an exception that is
    not a reported failure (a bug: it propagates with its traceback)."""
    from ..backends import BackendUnavailable
    from ..io import OutputError
    from .common import CommandError, in_cli_terms
    if isinstance(exc, OutputError):
        print(f"gfgpu {name}: {exc}", file=sys.stderr)
        return 1
    if isinstance(exc, (CommandError, BackendUnavailable, OSError, ValueError, TypeError)):
        # a library error, in the command's terms (CommandErrors are written in them already)
        terms = () if isinstance(exc, CommandError) else \
            getattr(sys.modules.get(getattr(getattr(args, "func", None), "__module__", "")), "CLI_TERMS", ())
        print(f"gfgpu {name}: {in_cli_terms(str(exc), terms)}", file=sys.stderr)
        return 2
    return None


if __name__ == "__main__":
    sys.exit(main())
