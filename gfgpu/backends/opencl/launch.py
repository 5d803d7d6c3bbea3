"""The OpenCL launch toolkit: what a feature's device code needs to build and launch its kernels.

The recursion primitive (:mod:`gfgpu.backends.opencl.backend`) and every feature's ``_opencl.py``
(``gfgpu/stereo``, ``gfgpu/motion``, ``gfgpu/edges``) build and launch through these functions, so
no feature touches a private name of the backend.  A kernel source is named by the package that
holds it (``anchor``, usually the caller's ``__package__``) and its file name there, so each
``.cl`` file lives beside the Python code that launches it.

Programs are built on first use, specialised by ``-D`` defines, and cached per (context, source,
defines); PyOpenCL caches the binaries on disk by source and options (``PYOPENCL_CACHE_DIR``) and
PoCL keeps its own cache (``POCL_CACHE_DIR``), so only the first process on a machine compiles.
"""

from __future__ import annotations

import re
import threading
from functools import cache

import numpy as np

from ..._core import boundary, bspline, waiting

__all__ = ["REALS", "GPU_GROUP", "kernel", "launch", "PresetLaunch", "group_size", "check_dtype", "plain",
           "written", "copy_bytes", "forget_programs"]

#: the real dtypes every kernel is built for
REALS = (np.dtype(np.float32), np.dtype(np.float64))

#: work-group size on non-CPU devices (a multiple of a warp / wavefront)
GPU_GROUP = 64

_programs = {}             # (context, anchor, source, defines) -> built pyopencl.Program
_kernels = {}              # (context, anchor, source, defines, name) -> pyopencl.Kernel (one per kernel)
# a pyopencl.Kernel call sets the shared kernel object's arguments, then enqueues it: two threads
# launching one kernel at once could enqueue each other's arguments (seen under a tiny
# sys.setswitchinterval: wrong pixels in shift and disparity) -- every launch holds this lock
_LAUNCH_LOCK = threading.RLock()
BUILD_NOTICE_S = 3.0       # a build longer than this says why the caller waits
_KERNEL_LOCK = threading.RLock()   # one kernel object per key, also when threads build at once


def forget_programs():
    """Drop every built program and kernel (a forked child must not reuse its parent's)."""
    _programs.clear()
    _kernels.clear()


_INCLUDE = re.compile(r'^#include "([\w./]+)".*$', re.MULTILINE)


@cache
def _source(anchor, name):
    """The text of ``name`` in package ``anchor``, each ``#include "file.cl"`` line replaced by that
    file's text, found in ``anchor`` or the nearest package above it that has it (a path such as
    ``"backends/opencl/tile.cl"`` names a file below a package above).  Expanded here,
    not by the OpenCL compiler, so that the program text (PoCL's cache key) holds every line it
    builds: an edited included file can never be served from a stale cache."""
    from importlib.resources import files
    package = anchor
    while not files(package).joinpath(name).is_file():
        if "." not in package:
            raise FileNotFoundError(f"OpenCL source {name!r} is in neither {anchor} nor a package above it")
        package = package.rpartition(".")[0]
    text = files(package).joinpath(name).read_text()
    return _INCLUDE.sub(lambda m: _source(package, m.group(1)), text)


def _program(context, anchor, source, defines):
    key = (context, anchor, source, defines)
    prog = _programs.get(key)
    if prog is None:
        import pyopencl as cl
        # no fast-math: accuracy relies on IEEE arithmetic.  -w: PoCL warns on every 512-bit
        # vector argument (an x86 ABI note), which PyOpenCL would surface as CompilerWarning.
        options = [f"-D{k}={v}" for k, v in defines] + ["-w"]
        with waiting.notice_after(BUILD_NOTICE_S, lambda: f"gfgpu: building OpenCL kernels ({source}) for "
                                  f"{context.devices[0].name.strip()}: the first run on this machine compiles "
                                  f"them (a minute or more); later runs read them from PoCL's cache", "build"):
            prog = cl.Program(context, _source(anchor, source)).build(options=options)
        _programs[key] = prog
    return prog


def kernel(be, anchor, source, name, dtype, **defines):
    """The kernel ``name`` of ``source`` (a ``.cl`` file in package ``anchor``), built for ``be``.

    Parameters
    ----------
    be : OpenCLBackend
    anchor : str
        The package that holds the source file, e.g. ``"gfgpu.stereo"`` (``__package__``).
    source : str
        The file name, e.g. ``"stereo.cl"``.
    name : str
        The kernel function.
    dtype : numpy.dtype
        The real type: defines ``REAL`` as ``float`` or ``double``.
    **defines
        Further ``-D`` defines (small configuration only: never sizes or counts, which are
        arguments, so a new shape builds nothing).

    Returns
    -------
    pyopencl.Kernel
        One object per (context, source, defines, name), also when threads ask at once.
    """
    real = "double" if np.dtype(dtype) == np.float64 else "float"
    defines = tuple(sorted(dict(REAL=real, **defines).items()))
    key = (be.context, anchor, source, defines, name)
    knl = _kernels.get(key)
    if knl is None:
        with _KERNEL_LOCK:
            knl = _kernels.get(key)
            if knl is None:
                # each attribute access would create a new kernel object: keep one
                knl = _kernels[key] = getattr(_program(be.context, anchor, source, defines), name)
    return knl


def launch(be, knl, gsize, lsize, arrays_in, arrays_out, args):
    """Enqueue ``knl`` on ``be``'s queue after the events of its arrays; the outputs get its event.

    Parameters
    ----------
    be : OpenCLBackend
    knl : pyopencl.Kernel
    gsize, lsize : tuple of int
        Global and local size (``lsize`` None: the driver's choice).
    arrays_in, arrays_out : list of pyopencl.array.Array
        The arrays it reads and writes (their pending events are waited for).
    args : sequence
        The kernel's arguments.

    Returns
    -------
    pyopencl.Event
    """
    wait = [e for a in arrays_in + arrays_out for e in a.events]
    with _LAUNCH_LOCK:
        evt = knl(be.queue, gsize, lsize, *args, wait_for=wait or None)
    for a in arrays_out:
        a.add_event(evt)
    return evt


class PresetLaunch:
    """Repeated launches of one kernel with its arguments set once: a private kernel object (the
    cached one may be launched by other threads), whose changing arguments alone are set before
    each launch.  PyOpenCL's call of a kernel sets all of them again (a stereo band sweep of 23
    arguments: ~110 us of the host's CPU per launch against ~30).  Ordered as :func:`launch`:
    after the pending events of its arrays; the outputs get its event.

    Parameters
    ----------
    be : OpenCLBackend
    knl : pyopencl.Kernel
        A kernel of :func:`kernel` (its program and name are taken, not the object).
    arrays_in, arrays_out : list of pyopencl.array.Array
        The arrays every launch reads and writes.
    args : sequence
        The kernel's arguments, set once.
    """

    def __init__(self, be, knl, arrays_in, arrays_out, args):
        import pyopencl as cl
        self._cl, self.be = cl, be
        self.knl = cl.Kernel(knl.program, knl.function_name)
        self.function_name = knl.function_name
        self.knl.set_args(*args)
        self.arrays_in, self.arrays_out = list(arrays_in), list(arrays_out)

    def __call__(self, gsize, lsize, changes):
        """Launch with the arguments ``changes`` ({index: value}) set first; returns the event."""
        for i, v in changes.items():
            self.knl.set_arg(i, v)
        wait = [e for a in self.arrays_in + self.arrays_out for e in a.events]
        evt = self._cl.enqueue_nd_range_kernel(self.be.queue, self.knl, gsize, lsize, wait_for=wait or None)
        for a in self.arrays_out:
            a.add_event(evt)
        return evt


def group_size(be):
    """Work-items per group for one-dimensional line kernels: 1 on a CPU (one work-item per core
    runs many lines), :data:`GPU_GROUP` (or the device's maximum) elsewhere."""
    return 1 if be.kind == "cpu" else min(GPU_GROUP, be.cl_device.max_work_group_size)


def check_dtype(be, dtype):
    """``dtype`` as a numpy dtype, refused (TypeError) if it is float64 and ``be`` has no fp64."""
    dtype = np.dtype(dtype)
    if dtype == np.float64 and not be.supports_float64:
        raise TypeError(f"float64 is not supported by OpenCL device {be.device} (no cl_khr_fp64); "
                        f"convert the input to float32 or choose another device")
    return dtype


def plain(be, a, name, dtype=None, output=False):
    """``a`` as ``be``'s C-contiguous array without an offset (kernels that take plain pointers);
    an input that is an offset or strided view is copied, an ``output`` is refused.

    Raises
    ------
    TypeError
        If ``a`` is not a ``pyopencl.array.Array`` of ``be``'s context, or not of ``dtype``.
    ValueError
        If ``output`` and ``a`` is not C-contiguous without offset.
    """
    if not be.owns(a):
        raise TypeError(f"{name} must be a pyopencl.array.Array in the context of {be.device}, "
                        f"got {type(a).__name__}")
    if dtype is not None and np.dtype(a.dtype) != np.dtype(dtype):
        raise TypeError(f"{name} must be {np.dtype(dtype)}, got {a.dtype}")
    if a.offset == 0 and a.flags.c_contiguous:
        return a
    if output:
        raise ValueError(f"{name} must be a C-contiguous array without offset")
    return a.copy()


def starting(be, a, name):
    """``a`` as an array that starts its own buffer: a C-contiguous offset view becomes a sub-buffer of
    the same memory where the device's base-address alignment allows (no copy: :func:`plain` would copy
    a 16 MB view per call), else :func:`plain`'s copy (pooled buffers have no sub-buffers)."""
    if (a.offset and a.flags.c_contiguous and hasattr(a.base_data, "get_sub_region")
            and a.offset % max(1, be.cl_device.mem_base_addr_align // 8) == 0):
        import pyopencl.array as cl_array
        sub = a.base_data.get_sub_region(a.offset, a.nbytes)
        sub.gfgpu_memory = a.base_data      # the parent buffer (and its host memory) lives as long
        return cl_array.Array(be.queue, a.shape, a.dtype, data=sub)
    return plain(be, a, name)


def written(be, a, name):
    """``(buffer, offset in elements)`` of an output array: C-contiguous, any whole-element offset
    (a caller's ``output=`` may be wrapped from an aligned address below it).

    Raises
    ------
    ValueError
        If ``a`` is not a C-contiguous array of ``be`` starting on a whole element.
    """
    if not be.owns(a) or not a.flags.c_contiguous:
        raise ValueError(f"{name} must be a C-contiguous array of this backend")
    item = np.dtype(a.dtype).itemsize
    if a.offset % item:
        raise ValueError(f"{name} must start on a whole element")
    return a.base_data, np.int64(a.offset // item)


def copy_bytes(be, dst, src, nbytes, dst_offset=0, src_offset=0):
    """Copy ``nbytes`` from ``src`` (at byte ``src_offset``) to ``dst`` (at ``dst_offset``) on the
    device, in order with the arrays' pending events; ``dst`` gets the copy's event."""
    import pyopencl as cl
    evt = cl.enqueue_copy(be.queue, dst.data, src.data, byte_count=int(nbytes), dst_offset=int(dst_offset),
                          src_offset=int(src_offset), wait_for=(src.events + dst.events) or None)
    dst.add_event(evt)
    return evt


def spline_defines():
    """The ``-D`` defines of a source that extends lines by a boundary mode and samples cubic
    B-splines (e.g. ``gfgpu/motion/spline.cl``): the mode codes ``MODE_*``
    (:data:`gfgpu._core.boundary.MODE_CODES`), ``SPLINE_POLE`` and the 'nearest' edge weights
    ``NEAR_A``, ``NEAR_B`` (:mod:`gfgpu._core.bspline`).  Read from the Python definitions at each
    build, so the kernels cannot drift from them (the same values every call: one build)."""
    near_a, near_b = bspline.NEAREST_EDGE
    return dict(**{f"MODE_{name.upper()}": code for name, code in boundary.MODE_CODES.items()},
                SPLINE_POLE=repr(float(bspline.SPLINE_POLE)), NEAR_A=repr(float(near_a)), NEAR_B=repr(float(near_b)))
