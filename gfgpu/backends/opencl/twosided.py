"""Two-sided steps on an OpenCL CPU device (``twosided.cl``; spec
:func:`gfgpu._core.twosided.run_two_sided_reference`), for :mod:`gfgpu.filters`' derivative,
projection and gradient: a column step's causal and anticausal passes over bands of columns in one
kernel, a backward sweep that stores its states every :data:`BLOCK_ROWS` rows, then blocks that
restart it from them and run the forward sweep, so that the inputs are read twice (the second time
from the cache) and each output is written once (the earlier sweep down then up the whole band
wrote each output twice and read it back from memory).  CPU devices only (:func:`runs_on`)."""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from . import launch

__all__ = ["runs_on", "run_two_sided"]

_CACHE_LINE = 64
_STREAM_BYTES = 1 << 23    # outputs from this size are written with non-temporal stores
_PLAN_CACHE = 32
#: rows of a block: phase 1 restarts each block's backward sweep from its carry and keeps the
#: block's anticausal parts in a scratch of BLOCK_ROWS x BAND vectors per output (in the cache)
BLOCK_ROWS = 32
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


def band(plan):
    """Most vectors of adjacent columns per work-item: the states of a band stay in registers."""
    states = len(set(plan.inputs)) * plan.sections * (1 if plan.real else 2)
    return max(1, min(4, 16 // states))


def run_two_sided(be, srcs, dsts, axis, plan, cvals=(0.0, 0.0), check=False):
    """Run a two-sided step along axis 1 (columns) of C-contiguous ``(B, N, M)`` arrays: ``srcs``
    and ``dsts``, one per input and output of ``plan`` (outputs overlap nothing), ``cvals`` each
    input's constant (mode 'constant').  With ``check`` the first (backward) sweep also tests that
    ``srcs[0]`` is finite and within the range limit, and the result is that bool (a blocking
    read); else None.  Raises ValueError or TypeError for arrays, axis or plan that do not fit."""

    if not runs_on(be):
        raise ValueError(f"two-sided steps run on OpenCL CPU devices, not on {be!r}")
    if axis != 1:
        raise ValueError(f"two-sided steps run lines along axis 1 (columns; rows: recurse_pair), got axis {axis}")
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
    lanes = _CACHE_LINE // dtype.itemsize
    units = int(be.cl_device.max_compute_units)
    width = band(plan)
    vecs = -(-m // lanes)
    nv = max(1, min(width, (b * vecs) // (2 * units)))     # every core gets two bands at least
    gsize, lsize = (-(-vecs // nv), b), (1, 1)
    knl = launch.kernel(be, __package__, "twosided.cl", "two_sided", dtype, LANES=lanes, SECTIONS=plan.sections,
                        NIN=nin, NOUT=nout, REAL_POLES=int(plan.real), BAND=width, CHECK=int(bool(check)))
    coef, omega = _buffers(be, plan, dtype)
    k = BLOCK_ROWS
    carries = be.empty((b, -(-n // k), nin * plan.sections, 2, m), dtype)
    per_item = nin * plan.sections * 2 * width + k * width * nout     # SCRATCH_VECS of twosided.cl
    scratch = be.empty((gsize[0] * b, per_item, lanes), dtype)
    flag = be.asarray(np.zeros(1, np.int32))
    s0, s1 = srcs[0], srcs[-1]
    d0, d1 = dsts[0], dsts[-1]
    item = dtype.itemsize
    real = dtype.type
    stream = int(first.nbytes >= _STREAM_BYTES)
    args = (s0.base_data, s1.base_data, d0.base_data, d1.base_data, np.int64(s0.offset // item),
            np.int64(s1.offset // item), np.int64(d0.offset // item), np.int64(d1.offset // item), coef.data,
            omega.data, np.int32(plan.omega.shape[-1]), real(cvals[0]), real(cvals[-1] if nin == 2 else 0.0),
            np.int32(b), np.int32(n), np.int32(m), np.int32(nv), np.int32(k), np.int32(stream), carries.data,
            scratch.data, flag.data)
    launch.launch(be, knl, gsize, lsize, list(srcs), list(dsts) + [carries, scratch] + ([flag] if check else []), args)
    if not check:
        return None
    return int(be.to_host(flag)[0]) == 0      # waits for the kernel (the flag holds its event)
