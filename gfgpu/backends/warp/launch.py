"""The Warp launch toolkit: what a feature's Warp kernels need to be launched on a backend.

Every feature's ``_warp.py`` (``gfgpu/stereo``, ``gfgpu/motion``, ``gfgpu/edges``) holds its kernels at
module scope (Warp builds a module's kernels together, on first launch, and caches them on disk in
its kernel cache) and launches them through these functions, so no feature touches a private
name of the backend.  Importing this module imports no Warp.
"""

from __future__ import annotations

import numpy as np

__all__ = ["launch", "contiguous", "real_type"]


def launch(be, kernel, dim, inputs):
    """Launch the Warp ``kernel`` over ``dim`` threads on ``be``'s device.

    Parameters
    ----------
    be : WarpBackend
    kernel : warp.Kernel
    dim : int or tuple of int
        The launch grid (one thread per element).
    inputs : list
        The kernel's arguments, in order.
    """
    import warp as wp
    wp.launch(kernel, dim=dim, inputs=inputs, device=be.wp_device)


def contiguous(be, a, name):
    """``a`` as a contiguous ``warp.array`` of ``be``'s device (a strided view is copied there).

    Raises
    ------
    TypeError
        If ``a`` is not a ``warp.array`` on ``be``'s device.
    """
    if not be.owns(a):
        raise TypeError(f"{name} must be a warp.array on {be.wp_device.alias}, got {type(a).__name__}")
    return a if a.is_contiguous else a.contiguous()


def real_type(be, a):
    """The Warp scalar type of the float array ``a`` (``warp.float32`` or ``warp.float64``)."""
    import warp as wp
    return wp.float64 if be.dtype_of(a) == np.float64 else wp.float32
