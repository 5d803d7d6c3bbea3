"""``gfgpu batch``: one operator over many image files, here or on a Dask cluster.

Examples::

    gfgpu batch shift photos/ -o shifted/ --dx 2.5 --dy -1.25
    gfgpu batch gradient 'scans/**/*.tif' -o grad/ -u 1.5 --format npy --workers 4
    gfgpu batch canny a.png b.png -o edges/ -u 1 --low 0.8 --high 0.95
    gfgpu batch blur frames/ -o blurred/ --dx 25 --dy -10 --scheduler tcp://head:8786
    gfgpu batch blur frames/ -o zoomed/ --zoom 0.1 --center-x 300 --center-y 200
    gfgpu batch blur frames/ -o spun/ --rotate 12 --psf box

The options name their axis (``--dx`` columns, ``--dy`` rows, ``--center-x`` column,
``--center-y`` row); :func:`_params` maps them onto the library's array-axis order
(``shift=(dy, dx)``, ``velocity=(dy, dx)``, ``center=(row, col)``, see :mod:`gfgpu.batch`).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import time

from ..batch import BLUR_MOTIONS, FORMATS, Result, check_parameters, discover_inputs, plan_jobs, run_batch, summarize
from ..io import remove_stale_temporaries
from ..motion.kinds import MOTIONS, PSFS
from .common import CommandError, announce_backend, backend_args, in_cli_terms
from .motion_args import CLI_TERMS as _MOTION_TERMS
from .motion_args import MOTION_OPTIONS, check_motion, psf_help

#: the library's argument names in its messages -> the options of ``gfgpu batch``
CLI_TERMS = _MOTION_TERMS
#: the conversion notes of the summary (gfgpu.io.conversion_note) in this command's options
NOTE_TERMS = (("write a .tif to keep", "--format tiff keeps"),)

_EPILOG = """\
Outputs are OUTDIR/<input stem>.<format>, written atomically (temporary file + rename), so an
interrupted batch leaves only complete files; a rerun skips the outputs that exist (resume)
unless --overwrite, and removes the temporary files (.gfgpu-HOST-PID-*) that killed runs left in
OUTDIR (their process is gone, or, from another host, they are over a day old). Inputs are never
overwritten; files inside OUTDIR are not taken from a directory or pattern (a batch whose OUTDIR
lies under its input pattern skips its own outputs). Anything that is not a regular file (a FIFO
named x.png, ...) is skipped, never opened, and reported. A file that fails (unreadable,
truncated, unsupported pixel type, ...) is reported with its reason and the others go on; the
exit status is 1 if any file failed, 2 for a usage error found before any work.

--workers N starts N local worker processes (Dask LocalCluster, one thread each).
--scheduler ADDRESS uses a running Dask cluster (e.g. tcp://head:8786, started with
`dask scheduler` and `dask worker ADDRESS --nthreads 1` per GPU): every worker must have gfgpu
installed and see the input and output paths at the same location (a shared filesystem).
See docs/batch.md."""


def _common_args(p):
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="image files, directories (their .png .jpg .jpeg .tif .tiff .bmp files, not recursive) "
                        "or glob patterns (quote them; ** spans directories)")
    p.add_argument("-o", "--output-dir", required=True, metavar="OUTDIR", help="output directory")
    p.add_argument("--format", choices=tuple(FORMATS), default="png",
                   help="png: 8-bit image to look at (default); tiff, npy: the raw float result")
    p.add_argument("--overwrite", action="store_true", help="recompute outputs that already exist")
    p.add_argument("--mode", default="reflect", choices=("reflect", "constant", "nearest", "mirror", "wrap"),
                   help="boundary extension (default reflect)")
    backend_args(p)
    run = p.add_mutually_exclusive_group()
    run.add_argument("--workers", type=int, metavar="N", help="N local worker processes (Dask LocalCluster)")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="address of a running Dask scheduler (files must be on a shared filesystem)")


def add_parser(subparsers):
    """Add the ``batch`` subcommand (with one sub-subcommand per operator) to ``subparsers``."""
    batch = subparsers.add_parser(
        "batch", help="one operator over many image files (here, local processes or a Dask cluster)",
        description="Run one operator over many image files: gfgpu batch OP INPUTS... -o OUTDIR [options].",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ops = batch.add_subparsers(dest="op", required=True, metavar="OP")

    def op_parser(name, text):
        p = ops.add_parser(name, help=text, description=text, epilog=_EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        _common_args(p)
        p.set_defaults(func=run)
        return p

    p = op_parser("shift", "translation by --dx/--dy pixels: integer part exact, fraction by the Green shift "
                                "(colour per channel)")
    p.add_argument("--dx", type=float, metavar="DX", help="displacement toward the right (columns), pixels")
    p.add_argument("--dy", type=float, metavar="DY", help="displacement downward (rows), pixels")

    p = op_parser("gradient", "Green's-function gradient of the grey image (PNG colour-coded; raw (gy, gx))")
    p.add_argument("-u", type=float, default=1.0, help="scale u of D (pixels, > 0), default 1.0")

    p = op_parser("canny", "edge map (Green's-function gradient + Canny's steps)")
    p.add_argument("-u", type=float, default=1.0, help="scale u of D (pixels, > 0), default 1.0")
    p.add_argument("--low", type=float, metavar="Q",
                   help="low hysteresis threshold as a quantile of the gradient magnitude in [0, 1] "
                        "(default: gfgpu.canny's absolute default)")
    p.add_argument("--high", type=float, metavar="Q", help="high threshold, a quantile in [0, 1]")

    p = op_parser("blur", "motion blur (--dx/--dy), zoom blur (--zoom U1) or rotation blur (--rotate DEGREES), "
                          "colour per channel")
    p.add_argument("--dx", type=float, metavar="DX", help="uniform motion toward the right (columns), pixels")
    p.add_argument("--dy", type=float, metavar="DY", help="uniform motion downward (rows), pixels")
    p.add_argument("--zoom", type=float, metavar="U1",
                   help="zoom rate u1 in (-0.828, 2): a point at x moves to c + (x - c)(1 + u1)")
    p.add_argument("--rotate", type=float, metavar="DEGREES",
                   help="rotation during the exposure, in [-360, 360] degrees, counter-clockwise on screen "
                        "for > 0 (blurred along the arcs)")
    p.add_argument("--center-x", type=float, metavar="X",
                   help="column of the zoom's or rotation's fixed point (default: each image's middle)")
    p.add_argument("--center-y", type=float, metavar="Y",
                   help="row of the zoom's or rotation's fixed point (default: each image's middle)")
    p.add_argument("--psf", choices=tuple(PSFS), default=next(iter(PSFS)), help=psf_help())
    p.add_argument("--keep-position", action="store_true",
                   help="blur in place instead of displacing the content (uniform motion, rotation and the "
                        "box zoom; the green zoom always displaces)")
    return subparsers


def _params(args):
    """The :mod:`gfgpu.batch` parameters of the options, in the library's (rows, cols) order."""
    if args.op == "shift":
        if args.dx is None and args.dy is None:
            raise CommandError("give the displacement: --dx (right) and/or --dy (down), pixels")
        return {"shift": (args.dy or 0.0, args.dx or 0.0)}                 # (dy, dx)
    if args.op == "gradient":
        return {"u": args.u}
    if args.op == "canny":
        return {"u": args.u, "low": args.low, "high": args.high}
    kind = check_motion(args)                      # one kind of gfgpu.motion.kinds, as gfgpu blur
    params = {BLUR_MOTIONS[kind]: MOTION_OPTIONS[kind][2](args),           # velocity=(vy, vx), zoom, rotation
              "keep_position": args.keep_position, "psf": args.psf}
    if MOTIONS[kind].uses_center:
        centre = (args.center_y, args.center_x)                            # (row, col)
        params["center"] = None if centre == (None, None) else centre
    return params


@contextlib.contextmanager
def _quiet_dask(on):
    """Dask's own log lines (workers started and killed, connections closed at shutdown) are not
    the command's output: only errors, here and (through the environment, read when they start)
    in the worker processes.  A file's failure is reported in the summary either way."""
    if not on:
        yield
        return
    key = "DASK_LOGGING__DISTRIBUTED"
    before, level = os.environ.get(key), logging.getLogger("distributed").level
    os.environ[key] = "critical"
    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logging.getLogger("distributed").setLevel(level)
        if before is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = before


def run(args):
    """Handler of ``gfgpu batch``: plan (errors before any work), run, summarise; 1 if a file failed."""
    if args.workers is not None and args.workers < 1:
        raise CommandError(f"--workers must be >= 1, got {args.workers}")
    params = _params(args)
    check_parameters(args.op, params, args.mode)
    left_out = []
    inputs = discover_inputs(args.inputs, exclude=args.output_dir, skipped=left_out)
    jobs = plan_jobs(inputs, args.output_dir, args.op, params, fmt=args.format, mode=args.mode,
                     backend=args.backend, device=args.device, overwrite=args.overwrite)
    if os.path.lexists(args.output_dir) and not os.path.isdir(args.output_dir):
        raise CommandError(f"-o {args.output_dir}: exists and is not a directory")
    if args.workers is None and args.scheduler is None:
        announce_backend(args)   # workers resolve their own; they say so in their results
    stale = remove_stale_temporaries(args.output_dir)
    if stale:
        print(f"removed {len(stale)} temporary file(s) of an interrupted run from {args.output_dir}", file=sys.stderr)
    in_outdir = sum(reason == "inside the output folder" for _, reason in left_out)
    if in_outdir:
        print(f"left out {in_outdir} file(s) inside the output folder {args.output_dir} (this batch's outputs)")
    t0 = time.perf_counter()
    with _quiet_dask(args.workers is not None or args.scheduler is not None):
        results = run_batch(jobs, workers=args.workers, scheduler=args.scheduler,
                            description=f"gfgpu batch {args.op}")
    results += [Result(path, "", "skipped", reason) for path, reason in left_out
                if reason != "inside the output folder"]
    text, code = summarize(results, time.perf_counter() - t0)
    print(in_cli_terms(text, NOTE_TERMS))
    return code
