"""gfgpu operators on Dask arrays: chunked, distributed, and exact across chunks.

Each wrapper takes a :class:`dask.array.Array` and returns one (lazy) with the same chunks.
A step along an axis that is cut into several chunks runs the recursion of every chunk on its
device and carries the state between chunks exactly (:mod:`gfgpu._core.carry`):

1. per chunk: the contribution of its last samples to the state leaving it, and of its first
   samples to the boundary mode's initial state (small host products, no device work);
2. a sequential scan, per column of chunks, of the affine maps ``Φ ↦ H Φ + E`` — ``S``
   complex numbers per line and chunk, so the scan moves little data;
3. per chunk, in parallel: the zero-state pass on the device plus the carried state's
   response.

The result equals the single-array call within the dtype's rounding (tested for random
chunkings), whatever the kernel's length — no overlap depth, no truncation.  Steps along an
axis held in one chunk run as plain per-block calls.  Image-plane operators that are not
separable along axes (oblique directions, zoom, canny's hysteresis) need whole image planes:
their wrappers rechunk the last two axes into one chunk (stacks stay chunked along their
other axes).

Backends travel by name (``backend="opencl", device="0"``, or a backend object, which
pickles as its name and device): each worker process builds its own backend, device context
and kernel caches on first use (:func:`gfgpu.get_backend` caches per process).  For GPU
workers run one worker process per GPU with one thread (``dask worker ADDRESS --nthreads 1``,
``CUDA_VISIBLE_DEVICES`` per process): threads of one process share its device queue (device
work is serialised per process), so they gain nothing.

Examples
--------
>>> import numpy as np, dask.array as da
>>> import gfgpu, gfgpu.dask
>>> img = np.random.default_rng(0).random((256, 192)).astype(np.float32)
>>> lazy = gfgpu.dask.shift(da.from_array(img, chunks=(50, 64)), (3.5, -2.0), backend="numpy")
>>> out = lazy.compute(scheduler="synchronous")
>>> bool(np.abs(out - gfgpu.shift(img, (3.5, -2.0), backend="numpy")).max() < 1e-5)
True
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import itertools
import threading

import dask
import dask.array as da
import numpy as np

from . import filters, greens
from ._core import carry
from ._core.boundary import filter_mode, interpolation_mode
from ._core.docstrings import docfiller
from ._core.lines import normalize_axis
from ._core.magnitude import within_range
from ._core.program import is_axis_angle, run_steps
from ._core.recursion import plan_pass
from ._core.translation import decay_length, step_offset, window_index, without_offset
from ._core.validation import finite_cval, flag, work_dtype
from .backends import Backend, backend_request, check_backend_name, resolve_backend
from .edges import canny as canny_2d
from .edges import check_arguments as check_canny_arguments
from .motion import motion_blur as motion_blur_2d
from .motion.field import check_quadrature
from .motion.kinds import motion_kind, psf_name

__all__ = ["green_filter", "shift", "derivative", "projection", "gradient", "motion_blur", "canny",
           "run_program"]


#: the parameter texts the wrappers share, each written once (``%(name)s`` in their docstrings)
_DOCS = {
    "x": """
        x : dask.array.Array
            The input, in any chunking (chunk sizes must be known: ``x.compute_chunk_sizes()``
            first); float32 and float64 kept, integers -> float32 (wider than 16 bits: float64).
        """,
    "channel_axis": """
        channel_axis : int, optional
            Axis of colour channels, each filtered on its own (never an axis operated on).
        """,
    "mode_cval": """
        mode : {'reflect', 'grid-mirror', 'constant', 'grid-constant', 'nearest', 'mirror', 'wrap',
                'grid-wrap'}, optional
            How the image continues beyond its border (scipy.ndimage's names and filter
            meaning, ``grid-*`` the same as their plain twins; default ``'reflect'``), see
            :func:`gfgpu.green_filter`.
        cval : float, optional
            The value beyond the border for ``mode='constant'`` (default 0).
        """,
    "shift_mode_cval": """
        mode : {'reflect', 'grid-mirror', 'constant', 'grid-constant', 'nearest', 'mirror', 'wrap',
                'grid-wrap'}, optional
            scipy.ndimage's interpolation meaning, as in :func:`gfgpu.shift` (``'constant'``:
            ``cval`` where the source lies outside ``[0, n - 1]``; ``'wrap'``: period
            ``n - 1``; ``'grid-constant'``/``'grid-wrap'``: the ``cval``/period-``n``
            extension); default ``'reflect'``.
        cval : float, optional
            The value beyond the border for ``'constant'`` and ``'grid-constant'`` (default 0).
        """,
    "differentiator": """
        a, eta, single_scale : optional
            The differentiator's parameters, as in :func:`gfgpu.derivative`: the weight ``a``
            and scale ratio ``eta`` of the two-scale D (eq. 25-26; defaults 1.1 and 3.5), or
            the one-scale D_u (eq. 19) with ``single_scale=True``.
        """,
    "projection_scale": """
        projection_scale : float, optional
            As in :func:`gfgpu.derivative`.
        """,
    "backend_device": """
        backend : str or Backend, optional
            ``'numpy'``, ``'warp'`` or ``'opencl'`` (default: the resolution rule of
            :mod:`gfgpu.backends`).  Tasks carry its name: each worker process builds its own
            backend, device context and kernel caches (a Backend object travels as its name and
            device).
        device : str, optional
            Its device (``'cuda:0'``, ``'0'``, ...); needs ``backend``.
        """,
    "result": """
        dask.array.Array
            Lazy (nothing runs before it is computed); float32 or float64; the chunks of ``x``,
            or of ``x`` rechunked where a step needs whole image planes (see the module notes).
        """,
    "raises": """
        TypeError, ValueError
            As the function this wraps, and for an ``x`` that is not a dask array, is empty or
            has unknown chunk sizes.  The parameters are checked here, before any task is built;
            NaN or infinite samples are found by the tasks, when the result is computed.
        """,
}
_docfiller = docfiller(_DOCS)


# --------------------------------------------------------------------------------------
# argument handling
# --------------------------------------------------------------------------------------
def _check_array(x):
    if not isinstance(x, da.Array):
        raise TypeError(f"input must be a dask.array.Array (use gfgpu.{{name}} for numpy arrays), "
                        f"got {type(x).__name__}")
    if x.ndim == 0:
        raise ValueError("input must have at least 1 dimension(s), got shape ()")
    if x.size == 0:
        raise ValueError(f"input is empty (shape {x.shape})")
    if any(np.isnan(c) for chunks in x.chunks for c in chunks):
        raise ValueError("input has unknown chunk sizes; call x.compute_chunk_sizes() first")
    return work_dtype(x.dtype)


def _backend_spec(backend, device):
    """``(name, device)`` of a backend: tasks carry this and each worker rebuilds the backend."""
    if isinstance(backend, Backend):
        if device is not None:
            raise ValueError("device= cannot be combined with a Backend object (it has its device)")
        return backend_request(backend)
    if backend is not None:
        check_backend_name(backend)
    elif device is not None:
        raise ValueError("device= needs backend= as well (e.g. backend='warp', device='cuda:0')")
    return backend, None if device is None else str(device)


def _backend(spec):
    return resolve_backend(*spec)


#: device work of one process is serialised: a thread pool would share one device queue and
#: the backends' upload caches, which gains nothing and is not thread-safe
_DEVICE_LOCK = threading.Lock()


def _device_section(be):
    return contextlib.nullcontext() if be.name == "numpy" else _DEVICE_LOCK


def _host_block(block, dtype):
    block = np.ascontiguousarray(block, dtype=dtype)
    if not np.isfinite(block).all():
        raise ValueError("input contains NaN or infinite values")
    return block


# --------------------------------------------------------------------------------------
# tasks (run in workers)
# --------------------------------------------------------------------------------------
def _local_task(block, steps, plane, mode, cval, spec, dtype):
    """Steps whose lines lie inside the block, on the worker's backend."""
    be = _backend(spec)
    # checked, and scaled by a power of two near the dtype's limit (exact: the lines lie in the block)
    host, cval, exp = within_range(np.ascontiguousarray(block, dtype=dtype), cval, dtype)
    with _device_section(be):
        out = be.to_host(run_steps(be, be.host_view(host), dtype, steps, mode, cval, plane,
                                   shape=host.shape)).reshape(host.shape)
    return np.ldexp(out, -exp, dtype=out.dtype) if exp else out


def _segment(lp, n, mode, dtype, start, stop):
    return carry.segments_at(plan_pass(lp, n, mode, dtype), start, stop, dtype)


def _rows(block, axis, rows, start):
    """Lines matrix of the samples ``rows`` (natural positions) of a block starting at ``start``."""
    return carry.line_matrix(np.moveaxis(block, axis, 0)[rows[0] - start:rows[1] - start], 0)


def _end_task(block, lp, n, mode, dtype, start, stop, axis):
    seg = _segment(lp, n, mode, dtype, start, stop)
    return carry.end_state(seg, _rows(block, axis, seg.tail_rows, start))


def _boundary_task(block, lp, n, mode, dtype, start, stop, axis, cval):
    seg = _segment(lp, n, mode, dtype, start, stop)
    return carry.boundary_state(seg, _rows(block, axis, seg.head_rows, start), cval)


def _sum_task(*terms):
    return sum(terms[1:], terms[0])


def _scan_task(state, end, lp, n, mode, dtype, start, stop):
    """State entering the next segment (traversal order) from the one entering this one."""
    seg = _segment(lp, n, mode, dtype, start, stop)
    return seg.transfer[:, None] * state + end


def _finish_task(block, *states, passes, n, mode, dtype, start, stop, axis, spec):
    be = _backend(spec)
    host, _, exp = within_range(np.ascontiguousarray(block, dtype=dtype), 0.0, dtype)   # as _local_task
    segs = [_segment(lp, n, mode, dtype, start, stop) for lp in passes]
    with _device_section(be):
        y = be.empty(host.shape, dtype)
        carry.zero_state_pass(be, be.host_view(host), y, axis, segs, shape=host.shape)
        out = be.to_host(y).reshape(host.shape)
    out = np.ldexp(out, -exp, dtype=out.dtype) if exp else out
    for seg, state in zip(segs, states):
        carry.add_correction(seg, out, state, axis)
    return out


# --------------------------------------------------------------------------------------
# graph construction
# --------------------------------------------------------------------------------------
def _task(function, *collections, **static):
    """A delayed call; ``static`` arguments are bound, so dask does not traverse them."""
    return dask.delayed(functools.partial(function, **static))(*collections)


def _carried_step(x, passes, axis, mode, cval, spec, dtype):
    """One step along a chunked axis, with the state carried exactly between chunks."""
    n = x.shape[axis]
    bounds = np.concatenate([[0], np.cumsum(x.chunks[axis])]).astype(int).tolist()
    nb = len(bounds) - 1
    # the client builds the plans once, only to see which chunks hold boundary samples
    segs = [carry.segments(plan_pass(lp, n, mode, dtype), bounds, dtype) for lp in passes]
    blocks = x.to_delayed()
    out = np.empty(blocks.shape, dtype=object)
    other = [range(k) if d != axis else [None] for d, k in enumerate(blocks.shape)]
    for index in itertools.product(*other):
        keys = [tuple(i if d == axis else index[d] for d in range(x.ndim)) for i in range(nb)]
        column = [blocks[k] for k in keys]
        states_per_pass = []
        for lp, seg_list in zip(passes, segs):
            where = [dict(lp=lp, n=n, mode=mode, dtype=dtype, start=bounds[i], stop=bounds[i + 1])
                     for i in range(nb)]
            ends = [_task(_end_task, column[i], axis=axis, **where[i]) for i in range(nb)]
            terms = [_task(_boundary_task, column[i], axis=axis, cval=cval, **where[i])
                     for i, seg in enumerate(seg_list) if seg.boundary.shape[1] or seg.boundary_c.any()]
            if not terms:   # a zero state: the boundary mode contributes nothing (e.g. cval 0)
                terms = [_task(_boundary_task, column[0], axis=axis, cval=0.0, **where[0])]
            state = _task(_sum_task, *terms)
            order = range(nb - 1, -1, -1) if seg_list[0].reverse else range(nb)
            states = [None] * nb
            for i in order:
                states[i] = state
                state = _task(_scan_task, state, ends[i], **where[i])
            states_per_pass.append(states)
        for i, key in enumerate(keys):
            shape = tuple(x.chunks[d][key[d]] for d in range(x.ndim))
            task = _task(_finish_task, column[i], *[s[i] for s in states_per_pass], passes=passes, n=n,
                         mode=mode, dtype=dtype, start=bounds[i], stop=bounds[i + 1], axis=axis, spec=spec)
            out[key] = da.from_delayed(task, shape=shape, dtype=dtype)
    return da.block(out.tolist())


@_docfiller
def run_program(x, program, *, mode="reflect", cval=0.0, backend=None, device=None):
    """Run a :class:`~gfgpu._core.program.Program` on a dask array (the wrappers' common engine).

    Parameters
    ----------
    %(x)s
    program : Program
        E.g. from :func:`gfgpu.filters.shift_program`.
    %(mode_cval)s
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    TypeError
        ``x`` not a dask array, unsupported dtype.
    ValueError
        Empty input, unknown chunk sizes, bad ``mode``/``cval``/backend; checked before any task
        is built.
    """
    dtype = _check_array(x)
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    spec = _backend_spec(backend, device)
    x = x.astype(dtype) if x.dtype != dtype else x
    for passes, axis, angle in program.steps:
        if angle is not None:
            x = _whole_planes(x).map_blocks(_local_task, [(passes, axis, angle)], program.plane, mode, cval,
                                            spec, dtype, dtype=dtype)
        elif len(x.chunks[axis]) == 1:
            x = x.map_blocks(_local_task, [(passes, axis, None)], None, mode, cval, spec, dtype, dtype=dtype)
        elif step_offset(passes) != 0:
            x = _translated_step(x, passes, axis, mode, cval, spec, dtype)
        else:
            x = _carried_step(x, passes, axis, mode, cval, spec, dtype)
    if not program.steps:
        x = x.map_blocks(_host_block, dtype, dtype=dtype)
    return x


def _translated_step(x, passes, axis, mode, cval, spec, dtype):
    """A translated step along a chunked axis: the translated window gathered lazily (index
    arithmetic), the passes carried across its chunks, the padding cropped
    (:mod:`gfgpu._core.translation`)."""
    n = x.shape[axis]
    offset = step_offset(passes)
    identity = len(passes) == 1 and passes[0].is_identity
    pad = 0 if identity else decay_length(passes, dtype)
    index = window_index(n, offset, pad, mode)
    window = da.take(x, np.maximum(index, 0), axis=axis)
    if (index < 0).any():    # constant mode: samples beyond the line are cval
        keep = (index >= 0).reshape([-1 if d == axis else 1 for d in range(x.ndim)])
        window = da.where(keep, window, np.asarray(cval, dtype))
    window = window.rechunk({axis: max(x.chunks[axis])}).astype(dtype)
    if identity:   # _host_block checks every block for NaN/inf, as the passes' tasks do
        return window.rechunk(x.chunks).map_blocks(_host_block, dtype, dtype=dtype)
    inner = [without_offset(lp) for lp in passes]
    if len(window.chunks[axis]) == 1:
        out = window.map_blocks(_local_task, [(inner, axis, None)], None, "nearest", cval, spec, dtype,
                                dtype=dtype)
    else:
        out = _carried_step(window, inner, axis, "nearest", cval, spec, dtype)
    crop = tuple(slice(pad, pad + n) if d == axis else slice(None) for d in range(x.ndim))
    return out[crop].rechunk(x.chunks)


def _whole_planes(x):
    """``x`` with its last two axes (the image plane) in one chunk."""
    if len(x.chunks[-1]) == 1 and len(x.chunks[-2]) == 1:
        return x
    return x.rechunk({x.ndim - 2: -1, x.ndim - 1: -1})


# --------------------------------------------------------------------------------------
# public wrappers
# --------------------------------------------------------------------------------------
@_docfiller
def green_filter(x, kernel, *, axis=None, angle=None, axes=None, channel_axis=None, anticausal=False,
                 mode="reflect", cval=0.0, backend=None, device=None):
    """:func:`gfgpu.green_filter` on a dask array; exact across chunks along ``axis``.

    Parameters
    ----------
    %(x)s
    kernel, axis, angle, axes, anticausal
        As in :func:`gfgpu.green_filter` (no ``output``: the result is lazy).  An oblique
        ``angle`` (radians from +x, the columns, toward +y, the rows) rechunks the image plane
        whole; a plane that is not on the last two axes (e.g. ``channel_axis=-1``) is moved
        there lazily and back.
    %(channel_axis)s
    %(mode_cval)s
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    %(raises)s
    """
    _check_array(x)
    if angle is not None and not is_axis_angle(angle):
        ya, xa = filters.image_plane(x.ndim, axes, channel_axis)
        last = (x.ndim - 2, x.ndim - 1)
        if (ya, xa) != last:
            program = filters.green_filter_program(x.ndim, kernel, angle=angle, anticausal=anticausal)
            moved = run_program(da.moveaxis(x, (ya, xa), last), program, mode=mode, cval=cval, backend=backend,
                                device=device)
            return da.moveaxis(moved, last, (ya, xa))
    program = filters.green_filter_program(x.ndim, kernel, axis=axis, angle=angle, axes=axes,
                                           channel_axis=channel_axis, anticausal=anticausal)
    return run_program(x, program, mode=mode, cval=cval, backend=backend, device=device)


@_docfiller
def shift(x, shift, *, mode="reflect", cval=0.0, axes=None, channel_axis=None, interpolation="green",
          backend=None, device=None):
    """:func:`gfgpu.shift` on a dask array; exact across chunks along every axis.

    Parameters
    ----------
    %(x)s
    shift : float or sequence of float
        Displacement along each axis operated on, array-axis order: ``(dy, dx)`` (rows, cols)
        for an image.
    axes, interpolation
        As in :func:`gfgpu.shift`.
    %(channel_axis)s
    %(shift_mode_cval)s
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    %(raises)s
    """
    dtype = _check_array(x)
    engine_mode, rule = interpolation_mode(mode)
    program = filters.shift_program(x.ndim, shift, axes=axes, channel_axis=channel_axis,
                                    interpolation=interpolation)
    if rule is None:
        return run_program(x, program, mode=engine_mode, cval=cval, backend=backend, device=device)
    # scipy's interpolation-only modes: 'mirror' shifts, masked or selected lazily (gfgpu.shift)
    cval = finite_cval(cval)
    _backend_spec(backend, device)
    branches = filters.shift_branches(x.shape, shift, rule, axes=axes, channel_axis=channel_axis)
    kw = dict(mode="mirror", cval=cval, backend=backend, device=device)
    fill = np.asarray(cval, dtype)

    def along(mask, axis):
        return mask.reshape([-1 if d == axis else 1 for d in range(x.ndim)])

    if rule == "constant":
        out = run_program(x, program, **kw)
        for a, _, branch in branches:
            if (branch < 0).any():
                out = da.where(along(branch < 0, a), fill, out)
        return out
    out = x
    for a, s, branch in branches:
        near = run_program(out, filters.shift_program(x.ndim, [s], axes=[a], interpolation=interpolation), **kw)
        if branch.any():
            far = run_program(out, filters.shift_program(x.ndim, [s + x.shape[a] - 1], axes=[a],
                                                         interpolation=interpolation), **kw)
            near = da.where(along(branch > 0, a), far, near)
        out = near
    return out


@_docfiller
def derivative(x, u, *, axis=None, axes=None, channel_axis=None, mode="reflect", cval=0.0, a=greens.EDGE_A,
               eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0, backend=None, device=None):
    """:func:`gfgpu.derivative` on a dask array; exact across chunks.

    Parameters
    ----------
    %(x)s
    u, axis, axes
        As in :func:`gfgpu.derivative`: the scale of D(x) (pixels, > 0) and the axis it
        differentiates along.
    %(differentiator)s
    %(projection_scale)s
    %(channel_axis)s
    %(mode_cval)s
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    %(raises)s
    """
    _check_array(x)
    program = filters.derivative_program(x.ndim, u, axis=axis, axes=axes, channel_axis=channel_axis, a=a,
                                         eta=eta, single_scale=single_scale, projection_scale=projection_scale)
    return run_program(x, program, mode=mode, cval=cval, backend=backend, device=device)


@_docfiller
def projection(x, u, *, axis=None, channel_axis=None, mode="reflect", cval=0.0, a=greens.EDGE_A,
               eta=greens.EDGE_ETA, single_scale=False, backend=None, device=None):
    """:func:`gfgpu.projection` on a dask array; exact across chunks.

    Parameters
    ----------
    %(x)s
    u, axis
        As in :func:`gfgpu.projection`.
    %(differentiator)s
    %(channel_axis)s
    %(mode_cval)s
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    %(raises)s
    """
    _check_array(x)
    program = filters.projection_program(x.ndim, u, axis=axis, channel_axis=channel_axis, a=a, eta=eta,
                                         single_scale=single_scale)
    return run_program(x, program, mode=mode, cval=cval, backend=backend, device=device)


@_docfiller
def gradient(x, u, *, axes=None, channel_axis=None, mode="reflect", cval=0.0, a=greens.EDGE_A,
             eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0, backend=None, device=None):
    """:func:`gfgpu.gradient` on a dask array: one lazy derivative per axis operated on.

    Parameters
    ----------
    %(x)s
    u, axes
        As in :func:`gfgpu.gradient`.
    %(differentiator)s
    %(projection_scale)s
    %(channel_axis)s
    %(mode_cval)s
    %(backend_device)s

    Returns
    -------
    tuple of dask.array.Array
        In array-axis order (``(d/dy, d/dx)`` for an image), each as described for
        :func:`derivative`.

    Raises
    ------
    %(raises)s
    """
    _check_array(x)
    ax = filters.operated_axes(x.ndim, axes, channel_axis)
    return tuple(derivative(x, u, axis=d, axes=ax, mode=mode, cval=cval, a=a, eta=eta, single_scale=single_scale,
                            projection_scale=projection_scale, backend=backend, device=device) for d in ax)


@_docfiller
def motion_blur(x, velocity, *, kind="uniform", psf="green", center=None, displace=True, mode="reflect", cval=0.0,
                channel_axis=None, backend=None, device=None, quadrature="gauss"):
    """:func:`gfgpu.motion_blur` on a dask array of images ``(..., H, W)``: every kind, every PSF.

    Each kind says what a chunk must hold (:mod:`gfgpu.motion.kinds`): uniform motion along an
    axis (``vy == 0`` or ``vx == 0``) with the G_u PSF (``psf='green'``) is exact across chunks
    (the recursion state carried between them); with the box PSF it rechunks that axis whole
    (its lines).  An oblique direction, a velocity field, a zoom or a rotation rechunk the image
    plane whole (stacks stay chunked along their leading axes).

    Parameters
    ----------
    x : dask.array.Array
        Images ``(..., H, W)``, or colour images with ``channel_axis``.
    velocity : pair of float, numpy array (2, H, W), or float
        As in :func:`gfgpu.motion_blur`: ``(vy, vx)`` pixels in array-axis order (rows, cols)
        for uniform motion, ``u1`` or ``(u1_y, u1_x)`` for a zoom, degrees for a rotation.  A
        **velocity field** is a numpy array ``(2, H, W)`` (rows, cols components) of the image
        plane's shape, the same for every image of the stack: it needs the whole plane (each
        chunk holds it, and every task gets the field).
    kind, psf, center, displace, quadrature
        As in :func:`gfgpu.motion_blur` (``kind`` one of ``'uniform'``, ``'zoom'``,
        ``'rotation'``; ``psf`` ``'green'`` or ``'box'``; ``center`` is ``(row, col)``;
        ``quadrature`` ``'gauss'`` or ``'exact'``, a velocity field's rule, sent to every task).
    %(mode_cval)s
    channel_axis : int, optional
        Axis of colour channels, blurred each on its own (moved first lazily, and back).
    %(backend_device)s

    Returns
    -------
    %(result)s

    Raises
    ------
    %(raises)s
        Among them: an unknown ``kind`` or ``psf`` (the message lists the names), a bad velocity, a
        field whose shape is not ``(2, H, W)`` of the image plane, a ``center`` outside its range.

    Examples
    --------
    >>> import numpy as np, dask.array as da, gfgpu, gfgpu.dask
    >>> img = np.random.default_rng(1).random((2, 40, 60))
    >>> field = np.zeros((2, 40, 60)); field[1, :, 30:] = 4.0          # right half moves 4 px right
    >>> lazy = gfgpu.dask.motion_blur(da.from_array(img, chunks=(1, 20, 30)), field, psf="box",
    ...                               backend="numpy")
    >>> lazy.chunks                                                    # the plane is whole
    ((1, 1), (40,), (60,))
    >>> ref = gfgpu.motion_blur(img, field, psf="box", backend="numpy")
    >>> bool(np.abs(lazy.compute(scheduler="synchronous") - ref).max() < 1e-12)
    True
    """
    dtype = _check_array(x)
    motion = motion_kind(kind, velocity)
    psf = psf_name(psf)
    displace = flag("displace", displace)
    quadrature = check_quadrature(quadrature)
    mode = filter_mode(mode)       # the engine's name for scipy's grid-* aliases
    cval = finite_cval(cval)
    spec = _backend_spec(backend, device)
    if channel_axis is not None:
        if x.ndim < 3:
            raise ValueError(f"channel_axis={channel_axis} needs a colour image of 3 dimensions or more, got "
                             f"shape {x.shape}")
        ch = normalize_axis(channel_axis, x.ndim, "channel_axis")
        out = motion_blur(da.moveaxis(x, ch, 0), velocity, kind=kind, psf=psf, center=center, displace=displace,
                          mode=mode, cval=cval, backend=backend, device=device, quadrature=quadrature)
        return da.moveaxis(out, 0, ch)
    if x.ndim < 2:
        raise ValueError(f"motion blur needs an image (at least 2 dimensions), got shape {x.shape}")
    # every check before any task is built (the workers would raise the same errors later)
    params = motion.fit(motion.parse(velocity), x.shape)
    fixed = motion.center(center, x.shape[-2], x.shape[-1])
    whole = motion.whole_axes(params, psf)
    if not whole:
        return run_program(x, motion.program(x.ndim, params, displace), mode=mode, cval=cval, backend=backend,
                           device=device)
    x = x.rechunk({x.ndim + axis: -1 for axis in whole})
    kw = dict(velocity=params, kind=kind, psf=psf, center=fixed, displace=displace, mode=mode, cval=cval,
              quadrature=quadrature)
    return x.map_blocks(_plane_task, motion_blur_2d, spec, dtype, kw, dtype=dtype)


def _plane_task(block, function, spec, dtype, kwargs):
    backend, device = spec
    with _device_section(_backend(spec)):
        return function(_host_block(block, dtype), backend=backend, device=device, **kwargs)


def _canny_task(block, spec, kwargs):
    backend, device = spec
    flat = block.reshape((-1,) + block.shape[-2:])
    with _device_section(_backend(spec)):
        out = np.stack([canny_2d(plane, backend=backend, device=device, **kwargs) for plane in flat])
    return out.reshape(block.shape)


@_docfiller
def canny(x, u=1.0, low_threshold=None, high_threshold=None, *, use_quantiles=False, backend=None,
          device=None, **kwargs):
    """:func:`gfgpu.canny` on each image of a dask stack ``(..., H, W)``.

    Hysteresis joins edge pixels across the whole image, so each image plane is one chunk (the
    plane is rechunked whole); stacks are processed in parallel along their leading axes.

    Parameters
    ----------
    %(x)s
    u, low_threshold, high_threshold, use_quantiles
        As in :func:`gfgpu.canny`.
    %(backend_device)s
    **kwargs
        :func:`gfgpu.canny`'s other keyword arguments (``mode``, ``cval``, ``a``, ``eta``, ...).

    Returns
    -------
    dask.array.Array of bool
        The edge maps, the image plane in one chunk.

    Raises
    ------
    TypeError, ValueError
        For an ``x`` that is not a dask array, is empty, has unknown chunk sizes or fewer than
        2 dimensions, a bad backend name, and every parameter :func:`gfgpu.canny` refuses
        (a ``mask`` must have the image plane's shape), before any task is built;
        ``return_gradient`` is refused (the result is one edge map per plane).
    """
    _check_array(x)
    if x.ndim < 2:
        raise ValueError(f"canny needs images (at least 2 dimensions), got shape {x.shape}")
    unknown = sorted(set(kwargs) - (set(inspect.signature(canny_2d).parameters) - {"image"}))
    if unknown:
        raise TypeError(f"gfgpu.dask.canny got unexpected keyword argument(s) {', '.join(unknown)}")
    if kwargs.get("return_gradient", False) is not False:
        raise TypeError("gfgpu.dask.canny returns edge maps only: return_gradient is not supported "
                        "(use gfgpu.dask.gradient for the gradient)")
    check_canny_arguments(u, low_threshold, high_threshold, use_quantiles=use_quantiles, shape=x.shape[-2:],
                          **kwargs)
    spec = _backend_spec(backend, device)
    kw = dict(kwargs, u=u, low_threshold=low_threshold, high_threshold=high_threshold,
              use_quantiles=use_quantiles)
    return _whole_planes(x).map_blocks(_canny_task, spec, kw, dtype=bool)
