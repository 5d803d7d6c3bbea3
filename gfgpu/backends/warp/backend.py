"""The NVIDIA Warp backend: ``warp.array`` on the CPU (``"cpu"``) or a CUDA GPU (``"cuda:N"``).

Warp is imported lazily: importing this module neither imports nor initialises Warp; the
first :class:`WarpBackend` does (quietly), and the kernels of :mod:`gfgpu.backends.warp.recurse`
are compiled once per process on first use, through Warp's kernel cache (``~/.cache/warp``
or ``WARP_CACHE_PATH``), so later processes only load them.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import tempfile
import threading
from collections import OrderedDict
from functools import cache

import numpy as np

from ..._core.hostpool import new_pool
from ..._core.magnitude import host_in_range
from ..._core.recursion import packed_block_powers
from ..._core.translation import _flat_index
from ..base import Backend, BackendUnavailable, check_line_plans, memory_hint

_REALS = (np.dtype(np.float32), np.dtype(np.float64))
_PLAN_CACHE_SIZE = 64      # uploaded plans, keyed by id(plan) (plans are cached upstream)
_INDEX_CACHE_SIZE = 8      # uploaded gather indices, keyed by id(index)
_POOL_BYTES = 1 << 16      # CPU arrays from this size live on the host pool's reused memory
GPU_THREADS = 132 * 1024   # threads a GPU pass should have in flight (an H200 holds 270,336)
GPU_BLOCK_DIM = 128        # threads per block of the line kernels on a GPU
MIN_BLOCK = 64             # shortest block of a block-parallel line (steps)


@cache
def cuda_driver_present():
    """True if the NVIDIA driver library loads (checked without importing Warp).

    The automatic backend choice asks this before initialising Warp, so a machine without a
    CUDA driver never initialises Warp unless Warp is the backend that runs.
    """
    names = {"win32": ("nvcuda.dll",), "darwin": ()}.get(sys.platform, ("libcuda.so", "libcuda.so.1"))
    for name in names:
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


_NO_DRIVER_LINE = b"Warp CUDA warning: Could not find or load the NVIDIA CUDA driver"


@contextlib.contextmanager
def _without_driver_warning():
    """Drop Warp's "no CUDA driver" line, printed by its native library on stderr at ``wp.init``.

    Where no CUDA driver exists, Warp on the CPU is a deliberate choice and ``gfgpu devices``
    says why CUDA is unavailable; everything else Warp writes to stderr is passed on.
    """
    if cuda_driver_present():
        yield
        return
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):     # no real stderr (embedded interpreters): nothing to filter
        yield
        return
    with tempfile.TemporaryFile() as capture:
        os.dup2(capture.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            kept = b"".join(line for line in capture.read().splitlines(keepends=True)
                            if not line.startswith(_NO_DRIVER_LINE))
            if kept:
                sys.stderr.write(kept.decode(errors="replace"))
                sys.stderr.flush()


def _fold(shape):
    """Warp arrays have at most 4 dimensions: leading axes beyond that are folded into one (the
    operators address arrays through their own (B, N, M) views, so the fold is invisible)."""
    shape = tuple(int(n) for n in shape)
    if len(shape) <= 4:
        return shape
    return (int(np.prod(shape[:-3], dtype=np.int64)),) + shape[-3:]


_INIT_LOCK = threading.Lock()


def _import_warp():
    """Import and initialise Warp quietly, once per process (under a lock: threads of a Dask
    worker may ask at once); raise :class:`BackendUnavailable` if it cannot."""
    try:
        import warp as wp
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise BackendUnavailable(f"warp-lang not installed ({exc})") from exc
    with _INIT_LOCK:
        if _INIT_STATE.get("pid") == os.getpid():
            if "error" in _INIT_STATE:
                raise BackendUnavailable(_INIT_STATE["error"])
            return wp
        # a library should not print Warp's start-up banner and module-load lines: `quiet` in
        # older Warp, `log_level` in newer (setting the unused one is harmless)
        wp.config.quiet = True
        if hasattr(wp, "LOG_WARNING"):
            wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
        _INIT_STATE.clear()
        _INIT_STATE["pid"] = os.getpid()
        try:
            with _without_driver_warning():
                wp.init()
        except Exception as exc:  # pragma: no cover - depends on the environment
            _INIT_STATE["error"] = f"warp-lang failed to initialise: {exc}{memory_hint()}"
            raise BackendUnavailable(_INIT_STATE["error"]) from exc
    return wp


_INIT_STATE = {}


def unavailable_reason():
    """Why the Warp backend cannot be used here, or None if it can.

    Returns
    -------
    str or None
        For example ``"warp-lang not installed"``.  Initialises Warp (quietly) if present.
    """
    try:
        _import_warp()
    except BackendUnavailable as exc:
        return str(exc)
    return None


def warp_devices():
    """Names of the Warp devices usable by :class:`WarpBackend`.

    Returns
    -------
    list of str
        ``"cpu"`` followed by ``"cuda:0"``, ``"cuda:1"``, ... for each CUDA GPU; empty when
        Warp is unavailable.
    """
    try:
        wp = _import_warp()
    except BackendUnavailable:
        return []
    return [d.alias for d in wp.get_devices()]


def block_split(shape, axis, kind):
    """``(lines, blocks, block)`` of a recursion pass over a ``(B, N, M)`` array along ``axis``.

    One thread per line (block) of the pass.  On a GPU, lines too few to fill it
    (:data:`GPU_THREADS` threads in flight) are cut into blocks of at least :data:`MIN_BLOCK`
    steps whose states are carried exactly (:func:`gfgpu._core.recursion.run_reference_blocks`);
    Warp's CPU kernels run one thread at a time, so there lines stay whole.
    """
    b, n, m = (int(x) for x in shape)
    lines, length = (b * m, n) if axis == 1 else (b * n, m)
    blocks = 1
    if kind != "cpu" and lines < GPU_THREADS and length >= 2 * MIN_BLOCK:
        blocks = min(-(-GPU_THREADS // lines), length // MIN_BLOCK)
    block = -(-length // blocks)
    return lines, -(-length // block), block


class WarpBackend(Backend):
    """Run the recursion primitive with Warp kernels on ``warp.array`` data.

    Parameters
    ----------
    device : str or int, optional
        A Warp device name, ``"cpu"`` or ``"cuda:N"`` (an int ``N`` means ``"cuda:N"``).
        Default: ``"cuda:0"`` when a CUDA GPU is available, else ``"cpu"``.

    Raises
    ------
    BackendUnavailable
        If warp-lang is not installed, fails to initialise, or ``device`` does not exist.

    Notes
    -----
    One Warp thread runs one line (the kernels of :mod:`gfgpu.backends.warp.recurse`).  Columns
    are processed through a transposed strided view, so both axes share one kernel body.  On
    a GPU adjacent threads read adjacent columns (coalesced).  Warp's CPU backend runs the
    threads one after another, so there a thread takes a cache line of adjacent columns at a
    time (a vector sample: 16 float32 or 8 float64 columns), which keeps column passes
    sequential in memory.  float32 and float64 are supported on every device.  Uploaded
    plans and gather indices are cached by identity (both are treated as immutable).

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.backends.warp import WarpBackend
    >>> be = WarpBackend("cpu")
    >>> a = be.asarray(np.ones((1, 4, 5), np.float32))
    >>> be.to_host(a).shape
    (1, 4, 5)
    """

    name = "warp"
    supports_float64 = True

    def __init__(self, device=None):
        wp = _import_warp()
        if device is None:
            device = "cuda:0" if wp.is_cuda_available() else "cpu"
        elif isinstance(device, int):
            device = f"cuda:{device}"   # an ordinal names a GPU, as in Warp's "cuda:N"
        try:
            self._device = wp.get_device(device)
        except Exception as exc:
            raise BackendUnavailable(f"Warp device {device!r} is not available "
                                     f"(usable: {', '.join(warp_devices())})") from exc
        self._wp = wp
        from . import recurse as kernels
        self._k = kernels
        self.device = self._device.alias if self._device.is_cpu else \
            f"{self._device.alias} ({self._device.name})"
        # the launch shapes follow ``kind``; a test may set "gpu" on the CPU device to run the
        # GPU shapes (block-parallel lines, the translate kernel, device finite checks) there
        self.kind = "cpu" if self._device.is_cpu else "gpu"
        self._plans = OrderedDict()    # (id(plan), dtype) -> (plan, arrays)
        self._indices = OrderedDict()  # id(index) -> (index, device array, max index)
        self._flat = {}                # (id(line index), shape, axis) -> (line index, flat gather index)
        self._host_pool = new_pool()   # the CPU device's arrays and numpy results (empty, host_result)

    @property
    def wp_device(self):
        """The ``warp.context.Device`` this backend runs on."""
        return self._device

    # ---- arrays -------------------------------------------------------------------
    def owns(self, array):
        return isinstance(array, self._wp.array) and array.device == self._device

    def asarray(self, host):
        host = np.ascontiguousarray(host)
        host = host.reshape(_fold(host.shape))
        return self._wp.array(host, dtype=self._wp.dtype_from_numpy(host.dtype), device=self._device)

    def to_host(self, array):
        host = getattr(array, "gfgpu_host", None)
        if host is not None:
            return host     # a host_result on the CPU: the numpy array is the memory (launches are synchronous)
        out = array.numpy()
        # on the CPU .numpy() is a view of the Warp allocation: copy so later kernels can't alter it
        return out.copy() if self._device.is_cpu else out

    def empty(self, shape, dtype):
        shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
        if self._device.is_cpu and int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize >= _POOL_BYTES:
            # reused host memory (gfgpu._core.hostpool): a fresh allocation of an image's size
            # costs a page fault per page at its first pass, more than the pass; CPU launches are
            # synchronous, so a released block is never in use by a kernel
            return self._alias(self._host_pool.take(shape, dtype))
        return self._wp.empty(_fold(shape), dtype=self._wp.dtype_from_numpy(np.dtype(dtype)),
                              device=self._device)

    def _alias(self, host):
        # by pointer with canonical strides: numpy calls arrays with odd strides on length-1
        # axes C-contiguous, Warp does not
        arr = self._wp.array(ptr=host.ctypes.data, dtype=self._wp.dtype_from_numpy(host.dtype),
                             shape=_fold(host.shape), device=self._device)
        arr.gfgpu_memory = host     # the numpy array owns the memory: keep it alive
        return arr

    def host_view(self, host):
        # Warp's CPU device reads numpy memory in place: no copy, no fresh allocation
        host = np.ascontiguousarray(host)
        return self._alias(host) if self._device.is_cpu else self.asarray(host)

    def host_result(self, shape, dtype, into=None):
        if not self._device.is_cpu:
            return self.empty(shape, dtype)
        host = self._host_pool.take(shape, dtype) if into is None else into
        arr = self._alias(host)
        arr.gfgpu_host = host     # keeps the memory alive; to_host returns it
        return arr

    def copy(self, src, dst):
        self._wp.copy(dst, src)
        return dst

    def is_contiguous(self, array):
        return bool(array.is_contiguous)

    def contiguous(self, array):
        return array if array.is_contiguous else array.contiguous()

    def from_dlpack(self, array):
        """A foreign array (``__dlpack__`` or ``__cuda_array_interface__``: torch, CuPy, JAX,
        Numba) as a ``warp.array`` on the same memory, no copy (:mod:`gfgpu._core.arrays`).

        ``wp.from_dlpack`` hands the producer Warp's current stream on the array's device, so
        the producer orders its pending work before ours (DLPack's stream protocol); results go
        back through ``warp.array.__dlpack__``, which does the same for the consumer.  A
        ``__cuda_array_interface__`` array is wrapped on this backend's device (the interface
        names no device).  The caller checks that the result is on this backend's device.
        """
        if hasattr(array, "__dlpack__"):
            return self._wp.from_dlpack(array)
        return self._wp.array(array, device=self._device, copy=False)

    def may_share_memory(self, a, b):
        if a.device != b.device or not a.size or not b.size:
            return False
        def span(x):
            item = np.dtype(self._wp.dtype_to_numpy(x.dtype)).itemsize
            extent = sum((n - 1) * abs(st) for n, st in zip(x.shape, x.strides)) + item
            return x.ptr, x.ptr + extent
        (a0, a1), (b0, b1) = span(a), span(b)
        return a0 < b1 and b0 < a1

    def dtype_of(self, array):
        return np.dtype(self._wp.dtype_to_numpy(array.dtype))

    def reshape(self, array, shape):
        return array.reshape(_fold(shape))

    def all_finite(self, array):
        if np.dtype(self._wp.dtype_to_numpy(array.dtype)) not in _REALS:
            return True   # integer arrays hold no NaN or infinity
        wp = self._wp
        count = wp.zeros(1, dtype=wp.int32, device=self._device)
        if array.size:
            flat = (array if array.is_contiguous else array.contiguous()).flatten()
            wp.launch(self._k.count_nonfinite, dim=array.size, inputs=[flat, count], device=self._device)
        return int(count.numpy()[0]) == 0

    def synchronize(self):
        self._wp.synchronize_device(self._device)

    @property
    def spec(self):
        return ("warp", self._device.alias)

    @property
    def memory_budget(self):
        return None if self._device.is_cpu else int(self._device.total_memory) // 2

    # ---- the primitive --------------------------------------------------------------
    def _plan_arrays(self, plan, dtype):
        """Upload ``plan.packed(dtype)`` once; plans are immutable, so id(plan) is a key."""
        key = (id(plan), dtype)
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plan:
            self._plans.move_to_end(key)
            return hit[1]
        wp = self._wp
        lam, kap, omega, omega_c = plan.packed(dtype)
        if omega.shape[1] == 0:
            # Warp kernels take no empty arrays' data pointers: pass one unused zero column
            omega = np.zeros((omega.shape[0], 1, 2), dtype)
        arrays = tuple(wp.array(a, dtype=wp.dtype_from_numpy(dtype), device=self._device)
                       for a in (lam, kap, omega, omega_c))
        self._plans[key] = (plan, arrays)   # keeping the plan keeps its id unique
        if len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return arrays

    def recurse_shape(self, shape, axis):
        """``(lines, blocks, block)`` of a :meth:`recurse` pass (:func:`block_split`)."""
        return block_split(shape, axis, self.kind)

    def _block_powers(self, plan, dtype, block, blocks):
        """(S, blocks, 2) products of each block's lam on the device, cached per plan and block."""
        key = (id(plan), dtype, "pow", block)
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plan:
            self._plans.move_to_end(key)
            return hit[1]
        packed = packed_block_powers(plan, block, dtype)
        arr = self._wp.array(packed, dtype=self._wp.dtype_from_numpy(dtype), device=self._device)
        self._plans[key] = (plan, arr)
        if len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return arr

    #: every device: on the CPU too the window is read by the pass, where the gathers around it
    #: built a full-size flat index per shape (a first shift at 1100x1300 after 1000x1200: 286 ms
    #: against 40 ms steady; windowed 40 ms first, 31 ms steady, same result)
    recurses_windows = True

    def recurse(self, src, dst, axis, plan, cval=0.0, accumulate=False, check=False, window=None):
        wp = self._wp
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a):
                raise TypeError(f"{arg} must be a warp.array on {self._device.alias}, got {type(a).__name__}")
            if a.ndim != 3 or not a.is_contiguous:
                raise ValueError(f"{arg} must be a C-contiguous 3-D array, got shape {a.shape}")
        if src.shape != dst.shape or src.dtype != dst.dtype:
            raise ValueError(f"src and dst must match: {src.shape} {src.dtype} vs {dst.shape} {dst.dtype}")
        dtype = np.dtype(wp.dtype_to_numpy(src.dtype))
        if dtype not in _REALS:
            raise TypeError(f"src must be float32 or float64, got {dtype}")
        if window is not None:
            return self._recurse_window(src, dst, axis, plan, cval, accumulate, check, window)
        if plan.n != src.shape[axis]:
            raise ValueError(f"plan is for lines of {plan.n} samples, axis {axis} has {src.shape[axis]}")
        if plan.sections > self._k.MAX_SECTIONS:
            raise ValueError(f"plans may have at most {self._k.MAX_SECTIONS} sections, got {plan.sections}")
        if accumulate and src.ptr == dst.ptr:
            raise ValueError("dst may not be src when accumulating")
        if src.size == 0:
            return True if check else dst
        lam, kap, omega, omega_c = self._plan_arrays(plan, dtype)
        real = src.dtype
        _, blocks, block = self.recurse_shape(src.shape, axis)
        if blocks > 1:
            return self._recurse_blocks(src, dst, axis, plan, dtype, cval, accumulate, check, blocks, block)
        finite = None
        if check:   # Warp's CPU threads run one at a time: numpy tests the same memory as fast
            finite = host_in_range(src.numpy()) if self.kind == "cpu" else self.all_finite(src)
        scalars = [plan.sections, plan.omega.shape[1], real(cval), real(plan.tap), int(plan.reverse),
                   int(bool(accumulate)), int(plan.constant)]
        for kernel, lines_src, lines_dst in self._line_views(src, dst, axis):
            self._launch(kernel, lines_src.shape[:2], [lines_src, lines_dst, lam, kap, omega, omega_c, *scalars])
        return finite if check else dst

    def _recurse_window(self, src, dst, axis, plan, cval, accumulate, check, window):
        """A translated pass read through a window index (:attr:`recurses_windows`)."""
        index, first = window
        if plan.n != len(index):
            raise ValueError(f"plan is for lines of {plan.n} samples, the window has {len(index)}")
        if not plan.constant or plan.sections > self._k.MAX_SECTIONS:
            raise ValueError("windowed passes take shift-invariant plans of at most 2 sections")
        if self.may_share_memory(src, dst):
            raise ValueError("dst may not overlap src in a windowed pass")
        dtype = np.dtype(self._wp.dtype_to_numpy(src.dtype))
        if src.size == 0:
            return True if check else dst
        finite = None
        if check:   # Warp's CPU threads run one at a time: numpy tests the same memory as fast
            finite = host_in_range(src.numpy()) if self.kind == "cpu" else self.all_finite(src)
        lam, kap, omega, omega_c = self._plan_arrays(plan, dtype)
        dev_index = self._index_array(index, src.shape[axis])
        if dev_index.dtype != self._wp.int32:
            raise ValueError("the window index must fit in int32")
        views = (src, dst) if axis == 2 else (src.transpose((0, 2, 1)), dst.transpose((0, 2, 1)))
        real = src.dtype
        self._launch(self._k.recurse_window, views[0].shape[:2],
                     [views[0], views[1], dev_index, int(first), lam, kap, omega, omega_c, plan.sections,
                      plan.omega.shape[1], real(cval), real(plan.tap), int(plan.reverse), int(bool(accumulate))])
        return finite if check else dst

    def _launch(self, kernel, dim, inputs):
        # explicit thread blocks on a GPU: 128 threads, so that a pass of few lines still spreads
        # over many multiprocessors
        kw = {} if self._device.is_cpu else {"block_dim": GPU_BLOCK_DIM}
        self._wp.launch(kernel, dim=dim, inputs=inputs, device=self._device, **kw)

    def _recurse_blocks(self, src, dst, axis, plan, dtype, cval, accumulate, check, blocks, block):
        """Block-parallel lines: block end states, their composition, the blocks' outputs."""
        wp = self._wp
        lam, kap, omega, omega_c = self._plan_arrays(plan, dtype)
        real = src.dtype
        views = (src, dst) if axis == 2 else (src.transpose((0, 2, 1)), dst.transpose((0, 2, 1)))
        b, lines = views[0].shape[0], views[0].shape[1]
        wdt = wp.dtype_from_numpy(dtype)
        carry = wp.empty((b, blocks, 2 * plan.sections, lines), dtype=wdt, device=self._device)
        partial = wp.empty((b, blocks, 2 * plan.sections, lines), dtype=wdt, device=self._device)
        flag = wp.zeros(1, dtype=wp.int32, device=self._device)
        self._launch(self._k.block_states, (b, lines, blocks),
                     [views[0], lam, kap, omega, plan.sections, plan.omega.shape[1], int(plan.reverse),
                      int(plan.constant), block, int(bool(check)), carry, partial, flag])
        self._launch(self._k.compose, (b, lines),
                     [carry, partial, omega_c, self._block_powers(plan, dtype, block, blocks), plan.sections,
                      real(cval)])
        self._launch(self._k.block_outputs, (b, lines, blocks),
                     [views[0], views[1], lam, kap, plan.sections, real(plan.tap), int(plan.reverse),
                      int(bool(accumulate)), int(plan.constant), block, carry])
        return int(flag.numpy()[0]) == 0 if check else dst

    def recurse_lines(self, src, dst, axis, plans, cval=0.0):
        wp = self._wp
        check_line_plans(src, dst, axis, plans)
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or not a.is_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous warp.array on {self._device.alias}")
        dtype = np.dtype(wp.dtype_to_numpy(src.dtype))
        if src.size == 0:
            return dst
        real = wp.dtype_from_numpy(dtype)
        key = (id(plans), dtype, "lines")
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plans:       # plans are immutable: uploaded once
            self._plans.move_to_end(key)
            dev, rev, init_len = hit[1]
        else:
            lam, kap, tap, reverse, omega, omega_c = plans.packed(dtype)
            init_len = omega.shape[1]
            if init_len == 0:
                omega = np.zeros((omega.shape[0], 1, 2), dtype)   # no empty arrays for kernels
            dev = [wp.array(a, dtype=real, device=self._device) for a in (lam, kap, tap, omega, omega_c)]
            rev = wp.array(reverse, dtype=wp.int32, device=self._device)
            self._plans[key] = (plans, (dev, rev, init_len))
            if len(self._plans) > _PLAN_CACHE_SIZE:
                self._plans.popitem(last=False)
        views = (src, dst) if axis == 2 else (src.transpose((0, 2, 1)), dst.transpose((0, 2, 1)))
        wp.launch(self._k.recurse_per_line, dim=views[0].shape[:2],
                  inputs=[views[0], views[1], dev[0], dev[1], dev[2], rev, dev[3], dev[4], init_len,
                          real(cval)], device=self._device)
        return dst

    def _line_views(self, src, dst, axis):
        """``(kernel, src, dst)``: views ``(B, lines, n)`` whose last axis is the lines' axis,
        and the kernel that runs them.

        Rows are the arrays themselves; columns the transposed ``(B, M, N)`` views.  On the CPU,
        whose Warp threads run one after another, columns go in groups of adjacent columns
        (vector samples, :mod:`gfgpu.backends.warp.recurse_lanes`, a CPU-only module) so that
        each thread walks down whole cache lines; the ``M % lanes`` columns left over go one per
        thread.
        """
        scalar = self._k.recurse_lines
        if axis == 2:
            return [(scalar, src, dst)]
        col_src, col_dst = src.transpose((0, 2, 1)), dst.transpose((0, 2, 1))
        if self.kind != "cpu":
            return [(scalar, col_src, col_dst)]   # GPU: adjacent threads, adjacent columns (coalesced)
        from . import recurse_lanes
        lane = recurse_lanes.LANE_TYPES[src.dtype]
        m = src.shape[2]
        body = m - m % lane._length_
        views = []
        if body:
            views.append((recurse_lanes.recurse_lanes, self._lane_view(src, lane, body),
                          self._lane_view(dst, lane, body)))
        if body < m:
            views.append((scalar, col_src[:, body:, :], col_dst[:, body:, :]))
        return views

    def _lane_view(self, a, lane, width):
        """Columns ``[0, width)`` of ``(B, N, M)`` array ``a`` as ``(B, width // L, N)`` L-column vectors."""
        size = self._wp.types.type_size_in_bytes(lane)
        return self._wp.array(ptr=a.ptr, dtype=lane, shape=(a.shape[0], width // lane._length_, a.shape[1]),
                              strides=(a.strides[0], size, a.strides[1]), device=self._device)

    def _index_array(self, index, size):
        """Upload a gather index once per identity (int32 when the source allows)."""
        key = id(index)
        hit = self._indices.get(key)
        if hit is not None and hit[0] is index:
            self._indices.move_to_end(key)
            dev, top = hit[1], hit[2]
        else:
            idx = np.asarray(index).reshape(-1)
            if idx.dtype.kind not in "iu":
                raise TypeError(f"index must be an integer array, got {idx.dtype}")
            top = int(idx.max()) if idx.size else -1
            small = top < 2**31 and (idx.size == 0 or int(idx.min()) >= -2**31)
            idx = np.ascontiguousarray(idx, np.int32 if small else np.int64)
            dev = self._wp.array(idx, dtype=self._wp.int32 if small else self._wp.int64, device=self._device)
            self._indices[key] = (index, dev, top)
            if len(self._indices) > _INDEX_CACHE_SIZE:
                self._indices.popitem(last=False)
        if top >= size:
            raise ValueError(f"index holds {top}, beyond the source's {size} elements")
        return dev

    def translate(self, src, dst, axis, index, cval=0.0, check=False):
        wp = self._wp
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or a.ndim != 3 or not a.is_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous 3-D warp.array on {self.device}")
        if tuple(src.shape) != tuple(dst.shape) or src.dtype != dst.dtype:
            raise ValueError(f"src and dst must match: {src.shape} {src.dtype} vs {dst.shape} {dst.dtype}")
        if self.may_share_memory(src, dst):
            raise ValueError("dst may not overlap src")
        b, n, m = src.shape
        length = src.shape[axis]
        if np.asarray(index).size != length:
            raise ValueError(f"index has {np.asarray(index).size} elements, axis {axis} has {length}")
        if src.size == 0:
            return True if check else None
        if self.kind == "cpu":
            # Warp's CPU kernels run on one thread: the flat gather (its index cached) measured
            # faster than a kernel that computes the index; the check is numpy's on the same memory
            finite = host_in_range(src.numpy()) if check else None
            key = (id(index), tuple(src.shape), axis)
            hit = self._flat.get(key)
            if hit is None or hit[0] is not index:
                hit = self._flat[key] = (index, _flat_index(tuple(src.shape), axis, index))
                if len(self._flat) > _INDEX_CACHE_SIZE:
                    self._flat.pop(next(iter(self._flat)))
            self.gather(src.flatten(), hit[1], cval, dst.flatten())
            return finite
        dev_index = self._index_array(index, length)
        if dev_index.dtype != wp.int32:
            raise ValueError("index must fit in int32")
        flag = wp.zeros(1, dtype=wp.int32, device=self._device)
        wp.launch(self._k.translate, dim=(b * n, m),
                  inputs=[src.reshape((b * n, m)), dev_index, src.dtype(cval), n, int(axis == 2), int(bool(check)),
                          dst.reshape((b * n, m)), flag], device=self._device)
        return int(flag.numpy()[0]) == 0 if check else None

    def input_finite(self, host, data):
        # a GPU tests its copy in parallel; Warp's CPU kernels run on one thread, as numpy does
        return host_in_range(host) if self.kind == "cpu" else self.all_finite(data)

    def gather(self, src, index, cval, out):
        wp = self._wp
        if src.dtype != out.dtype:
            raise ValueError(f"src and out must have one dtype, got {src.dtype} and {out.dtype}")
        dev_index = self._index_array(index, src.size)
        if dev_index.size != out.size:
            raise ValueError(f"index has {dev_index.size} elements, out has {out.size}")
        if out.size:
            wp.launch(self._k.gather, dim=out.size,
                      inputs=[src.flatten(), dev_index, src.dtype(cval), out.flatten()],
                      device=self._device)
        return out
