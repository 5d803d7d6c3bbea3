"""The contract every backend implements.

A backend owns a kind of array (numpy, ``warp.array``, ``pyopencl.array.Array``) on one
device and runs the single recursion primitive of :mod:`gfgpu._core.recursion` on it, plus a
gather used to lay oblique lines out as rows.  Everything else is host composition
(:mod:`gfgpu.filters`), except the fused kernels that applications register
(:mod:`gfgpu.backends.fused`).  Backends pickle by name and device (see
:mod:`gfgpu.backends`).
"""

from __future__ import annotations

import numpy as np


def check_line_plans(src, dst, axis, plans):
    """Shape checks shared by every backend's :meth:`Backend.recurse_lines`."""
    if axis not in (1, 2):
        raise ValueError(f"axis must be 1 or 2, got {axis}")
    if len(src.shape) != 3 or tuple(src.shape) != tuple(dst.shape):
        raise ValueError(f"src and dst must be 3-D arrays of one shape, got {src.shape} and {dst.shape}")
    if plans.n != src.shape[axis] or plans.lines != src.shape[3 - axis]:
        raise ValueError(f"plans are for {plans.lines} lines of {plans.n} samples; the array has "
                         f"{src.shape[3 - axis]} lines of {src.shape[axis]} along axis {axis}")


def memory_hint():
    """A hint for start-up failures when the process runs under an address-space limit (device
    runtimes reserve much virtual memory when they start); "" without a limit."""
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, ValueError, OSError):
        return ""
    if soft == resource.RLIM_INFINITY:
        return ""
    return (f" (the process's address-space limit, {soft / 2**30:.1f} GiB, may be too small: the device "
            f"runtime reserves virtual memory when it starts; memory may have run out)")


class BackendUnavailable(RuntimeError):
    """The requested backend or device cannot be used here (the message says why)."""


class Backend:
    #: registry name: "numpy", "warp" or "opencl"
    name = "base"

    #: human-readable device description, e.g. "cpu", "cuda:0 (NVIDIA H100)", "pthread-AMD EPYC"
    device = ""

    #: whether float64 arrays can be processed
    supports_float64 = True

    #: whether :meth:`recurse` takes ``window=(index, first)``: an integer translation fused into
    #: the pass (the line is read through ``index``, output sample ``x`` is window position
    #: ``first + x``); backends without it get the translation as gathers around the pass
    recurses_windows = False

    #: the launch shapes the backend uses: "cpu" (few work-items, vector lanes, bands of columns)
    #: or "gpu" (one line per work-item, block-parallel lines); a test may set "gpu" on a CPU
    #: device so that the branches a GPU takes run there
    kind = "cpu"

    #: whether :meth:`copy` writes into non-contiguous views of device arrays
    writes_views = True

    # ---- arrays -------------------------------------------------------------------
    def owns(self, array) -> bool:
        """True if ``array`` is this backend's array type on this backend's device."""
        raise NotImplementedError

    def asarray(self, host: np.ndarray):
        """Copy a C-contiguous numpy array to the device (same dtype, same shape)."""
        raise NotImplementedError

    def to_host(self, array) -> np.ndarray:
        """Copy a device array back to a numpy array."""
        raise NotImplementedError

    def empty(self, shape, dtype):
        """Uninitialised C-contiguous device array."""
        raise NotImplementedError

    def host_view(self, host: np.ndarray):
        """A device array that reads ``host`` (C-contiguous) and is never written.

        Devices that share the host's memory may wrap it without a copy; the default copies.
        """
        return self.asarray(host)

    def host_result(self, shape, dtype, into=None):
        """A device array for a final result that :meth:`to_host` can return without a copy.

        ``into``, when given, is a writeable C-contiguous numpy array of ``shape`` and ``dtype``
        (the caller's ``output``): devices that share the host's memory write the result into
        it, and :meth:`to_host` then returns ``into`` itself.  The default ignores ``into``
        and returns an ordinary :meth:`empty` array.
        """
        return self.empty(shape, dtype)

    def copy(self, src, dst):
        """Copy device array ``src`` into ``dst`` (same shape and dtype, C-contiguous)."""
        raise NotImplementedError

    def is_contiguous(self, array) -> bool:
        """True if the device array is C-contiguous."""
        raise NotImplementedError

    def contiguous(self, array):
        """``array`` itself if C-contiguous, else a C-contiguous copy made on the device (views:
        slices, steps, transposes)."""
        raise NotImplementedError

    def may_share_memory(self, a, b) -> bool:
        """True if device arrays ``a`` and ``b`` may overlap in memory (bounds check)."""
        raise NotImplementedError

    def dtype_of(self, array) -> np.dtype:
        """numpy dtype of a device array."""
        return np.dtype(array.dtype)

    def reshape(self, array, shape):
        """View of a C-contiguous device array with a new shape (no copy)."""
        raise NotImplementedError

    def all_finite(self, array) -> bool:
        """True if no element is NaN or infinite, nor at or beyond the range limit of its
        dtype (:func:`gfgpu._core.magnitude.range_limit`: the input check; a False verdict
        is settled on the host, :meth:`gfgpu._core.job.Job.settle`)."""
        raise NotImplementedError

    def synchronize(self):
        """Block until queued work has finished (used by benchmarks)."""

    @property
    def memory_budget(self):
        """Default working set in bytes (:mod:`gfgpu._core.strips`): None where device memory is
        host memory (CPU devices), half the device's memory on a GPU."""
        return None

    # ---- the primitive --------------------------------------------------------------
    def recurse(self, src, dst, axis, plan, cval=0.0, accumulate=False, check=False):
        """Run one pass of :func:`gfgpu._core.recursion.run_reference` on every line.

        ``src`` and ``dst`` are C-contiguous device arrays of shape ``(B, N, M)`` and the
        same dtype; ``axis`` is 1 (lines along N: ``B*M`` lines, lanes contiguous) or 2 (lines
        along M: ``B*N`` contiguous lines).  ``plan`` is a :class:`gfgpu._core.recursion.PassPlan`
        with ``plan.n`` equal to the line length.  ``dst`` may be ``src`` unless
        ``accumulate`` is true.  Returns ``dst``; with ``check=True`` the pass also tests, in the
        same read of ``src``, that every element of ``src`` is finite and within the range limit
        (:meth:`all_finite`) and returns that bool (``dst`` is written either way).

        Lines too few to fill the device may be cut into blocks whose states are carried
        exactly (:func:`gfgpu._core.recursion.run_reference_blocks` is the specification):
        the result equals :func:`~gfgpu._core.recursion.run_reference` within float rounding.
        """
        raise NotImplementedError

    def recurse_lines(self, src, dst, axis, plans, cval=0.0):
        """Per-line variant of :meth:`recurse`: line ``i`` (index along the other image
        axis) runs its own pass of ``plans`` (:class:`gfgpu._core.recursion.LinePlans`, spec
        :func:`gfgpu._core.recursion.run_reference_lines`); the batch axis 0 shares the plans.
        ``dst`` may be ``src``."""
        raise NotImplementedError

    def gather(self, src, index, cval, out):
        """``out.flat[i] = src.flat[index[i]]`` or ``cval`` where ``index[i] < 0``.

        ``index`` is a host int32/int64 numpy array of ``out.size`` elements (backends may
        cache its upload by identity).
        """
        raise NotImplementedError

    def translate(self, src, dst, axis, index, cval=0.0, check=False):
        """Integer translation of lines: one index per position, shared by every line.

        ``src`` and ``dst`` are distinct C-contiguous ``(B, N, M)`` device arrays of one dtype;
        along ``axis`` (1 or 2), ``dst`` at position ``k`` is ``src`` at ``index[k]``, or
        ``cval`` where ``index[k] < 0`` (``index``: a host integer array of ``N`` or ``M``
        elements, e.g. :func:`gfgpu._core.translation.window_index`).

        With ``check=True`` the pass also tests, in the same read of ``src``, that every element
        of ``src`` is finite and within the range limit (:meth:`all_finite`), and returns that bool
        (``dst`` is then written either way); without it, returns None.  The default is a
        :meth:`gather` with the full index.
        """
        from .._core.translation import _flat_index
        finite = self.all_finite(src) if check else None
        self.gather(self.reshape(src, (-1,)), _flat_index(tuple(src.shape), axis, index), cval,
                    self.reshape(dst, (-1,)))
        return finite

    def input_finite(self, host, data) -> bool:
        """True if the host input ``host``, placed on the device as ``data`` (its
        :meth:`host_view`), holds no NaN or infinity and lies within the range limit
        (:meth:`all_finite`); devices may test ``data`` in parallel."""
        from .._core.magnitude import host_in_range
        return host_in_range(host)

    # ---- pickling: by name, rebuilt in the receiving process ----------------------------
    @property
    def spec(self):
        """``(name, device)`` such that ``gfgpu.get_backend(*spec)`` builds this backend's
        equivalent in another process (device contexts and queues do not pickle)."""
        return (self.name, None)

    def __repr__(self):
        return f"<gfgpu backend {self.name!r} on {self.device}>"

