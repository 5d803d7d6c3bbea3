"""The OpenCL backend: ``pyopencl.array.Array`` data on any OpenCL device (PoCL on the CPU, GPUs).

PyOpenCL is imported lazily: importing this module neither imports PyOpenCL nor creates a
context.  The device sources beside this module (``recurse.cl``: the recursion primitive,
gather and the non-finite check; ``recurse_lines.cl``: the per-line primitive) are built
on first use, specialised by ``-D`` defines (real type, sections, constant coefficients,
lanes, layout), and cached per (context, source, defines).  PyOpenCL caches the binaries on disk by source and
options (``PYOPENCL_CACHE_DIR``) and PoCL keeps its own cache (``POCL_CACHE_DIR``), so only
the first process on a machine pays the compile time (:mod:`gfgpu.backends.opencl.launch`, the
toolkit that the features' device code builds and launches with).
"""

from __future__ import annotations

import atexit
import ctypes
import os
import shutil
import tempfile
import threading
import warnings
from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from ..._core.hostpool import new_pool
from ..._core.magnitude import host_in_range
from ..._core.recursion import PassPlan, packed_block_powers
from ..base import Backend, BackendUnavailable, check_line_plans, memory_hint
from . import launch
from .probe import wide_vector_failure

_PLAN_CACHE_SIZE = 64      # uploaded plans, keyed by id(plan) (plans are cached upstream)
_INDEX_CACHE_SIZE = 8      # uploaded gather indices, keyed by id(index)
_CACHE_LINE = 64           # bytes per step of a CPU work-item (one cache line)
_ROW_VECTOR = 32           # bytes of rows per CPU row work-item: one 256-bit (AVX2) register, whose tile
                           # transposes in in-lane shuffles (64-byte tiles spilled: row pass 2.4x slower)
_SHEAR_VECS = 4            # vectors of adjacent steps per work-item of the shallow shears (recurse_lines.cl)
_BAND = 64                 # most vectors (cache lines) of adjacent columns per CPU work-item
_DRAM_BAND = 16            # ... when the pass runs from memory and stores whole lines (recurse_launch)
_STREAM_BYTES = 1 << 23    # arrays from this size are written with non-temporal stores (CPU columns)
_MIN_BLOCK = 1024          # shortest block of a block-parallel line on a CPU (steps)
_MIN_GPU_BLOCK = 64        # ... and on a GPU
_GPU_ITEMS_PER_UNIT = 1024  # work-items per compute unit a GPU pass should have in flight

_queue_backends = {}       # command queue -> OpenCLBackend (arrays found on that queue)


#: the process that first touched the OpenCL runtime (None: not yet)
_runtime_pid = None

FORK_MESSAGE = ("OpenCL was initialised in the parent process before this process was forked, and OpenCL "
                "runtimes (PoCL included) hang when used after a fork: start worker processes with the "
                "'spawn' or 'forkserver' method (multiprocessing.set_start_method), or use backend='warp' "
                "or 'numpy' in forked workers")


def _writable_dir(path):
    try:
        os.makedirs(path, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path):
            return True
    except OSError:
        return False


def _prepare_caches():
    """Kernel caches the runtime can write, before it starts (PoCL reads the variables then).

    An explicit ``POCL_CACHE_DIR`` must be a writable directory (else a clear error); an
    unwritable default cache root (``XDG_CACHE_HOME`` or ``~/.cache``, e.g. a read-only HOME)
    is replaced by a temporary directory for this process, with a warning naming the variables.
    """
    pocl = os.environ.get("POCL_CACHE_DIR")
    if pocl and not _writable_dir(pocl):
        raise BackendUnavailable(f"POCL_CACHE_DIR={pocl!r} is not a writable directory: point it to one "
                                 f"(or unset it)")
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    if not _writable_dir(root):
        tmp = tempfile.mkdtemp(prefix="gfgpu-cache-")
        atexit.register(shutil.rmtree, tmp, ignore_errors=True)     # for this process only
        os.environ["XDG_CACHE_HOME"] = tmp
        warnings.warn(f"gfgpu: the cache directory {root!r} cannot be written; compiled OpenCL kernels are "
                      f"cached in {tmp!r} for this process only (set XDG_CACHE_HOME or POCL_CACHE_DIR to a "
                      f"writable directory to keep them)", RuntimeWarning, stacklevel=3)


def _import_cl():
    """PyOpenCL, once this process may use the OpenCL runtime; BackendUnavailable otherwise."""
    global _runtime_pid
    if _runtime_pid is not None and _runtime_pid != os.getpid():
        raise BackendUnavailable(FORK_MESSAGE)
    if _runtime_pid is None:
        _prepare_caches()
    try:
        import pyopencl as cl
        import pyopencl.array  # registers cl.array
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise BackendUnavailable(f"pyopencl not installed ({exc})") from exc
    _runtime_pid = os.getpid()
    return cl


def _forget_in_child():
    # objects of the parent's runtime must never be reused in a forked child
    launch.forget_programs()
    _queue_backends.clear()


os.register_at_fork(after_in_child=_forget_in_child)


def _kind(device):
    import pyopencl as cl
    if device.type & cl.device_type.GPU:
        return "gpu"
    if device.type & cl.device_type.CPU:
        return "cpu"
    return "accelerator"


def opencl_devices():
    """Every OpenCL device of every platform, in one flat list.

    Returns
    -------
    list of (int, pyopencl.Device, str)
        ``(index, device, kind)`` with ``kind`` one of ``"gpu"``, ``"cpu"``,
        ``"accelerator"``; ``index`` is what :class:`OpenCLBackend` accepts.  Empty when
        PyOpenCL or an OpenCL platform is missing.
    """
    try:
        cl = _import_cl()
    except BackendUnavailable:
        return []
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # no platform: nothing to list (unavailable_reason says why)
        return []
    devs = []
    for platform in platforms:
        try:
            devs.extend(platform.get_devices())
        except cl.Error:  # a platform without devices raises DEVICE_NOT_FOUND
            pass
    return [(i, d, _kind(d)) for i, d in enumerate(devs)]


_PROBE = "__kernel void gfgpu_probe(__global float *a) { a[get_global_id(0)] = 1.0f; }"
_build_failures = {}       # device pointer -> None (it compiles) or the reason it cannot


def build_failure(device):
    """Why ``device`` cannot compile OpenCL C, or None if it can (probed once per process).

    A device can be listed and fail every build (PyOpenCL's bundled PoCL 3.0 on AMD Zen 5:
    "unknown target CPU 'generic'"), or build this probe and abort the process on 16-wide
    vectors (:mod:`~gfgpu.backends.opencl.probe`, for CPU devices).  Such a device is never
    chosen by default, and choosing it names the reason.

    Parameters
    ----------
    device : pyopencl.Device

    Returns
    -------
    str or None
    """
    cl = _import_cl()
    key = device.int_ptr
    if key not in _build_failures:
        detail = None
        try:
            cl.Program(cl.Context([device]), _PROBE).build()
        except cl.Error as exc:
            log = [line.strip() for line in str(exc).splitlines() if "error" in line.lower()]
            detail = next((line for line in log if line.startswith("error:")), log[-1] if log else str(exc))
        if detail is None and _kind(device) == "cpu":
            # (a compiler that builds the probe may still abort the process on 16-wide vectors)
            wide = wide_vector_failure(device)
            detail = None if wide is None else f"16-wide vectors: {wide}"
        _build_failures[key] = None if detail is None else (
            f"OpenCL device {device.name.strip()!r} ({device.platform.version.split('  ')[0].strip()}) "
            f"cannot compile kernels ({detail}): its compiler does not support this machine; install a "
            f"newer OpenCL runtime for it (for a CPU, your distribution's PoCL, e.g. Debian/Ubuntu "
            f"'apt-get install pocl-opencl-icd'), or use backend='warp' or 'numpy'")
    return _build_failures[key]


def unavailable_reason():
    """Why the OpenCL backend cannot be used here, or None if it can.

    Returns
    -------
    str or None
        For example ``"pyopencl not installed"`` or ``"no OpenCL platform found: install
        pocl-binary-distribution"``.
    """
    try:
        cl = _import_cl()
    except BackendUnavailable as exc:
        return str(exc)
    try:
        platforms = cl.get_platforms()
    except cl.Error:  # PLATFORM_NOT_FOUND_KHR from the ICD loader
        platforms = []
    if not platforms:
        return ("no OpenCL platform found: install pocl-binary-distribution (CPU) or a GPU driver's ICD"
                + memory_hint())
    devs = opencl_devices()
    if not devs:
        return "no OpenCL device found on platforms " + ", ".join(p.name.strip() for p in platforms)
    failures = [build_failure(d) for _, d, _ in devs]
    if all(failures):
        return "; ".join(dict.fromkeys(failures))     # no device compiles: each reason once
    return None


def backend_for_queue(queue):
    """The (cached) :class:`OpenCLBackend` that runs on ``queue``, for arrays found there.

    Parameters
    ----------
    queue : pyopencl.CommandQueue

    Returns
    -------
    OpenCLBackend
    """
    be = _queue_backends.get(queue)
    if be is None:
        be = _queue_backends[queue] = OpenCLBackend(queue)
    return be


#: host arrays at least this large are shared with CPU devices instead of copied
_ZERO_COPY_BYTES = 1 << 16
_IN_FLIGHT_MAX = 32           # wrapped host arrays kept alive before the queue is drained


def _aligned_copy(host, align):
    out = _aligned_empty(host.shape, host.dtype, align)
    np.copyto(out, host)
    return out


def _aligned_empty(shape, dtype, align):
    """``np.empty`` whose data starts on an ``align``-byte boundary."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    raw = np.empty(nbytes + align, np.uint8)
    start = -raw.ctypes.data % align
    return raw[start:start + nbytes].view(dtype).reshape(shape)


def _interior(index):
    """``(lo, hi, shift)`` with ``index[j] == j - shift`` for ``lo <= j < hi``, the longest
    such run of a translation's line index (``(0, 0, 0)`` if there is none)."""
    j = np.arange(index.size)
    diff = j - index
    valid = index >= 0
    if not valid.any():
        return 0, 0, 0
    shift = int(np.median(diff[valid]))
    same = np.flatnonzero(valid & (diff == shift))
    if same.size == 0:
        return 0, 0, 0
    # the longest run of consecutive positions with index == j - shift
    breaks = np.flatnonzero(np.diff(same) != 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks + 1, [same.size]])
    longest = int(np.argmax(ends - starts))
    return int(same[starts[longest]]), int(same[ends[longest] - 1]) + 1, shift


def shear_launch(geometry, itemsize, kind):
    """``(lanes, variant)`` of the shears of a sheared layout (recurse_lines.cl, ``shear_in`` and
    ``shear_out``): adjacent steps per work-item and the kernels' ``SHEAR_TILE``.

    A CPU work-item runs one cache line of adjacent steps (``64 / itemsize`` lanes) where every
    access can be a whole vector: steep directions in the layout ``(steps, lines)`` (the lanes are
    rows of both arrays: tiles transposed in registers, variant 1) and shallow ones in ``(lines,
    steps)`` (a row of either array holds the lanes, ``_SHEAR_VECS`` vectors per work-item: variant
    2), the layouts
    :func:`gfgpu._core.oblique.run_oblique_lines` takes by default.  Other layouts, and GPU
    launches (adjacent work-items on adjacent steps), run one step per work-item (variant 0).
    """
    g = geometry
    lanes = _CACHE_LINE // itemsize
    if kind == "cpu":
        if g.transposed and g.stride == 1 and g.lines % lanes == 0:
            return lanes, 1
        if not g.transposed and g.tstride == 1:
            return lanes, 2
    return 1, 0


class RecurseShape(NamedTuple):
    """The launch of one :meth:`OpenCLBackend.recurse` pass (:meth:`OpenCLBackend.recurse_shape`)."""

    lanes: int       # lines per vector (a work-item's SIMD width; 1 on a GPU)
    vectors: int     # vectors of adjacent columns per work-item (columns on a CPU; else 1)
    block: int       # steps per block of a line (n: whole lines)
    blocks: int      # blocks per line (1: whole lines, no carries)
    gsize: tuple     # global size of the pass kernel
    lsize: tuple     # local size
    rows_as_blocks: bool = False   # few long rows on a CPU: each line's blocks are rows of a view, in lanes


def _row_blocks(lines, m, lanes, units):
    """Blocks per line for rows of blocks (:func:`recurse_launch`), else 0: two work-items of full
    lanes per core, blocks of whole tiles (at least ``_MIN_BLOCK`` steps) dividing the line."""
    least = -(-2 * lanes * units // lines)
    for nb in range(least, 4 * least + 1):
        if m % nb == 0 and (m // nb) % lanes == 0 and m // nb >= _MIN_BLOCK:
            return nb
    return 0


def recurse_launch(shape, axis, itemsize, units, kind, group, length=None, constant=True, cache=0):
    """The launch of one recursion pass over a ``(B, N, M)`` array along ``axis`` (1 or 2).

    Parameters
    ----------
    shape : tuple of int
        ``(B, N, M)``.
    axis : int
        1: lines along N (columns), 2: lines along M (rows).
    itemsize : int
        Bytes per sample (4 or 8).
    units : int
        The device's compute units (cores of a CPU, multiprocessors of a GPU).
    kind : str
        "cpu" or "gpu" (the backend's ``kind``).
    group : int
        Work-items per work-group.
    length : int, optional
        Steps per line when they differ from the line's samples (a windowed pass): such lines
        are never cut into blocks.
    constant : bool, optional
        The pass has constant coefficients (rows of blocks need them).
    cache : int, optional
        Bytes of the device's memory cache (``global_mem_cache_size``; 0: none known).

    Returns
    -------
    RecurseShape
        A CPU work-item runs ``LANES = 64 / itemsize`` columns in vector lanes (one cache line per
        step; rows ``32 / itemsize``, one 256-bit register: ``_ROW_VECTOR``), columns in bands of
        up to ``_BAND`` vectors (every core still gets two work-items; ``_DRAM_BAND`` when the
        input and output together exceed ``cache`` and either rows are whole cache lines or the
        pass streams its stores); a GPU work-item runs one line.  Lines too few for the device
        (fewer work-items than cores on a CPU, than ``_GPU_ITEMS_PER_UNIT`` per multiprocessor
        on a GPU) are cut into blocks of at least ``_MIN_BLOCK`` (GPU: ``_MIN_GPU_BLOCK``) steps
        whose states are carried exactly (:func:`gfgpu._core.recursion.run_reference_blocks`).
        CPU rows too few to fill a work-item's lanes per core put each line's blocks in the lanes
        (``rows_as_blocks``: rows of the ``(lines * blocks, block)`` view; ``block`` divides the
        line; constant plans).
    """
    b, n, m = (int(x) for x in shape)
    cpu = kind == "cpu"
    lanes = (_ROW_VECTOR if axis == 2 else _CACHE_LINE) // itemsize if cpu else 1
    if cpu and axis == 2 and length is None and constant and b * n < lanes * units:
        nb = _row_blocks(b * n, m, lanes, units)
        if nb:
            items = -(-(b * n * nb) // lanes)
            return RecurseShape(lanes, 1, m // nb, nb, (items, 1), (1, 1), True)
    if axis == 1:   # columns: B*M lines, LANES x nv adjacent ones per work-item
        vecs = -(-m // lanes)
        # PoCL, 2 cores, A/B of the kernel: from memory, bands of 16 vectors ran 6-30 % faster
        # than 64 (8, 32: less); within the cache 7-29 % slower.  Rows not of whole cache lines
        # share a line at each band's edges: with plain stores narrower bands (more edges) ran
        # 14-22 % slower, with the streamed row interiors (arrays of _STREAM_BYTES; recurse.cl,
        # store_row_nt) 16 vectors ran 14-25 % faster than 47 at 3000^2 float32
        dram = 2 * b * n * m * itemsize > cache and (m % lanes == 0 or b * n * m * itemsize >= _STREAM_BYTES)
        widest = _DRAM_BAND if dram else _BAND
        nv = max(1, min(widest, (b * vecs) // (2 * units))) if cpu else 1
        items, outer = -(-vecs // nv), b
    else:           # rows: B*N lines, LANES per work-item
        nv, items, outer = 1, -(-(b * n) // lanes), 1
    windowed = length is not None
    length = (n if axis == 1 else m) if length is None else int(length)
    want = units if cpu else units * _GPU_ITEMS_PER_UNIT
    have = items * outer
    shortest = _MIN_BLOCK if cpu else _MIN_GPU_BLOCK
    nblocks = 1
    if have < want and length >= 2 * shortest and not windowed:
        nblocks = min(-(-want // have), length // shortest)
    block = length
    if nblocks > 1:
        per_block = -(-length // nblocks)
        block = -(-per_block // lanes) * lanes      # whole tiles of LANES steps
        nblocks = -(-length // block)
    group = min(group, items)    # fewer lines than a group: no idle work-items
    if axis == 1:
        gsize, lsize = (-(-items // group) * group, b, nblocks), (group, 1, 1)
    else:
        gsize, lsize = (-(-items // group) * group, nblocks), (group, 1)
    return RecurseShape(lanes, nv, block, nblocks, gsize, lsize)


class OpenCLBackend(Backend):
    """Run the recursion primitive with OpenCL kernels on ``pyopencl.array.Array`` data.

    Parameters
    ----------
    device : int, str, pyopencl.Device, pyopencl.Context or pyopencl.CommandQueue, optional
        An index into :func:`opencl_devices`, a substring of a device name
        (case-insensitive), a device, or a context/queue whose arrays should be processed
        in place.  Default: the first GPU, else the first device.

    Raises
    ------
    BackendUnavailable
        If PyOpenCL or an OpenCL platform is missing, or ``device`` matches no device.

    Notes
    -----
    One source, ``gfgpu/backends/opencl/recurse.cl``, specialised by defines.  On a CPU a work-item
    runs lines in the lanes of a vector: columns ``64 / itemsize`` (16 float32, 8 float64), so
    each step loads one cache line of adjacent samples; rows ``32 / itemsize`` (8 float32,
    4 float64, one 256-bit register), loading a square tile and transposing it in registers.
    Work-groups are one work-item so that PoCL spreads lines over all cores.  On a GPU a
    work-item runs one line, work-groups hold 64.  float64 needs a device with fp64
    (``supports_float64``); otherwise a ``TypeError``.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.backends.opencl import OpenCLBackend
    >>> be = OpenCLBackend()
    >>> a = be.asarray(np.ones((1, 4, 5), np.float32))
    >>> be.to_host(a).shape
    (1, 4, 5)
    """

    name = "opencl"

    def __init__(self, device=None):
        cl = _import_cl()
        self._cl = cl
        self._array = cl.array
        if isinstance(device, cl.CommandQueue):
            self.queue = device
            self.context = device.context
            self._device = device.device
        else:
            if isinstance(device, cl.Context):
                self.context = device
                self._device = device.devices[0]
            else:
                self._device = self._find_device(device)
                self.context = cl.Context([self._device])
            self.queue = cl.CommandQueue(self.context, self._device)
        broken = build_failure(self._device)
        if broken:       # a context or queue of the caller's (or an array's) on a device that cannot compile
            raise BackendUnavailable(broken)
        dev = self._device
        self.device = f"{dev.name.strip()} ({dev.platform.name.strip()})"
        self.kind = _kind(dev)
        self._host_align = max(64, dev.mem_base_addr_align // 8)
        try:
            fp64 = bool(dev.double_fp_config)
        except cl.Error:  # devices without fp64 may reject the query
            fp64 = False
        self.supports_float64 = fp64 or "cl_khr_fp64" in dev.extensions
        # temporaries from pools (a fresh page costs a fault at first touch, more than a pass): a
        # CPU device's arrays and numpy results on reused host memory (gfgpu._core.hostpool), a GPU's
        import pyopencl.tools as cl_tools
        self._pool = cl_tools.MemoryPool(cl_tools.ImmediateAllocator(self.queue))
        # queued kernels may still write a block whose array Python dropped: frees wait on the queue
        self._host_pool = new_pool(fence=self.queue.finish)
        self._plans = OrderedDict()    # (id(plan), dtype) -> (plan, buffers)
        self._indices = OrderedDict()  # id(index) -> (index, device int32 array, max index, size)
        # host arrays wrapped for the device, kept until the queue drains, per thread (its Thread
        # object: an ident can be reused): another thread may not have enqueued their kernels yet
        self._in_flight = {}
        self._in_flight_lock = threading.Lock()
        self._spare = None             # placeholder buffer (_dummy)

    def _find_device(self, device):
        devs = opencl_devices()
        if not devs:
            raise BackendUnavailable(unavailable_reason() or "no OpenCL device found")
        listing = "; ".join(f"{i}: {d.name.strip()} ({k})" for i, d, k in devs)
        if device is None:
            chosen = [d for _, d, k in devs if k == "gpu"] + [d for _, d, k in devs if k != "gpu"]
        elif isinstance(device, self._cl.Device):
            chosen = [device]
        elif isinstance(device, (bool, np.bool_)):
            raise TypeError(f"device must be an index, a name, a pyopencl Device, Context or CommandQueue; "
                            f"got {device!r}")
        elif isinstance(device, (int, np.integer)):
            if not 0 <= device < len(devs):
                raise BackendUnavailable(f"OpenCL device index {device} out of range (devices: {listing})")
            chosen = [devs[device][1]]
        elif isinstance(device, str):
            if device.strip().isdigit():
                return self._find_device(int(device))
            want = device.strip().lower()
            chosen = [d for _, d, k in devs if want in d.name.lower() or want == k]
            if not chosen:
                raise BackendUnavailable(f"no OpenCL device matches {device!r} (devices: {listing})")
        else:
            raise TypeError(f"device must be an index, a name, a pyopencl Device, Context or "
                            f"CommandQueue; got {type(device).__name__}")
        # the first of the candidates that compiles (a name or kind may match a broken runtime's
        # device beside a working one's); if none does, the reason
        for d in chosen:
            if build_failure(d) is None:
                return d
        raise BackendUnavailable(build_failure(chosen[0]))

    # ---- arrays -------------------------------------------------------------------
    def _check_dtype(self, dtype):
        return launch.check_dtype(self, dtype)

    @property
    def cl_device(self):
        """The ``pyopencl.Device`` this backend runs on."""
        return self._device

    def owns(self, array):
        return isinstance(array, self._array.Array) and array.context == self.context

    def asarray(self, host):
        host = np.ascontiguousarray(host)
        self._check_dtype(host.dtype)
        if host.nbytes == 0:
            return self._array.to_device(self.queue, host)
        # copied as the buffer is made: to_device's blocking write waits for the whole queue
        mf = self._cl.mem_flags
        buf = self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=host)
        return self._array.Array(self.queue, host.shape, host.dtype, data=buf)

    def to_host(self, array):
        host = getattr(array, "gfgpu_host", None)
        if host is not None:
            # a host_result array: its memory is the numpy array; mapping it (no copy on a CPU
            # device) is what makes the kernels' writes visible to the host, per the spec
            mapped, _ = self._cl.enqueue_map_buffer(self.queue, array.base_data, self._cl.map_flags.READ,
                                                    array.offset, host.shape, host.dtype, is_blocking=True)
            mapped.base.release(self.queue)
            self._drained()   # the queue is in order: every command this thread enqueued is done
            return host
        out = array.get(queue=self.queue)
        self._drained()
        return out

    def _drained(self, ended=()):
        """Drop the wrapped host arrays of this thread (after a blocking command of its own) and of
        the threads ``ended``."""
        with self._in_flight_lock:
            for thread in (threading.current_thread(), *ended):
                self._in_flight.pop(thread, None)

    def _wrap_host(self, host, flags):
        # PoCL uses host memory in place only from an address aligned to the device's base-address
        # alignment (128 bytes; numpy gives 16): otherwise it copies the array at every use and map.
        # The buffer therefore starts at the aligned address below the data (same page: readable,
        # never written) and the array begins at an element offset within it.
        addr = host.ctypes.data
        delta = addr % self._host_align
        if delta % host.dtype.itemsize:
            host = _aligned_copy(host, self._host_align)   # misaligned elements: a copy, as numpy would make
            addr, delta = host.ctypes.data, 0
        memory = (ctypes.c_char * (host.nbytes + delta)).from_address(addr - delta) if delta else host
        buf = self._cl.Buffer(self.context, flags | self._cl.mem_flags.USE_HOST_PTR, hostbuf=memory)
        buf.gfgpu_memory = host     # ... as long as any view of the array (they share the buffer)
        arr = self._array.Array(self.queue, host.shape, host.dtype, data=buf, offset=delta)
        arr.gfgpu_host = host       # keeps the memory alive as long as the device array
        # ... and until queued kernels have read it, even if the caller drops the array first
        me = threading.current_thread()
        if len(self._in_flight.get(me, ())) >= _IN_FLIGHT_MAX:
            self.synchronize()
        with self._in_flight_lock:
            self._in_flight.setdefault(me, []).append(host)
        return arr

    def host_view(self, host):
        # a CPU device reads the numpy array in place: the upload would cost more than a pass
        host = np.ascontiguousarray(host)
        self._check_dtype(host.dtype)
        if self.kind != "cpu" or host.nbytes < _ZERO_COPY_BYTES:
            return self.asarray(host)
        return self._wrap_host(host, self._cl.mem_flags.READ_ONLY)

    def host_result(self, shape, dtype, into=None):
        dtype = self._check_dtype(dtype)
        if self.kind != "cpu" or int(np.prod(shape)) * dtype.itemsize < _ZERO_COPY_BYTES:
            return self.empty(shape, dtype)
        # new results start on a page of the host pool (reused memory: no page faults once a
        # shape of the class has been seen); a caller's output is wrapped from the aligned
        # address below it
        host = self._host_pool.take(shape, dtype) if into is None else into
        return self._wrap_host(host, self._cl.mem_flags.READ_WRITE)

    writes_views = False      # enqueue_copy moves bytes: strides of a view are not honoured

    def copy(self, src, dst):
        if not dst.flags.c_contiguous:
            raise ValueError("dst must be C-contiguous (a view cannot be written by a byte copy)")
        if src.nbytes:
            wait = [e for a in (src, dst) for e in a.events]
            evt = self._cl.enqueue_copy(self.queue, dst.base_data, src.base_data, byte_count=src.nbytes,
                                        src_offset=src.offset, dst_offset=dst.offset, wait_for=wait or None)
            dst.add_event(evt)
        return dst

    def is_contiguous(self, array):
        return bool(array.flags.c_contiguous)

    def contiguous(self, array):
        dtype = self._check_dtype(array.dtype)
        if array.flags.c_contiguous or array.size == 0:
            return array
        if dtype not in launch.REALS:
            raise TypeError(f"input must be float32 or float64, got {dtype}")
        item = dtype.itemsize
        if any(st % item for st in array.strides) or array.offset % item:
            raise ValueError("input is a view whose strides are not whole elements; pass a contiguous array")
        # a device-side copy through the gather kernel: element offsets of the view in its buffer
        index = np.zeros((), np.int64)
        for n, st in zip(array.shape, array.strides):
            index = index[..., None] + (np.arange(n, dtype=np.int64) * (st // item))
        index = np.ascontiguousarray(index.reshape(-1))
        available = array.base_data.size // item - array.offset // item
        dev_index, _ = self._index_array(index, available)
        out = self.empty(array.shape, dtype)
        knl = self._kernel("gather", dtype)
        group = 64 if self.kind == "cpu" else launch.group_size(self)
        gsize = (-(-out.size // group) * group,)
        args = (array.base_data, np.int64(array.offset // item), dev_index.data, out.base_data,
                np.int64(out.offset // item), dtype.type(0), np.int64(out.size))
        launch.launch(self, knl, gsize, (group,), [dev_index], [out], args)
        return out

    def may_share_memory(self, a, b):
        if a.base_data is None or b.base_data is None or a.base_data != b.base_data:
            return False
        return a.offset < b.offset + b.nbytes and b.offset < a.offset + a.nbytes

    def empty(self, shape, dtype):
        shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
        dtype = self._check_dtype(dtype)
        if self.kind == "cpu" and int(np.prod(shape, dtype=np.int64)) * dtype.itemsize >= _ZERO_COPY_BYTES:
            # pooled host memory, used in place; no _in_flight entry: its next user is a command of
            # this in-order queue or a result read after a blocking map, after every earlier command
            host = self._host_pool.take(shape, dtype)
            buf = self._cl.Buffer(self.context, self._cl.mem_flags.READ_WRITE | self._cl.mem_flags.USE_HOST_PTR,
                                  hostbuf=host)
            # the memory lives as long as the buffer object, which every view of the array shares
            buf.gfgpu_memory = host
            return self._array.Array(self.queue, shape, dtype, data=buf)
        return self._array.empty(self.queue, shape, dtype, allocator=self._pool)

    def reshape(self, array, shape):
        return array.reshape(tuple(shape))

    def all_finite(self, array):
        dtype = np.dtype(array.dtype)
        if dtype not in launch.REALS or array.size == 0:
            return True   # integer arrays hold no NaN or infinity
        if not array.flags.c_contiguous:
            return host_in_range(array.get(queue=self.queue))
        size = array.size
        if self.kind == "cpu":
            # a few contiguous chunks per core
            items = min(size, 8 * self._device.max_compute_units)
            chunk = -(-size // items)
            first, stride, count, group = chunk, 1, chunk, 1
        else:
            # grid-stride loop: adjacent work-items read adjacent elements
            group = launch.group_size(self)
            items = min(-(-size // group), 256 * self._device.max_compute_units) * group
            first, stride, count = 1, items, -(-size // items)
        mf = self._cl.mem_flags
        flag = np.zeros(1, np.int32)
        flag_buf = self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=flag)
        knl = self._kernel("any_nonfinite", dtype)
        args = (array.base_data, np.int64(array.offset // dtype.itemsize), np.int64(size),
                np.int64(first), np.int64(stride), np.int64(count), flag_buf)
        gsize = -(-items // group) * group
        evt = launch.launch(self, knl, (gsize,), (group,), [array], [], args)
        self._cl.enqueue_copy(self.queue, flag, flag_buf, wait_for=[evt])   # blocking
        return int(flag[0]) == 0

    def synchronize(self):
        with self._in_flight_lock:   # threads ended before the finish have enqueued all they will
            ended = [thread for thread in self._in_flight if not thread.is_alive()]
        self.queue.finish()
        self._drained(ended)

    @property
    def spec(self):
        # the device's index in opencl_devices(): the same machine layout is assumed elsewhere
        for index, dev, _ in opencl_devices():
            if dev == self._device:
                return ("opencl", index)
        return ("opencl", self._device.name.strip())

    @property
    def memory_budget(self):
        # one buffer may not exceed max_mem_alloc_size either; strips keep buffers below both
        if self.kind == "cpu":
            return None
        return int(min(self._device.global_mem_size // 2, 4 * self._device.max_mem_alloc_size))

    # ---- kernels --------------------------------------------------------------------
    def _kernel(self, name, dtype, **defines):
        return launch.kernel(self, __package__, "recurse.cl", name, dtype, **defines)

    def recurse_lines(self, src, dst, axis, plans, cval=0.0):
        check_line_plans(src, dst, axis, plans)
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or not a.flags.c_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous pyopencl.array.Array in the context of "
                                f"{self.device}")
        dtype = self._check_dtype(src.dtype)
        if src.size == 0:
            return dst
        lam, kap, tap, reverse, omega, omega_c = self._plan_buffers(plans, dtype)   # uploaded once
        b, rows, cols = src.shape
        n, lines = (cols, rows) if axis == 2 else (rows, cols)
        line_stride, step = (cols, 1) if axis == 2 else (1, cols)
        item = dtype.itemsize
        args = (src.base_data, dst.base_data, np.int64(src.offset // item), np.int64(dst.offset // item),
                lam, kap, tap, reverse, omega, omega_c, np.int32(plans.omega.shape[1]), np.int32(n),
                np.int32(lines), np.int64(line_stride), np.int64(step), np.int64(rows * cols), dtype.type(cval))
        if self.kind == "cpu":
            # a line's recursion is one chain of dependent multiply-adds: 2 x 32 bytes of adjacent
            # lines per work-item, in two vectors of lanes (recurse_lines_lanes; a vector of lines
            # of both directions runs line by line)
            lanes, vecs = 32 // item, 2
            knl = launch.kernel(self, __package__, "recurse_lines.cl", "recurse_lines_lanes", dtype,
                                LANES=lanes, VECS=vecs, ROWS=int(axis == 2))
            launch.launch(self, knl, (-(-lines // (lanes * vecs)), b), (1, 1), [src], [dst], args)
            return dst
        knl = launch.kernel(self, __package__, "recurse_lines.cl", "recurse_lines", dtype)
        group = launch.group_size(self)
        gsize = (-(-lines // group) * group, b)
        launch.launch(self, knl, gsize, (group, 1), [src], [dst], args)
        return dst

    def shear_lines(self, src, dst, plan, forward, cval=0.0):
        """The gather and column allpass of an oblique pass as one kernel (recurse_lines.cl:
        shear_in when ``forward``, image -> sheared layout; shear_out, layout -> image), for the
        :class:`gfgpu._core.oblique.ShearPlan` ``plan``; ``src``, ``dst`` C-contiguous device
        arrays holding B image planes and B layouts (any shape)."""
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or not a.flags.c_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous pyopencl.array.Array in the context of "
                                f"{self.device}")
        dtype = self._check_dtype(src.dtype)
        if src.size == 0 or dst.size == 0:
            return dst
        g = plan.geometry
        qs, ts = (1, g.lines) if g.transposed else (g.steps, 1)
        image_plane, layout_plane = int(np.prod(plan.plane)), g.lines * g.steps
        image, layout = (src, dst) if forward else (dst, src)
        batch = image.size // image_plane
        if image.size != batch * image_plane or layout.size != batch * layout_plane:
            raise ValueError(f"shear_lines: arrays of {image.size} and {layout.size} samples do not hold whole "
                             f"planes of {plan.plane} and layouts of {g.lines * g.steps}")
        lanes, variant = shear_launch(g, dtype.itemsize, self.kind)
        coef, base, shift, start = self._plan_buffers(plan.grouped(lanes), dtype)   # uploaded once
        item = dtype.itemsize
        vecs = _SHEAR_VECS if variant == 2 else 1
        defines = dict(SHEAR_LANES=lanes, SHEAR_TILE=variant, SHEAR_VECS=vecs, SHEAR_INT="int" if item == 4 else "long")
        head = (src.base_data, np.int64(src.offset // item), dst.base_data, np.int64(dst.offset // item), coef)
        strides = (np.int64(qs), np.int64(ts), np.int64(g.stride), np.int64(g.tstride))
        if forward:
            knl = launch.kernel(self, __package__, "recurse_lines.cl", "shear_in", dtype, **defines)
            args = head + (base, shift, np.int32(g.lines), np.int32(g.steps)) + strides + (
                np.int64(image_plane), np.int64(layout_plane), dtype.type(cval))
        else:
            knl = launch.kernel(self, __package__, "recurse_lines.cl", "shear_out", dtype, **defines)
            args = head + (start, np.int32(g.lines), np.int32(g.steps), np.int32(g.across)) + strides + (
                np.int64(layout_plane), np.int64(image_plane))
        group = 1 if self.kind == "cpu" else launch.group_size(self)
        items = -(-g.steps // (lanes * vecs))
        launch.launch(self, knl, (-(-items // group) * group, batch), (group, 1), [src], [dst], args)
        return dst

    def _plan_buffers(self, plan, dtype):
        """Upload ``plan.packed(dtype)`` once (a PassPlan or LinePlans); plans are immutable, so
        id(plan) is a key."""
        key = (id(plan), dtype)
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plan:
            self._plans.move_to_end(key)
            return hit[1]
        mf = self._cl.mem_flags
        buffers = []
        for a in plan.packed(dtype):
            if a.size == 0:
                a = np.zeros(2, a.dtype)   # L = 0 (constant mode): OpenCL has no empty buffers
            buffers.append(self._cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a))
        self._plans[key] = (plan, tuple(buffers))   # keeping the plan keeps its id unique
        if len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return self._plans[key][1]

    # ---- the primitive --------------------------------------------------------------
    def recurse_shape(self, shape, axis, dtype, length=None, constant=True):
        """How :meth:`recurse` runs lines of a ``(B, N, M)`` array along ``axis``
        (:func:`recurse_launch` for this device)."""
        dev = self._device
        return recurse_launch(shape, axis, np.dtype(dtype).itemsize, int(dev.max_compute_units),
                              self.kind, launch.group_size(self), length, constant, int(dev.global_mem_cache_size))

    #: :meth:`recurse` takes ``window=``: an integer translation fused into the pass
    recurses_windows = True

    def _block_powers(self, plan, dtype, block, nblocks):
        """(S, nblocks, 2) products of each block's lam (float64, then the real type), cached."""
        key = (id(plan), dtype, "pow", block)
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plan:
            self._plans.move_to_end(key)
            return hit[1]
        packed = packed_block_powers(plan, block, dtype)
        mf = self._cl.mem_flags
        buf = self._cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=packed)
        self._plans[key] = (plan, buf)
        if len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return buf

    def recurse(self, src, dst, axis, plan, cval=0.0, accumulate=False, check=False, window=None):
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a):
                raise TypeError(f"{arg} must be a pyopencl.array.Array in the context of {self.device}, "
                                f"got {type(a).__name__}")
            if a.ndim != 3 or not a.flags.c_contiguous:
                raise ValueError(f"{arg} must be a C-contiguous 3-D array, got shape {a.shape}")
        if src.shape != dst.shape or src.dtype != dst.dtype:
            raise ValueError(f"src and dst must match: {src.shape} {src.dtype} vs {dst.shape} {dst.dtype}")
        dtype = np.dtype(src.dtype)
        if dtype not in launch.REALS:
            raise TypeError(f"src must be float32 or float64, got {dtype}")
        self._check_dtype(dtype)
        same = src.base_data == dst.base_data and src.offset == dst.offset
        if window is not None:
            index, first = window
            if plan.n != len(index):
                raise ValueError(f"plan is for lines of {plan.n} samples, the window has {len(index)}")
            if self.may_share_memory(src, dst):
                raise ValueError("dst may not overlap src in a windowed pass")
        elif plan.n != src.shape[axis]:
            raise ValueError(f"plan is for lines of {plan.n} samples, axis {axis} has {src.shape[axis]}")
        if accumulate and same:
            raise ValueError("dst may not be src when accumulating")
        b, n, m = src.shape
        if src.size == 0:
            return True if check else dst
        shape = self.recurse_shape(src.shape, axis, dtype, None if window is None else plan.n, plan.constant)
        if shape.rows_as_blocks:
            return self._recurse_row_blocks(src, dst, plan, dtype, cval, accumulate, check, shape)
        if window is None:
            win_buf, first = self._dummy(), 0
        else:
            win_dev, _ = self._index_array(index, src.shape[axis])
            win_buf, first = win_dev.data, int(first)
        cpu = self.kind == "cpu"
        config = dict(SECTIONS=plan.sections, CONSTANT_COEF=int(plan.constant), LANES=shape.lanes,
                      ROWS=int(axis == 2), BAND=_BAND if cpu and axis == 1 else 1, STREAM=int(cpu),
                      WINDOW=int(window is not None))
        lam, kap, omega, omega_c = self._plan_buffers(plan, dtype)
        real = dtype.type
        item = dtype.itemsize
        mf = self._cl.mem_flags
        flag = np.zeros(1, np.int32)
        flag_buf = (self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=flag)
                    if check else self._dummy())
        # non-temporal stores (columns) only for arrays well beyond the caches: a small result is
        # read again by the next pass, from the cache
        stream = int(cpu and src.nbytes >= _STREAM_BYTES)
        head = (src.base_data, dst.base_data, np.int64(src.offset // item), np.int64(dst.offset // item),
                lam, kap, omega, omega_c, np.int32(plan.omega.shape[1]), np.int32(plan.n),
                real(cval), real(plan.tap), np.int32(plan.reverse), np.int32(bool(accumulate)),
                np.int32(b), np.int32(n), np.int32(m), np.int32(shape.vectors), np.int32(stream), flag_buf,
                np.int32(shape.block), np.int32(shape.blocks))
        if shape.blocks == 1:
            knl = self._kernel("recurse", dtype, PHASE=0, CHECK=int(bool(check)), **config)
            evt = launch.launch(self, knl, shape.gsize, shape.lsize, [src], [dst],
                                head + (self._dummy(), self._dummy(), win_buf, np.int32(first)))
        else:
            outer, count = (b, m) if axis == 1 else (1, b * n)
            size = outer * shape.blocks * plan.sections * 2 * count
            carry = self.empty((size,), dtype)
            partial = self.empty((size,), dtype)
            tail = (carry.base_data, partial.base_data, win_buf, np.int32(first))
            knl = self._kernel("recurse", dtype, PHASE=1, CHECK=int(bool(check)), **config)
            launch.launch(self, knl, shape.gsize, shape.lsize, [src], [carry, partial], head + tail)
            compose = self._kernel("compose", dtype, SECTIONS=plan.sections, LANES=1)
            group = launch.group_size(self) if not cpu else 64
            launch.launch(self, compose, (-(-count // group) * group, outer), (group, 1), [partial], [carry],
                          (carry.base_data, partial.base_data, omega_c,
                           self._block_powers(plan, dtype, shape.block, shape.blocks), real(cval),
                           np.int32(shape.blocks), np.int64(count), np.int32(outer)))
            knl = self._kernel("recurse", dtype, PHASE=2, **config)
            evt = launch.launch(self, knl, shape.gsize, shape.lsize, [src, carry], [dst], head + tail)
        if not check:
            return dst
        self._cl.enqueue_copy(self.queue, flag, flag_buf, wait_for=[evt])   # blocking
        return int(flag[0]) == 0

    def _row_view_plan(self, plan, block):
        """``plan`` for a block run as a row of ``block`` steps (no initial state), cached."""
        key = (id(plan), "rows", block)
        hit = self._plans.get(key)
        if hit is not None and hit[0] is plan:
            self._plans.move_to_end(key)
            return hit[1]
        sections = plan.sections
        view = PassPlan(plan.lam[:, :block], plan.kap[:, :block], np.zeros((sections, 0), np.complex128),
                        np.zeros(sections, np.complex128), plan.tap, plan.reverse, True)
        self._plans[key] = (plan, view)
        if len(self._plans) > _PLAN_CACHE_SIZE:
            self._plans.popitem(last=False)
        return view

    def _recurse_row_blocks(self, src, dst, plan, dtype, cval, accumulate, check, shape):
        """Few long rows with their blocks in the lanes (``rows_as_blocks``): the blocks, rows of a
        ``(lines * blocks, block)`` view, run from zero (PHASE 1, with the check); the block kernel
        gives the omega terms of the lines' first blocks; ``compose_rows`` makes the start states;
        PHASE 2 writes (:func:`gfgpu._core.recursion.run_reference_blocks`)."""
        b, n, m = src.shape
        lines, nb, blen = b * n, shape.blocks, shape.block
        rows = lines * nb
        sections, item, real = plan.sections, dtype.itemsize, dtype.type
        view = self._row_view_plan(plan, blen)
        lam, kap, omega, omega_c = self._plan_buffers(view, dtype)
        mf = self._cl.mem_flags
        flag = np.zeros(1, np.int32)
        flag_buf = (self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=flag)
                    if check else self._dummy())
        carry = self.empty((sections * 2 * rows,), dtype)
        scratch = self.empty((sections * 2 * rows,), dtype)
        config = dict(SECTIONS=sections, CONSTANT_COEF=1, LANES=shape.lanes, ROWS=1, BAND=1, STREAM=1, WINDOW=0)
        head = (src.base_data, dst.base_data, np.int64(src.offset // item), np.int64(dst.offset // item),
                lam, kap, omega, omega_c, np.int32(0), np.int32(blen), real(cval), real(plan.tap),
                np.int32(plan.reverse), np.int32(bool(accumulate)), np.int32(1), np.int32(rows), np.int32(blen),
                np.int32(1), np.int32(0), flag_buf, np.int32(blen), np.int32(1))
        tail = (carry.base_data, scratch.base_data, self._dummy(), np.int32(0))
        knl = self._kernel("recurse", dtype, PHASE=1, CHECK=int(bool(check)), **config)
        launch.launch(self, knl, shape.gsize, shape.lsize, [src], [carry, scratch], head + tail)
        # the initial state: the omega terms of the samples of each line's first blocks (traversal)
        L = plan.omega.shape[1]
        lblocks = -(-L // blen)
        partial = self.empty((max(1, nb * sections * 2 * lines),), dtype)
        if lblocks:   # (TERMS_ONLY: the omega terms alone, no recursion over the blocks)
            lam0, kap0, omega0, omega_c0 = self._plan_buffers(plan, dtype)
            first = (src.base_data, dst.base_data, np.int64(src.offset // item), np.int64(dst.offset // item),
                     lam0, kap0, omega0, omega_c0, np.int32(L), np.int32(plan.n), real(cval), real(plan.tap),
                     np.int32(plan.reverse), np.int32(0), np.int32(b), np.int32(n), np.int32(m), np.int32(1),
                     np.int32(0), self._dummy(), np.int32(blen), np.int32(nb),
                     self._dummy(), partial.base_data, self._dummy(), np.int32(0))
            knl = self._kernel("recurse", dtype, PHASE=1, CHECK=0, TERMS_ONLY=1, **config)
            launch.launch(self, knl, (-(-lines // shape.lanes), lblocks), (1, 1), [src], [partial], first)
        compose = self._kernel("compose_rows", dtype, SECTIONS=sections, LANES=1)
        launch.launch(self, compose, (-(-lines // 64) * 64,), (64,), [partial], [carry],
                      (carry.base_data, partial.base_data, self._plan_buffers(plan, dtype)[3],
                       self._block_powers(plan, dtype, blen, nb), real(cval), np.int32(nb), np.int32(lblocks),
                       np.int32(nb), np.int64(lines), np.int32(plan.reverse)))
        knl = self._kernel("recurse", dtype, PHASE=2, CHECK=0, **config)
        evt = launch.launch(self, knl, shape.gsize, shape.lsize, [src, carry], [dst], head + tail)
        if not check:
            return dst
        self._cl.enqueue_copy(self.queue, flag, flag_buf, wait_for=[evt])   # blocking
        return int(flag[0]) == 0

    def fuses_pair(self, axis, first, second):
        """True when :meth:`recurse_pair` runs these two plans in one kernel: rows on a CPU
        (the rows a work-item writes stay in its cache for the second sweep), both with constant
        coefficients and as many sections."""
        return (self.kind == "cpu" and axis == 2 and first.constant and second.constant
                and first.sections == second.sections and first.n == second.n)

    def recurse_pair(self, src, dst, axis, first, second, cval=0.0, check=False):
        """``recurse(src, dst, axis, first)`` then ``recurse(src, dst, axis, second,
        accumulate=True)`` in one kernel (:meth:`fuses_pair` must hold); with ``check`` returns
        whether ``src`` is finite, as :meth:`recurse` does."""
        if not self.fuses_pair(axis, first, second):
            raise ValueError("recurse_pair takes rows on a CPU device and two constant plans of as many sections")
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or a.ndim != 3 or not a.flags.c_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous 3-D pyopencl.array.Array in the context of "
                                f"{self.device}")
        if src.shape != dst.shape or src.dtype != dst.dtype:
            raise ValueError(f"src and dst must match: {src.shape} {src.dtype} vs {dst.shape} {dst.dtype}")
        if self.may_share_memory(src, dst):
            raise ValueError("dst may not overlap src")
        if first.n != src.shape[2]:
            raise ValueError(f"plans are for lines of {first.n} samples, axis 2 has {src.shape[2]}")
        dtype = self._check_dtype(src.dtype)
        b, n, m = src.shape
        if src.size == 0:
            return True if check else dst
        shape = self.recurse_shape(src.shape, axis, dtype)
        knl = self._kernel("recurse_pair", dtype, SECTIONS=first.sections, CONSTANT_COEF=1, LANES=shape.lanes,
                           ROWS=1, CHECK=int(bool(check)))
        real, item = dtype.type, dtype.itemsize
        a = self._plan_buffers(first, dtype)
        z = self._plan_buffers(second, dtype)
        mf = self._cl.mem_flags
        flag = np.zeros(1, np.int32)
        flag_buf = (self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=flag)
                    if check else self._dummy())
        args = (src.base_data, dst.base_data, np.int64(src.offset // item), np.int64(dst.offset // item),
                *a, np.int32(first.omega.shape[1]), real(first.tap), np.int32(first.reverse),
                *z, np.int32(second.omega.shape[1]), real(second.tap), np.int32(second.reverse),
                np.int32(m), real(cval), np.int32(b), np.int32(n), np.int32(m), flag_buf)
        gsize = (shape.gsize[0],)
        evt = launch.launch(self, knl, gsize, (shape.lsize[0],), [src], [dst], args)
        if not check:
            return dst
        self._cl.enqueue_copy(self.queue, flag, flag_buf, wait_for=[evt])   # blocking
        return int(flag[0]) == 0

    def _dummy(self):
        """A small buffer for kernel arguments a variant does not use."""
        if self._spare is None:
            self._spare = self._cl.Buffer(self.context, self._cl.mem_flags.READ_WRITE, 64)
        return self._spare

    def translate(self, src, dst, axis, index, cval=0.0, check=False):
        for arg, a in (("src", src), ("dst", dst)):
            if not self.owns(a) or a.ndim != 3 or not a.flags.c_contiguous:
                raise TypeError(f"{arg} must be a C-contiguous 3-D pyopencl.array.Array in the context of "
                                f"{self.device}")
        if axis not in (1, 2):
            raise ValueError(f"axis must be 1 or 2, got {axis}")
        if src.shape != dst.shape or src.dtype != dst.dtype:
            raise ValueError(f"src and dst must match: {src.shape} {src.dtype} vs {dst.shape} {dst.dtype}")
        if self.may_share_memory(src, dst):
            raise ValueError("dst may not overlap src")
        dtype = self._check_dtype(src.dtype)
        if dtype not in launch.REALS:
            raise TypeError(f"src must be float32 or float64, got {dtype}")
        b, n, m = src.shape
        length = src.shape[axis]
        idx = np.asarray(index).reshape(-1)
        if idx.size != length:
            raise ValueError(f"index has {idx.size} elements, axis {axis} has {length}")
        if src.size == 0:
            return True if check else None
        dev_index, _ = self._index_array(index, length)
        lo, hi, shift = _interior(idx) if axis == 2 else (0, 0, 0)
        seg = 2048 if self.kind == "cpu" else 1   # CPU: a vectorised loop per segment; GPU: coalesced items
        group = launch.group_size(self)
        items = -(-m // seg)
        knl = self._kernel("translate", dtype, CHECK=int(bool(check)))
        flag = np.zeros(1, np.int32)
        mf = self._cl.mem_flags
        flag_buf = self._cl.Buffer(self.context, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=flag)
        args = (src.base_data, np.int64(src.offset // dtype.itemsize), dev_index.data, dst.base_data,
                np.int64(dst.offset // dtype.itemsize), dtype.type(cval), np.int32(n), np.int32(m),
                np.int32(axis == 2), np.int32(seg), np.int32(lo), np.int32(hi), np.int32(shift), flag_buf)
        evt = launch.launch(self, knl, (-(-items // group) * group, b * n), (group, 1), [src, dev_index], [dst], args)
        if not check:
            return None
        self._cl.enqueue_copy(self.queue, flag, flag_buf, wait_for=[evt])   # blocking
        return int(flag[0]) == 0

    def input_finite(self, host, data):
        # the kernel reads the data once on every core, numpy's max and min twice on one (4096^2
        # float32: 2.8 vs 9.3 ms); a small array on the host, without a launch
        return host_in_range(host) if host.nbytes < _ZERO_COPY_BYTES else self.all_finite(data)

    def _index_array(self, index, size):
        """Upload a gather index once per identity, as int32 (the kernel's index type).

        Returns the device array (None when empty) and its element count.
        """
        key = id(index)
        hit = self._indices.get(key)
        if hit is not None and hit[0] is index:
            self._indices.move_to_end(key)
        else:
            idx = np.asarray(index).reshape(-1)
            if idx.dtype.kind not in "iu":
                raise TypeError(f"index must be an integer array, got {idx.dtype}")
            top = int(idx.max()) if idx.size else -1
            if top >= 2**31:
                raise ValueError(f"index holds {top}: the OpenCL gather takes int32 indices "
                                 f"(sources of at most 2**31 elements)")
            # every negative index means cval: clamping keeps int64 values in int32 range
            idx = np.ascontiguousarray(np.maximum(idx, -1) if idx.dtype.kind == "i" else idx, np.int32)
            # copied as the buffer is made: a blocking write waited for every queued command (a
            # call's first pass), a queued one cost ~1.5 ms of host time
            dev = None
            if idx.size:
                mf = self._cl.mem_flags
                buf = self._cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=idx)
                dev = self._array.Array(self.queue, idx.shape, idx.dtype, data=buf)
            hit = self._indices[key] = (index, dev, top, idx.size)   # keeping index keeps its id unique
            if len(self._indices) > _INDEX_CACHE_SIZE:
                self._indices.popitem(last=False)
        _, dev, top, count = hit
        if top >= size:
            raise ValueError(f"index holds {top}, beyond the source's {size} elements")
        return dev, count

    def gather(self, src, index, cval, out):
        for arg, a in (("src", src), ("out", out)):
            if not self.owns(a):
                raise TypeError(f"{arg} must be a pyopencl.array.Array in the context of {self.device}, "
                                f"got {type(a).__name__}")
            if not a.flags.c_contiguous:
                raise ValueError(f"{arg} must be C-contiguous")
        if src.dtype != out.dtype:
            raise ValueError(f"src and out must have one dtype, got {src.dtype} and {out.dtype}")
        dtype = self._check_dtype(src.dtype)
        if dtype not in launch.REALS:
            raise TypeError(f"src must be float32 or float64, got {dtype}")
        dev_index, count = self._index_array(index, src.size)
        if count != out.size:
            raise ValueError(f"index has {count} elements, out has {out.size}")
        if out.size == 0:
            return out
        knl = self._kernel("gather", dtype)
        item = dtype.itemsize
        # on a CPU, PoCL vectorises the loop over a group's work-items: 64 per group, not 1
        group = 64 if self.kind == "cpu" else launch.group_size(self)
        gsize = (-(-out.size // group) * group,)
        args = (src.base_data, np.int64(src.offset // item), dev_index.data, out.base_data,
                np.int64(out.offset // item), dtype.type(cval), np.int64(out.size))
        launch.launch(self, knl, gsize, (group,), [src, dev_index], [out], args)
        return out
