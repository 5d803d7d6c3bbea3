"""Options shared by ``gfgpu blur`` and ``gfgpu frames``: the kind of motion and its parameters.

The options name their axis (``--dx`` columns, ``--dy`` rows, ``--center-x`` column,
``--center-y`` row) and :func:`motion_input` maps them onto the library's array-axis order:
``velocity=(dy, dx)`` and ``center=(row, col)``.
"""

from __future__ import annotations

from .common import MODE_HELP, MODES, CommandError, backend_args, finite_float, image_args, read_input, split_alpha_work


def motion_args(p):
    image_args(p)
    p.add_argument("--dx", type=finite_float, metavar="DX",
                   help="uniform motion toward the right (columns), pixels during the exposure")
    p.add_argument("--dy", type=finite_float, metavar="DY",
                   help="uniform motion downward (rows), pixels during the exposure")
    p.add_argument("--zoom", type=finite_float, metavar="U1",
                   help="zoom rate u1 in (-0.828, 2): a point at x moves to c + (x - c)(1 + u1); "
                        "u1 > 0 zooms in, u1 < 0 zooms out (reads beyond the border through --mode)")
    p.add_argument("--rotate", type=finite_float, metavar="DEGREES",
                   help="rotation during the exposure, in [-360, 360] degrees, counter-clockwise on "
                        "screen for > 0, about the centre (blurred along the arcs)")
    p.add_argument("--center-x", type=finite_float, metavar="X",
                   help="column of the zoom/rotation centre (default: middle)")
    p.add_argument("--center-y", type=finite_float, metavar="Y",
                   help="row of the zoom/rotation centre (default: middle)")
    p.add_argument("--keep-position", action="store_true",
                   help="uniform motion or rotation: blur in place instead of displacing the content")
    p.add_argument("--mode", default="reflect", choices=MODES, help=MODE_HELP)
    backend_args(p)


def check_motion(args):
    """The options' consistency (CommandError), before reading anything."""
    uniform = args.dx is not None or args.dy is not None
    kinds = [name for name, given in (("--dx/--dy", uniform), ("--zoom", args.zoom is not None),
                                      ("--rotate", args.rotate is not None)) if given]
    if len(kinds) != 1:
        got = f"; got {' and '.join(kinds)}" if kinds else ""
        raise CommandError(f"give one motion: --dx/--dy (uniform, pixels), --zoom U1 or --rotate DEGREES{got}")
    if uniform and (args.center_x, args.center_y) != (None, None):
        raise CommandError("--center-x/--center-y apply to --zoom and --rotate only")


def motion_input(args):
    """``(image, work, has_alpha, label, keyword arguments of motion_blur / synthesize_motion)``.

    ``image`` is the file's array, ``work`` the float32 array to filter (with alpha:
    premultiplied, see :func:`gfgpu.cli.common.split_alpha_work`).  ``--dx``/``--dy`` become
    ``velocity=(dy, dx)`` (rows, cols; a missing one is 0), and ``--center-x``/``--center-y``
    become ``center=(row, col)`` (a missing one is the middle).
    """
    check_motion(args)
    uniform = args.dx is not None or args.dy is not None
    image, label = read_input(args)
    img, alpha = split_alpha_work(image)
    if img.ndim not in (2, 3):
        raise CommandError(f"{label}: expected a grey or colour image, got shape {img.shape}")
    given = (args.center_x, args.center_y) != (None, None)
    center = None
    if given:
        h, w = img.shape[:2]
        center = (args.center_y if args.center_y is not None else (h - 1) / 2.0,    # (row, col)
                  args.center_x if args.center_x is not None else (w - 1) / 2.0)
    if uniform:
        kw = dict(kind="uniform", velocity=(args.dy or 0.0, args.dx or 0.0),       # (vy, vx)
                  displace=not args.keep_position)
    elif args.rotate is not None:
        kw = dict(kind="rotation", velocity=args.rotate, center=center, displace=not args.keep_position)
    else:
        kw = dict(kind="zoom", velocity=args.zoom, center=center)
    kw.update(mode=args.mode, channel_axis=-1 if img.ndim == 3 else None)
    return image, img, alpha, label, kw
