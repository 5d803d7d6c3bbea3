"""Reused host memory for the working arrays and results of CPU devices.

On a CPU device (PoCL, Warp's CPU) device memory is host memory, and the first write to a
freshly allocated page costs a page fault: measured on a loaded 2-core machine, a fresh
5.7 MB buffer took 10-50 ms at its first pass against 3 ms for the same pass on touched
memory, and a fresh 64 MB array (4096² float32) 6-14 ms before the first byte of a 4.7 ms
copy.  numpy's own large arrays come from ``mmap`` and are fresh on every call; PyOpenCL's
memory pool keeps buffers in bins 1/16 apart, so a slightly different shape allocates fresh
memory.  :class:`HostPool` keeps released blocks and hands them out again:

- sizes are rounded up to *half-octave classes* (``2**(k/2)`` bytes, whole pages), so shapes
  within ~41 % of each other share a class (a 1000×1200 and a 1100×1300 float32 image do);
  a request may also take a held block of the next class up (at most ~2× its size);
- a block goes back to the pool when the last array on it is garbage collected (a result the
  caller dropped, a temporary of a finished call), never while an array uses it;
- at most ``limit`` bytes are held (least recently released blocks are freed first), so a
  process that sees many shapes does not accumulate memory; a request that no held block
  serves first frees the oldest held blocks until the fresh block fits beside the rest within
  the limit, so the pool adds at most ``limit`` bytes to a call's peak memory;
- the limit is 256 MiB (a 4096² float32 image's result and two working arrays), or the
  environment variable ``GFGPU_HOST_POOL`` (bytes or ``"512M"``; ``0`` switches reuse off: every
  block is freed when its last array goes).  What a pool holds stays resident in the process
  (a Dask worker counts it as used memory).

The pool recycles memory, never results: every block's content is overwritten by the pass
that takes it.  Device queues: a block is reused by the same backend only (one pool per
backend instance, whose in-order queue orders the reuse after every earlier command).  Freeing
is not ordered by a queue: a block whose array Python dropped may still be written by a queued
kernel (an OpenCL device buffer on host memory), so a pool made with a ``fence`` (the queue's
``finish``) calls it before it frees any block, and frees only in :meth:`HostPool.take` and
:meth:`HostPool.clear`, never from the garbage collector's release.
"""

from __future__ import annotations

import math
import os
import re
import threading
import weakref
from collections import OrderedDict, deque

import numpy as np

__all__ = ["HostPool", "size_class"]

PAGE = 4096                 # bytes: blocks are whole pages, page-aligned
DEFAULT_LIMIT = 256 << 20   # held bytes at most (256 MiB) unless GFGPU_HOST_POOL says


def size_class(nbytes):
    """The bytes of the half-octave class of a request of ``nbytes``: whole pages, the least
    ``ceil(2**(k/2))`` pages that hold it (a class's own size is its class).

    Examples
    --------
    >>> size_class(4_800_000) == size_class(5_720_000)     # 1000x1200 and 1100x1300 float32
    True
    >>> size_class(4096 * 4096 * 4) == 4096 * 4096 * 4     # a power of two is its own class
    True
    """
    pages = max(1, -(-int(nbytes) // PAGE))
    k = max(0, math.floor(2 * math.log2(pages)) - 1)
    while math.ceil(2.0 ** (k / 2)) < pages:    # the least class that holds the pages
        k += 1
    return math.ceil(2.0 ** (k / 2)) * PAGE


class _Lease:
    """The owner (``.base``) of the arrays handed out on one block: the block returns to its
    pool when the lease is collected, i.e. when no array on the block is left."""

    __slots__ = ("__array_interface__", "__weakref__")

    def __init__(self, address, shape, dtype):
        self.__array_interface__ = {"shape": tuple(shape), "typestr": np.dtype(dtype).str,
                                    "data": (address, False), "version": 3}


class HostPool:
    """Page-aligned, C-contiguous numpy arrays on reused memory (see the module notes).

    Parameters
    ----------
    limit : int, optional
        Most bytes of released blocks held for reuse (default :data:`DEFAULT_LIMIT`, 256 MiB).
    fence : callable, optional
        Called (no arguments) before held blocks are freed: it must return once no queued device
        command uses them (an in-order queue's ``finish``).  With a fence, blocks released beyond
        the limit stay held until the next :meth:`take` or :meth:`clear`.

    Examples
    --------
    >>> pool = HostPool()
    >>> a = pool.take((1000, 1200), np.float32)
    >>> address = a.ctypes.data
    >>> del a                                   # released: held for the next request
    >>> b = pool.take((1100, 1300), np.float32)
    >>> b.ctypes.data == address, pool.stats["fresh"]
    (True, 1)
    """

    def __init__(self, limit=DEFAULT_LIMIT, fence=None):
        self.limit = int(limit)
        self._fence = fence
        self._lock = threading.Lock()
        self._held = OrderedDict()      # id(raw) -> (class bytes, raw), oldest release first
        self._held_bytes = 0
        # blocks released by the collector, moved into _held under the lock by the next take,
        # clear or held_bytes: a finaliser may run inside take's locked section (a collection
        # triggered by any allocation there), where taking the lock would deadlock
        self._returned = deque()
        #: counters: "fresh" blocks allocated, "reused" requests served from held blocks
        self.stats = {"fresh": 0, "reused": 0}

    @property
    def held_bytes(self):
        """Bytes of released blocks held for reuse."""
        with self._lock:
            self._settle()
            return self._held_bytes

    def take(self, shape, dtype):
        """An uninitialised C-contiguous array of ``shape`` and ``dtype`` whose data start on a
        page boundary, on a held block where one fits (its class or the next), else on a fresh one."""
        dtype = np.dtype(dtype)
        shape = tuple(int(s) for s in shape)
        nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        want = size_class(nbytes)
        raw = None
        doomed = []
        with self._lock:
            self._settle()
            best = None
            for key, (size, block) in self._held.items():
                # the request's class, else the least held block up to the next class
                if want <= size <= size_class(want + 1) and (best is None or size < best[1]):
                    best = (key, size, block)
                    if size == want:
                        break
            if best is not None:
                key, size, raw = best
                del self._held[key]
                self._held_bytes -= size
                self.stats["reused"] += 1
                doomed = self._trim(self.limit)     # blocks released beyond the limit meanwhile
            else:
                # a miss: held blocks that would stand beside the fresh one beyond the limit go first
                doomed = self._trim(max(0, self.limit - want))
        self._free(doomed)
        if raw is None:
            raw = np.empty(want + PAGE, np.uint8)
            self.stats["fresh"] += 1
        start = -raw.ctypes.data % PAGE
        lease = _Lease(raw.ctypes.data + start, shape, dtype)
        weakref.finalize(lease, self._release, raw, raw.size - PAGE)
        return np.asarray(lease)

    def _release(self, raw, size):
        # runs in the garbage collector, possibly inside this pool's locked section: never waits
        # for the lock.  With a fence nothing is freed here (the fence may block on a queue, and
        # a finaliser may run inside a call on that queue); without one, blocks beyond the limit
        # are freed now if the lock is free, else by the next take
        self._returned.append((size, raw))
        if self._fence is None and self._lock.acquire(blocking=False):
            try:
                self._settle()
                doomed = self._trim(self.limit)
            finally:
                self._lock.release()
            del doomed          # no fence: no queue writes to host memory after its array is gone

    def _settle(self):
        # the lock is held: released blocks join the held ones, oldest release first
        while self._returned:
            size, raw = self._returned.popleft()
            self._held[id(raw)] = (size, raw)
            self._held_bytes += size

    def _trim(self, keep):
        # the lock is held: the least recently released blocks, taken out until at most keep bytes
        # stay; the caller frees them (after the fence)
        doomed = []
        while self._held_bytes > keep and self._held:
            _, (old, raw) = self._held.popitem(last=False)
            self._held_bytes -= old
            doomed.append(raw)
        return doomed

    def _free(self, doomed):
        if doomed and self._fence is not None:
            self._fence()       # no queued command may write a block after it is freed
        doomed.clear()

    def clear(self):
        """Free every held block (arrays in use keep theirs), after the fence if there is one."""
        with self._lock:
            self._settle()
            doomed = self._trim(0)
        self._free(doomed)


_pools = weakref.WeakSet()


def default_limit():
    """The held-bytes limit of a backend's pool: ``GFGPU_HOST_POOL`` (bytes, ``"512M"``; ``0``: no
    reuse) if set, else :data:`DEFAULT_LIMIT`.

    Raises
    ------
    ValueError
        If ``GFGPU_HOST_POOL`` is not a byte count.
    """
    value = os.environ.get("GFGPU_HOST_POOL", "").strip()
    if not value:
        return DEFAULT_LIMIT
    from .strips import parse_bytes
    try:
        if re.fullmatch(r"0+(\.0*)?|\.0+", value):     # 0, 0.0, .0: no reuse
            return 0
        return parse_bytes(value, "GFGPU_HOST_POOL")
    except ValueError:
        raise ValueError(f"the environment variable GFGPU_HOST_POOL must be 0 (no reuse) or a positive byte "
                         f"count such as 268435456, '256M' or '1G'; got {value!r}") from None


def new_pool(limit=None, fence=None):
    """A :class:`HostPool` that a forked child empties (its parent's blocks are copies there);
    ``limit`` None: :func:`default_limit`; ``fence`` as in :class:`HostPool`."""
    pool = HostPool(default_limit() if limit is None else limit, fence)
    _pools.add(pool)
    return pool


def _clear_in_child():
    # no fence in a child (its parent's queues are not its own) and no lock a parent's thread
    # may have held at the fork: the child starts with empty pools
    for pool in list(_pools):
        pool._fence = None
        pool._lock = threading.Lock()
        pool._held = OrderedDict()
        pool._held_bytes = 0
        pool._returned = deque()


os.register_at_fork(after_in_child=_clear_in_child)
