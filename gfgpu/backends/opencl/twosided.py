"""Two-sided steps on an OpenCL CPU device (``twosided.cl``; spec
:func:`gfgpu._core.twosided.run_two_sided_reference`), for :mod:`gfgpu.filters`' derivative,
projection and gradient: a step's causal and anticausal passes in one kernel, along columns (bands
of columns) or rows (a vector of rows per work-item, tiles transposed in registers).  A work-item's
backward sweep reads its lines from memory and keeps their anticausal parts in a scratch that stays
in the cache; its forward sweep reads the lines again from the cache and writes each output once.
CPU devices only (:func:`runs_on`)."""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from . import launch

__all__ = ["runs_on", "takes", "run_two_sided"]

_CACHE_LINE = 64
_STREAM_BYTES = 1 << 23    # outputs from this size are written with non-temporal stores
_PLAN_CACHE = 32
#: vectors (cache lines) of adjacent columns per band of a step along columns; rows prefetched ahead
#: (4096^2 float32, A/B in one process: 4 vectors ran 0.6x the CPU time of the blocked kernel, 1 and
#: 2 vectors or 32-byte vectors slower, 8 no faster; 4 to 12 rows ahead alike, none or 24 slower)
BAND, AHEAD = 4, 8
#: work-items per core (each takes the next band or rows from a counter: balanced under other load)
ITEMS_PER_CORE = 2
#: longest rows of a step along rows (a work-item's scratch: a row of 32-byte vectors per input and output)
MAX_ROW = 1 << 15
_uploads = weakref.WeakKeyDictionary()    # backend -> OrderedDict((id(plan), dtype) -> (plan, buffers))


def runs_on(be):
    """True when ``be`` runs :func:`run_two_sided`: an OpenCL CPU device."""
    return be.name == "opencl" and be.kind == "cpu"


def _buffers(be, plan, dtype):
    """The plan's coefficient and initial-state arrays on the device, uploaded once per plan
    (plans are cached and immutable: id(plan) is a key while the plan is kept)."""
    cache = _uploads.setdefault(be, OrderedDict())
    key = (id(plan), dtype.str)
    hit = cache.get(key)
    if hit is not None and hit[0] is plan:
        cache.move_to_end(key)
        return hit[1]
    bufs = tuple(be.asarray(a) for a in plan.packed(dtype))
    cache[key] = (plan, bufs)
    if len(cache) > _PLAN_CACHE:
        cache.popitem(last=False)
    return bufs


def _layout(be, shape, axis, dtype, nin, nout):
    """``(work-items, lanes, scratch vectors per line sample per work-item)`` of a step."""
    b, n, m = shape
    if axis == 2:
        lanes = 32 // dtype.itemsize      # a 256-bit vector of rows
        items, per_step = -(-(b * n) // lanes), nout + nin      # scratch: the transposed samples too
    else:
        lanes = _CACHE_LINE // dtype.itemsize
        items, per_step = b * -(-m // (lanes * BAND)), BAND * nout
    return max(1, min(items, ITEMS_PER_CORE * int(be.cl_device.max_compute_units))), lanes, per_step


def takes(be, shape, axis, dtype=np.float32, nin=1, nout=1):
    """True when :func:`run_two_sided` runs a step along ``axis`` of a ``(B, N, M)`` view of
    ``dtype`` with ``nin`` inputs and ``nout`` outputs on ``be``: rows when there are enough to
    fill every core's lanes (8 work-items' worth) and each fits the work-item's scratch
    (:data:`MAX_ROW` samples); both axes when the scratch is no larger than the inputs and
    outputs together (a band holds whole vectors of :data:`BAND` cache lines per row: a narrow,
    tall image would need many times its size, 9.5 GiB for a (2e7, 2) float32 one, and runs the
    generic passes instead)."""
    if not runs_on(be) or axis not in (1, 2):
        return False
    b, n, m = shape
    if axis == 2 and not (b * n >= 8 * int(be.cl_device.max_compute_units) and m <= MAX_ROW):
        return False
    items, lanes, per_step = _layout(be, shape, axis, np.dtype(dtype), nin, nout)
    return items * shape[axis] * per_step * lanes <= (nin + nout) * b * n * m


def run_two_sided(be, srcs, dsts, axis, plan, cvals=(0.0, 0.0), check=False):
    """Run a two-sided step along ``axis`` (1: columns, 2: rows) of C-contiguous ``(B, N, M)``
    arrays: ``srcs`` and ``dsts``, one per input and output of ``plan`` (outputs overlap nothing),
    ``cvals`` each input's constant (mode 'constant').  With ``check`` the first (backward) sweep also tests that
    ``srcs[0]`` is finite and within the range limit, and the result is that bool (a blocking
    read); else None.  Raises ValueError or TypeError for arrays, axis or plan that do not fit."""

    if not runs_on(be):
        raise ValueError(f"two-sided steps run on OpenCL CPU devices, not on {be!r}")
    if axis not in (1, 2):
        raise ValueError(f"axis must be 1 (columns) or 2 (rows), got {axis}")
    nin, nout = len(set(plan.inputs)), len(plan.inputs)
    if len(srcs) != nin or len(dsts) != nout:
        raise ValueError(f"the plan takes {nin} input(s) and {nout} output(s), got {len(srcs)} and {len(dsts)}")
    first = srcs[0]
    like = (first.shape, first.dtype)
    for a in list(srcs) + list(dsts):
        if not (be.owns(a) and a.flags.c_contiguous and (a.shape, a.dtype) == like and a.ndim == 3):
            raise TypeError(f"srcs and dsts must be C-contiguous 3-D arrays of {be.device} of one shape and dtype")
    if any(be.may_share_memory(d, o) for k, d in enumerate(dsts) for o in list(srcs) + list(dsts[:k])):
        raise ValueError("an output overlaps an input or another output")
    if plan.n != first.shape[axis]:
        raise ValueError(f"plan is for lines of {plan.n} samples, axis {axis} has {first.shape[axis]}")
    dtype = launch.check_dtype(be, first.dtype)
    if dtype not in launch.REALS:
        raise TypeError(f"srcs must be float32 or float64, got {dtype}")
    b, n, m = first.shape
    if first.size == 0:
        return True if check else None
    coef, omega = _buffers(be, plan, dtype)
    config = dict(SECTIONS=plan.sections, NIN=nin, NOUT=nout, REAL_POLES=int(plan.real), CHECK=int(bool(check)))
    flag = be.asarray(np.zeros(2, np.int32))     # the check's flag, the work-items' counter
    items, lanes, per_step = _layout(be, first.shape, axis, dtype, nin, nout)
    if axis == 2:
        knl = launch.kernel(be, __package__, "twosided.cl", "two_sided_rows", dtype, ROWS=1, LANES=lanes, **config)
    else:
        knl = launch.kernel(be, __package__, "twosided.cl", "two_sided", dtype, LANES=lanes, BAND=BAND, AHEAD=AHEAD,
                            **config)
    scratch = be.empty((items * plan.n * per_step, lanes), dtype)
    item, real = dtype.itemsize, dtype.type
    s0, s1, d0, d1 = srcs[0], srcs[-1], dsts[0], dsts[-1]
    args = (s0.base_data, s1.base_data, d0.base_data, d1.base_data, np.int64(s0.offset // item),
            np.int64(s1.offset // item), np.int64(d0.offset // item), np.int64(d1.offset // item), coef.data,
            omega.data, np.int32(plan.omega.shape[-1]), real(cvals[0]), real(cvals[-1] if nin == 2 else 0.0),
            np.int32(b), np.int32(n), np.int32(m), np.int32(s0.nbytes >= _STREAM_BYTES), scratch.data, flag.data)
    launch.launch(be, knl, (items,), (1,), list(srcs), list(dsts) + [scratch, flag], args)
    if not check:
        return None
    return int(be.to_host(flag)[0]) == 0      # waits for the kernel (the flag holds its event)
