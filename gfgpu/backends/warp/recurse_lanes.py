"""The CPU-only variant of the recursion kernel: adjacent columns as the lanes of a vector sample.

On the CPU, Warp threads run one after another, so columns go in groups of adjacent columns: one
thread advances a 64-byte cache line of lines in lockstep (:data:`LANE_TYPES`), with the same
arithmetic as :func:`gfgpu.backends.warp.recurse.run_line`.  A module of its own so that a CUDA
device never compiles these overloads (Warp builds a module's every kernel for a device on its
first launch there).
"""

from typing import Any

import warp as wp

from .recurse import run_line

wp.set_module_options({"enable_backward": False})

#: kernels for the CPU only: the device check builds no CUDA code of this module
CPU_ONLY = True

#: vector sample type of each real type: one 64-byte cache line of adjacent columns
LANE_TYPES = {wp.float32: wp.types.vector(length=16, dtype=wp.float32),
              wp.float64: wp.types.vector(length=8, dtype=wp.float64)}


@wp.kernel
def recurse_lanes(
    src: wp.array3d(dtype=Any),
    dst: wp.array3d(dtype=Any),
    lam: wp.array3d(dtype=Any),
    kap: wp.array3d(dtype=Any),
    omega: wp.array3d(dtype=Any),
    omega_c: wp.array2d(dtype=Any),
    sections: int,
    init_len: int,
    cval: Any,
    tap: Any,
    reverse: int,
    accumulate: int,
    constant: int,
):
    """:func:`~gfgpu.backends.warp.recurse.run_line` on line group ``(b, i)`` of vector samples."""
    b, i = wp.tid()
    run_line(src, dst, lam, kap, omega, omega_c, sections, init_len, cval, tap, reverse, accumulate, constant, b, i)


for _real in (wp.float32, wp.float64):
    wp.overload(recurse_lanes, {"src": wp.array3d(dtype=LANE_TYPES[_real]), "dst": wp.array3d(dtype=LANE_TYPES[_real]),
                                "lam": wp.array3d(dtype=_real), "kap": wp.array3d(dtype=_real),
                                "omega": wp.array3d(dtype=_real), "omega_c": wp.array2d(dtype=_real),
                                "cval": _real, "tap": _real})
del _real
