"""Options shared by ``gfgpu blur`` and ``gfgpu frames``: the kind of motion, its parameters, the PSF.

The kinds of motion and the point-spread functions are the table of :mod:`gfgpu.motion.kinds`:
``--psf`` offers its PSF names, and each kind the table offers has its options here
(:data:`MOTION_OPTIONS`; a velocity field, an array per image, has none).  A kind that the table
gains without options here is not offered by the commands (a test requires every kind to have
them), so the command line never fails to start over it.  The options name
their axis (``--dx`` columns, ``--dy`` rows, ``--center-x`` column, ``--center-y`` row) and
:func:`motion_input` maps them onto the library's array-axis order: ``velocity=(dy, dx)`` and
``center=(row, col)``.
"""

from __future__ import annotations

from ..motion.kinds import KINDS, MOTIONS, PSFS
from .common import MODE_HELP, MODES, CommandError, backend_args, finite_float, image_args, read_input, split_alpha_work

#: per kind of :data:`gfgpu.motion.kinds.KINDS`: its options, their usage in messages, and its
#: ``velocity`` from the parsed options (None where they are not given)
MOTION_OPTIONS = {
    "uniform": ("--dx/--dy", "--dx/--dy (uniform, pixels)",
                lambda a: None if a.dx is None and a.dy is None else (a.dy or 0.0, a.dx or 0.0)),   # (vy, vx)
    "zoom": ("--zoom", "--zoom U1", lambda a: a.zoom),
    "rotation": ("--rotate", "--rotate DEGREES", lambda a: a.rotate),
}


#: the library's argument names in its messages -> the options of the command line (in this order)
CLI_TERMS = (
    ("velocity (zoom u1)", "--zoom"),
    ("velocity (rotation angle in degrees)", "--rotate (degrees)"),
    ("velocity (rotation angle)", "--rotate"),
    ("center (row, col)", "the centre (--center-y, --center-x)"),
)


def _offered():
    """The kinds of the table that have options here, in table order."""
    return [kind for kind in KINDS if kind in MOTION_OPTIONS]


def _options_of(kind):
    return MOTION_OPTIONS[kind]


def psf_help():
    """The help of ``--psf``: the table's PSFs and what each is."""
    return "point-spread function along the path: " + "; ".join(f"{p.name}: {p.summary}" for p in PSFS.values())


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
    p.add_argument("--psf", choices=tuple(PSFS), default=next(iter(PSFS)), help=psf_help())
    p.add_argument("--keep-position", action="store_true",
                   help="blur in place instead of displacing the content (uniform motion, rotation and "
                        "the box zoom; the green zoom always displaces)")
    p.add_argument("--mode", default="reflect", choices=MODES, help=MODE_HELP)
    backend_args(p)


def motion_kind_of(args):
    """The kind of motion the options give (CommandError unless exactly one is given)."""
    given = [kind for kind in _offered() if _options_of(kind)[2](args) is not None]
    if len(given) != 1:
        got = f"; got {' and '.join(_options_of(k)[0] for k in given)}" if given else ""
        usage = [_options_of(k)[1] for k in _offered()]
        raise CommandError(f"give one motion: {', '.join(usage[:-1])} or {usage[-1]}{got}")
    return given[0]


def check_motion(args):
    """The options' consistency (CommandError), before reading anything."""
    kind = motion_kind_of(args)
    if (args.center_x, args.center_y) != (None, None) and not MOTIONS[kind].uses_center:
        centred = " and ".join(_options_of(k)[0] for k in _offered() if MOTIONS[k].uses_center)
        raise CommandError(f"--center-x/--center-y apply to {centred} only")
    if kind == "zoom" and getattr(args, "keep_position", False) and args.psf == "green":
        # gfgpu.motion_blur ignores displace=False for the Green zoom (its kernel is one-sided)
        raise CommandError("--keep-position does not apply to --zoom with --psf green (the Green zoom always "
                           "displaces the content); use --psf box for an in-place zoom blur")
    # the value's range too (ValueError in the library's terms, reported in the command's: CLI_TERMS),
    # so that an out-of-range --zoom or --rotate is refused before the backend starts
    MOTIONS[kind].parse(_options_of(kind)[2](args))
    return kind


def motion_input(args):
    """``(image, work, has_alpha, label, keyword arguments of motion_blur / synthesize_motion)``.

    ``image`` is the file's array, ``work`` the float32 array to filter (with alpha:
    premultiplied, see :func:`gfgpu.cli.common.split_alpha_work`).  ``--dx``/``--dy`` become
    ``velocity=(dy, dx)`` (rows, cols; a missing one is 0), and ``--center-x``/``--center-y``
    become ``center=(row, col)`` (a missing one is the middle).
    """
    kind = check_motion(args)
    image, label = read_input(args)
    img, alpha = split_alpha_work(image)
    if img.ndim not in (2, 3):
        raise CommandError(f"{label}: expected a grey or colour image, got shape {img.shape}")
    kw = dict(kind=kind, velocity=_options_of(kind)[2](args), psf=args.psf, displace=not args.keep_position)
    if MOTIONS[kind].uses_center and (args.center_x, args.center_y) != (None, None):
        h, w = img.shape[:2]
        kw["center"] = (args.center_y if args.center_y is not None else (h - 1) / 2.0,    # (row, col)
                        args.center_x if args.center_x is not None else (w - 1) / 2.0)
    kw.update(mode=args.mode, channel_axis=-1 if img.ndim == 3 else None)
    return image, img, alpha, label, kw
