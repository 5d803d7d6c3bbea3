"""Batch processing of image files: one task per file, run here or on a Dask cluster.

The engine behind ``gfgpu batch``.  A batch is planned in the calling process
(:func:`discover_inputs`, :func:`check_parameters`, :func:`plan_jobs`: every problem that concerns
the whole batch is reported before any work), then each file is one call of
:func:`process_file`, which reads the image, applies one operator of the public API and writes
the result atomically.  :func:`run_batch` runs the calls in this process, on a
``dask.distributed.LocalCluster`` of worker processes, or on any Dask cluster given by its
scheduler address (the same code on one machine or many).

Per-file problems (an unreadable or truncated file, an unsupported pixel type, a filter error)
never stop the batch: they come back as ``failed`` results with the reason.  Existing outputs are
skipped (resume) unless ``overwrite``; inputs are never written.  Discovery leaves out anything
that is not a regular file (a FIFO named ``x.png`` would block a reader forever: it is never
opened) and, given the output folder, the files inside it (a batch's own outputs are not inputs
of its rerun).

Importing this module starts nothing: Dask is imported only when a cluster is asked for.
"""

from __future__ import annotations

import contextlib
import glob
import os
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ._core.boundary import SCIPY_MODES
from ._core.validation import finite_scalar, work_dtype
from .backends import resolve_backend
from .edges import canny
from .filters import gradient, shift
from .io import (
    conversion_note,
    gradient_to_rgb,
    has_alpha,
    premultiply,
    read_image,
    regular_file_problem,
    save_npy,
    save_png,
    to_output,
    unpremultiply,
    write_atomic,
    write_image,
)
from .motion import motion_blur
from .motion.kinds import KINDS, MOTIONS

__all__ = ["IMAGE_EXTENSIONS", "FORMATS", "OPS", "PARAMETERS", "BLUR_MOTIONS", "Job", "Result", "discover_inputs",
           "check_parameters", "plan_jobs", "process_file", "run_batch", "summarize"]

#: extensions of the image files taken from a directory (compared case-insensitively)
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
#: output formats and their file extensions
FORMATS = {"png": ".png", "tiff": ".tiff", "npy": ".npy"}
#: operators (see :func:`process_file` for their parameters)
OPS = ("shift", "gradient", "canny", "blur")
#: blur's motion parameter of each kind of :data:`gfgpu.motion.kinds.KINDS` (exactly one is given):
#: ``velocity=(vy, vx)`` for uniform motion, else the kind's name (``zoom=u1``, ``rotation=degrees``)
BLUR_MOTIONS = {kind: "velocity" if kind == "uniform" else kind for kind in KINDS}
#: the parameters each operator takes; pairs are in array-axis order (rows, cols)
PARAMETERS = {"shift": ("shift",), "gradient": ("u",), "canny": ("u", "low", "high"),
              "blur": (*BLUR_MOTIONS.values(), "keep_position", "center", "psf")}
_MODES = SCIPY_MODES      # each operator gives a name its scipy meaning (filter or interpolation)


@dataclass
class Job:
    """One file of a batch: everything a worker process needs, as plain picklable values.

    ``params`` holds the operator's parameters (see :func:`process_file`); ``backend`` is a
    backend *name* and ``device`` a device string, resolved in the process that runs the job
    (:func:`gfgpu.get_backend` caches one backend per process).
    """

    input: str
    output: str
    op: str
    params: dict = field(default_factory=dict)
    fmt: str = "png"
    mode: str = "reflect"
    backend: str | None = None
    device: str | None = None
    overwrite: bool = False


@dataclass
class Result:
    """What happened to one file: ``status`` is ``'ok'``, ``'skipped'`` or ``'failed'``."""

    input: str
    output: str
    status: str
    message: str = ""
    seconds: float = 0.0
    ran_on: str = ""       # "backend NAME on DEVICE" of the process that computed it
    note: str = ""         # what the output did to the values (gfgpu.io.conversion_note), "" if nothing


# --------------------------------------------------------------------------------------
# planning (in the calling process, before any work)
# --------------------------------------------------------------------------------------
def _is_image_name(name):
    return os.path.splitext(name)[1].lower() in IMAGE_EXTENSIONS


def discover_inputs(items, *, exclude=None, skipped=None):
    """Absolute paths of the input files named by ``items``, sorted and de-duplicated.

    Parameters
    ----------
    items : sequence of str or path
        Each is a directory (its image files, :data:`IMAGE_EXTENSIONS` in any letter case, not
        recursive, hidden files left out), a glob pattern (``*``, ``?``, ``[...]``; ``**`` spans
        directories; every matching file whatever its extension) or a file.  A file that does
        not exist is kept: it fails in :func:`process_file` with the reason, like any other
        unreadable file.  Anything that exists but is not a regular file (a FIFO, a socket, a
        device) is left out, never opened.
    exclude : str or path, optional
        The batch's output folder: a glob pattern whose fixed part (``imgs`` of
        ``imgs/**/*.png``) lies strictly above it does not yield its files, so a batch whose
        outputs lie under its input pattern skips them on a rerun.  Files named explicitly, a
        directory, or a pattern rooted in the output folder itself are kept (and refused by
        :func:`plan_jobs` where an output would overwrite them).
    skipped : list, optional
        Receives ``(path, reason)`` for each entry left out (not a regular file, or inside
        ``exclude``).

    Returns
    -------
    list of str
        Absolute paths, sorted; the same file reached twice (also through a symbolic link) is
        listed once.

    Raises
    ------
    ValueError
        No items, or a directory or pattern that yields no file (the message names it).

    Examples
    --------
    >>> import os, tempfile
    >>> d = tempfile.mkdtemp()
    >>> for name in ("b.PNG", "a.jpg", "notes.txt"):
    ...     open(os.path.join(d, name), "wb").close()
    >>> [os.path.basename(p) for p in discover_inputs([d, os.path.join(d, "*.jpg")])]
    ['a.jpg', 'b.PNG']
    """
    items = [os.fspath(i) for i in items]
    if not items:
        raise ValueError("inputs: give at least one file, directory or glob pattern")
    skipped = [] if skipped is None else skipped
    outside = os.path.realpath(os.fspath(exclude)) if exclude is not None else None
    found, left_out = {}, set()
    for item in items:
        below = False       # the output folder lies strictly below this pattern's fixed root
        if os.path.isdir(item):
            names = sorted(n for n in os.listdir(item) if not n.startswith(".") and _is_image_name(n))
            matches = [os.path.join(item, n) for n in names if not os.path.isdir(os.path.join(item, n))]
            if not matches:
                raise ValueError(f"input directory {item!r} holds no image file "
                                 f"({', '.join(IMAGE_EXTENSIONS)})")
        elif not os.path.lexists(item) and any(c in item for c in "*?["):
            matches = [p for p in glob.glob(item, recursive=True) if not os.path.isdir(p)]
            if not matches:
                raise ValueError(f"input pattern {item!r} matches no file")
            root = os.path.realpath(_pattern_root(item))
            below = outside is not None and outside != root and os.path.commonpath([outside, root]) == root
        else:
            matches = [item]
        for path in matches:
            path = os.path.abspath(path)
            problem = regular_file_problem(path)
            reason = None
            if problem is not None:
                reason = f"not a regular file ({problem}): not read"
            elif below and os.path.commonpath([outside, os.path.realpath(path)]) == outside:
                reason = "inside the output folder"
            if reason is not None:
                if path not in left_out:
                    left_out.add(path)
                    skipped.append((path, reason))
                continue
            found.setdefault(os.path.realpath(path), path)
    return sorted(found.values())


def _pattern_root(pattern):
    """The part of a glob pattern before its first component with a wildcard."""
    parts = []
    for part in pattern.split(os.sep):
        if any(c in part for c in "*?["):
            break
        parts.append(part)
    return os.sep.join(parts) or ("." if not pattern.startswith(os.sep) else os.sep)


def _probe_image():
    # a small textured image: distinct gradient magnitudes, so quantile thresholds are ordered
    yy, xx = np.mgrid[:24, :24]
    return (np.sin(xx / 3.0) * np.cos(yy / 5.0) + 0.01 * xx).astype(np.float32)


def _check_keys(op, params):
    """ValueError for a parameter ``op`` does not take (e.g. a misspelt or renamed key)."""
    unknown = sorted(set(params) - set(PARAMETERS[op]))
    if unknown:
        raise ValueError(f"{op} takes the parameters {', '.join(PARAMETERS[op])}; got unknown "
                         f"{', '.join(map(repr, unknown))} (shift=(dy, dx), velocity=(vy, vx) and "
                         f"center=(row, col) are in array-axis order, rows then columns)")
    if op == "shift" and "shift" not in params:
        raise ValueError("shift needs shift=(dy, dx): pixels down the rows and right along the columns")
    if op == "blur":
        _blur_kind(params)


def _blur_kind(params):
    """The kind of motion of blur's ``params``: the one motion parameter given (ValueError else)."""
    given = [kind for kind, key in BLUR_MOTIONS.items() if params.get(key) is not None]
    if len(given) != 1:
        forms = ", ".join(f"{key}={MOTIONS[kind].form}" for kind, key in BLUR_MOTIONS.items())
        got = f"; got {' and '.join(BLUR_MOTIONS[k] for k in given)}" if given else ""
        raise ValueError(f"blur needs exactly one of {forms}{got}")
    kind = given[0]
    if params.get("center") is not None and not MOTIONS[kind].uses_center:
        centred = sorted(key for k, key in BLUR_MOTIONS.items() if MOTIONS[k].uses_center)
        raise ValueError(f"center=(row, col) applies to {' and '.join(centred)} only")
    if np.ndim(params[BLUR_MOTIONS[kind]]) == 3:
        raise ValueError("a velocity field (2, H, W) belongs to one image: blur takes velocity=(vy, vx), the same "
                         "for every file (use gfgpu.motion_blur for a field)")
    return kind


def _center(center, img):
    """``center = (row, col)`` for ``img``; a ``None`` coordinate is the image's middle along that axis."""
    if center is None:
        return None
    if np.ndim(center) != 1 or len(center) != 2:
        raise ValueError(f"center must be a pair (row, col), got {center!r}")
    row, col = center
    h, w = img.shape[:2]
    return (finite_scalar("center (row, col)", (h - 1) / 2.0 if row is None else row),
            finite_scalar("center (row, col)", (w - 1) / 2.0 if col is None else col))


def check_parameters(op, params, mode="reflect"):
    """Validate an operator's parameters once, before a batch, with the library's own checks.

    Runs ``op`` on a 24 x 24 test image with the numpy backend (a few milliseconds), so a bad
    value (``u <= 0``, a zoom rate outside its range, ``low > high``, ...) is reported once with
    the message of the function that rejects it, instead of once per file.  A zoom ``center``
    or rotation ``center`` is checked for its form here and for its position per image (a zoom's
    must lie inside each one).

    Parameters
    ----------
    op : {'shift', 'gradient', 'canny', 'blur'}
    params : dict
        The operator's parameters, see :func:`process_file` (keys in :data:`PARAMETERS`).
    mode : str, optional
        Boundary mode, as in :func:`gfgpu.green_filter`.

    Raises
    ------
    ValueError
        Unknown ``op`` or ``mode``, an unknown or missing parameter (e.g. the old ``by`` of
        ``shift``, now ``shift=(dy, dx)``), or a value the operator rejects.
    TypeError
        A non-numeric value.

    Examples
    --------
    >>> check_parameters("blur", {"velocity": (-2.0, 6.0)})
    >>> check_parameters("shift", {"by": (1.0, 2.0)})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: shift takes the parameters shift; got unknown 'by' (shift=(dy, dx), ...)
    """
    if op not in OPS:
        raise ValueError(f"op must be one of {', '.join(OPS)}; got {op!r}")
    if mode not in _MODES:
        raise ValueError(f"mode must be one of {', '.join(_MODES)}; got {mode!r}")
    _check_keys(op, params)
    if op == "canny" and params.get("low") is not None and params.get("high") is not None \
            and params["low"] > params["high"]:
        raise ValueError(f"the low quantile ({params['low']}) must not exceed the high one ({params['high']})")
    probe = dict(params)
    if probe.get("center") is not None:
        _center(probe.pop("center"), np.zeros((2, 2)))    # its form; its position per image
    _OPERATORS[op](_probe_image(), probe, dict(mode=mode, backend="numpy", device=None))


def _file_id(path):
    st = os.stat(path)
    return st.st_dev, st.st_ino


def plan_jobs(inputs, outdir, op, params=None, *, fmt="png", mode="reflect", backend=None, device=None,
              overwrite=False):
    """One :class:`Job` per input, writing ``outdir/<input stem>.<format extension>``.

    Parameters
    ----------
    inputs : sequence of str
        Input files (e.g. from :func:`discover_inputs`).
    outdir : str
        Output directory (created when the batch runs).
    op : {'shift', 'gradient', 'canny', 'blur'}
    params : dict, optional
        The operator's parameters (see :func:`process_file`).
    fmt : {'png', 'tiff', 'npy'}
        Output format: ``.png``, ``.tiff`` or ``.npy``.
    mode, backend, device, overwrite
        Copied into each job.

    Returns
    -------
    list of Job

    Raises
    ------
    ValueError
        Unknown ``op`` or ``fmt``; two inputs with the same stem (their outputs would collide);
        an output that would be one of the inputs (inputs are never overwritten).
    """
    if op not in OPS:
        raise ValueError(f"op must be one of {', '.join(OPS)}; got {op!r}")
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {', '.join(FORMATS)}; got {fmt!r}")
    outdir = os.path.abspath(os.fspath(outdir))
    input_real = {os.path.realpath(p) for p in inputs}
    input_ids = set()
    for p in inputs:
        with contextlib.suppress(OSError):   # a missing input fails later, per file
            input_ids.add(_file_id(p))
    by_stem, jobs = {}, []
    for path in inputs:
        stem = os.path.splitext(os.path.basename(path))[0]
        if stem in by_stem:
            raise ValueError(f"inputs {by_stem[stem]!r} and {path!r} have the same name stem {stem!r}: both "
                             f"would be written to {os.path.join(outdir, stem + FORMATS[fmt])!r}")
        by_stem[stem] = path
        out = os.path.join(outdir, stem + FORMATS[fmt])
        same = os.path.realpath(out) in input_real
        if not same and os.path.exists(out):
            same = _file_id(out) in input_ids   # hard links
        if same:
            raise ValueError(f"output {out!r} would overwrite an input file; choose another output directory "
                             f"or format")
        jobs.append(Job(path, out, op, dict(params or {}), fmt, mode, backend, device, bool(overwrite)))
    return jobs


# --------------------------------------------------------------------------------------
# one file (runs in a worker process)
# --------------------------------------------------------------------------------------
def _read(path):
    """The image with its alpha channel, if any (grey + alpha ``(H, W, 2)``, RGBA ``(H, W, 4)``)."""
    img = np.asarray(read_image(path))
    if not (img.dtype.kind in "biu" or img.dtype in (np.float16, np.float32, np.float64)):
        raise TypeError(f"unsupported pixel type {img.dtype} (expected bool, integer or float32/float64 "
                        f"samples)")
    if img.ndim == 3 and img.shape[-1] == 1:
        img = img[..., 0]
    if not (img.ndim == 2 or (img.ndim == 3 and img.shape[-1] in (2, 3, 4))):
        raise ValueError(f"expected a grey (H, W) or colour (H, W, 3|4) image, got shape {img.shape}")
    return img


def _no_alpha(img):
    """Colour (or grey) without alpha: gradient and canny see the image content only."""
    if has_alpha(img):
        img = img[..., :-1]
    return img[..., 0] if img.ndim == 3 and img.shape[-1] == 1 else img


def _colour_filter(img, apply):
    """``apply(work)`` on the float image; with alpha, premultiplied (colour x alpha and alpha filtered
    alike, then colour divided by the filtered alpha), so edges get no dark fringes."""
    if has_alpha(img):
        return unpremultiply(apply(premultiply(img, _working(img).dtype)), img.dtype)
    return apply(_working(img))


def _working(img):
    """The float array an operator filters, by the API's dtype policy (gfgpu._core.validation.work_dtype):
    float32/float64 kept, bool and integers of up to 16 bits float32, wider integers float64 (float32 would
    round them above 2**24: 2,000,000,003 read as 2,000,000,000)."""
    return img.astype(work_dtype(img.dtype), copy=False)


def _channel_axis(img):
    return -1 if img.ndim == 3 else None


def _op_shift(img, p, kw):
    _check_keys("shift", p)
    raw = _colour_filter(img, lambda work: shift(work, p["shift"], channel_axis=_channel_axis(img),
                                                  **kw))                        # (dy, dx); colour per channel
    return raw, lambda: to_output(raw, img, "x.png")


def _op_gradient(img, p, kw):
    _check_keys("gradient", p)
    work = _working(_no_alpha(img))
    grey = work.mean(axis=-1) if work.ndim == 3 else work   # one gradient per pixel
    gy, gx = gradient(grey, p.get("u", 1.0), **kw)
    return np.stack([gy, gx]), lambda: gradient_to_rgb(gy, gx)


def _op_canny(img, p, kw):
    _check_keys("canny", p)
    img = _no_alpha(img)
    work = _working(img)
    if img.dtype.kind in "iu":
        # canny's convention: integers scaled to [0, 1] by the dtype's maximum, in float64 (a float32
        # division rounds int32 values), then in the working type, as gfgpu canny and gfgpu.canny
        work = (img.astype(np.float64) / np.iinfo(img.dtype).max).astype(work.dtype, copy=False)
    grey = work.mean(axis=-1, dtype=work.dtype) if work.ndim == 3 else work
    edges = canny(grey, p.get("u", 1.0), p.get("low"), p.get("high"), use_quantiles=True, **kw)
    return edges, lambda: edges.astype(np.uint8) * np.uint8(255)


def _op_blur(img, p, kw):
    _check_keys("blur", p)
    kind = _blur_kind(p)
    velocity = p[BLUR_MOTIONS[kind]]                         # (vy, vx), u1 or (u1_y, u1_x), degrees
    how = dict(kind=kind, displace=not p.get("keep_position", False))
    if p.get("psf") is not None:
        how["psf"] = p["psf"]                                # checked by motion_blur against the table
    if MOTIONS[kind].uses_center:
        how["center"] = _center(p.get("center"), img)        # (row, col)
    raw = _colour_filter(img, lambda work: motion_blur(work, velocity, channel_axis=_channel_axis(img), **how,
                                                       **kw))
    return raw, lambda: to_output(raw, img, "x.png")


_OPERATORS = {"shift": _op_shift, "gradient": _op_gradient, "canny": _op_canny, "blur": _op_blur}


def _write(path, fmt, raw, display):
    if fmt == "png":
        image = display()
        if image.dtype == np.uint8 and not has_alpha(image):
            save_png(path, image)
        else:
            write_image(path, image)
    elif fmt == "npy":
        save_npy(path, raw)
    elif np.ndim(raw) in (2, 3) and (np.ndim(raw) == 2 or np.shape(raw)[-1] <= 4):
        write_image(path, raw)                 # tifffile: the raw samples, alpha as an extra sample
    else:
        import tifffile
        write_atomic(path, lambda tmp: tifffile.imwrite(tmp, raw))   # gradient's (2, H, W)


def process_file(job):
    """Run one :class:`Job`: read, filter, write atomically; never raises for a per-file problem.

    Operators and their ``job.params``:

    - ``shift``: ``shift=(dy, dx)`` pixels in array-axis order (rows down, cols right);
      :func:`gfgpu.shift`, colour images per channel (``channel_axis=-1``).
    - ``gradient``: ``u``; :func:`gfgpu.gradient` of the grey image (channel mean).  Raw
      output ``(2, H, W)`` = ``(gy, gx)``; PNG colour-coded (hue = orientation, value =
      magnitude), as ``gfgpu gradient``.
    - ``canny``: ``u``, ``low``, ``high`` (quantiles of the gradient magnitude in [0, 1];
      ``None`` = :func:`gfgpu.canny`'s absolute defaults); grey image, integers scaled to
      [0, 1].  Raw output the boolean edge map; PNG 0/255.
    - ``blur``: exactly one motion of :data:`BLUR_MOTIONS` (the kinds of
      :mod:`gfgpu.motion.kinds`): ``velocity=(vy, vx)`` pixels (rows, cols), ``zoom=u1`` (one
      rate or ``(u1_y, u1_x)``) or ``rotation=degrees`` (counter-clockwise on screen);
      [``center=(row, col)`` for a zoom or rotation, default each image's centre; a ``None``
      coordinate is the middle of that axis]; [``keep_position``: blur in place, as
      ``displace=False``]; [``psf``: ``'green'`` (default) or ``'box'``];
      :func:`gfgpu.motion_blur`, colour images per channel.

    Any other key (such as the ``by`` of earlier versions) fails the file with a
    ``ValueError``; :func:`check_parameters` reports it once before a batch.

    Images are read with :func:`gfgpu.io.read_image` (imageio's Pillow plugin, TIFF through
    tifffile: upright, CMYK as RGB; animations, multi-page TIFFs, complex samples and anything
    but a regular file fail the file).  ``shift`` and ``blur`` keep an alpha channel, filtered
    premultiplied (colour x alpha and alpha alike, then divided by the filtered alpha where it
    is > 0: no dark fringes); ``gradient`` and ``canny`` ignore it.  Bool and integer images of
    up to 16 bits are filtered in float32, wider integers (int32, uint32, int64) in float64,
    float32/float64 in their own type (the API's dtype policy).  ``png`` writes the image at
    the input's depth (:func:`gfgpu.io.to_output`: uint8 and uint16 rounded and clipped, 16-bit
    PNG for 16-bit input; other types the 8-bit display conversion
    :func:`gfgpu.io.to_display_8bit`, stated in :attr:`Result.note` for ``shift`` and ``blur``);
    ``npy`` and ``tiff`` the raw result.  The output's folder is created if needed.

    Parameters
    ----------
    job : Job

    Returns
    -------
    Result
        ``'skipped'`` when the output exists and ``job.overwrite`` is false; ``'failed'`` with
        ``"ExceptionType: reason"`` for any error of this file (unreadable, truncated, an
        unsupported pixel type such as complex, a parameter this image rejects, a write
        error); ``'ok'`` otherwise.  The output is written to a temporary file beside it and
        renamed into place, so it is either complete or absent.

    Examples
    --------
    >>> import os, tempfile, numpy as np, imageio.v3 as iio
    >>> d = tempfile.mkdtemp()
    >>> iio.imwrite(os.path.join(d, "a.png"), np.zeros((8, 8), np.uint8))
    >>> job = Job(os.path.join(d, "a.png"), os.path.join(d, "out", "a.npy"), "shift",
    ...           {"shift": (0.0, 1.5)}, fmt="npy", backend="numpy")
    >>> r = process_file(job)
    >>> r.status, np.load(r.output).shape
    ('ok', (8, 8))
    >>> process_file(job).status
    'skipped'
    """
    t0 = time.perf_counter()

    def result(status, message=""):
        return Result(job.input, job.output, status, message, time.perf_counter() - t0)

    try:
        if os.path.exists(job.output):
            if os.path.exists(job.input) and os.path.samefile(job.input, job.output):
                return result("failed", "output is the input file; refusing to overwrite it")
            if not job.overwrite:
                return result("skipped", "output exists (--overwrite recomputes it)")
        if job.op not in _OPERATORS:
            raise ValueError(f"op must be one of {', '.join(OPS)}; got {job.op!r}")
        if job.fmt not in FORMATS:
            raise ValueError(f"fmt must be one of {', '.join(FORMATS)}; got {job.fmt!r}")
        img = _read(job.input)
        os.makedirs(os.path.dirname(os.path.abspath(job.output)), exist_ok=True)
        be = resolve_backend(job.backend, job.device)
        raw, display = _OPERATORS[job.op](img, job.params, dict(mode=job.mode, backend=be))
        _write(job.output, job.fmt, raw, display)
    except Exception as exc:   # per-file problems are results: the rest of the batch goes on
        return result("failed", f"{type(exc).__name__}: {exc}")
    done = result("ok")
    done.ran_on = f"backend {be.name} on {be.device}"
    if job.fmt == "png" and job.op in _KEEPS_VALUES:
        done.note = conversion_note(img, job.output) or ""
    return done


#: the operators whose ``png`` output is the image's values at the input's depth (:func:`gfgpu.io.to_output`;
#: float and wide-integer input then 8-bit, which :func:`gfgpu.io.conversion_note` states); gradient's and
#: canny's are renderings (colour-coded, 0/255) of a result that has no depth of its own
_KEEPS_VALUES = ("shift", "blur")


# --------------------------------------------------------------------------------------
# execution: here, a LocalCluster, or a remote Dask scheduler
# --------------------------------------------------------------------------------------
def run_batch(jobs, *, workers=None, scheduler=None, progress=True, description="gfgpu batch"):
    """Run :func:`process_file` on every job; the results, sorted by input path.

    Parameters
    ----------
    jobs : sequence of Job
    workers : int, optional
        Start a ``dask.distributed.LocalCluster`` of ``workers`` processes with one thread
        each (each process owns its backend, its device context and its kernel caches) and
        run one task per file on it.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``): the tasks run on its
        workers, which must see the input and output paths (a shared filesystem, mounted at
        the same path) and have gfgpu installed.
    progress : bool
        Show a tqdm progress bar (on a terminal).
    description : str
        The bar's label.

    Without ``workers`` and ``scheduler`` the jobs run here, one after another.

    Returns
    -------
    list of Result

    Raises
    ------
    ValueError
        Both ``workers`` and ``scheduler``, or ``workers < 1``.
    """
    from tqdm import tqdm
    if workers is not None and scheduler is not None:
        raise ValueError("give either workers or scheduler, not both")
    if workers is not None and (int(workers) != workers or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    jobs = list(jobs)
    results = []
    with tqdm(total=len(jobs), desc=description, unit="file", disable=None if progress else True) as bar:
        if workers is None and scheduler is None:
            for job in jobs:
                results.append(process_file(job))
                bar.update(1)
        else:
            results = _run_on_dask(jobs, workers, scheduler, bar)
    return sorted(results, key=lambda r: r.input)


#: Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers, which switches off glibc's
#: dynamic mmap threshold: every large temporary array is then a fresh mmap that is
#: page-faulted in and zeroed.  Measured on 1024^2 canny tasks (numpy backend): 0.40-0.49 s
#: of CPU per file instead of 0.29-0.31 s.  A batch task frees all its arrays, so the workers of our
#: own LocalCluster run with glibc's default (memory held stays at one task's peak).
_LOCAL_WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


@contextlib.contextmanager
def _environ_restored(keys):
    """Dask's nannies write their pre-spawn variables into this process's environment; undo that."""
    before = {k: os.environ.get(k) for k in keys}
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT blocked in this thread while the block runs: the threads and processes started there
    inherit the mask (the workers never act on a Ctrl-C), and a Ctrl-C meanwhile stays pending
    for this process, raised as KeyboardInterrupt when the block ends (ignoring it instead lost it:
    a batch interrupted while its cluster started ran to the end).  A no-op outside the main
    thread or where signal masks do not exist."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # multiprocessing's resource tracker, started at the first spawn, UNBLOCKS SIGINT in the thread
    # that starts it (after blocking it for the tracker's own spawn): inside the block, that would
    # leave every worker spawned after it acting on Ctrl-C.  Started here first, it stays out of the way.
    from multiprocessing import resource_tracker
    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _run_on_dask(jobs, workers, scheduler, bar):
    import dask
    from dask.distributed import Client, LocalCluster, as_completed
    results = []
    with contextlib.ExitStack() as stack:
        if scheduler is not None:
            client = stack.enter_context(Client(scheduler))
        else:
            spawn_env = [*dask.config.get("distributed.nanny.pre-spawn-environ"), "PYTHONHASHSEED"]
            stack.enter_context(_environ_restored(spawn_env))   # restored after the cluster closes
            # the worker processes start with SIGINT ignored (Python then installs no KeyboardInterrupt
            # handler in them): a Ctrl-C reaches the whole process group, and only this process, which
            # closes the cluster, should act on it -- else each worker prints its own traceback
            with dask.config.set(_LOCAL_WORKER_CONFIG), _sigint_ignored():
                cluster = stack.enter_context(LocalCluster(n_workers=int(workers), threads_per_worker=1,
                                                           processes=True, dashboard_address=":0"))  # any free port
            client = stack.enter_context(Client(cluster))
        n = len(client.nthreads())
        print(f"dask: {n} worker(s) at {client.scheduler.address}", file=sys.stderr)
        futures = client.map(process_file, jobs, pure=False)
        job_of = {f.key: job for f, job in zip(futures, jobs)}
        for future in as_completed(futures):
            try:
                results.append(future.result())
            except Exception as exc:   # the task itself was lost (e.g. its worker died repeatedly)
                job = job_of[future.key]
                results.append(Result(job.input, job.output, "failed", f"task lost: {type(exc).__name__}: {exc}"))
            future.release()
            bar.update(1)
    return results


def summarize(results, seconds=None):
    """``(text, exit_code)``: counts, each failure with its reason, each input left out before
    planning (a skipped result without output, e.g. a FIFO) with its reason, each conversion note
    (float or wide-integer input written as 8-bit PNG: :attr:`Result.note`); exit code 1 if any
    failed."""
    counts = {s: sum(r.status == s for r in results) for s in ("ok", "skipped", "failed")}
    head = f"{len(results)} file(s): {counts['ok']} ok, {counts['skipped']} skipped, {counts['failed']} failed"
    if seconds is not None:
        head += f" in {seconds:.1f} s"
    ran_on = sorted({r.ran_on for r in results if r.ran_on})
    lines = [head] + [f"  ran on {where}" for where in ran_on]
    lines += [f"  skipped: {r.input}: {r.message}" for r in results if r.status == "skipped" and not r.output]
    lines += [f"  failed: {r.input}: {r.message}" for r in results if r.status == "failed"]
    lines += [f"  note: {r.input}: {r.note}" for r in results if r.status == "ok" and r.note]
    return "\n".join(lines), int(counts["failed"] > 0)
