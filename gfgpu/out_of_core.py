"""Images larger than memory: an operator from one ``.npy`` file to another, strip by strip.

The strips are read and written by file offset (no memory map), so the process holds only
the working set (:func:`gfgpu.set_working_set`) whatever the image size; lines that cross
strips carry their recursion state exactly (:mod:`gfgpu._core.strips`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from . import filters
from ._core.boundary import filter_mode
from ._core.strips import FiniteStore, NpyStore, Strips, get_working_set, parse_bytes, strip_rows
from ._core.validation import finite_cval, float_dtype, wide_integer, work_dtype
from .backends import resolve_backend
from .io import write_atomic
from .motion import uniform_motion_program

__all__ = ["filter_npy", "OPERATORS"]


def _operators():
    return {
        "green_filter": filters.green_filter_program,
        "shift": filters.shift_program,
        "derivative": filters.derivative_program,
        "projection": filters.projection_program,
        "motion_blur": uniform_motion_program,
    }


#: operators :func:`filter_npy` runs, with their parameters (those of the in-memory functions)
OPERATORS = ("green_filter", "shift", "derivative", "projection", "motion_blur")


def filter_npy(operator, source, destination, *, mode="reflect", cval=0.0, working_set=None,
               backend=None, device=None, dtype=None, progress=False, **parameters):
    """Filter a ``.npy`` image into another ``.npy`` file, holding only the working set in memory.

    Parameters
    ----------
    operator : {'green_filter', 'shift', 'derivative', 'projection', 'motion_blur'}
        The operator; ``parameters`` are those of the in-memory function, keywords only, with
        every pair in array-axis order (rows, cols): e.g. ``shift=(2.5, -1)`` (``(dy, dx)``)
        for ``'shift'``, ``kernel=UniformGreen(3), axis=0`` for ``'green_filter'``,
        ``u=1.0, axis=1`` for ``'derivative'``, ``velocity=(0, 12)`` (``(vy, vx)``: 12 px to
        the right) for ``'motion_blur'`` (uniform motion only).
    source, destination : str or path
        Input ``.npy`` (C order, any real dtype) and output path; the output is written to a
        temporary file beside it and renamed into place when complete.  It may not be the input.
    mode, cval : optional
        Boundary handling, as in :func:`gfgpu.green_filter`.
    working_set : int or str, optional
        Bytes of memory for strips (default :func:`get_working_set`, or 256 MiB where that is
        unlimited).
    backend, device : str, optional
        As in :func:`gfgpu.green_filter`.
    dtype : {float32, float64}, optional
        Computation and output dtype; default the input's float type (integers of up to 16 bits
        and bools -> float32, wider integers -> float64; ``float32`` may be asked for them).
    progress : bool
        Show a progress bar over strips.

    Returns
    -------
    dict
        ``shape``, ``dtype``, ``strip_rows`` and ``strips`` of the run.

    Raises
    ------
    ValueError
        Unknown operator, same source and destination, unreadable or truncated input, an
        oblique direction whose image plane exceeds the working set, non-finite input, or a
        parameter the operator rejects.
    TypeError
        An unknown parameter, an unsupported ``dtype`` or one that would downcast the input.

    Notes
    -----
    Each strip of the input is read by offset (no memory map), filtered, corrected with the
    carried recursion state (:mod:`gfgpu._core.carry`) and written by offset, so peak memory is the
    working set plus ``16 S`` bytes per line and pass for the carried states.  Strips are
    read twice for steps along the first axis (the boundary rows and strip ends first, then
    the strips); non-finite values are detected strip by strip and abort the run, leaving no
    output.

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> from gfgpu import filter_npy
    >>> d = tempfile.mkdtemp()
    >>> np.save(os.path.join(d, "in.npy"), np.ones((300, 200), np.float32))
    >>> info = filter_npy("shift", os.path.join(d, "in.npy"), os.path.join(d, "out.npy"),
    ...                   shift=(2.5, 0), working_set="100K", backend="numpy")
    >>> info["strips"] > 1, float(np.load(os.path.join(d, "out.npy"))[150, 100])
    (True, 1.0)
    """
    builders = _operators()
    if operator not in builders:
        raise ValueError(f"operator must be one of {', '.join(OPERATORS)}; got {operator!r}")
    if operator == "shift" and mode in ("constant", "wrap"):
        # scipy's interpolation meaning of these two (cval beyond [0, n-1]; period n - 1) is not
        # streamed in strips: refused rather than given the grid meaning under scipy's name
        raise ValueError(f"mode={mode!r} (scipy's interpolation meaning) is not available to filter_npy('shift'); "
                         f"use mode='grid-{mode}' (cval beyond the grid; period n) or another mode")
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    if os.path.exists(destination) and os.path.samefile(source, destination):
        raise ValueError(f"destination {destination!r} is the source file; it is never overwritten")
    src = NpyStore.open(source)
    try:
        work = work_dtype(src.dtype, "input") if dtype is None else float_dtype("dtype", dtype)
        # float32 for a wide integer input is an explicit choice of float32's rounding above 2**24
        if work.itemsize < work_dtype(src.dtype).itemsize and not wide_integer(src.dtype):
            raise TypeError(f"dtype {work} would downcast the {src.dtype} input")
        if not src.shape or 0 in src.shape:
            raise ValueError(f"input is empty (shape {src.shape})")
        be = resolve_backend(backend, device, None)
        if work == np.float64 and not be.supports_float64:
            raise TypeError(f"{be!r} has no float64 support; pass dtype='float32' explicitly")
        program = builders[operator](len(src.shape), **parameters)
        limit = parse_bytes(working_set) if working_set is not None else (get_working_set(be) or 256 << 20)
        rows = strip_rows(src.shape, work, limit)
        runner = Strips(be, work, mode, cval, progress=f"gfgpu {operator}" if progress else None)

        def write(tmp):
            dst = NpyStore.create(tmp, src.shape, work)
            try:
                runner.run(program, FiniteStore(src), dst, limit)
            finally:
                dst.close()
        write_atomic(os.fspath(destination), write)
    finally:
        src.close()
    return {"shape": src.shape, "dtype": str(work), "strip_rows": rows,
            "strips": math.ceil(src.shape[0] / rows)}
