"""Device buffers kept across calls: the one helper behind :class:`gfgpu.stereo.StereoMatcher`'s
buffers and the fused matchers' workspaces (``_opencl.py``, ``_opencl_groups.py``, ``_warp.py``,
``matching.py``).

Plain host code with no sibling import, so that every module of the package may import it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["empty"]


def empty(be, workspace, name, shape, dtype):
    """A device buffer of ``shape`` and ``dtype`` on backend ``be``: a new one, or the one of that
    ``name``, shape and dtype that ``workspace`` already holds.

    Parameters
    ----------
    be : Backend
        The backend whose ``empty(shape, dtype)`` allocates (numpy, Warp or OpenCL).
    workspace : dict or None
        Buffers kept by the caller across calls (a :class:`~gfgpu.stereo.StereoMatcher`'s), keyed
        by ``(name, shape, dtype)``; None: always a new buffer.
    name : str
        What the buffer holds (two buffers of one shape and dtype stay apart by their names).
    shape : tuple of int
    dtype : numpy dtype

    Returns
    -------
    array of ``be``
        Uninitialised where new; a kept buffer holds what its last user wrote.

    Examples
    --------
    >>> from gfgpu.backends import resolve_backend
    >>> be, kept = resolve_backend("numpy", None), {}
    >>> a = empty(be, kept, "cost", (2, 3), np.uint8)
    >>> a is empty(be, kept, "cost", (2, 3), np.uint8), a is empty(be, kept, "cost", (3, 2), np.uint8)
    (True, False)
    """
    if workspace is None:
        return be.empty(shape, dtype)
    key = (name, tuple(int(s) for s in shape), np.dtype(dtype).str)
    buf = workspace.get(key)
    if buf is None:
        buf = workspace[key] = be.empty(shape, dtype)
    return buf
