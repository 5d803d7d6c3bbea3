"""The GPU-shaped semi-global matcher on OpenCL (``sgm_groups.cl``): the ``be.kind != "cpu"``
branch of :func:`gfgpu.stereo._opencl.launch_match`.

Every line of work is a work-group with the disparity samples across its work-items (a lane owns
:func:`group_shape`'s ``CH`` contiguous samples): block costs into a uint8 volume, one launch per
path direction and its opposite with every line of the direction at once, paths adding into one
int16 sum volume, then the two-view selection a row per group.  Memory: ``H W n`` bytes of costs
and ``2 H W n`` of sums (3 bytes per sample).  Bit-identical to
:func:`gfgpu.stereo.spec.semi_global_match_reference`; docs/stereo.md ("A GPU-shaped matcher")
gives the launch sizes and the roofline estimate.
"""

from __future__ import annotations

import numpy as np

from ..backends.opencl import launch as ocl
from . import spec as specs
from .workspace import empty as _empty

#: int16 path value of the samples out of view and of the padding samples in sgm_groups.cl
#: (``PAD_COST``; the specification's int32 ``PATH_UNDEFINED`` does not fit): above every path value
#: in view (the kernel adds the penalties in int, stores path values as int16)
PATH_PAD = 1 << 14

#: largest penalty P1, P2: a path value in view, at most ``COST_MAX + P2``, stays below :data:`PATH_PAD`
PENALTY_MAX = PATH_PAD - 1 - specs.COST_MAX

#: columns of a row that one work-group of the cost kernels takes (group_cost: the window's first
#: sums cost ``block`` columns of popcounts per tile, the rest 2 per column), at most
COST_TILE = 32

#: rows of a band that one work-group of ``group_cost_columns`` walks down (its column sums' first
#: row costs ``block`` popcounts per entry, the others 2)
COST_ROWS = 32

#: local memory of ``group_cost_columns``'s column sums, in bytes (at most half the device's):
#: ``(tile + window - 1) * lanes * CH`` ushorts; where 8 columns do not fit, ``group_cost``
COST_LOCAL_BYTES = 32768

#: the path directions of one launch each (with their opposites), in the order of
#: :data:`gfgpu.stereo.spec.SGM_PATHS`
_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))


def group_shape(n):
    """Work-items per group and samples per work-item for ``n`` disparity samples.

    32 lanes up to 256 samples, 64 up to 512, 128 beyond (a work-group of one to four 32-wide
    warps); each lane then holds ``CH = ceil(n / lanes)`` samples (8 or fewer up to 1024 samples,
    in registers).  The kernels are built for ``(lanes, CH)`` only: every ``n`` up to
    ``lanes * CH`` shares that build.

    Parameters
    ----------
    n : int
        Disparity samples per pixel, at least 1.

    Returns
    -------
    (lanes, ch) : tuple of int
    """
    lanes = 32 if n <= 256 else 64 if n <= 512 else 128
    return lanes, -(-n // lanes)


def _colsum_entries(be):
    # the column sums' ushorts (a build option: a static local array; a few where the budget is 0)
    return max(8, min(COST_LOCAL_BYTES, be.cl_device.local_mem_size // 2) // 2)


def _kernel(be, name, lanes, ch):
    # INT_MIN (NO_MATCH) is no C literal: written as a difference, as limits.h does
    return ocl.kernel(be, __package__, "sgm_groups.cl", name, np.float32, LANES=int(lanes), CH=int(ch),
                      NO_MATCH=f"({specs.NO_MATCH + 1}-1)", OUT_OF_VIEW=int(specs.OUT_OF_VIEW),
                      COST_MAX=int(specs.COST_MAX), PAD_COST=PATH_PAD, COLSUM_ENTRIES=_colsum_entries(be))


def cost_tile(be, lanes, ch, block):
    """Columns per work-group of ``group_cost_columns`` for this group shape and window: as many
    as its column sums' local memory holds, at most :data:`COST_TILE`; 0 where fewer than 8 fit
    (then ``group_cost``, which needs no local memory, runs)."""
    tile = min(COST_TILE, _colsum_entries(be) // (lanes * ch) - (block - 1))
    return tile if tile >= 8 else 0


def launch_match(be, cl_, cr, disp, disp_right, margin, first_step, n, steps, block, p1, p2, paths, uniqueness,
                 workspace=None, shape=None):
    """Cost, aggregation and selection of :func:`gfgpu.stereo.spec.semi_global_match_reference`
    in work-groups (GPUs).

    Parameters
    ----------
    be : OpenCLBackend
    cl_ : (1, H, W) uint64 pyopencl array
        The left view's census codes.
    cr : (steps, H, W) uint64 pyopencl array
        The right view's, one plane per sub-pixel phase.
    disp, disp_right, margin : (H, W) float32, int32, float32 pyopencl arrays
        Written: as ``select_disparity_reference`` returns them.
    first_step, n, steps, block, p1, p2, paths, uniqueness : int
        As for ``semi_global_match_reference`` (``first_step`` a multiple of ``steps``; ``n`` 1..32767,
        p1 and p2 0..:data:`PENALTY_MAX`).
    workspace : dict, optional
        Keeps the cost and sum volumes across calls (:class:`gfgpu.stereo.StereoMatcher`).
    shape : (lanes, ch), optional
        The work-group shape; :func:`group_shape` (n) by default (the tests force small groups).

    Returns
    -------
    disp, disp_right, margin

    Raises
    ------
    ValueError
        ``n``, ``p1``, ``p2`` or ``shape`` out of range (before any work).
    """
    h, w = disp.shape
    if disp.size == 0:
        return disp, disp_right, margin
    if not 1 <= n <= 32767:
        raise ValueError(f"n_disp must be 1..32767 (16-bit sample indices of the selection), got {n}")
    if not (0 <= p1 <= PENALTY_MAX and 0 <= p2 <= PENALTY_MAX):
        raise ValueError(f"p1 and p2 must be 0..{PENALTY_MAX} (int16 path costs), got p1={p1}, p2={p2}")
    lanes, ch = group_shape(n) if shape is None else shape
    if lanes * ch < n:
        raise ValueError(f"shape {shape} holds {lanes * ch} samples per pixel, fewer than n_disp = {n}")
    cost = _empty(be, workspace, "cost", (h, w, n), np.uint8)
    total = _empty(be, workspace, "sum", (h, w, n), np.int16)
    shift = specs.cost_shift(int(block))
    tile = cost_tile(be, lanes, ch, block)
    if tile:         # column sums in local memory: each Hamming distance about twice
        ocl.launch(be, _kernel(be, "group_cost_columns", lanes, ch), (-(-w // tile) * lanes, -(-h // COST_ROWS)),
                   (lanes, 1), [cl_, cr], [cost],
                   (cl_.data, cr.data, cost.data, np.int32(h), np.int32(w), np.int32(n), np.int32(first_step),
                    np.int32(steps), np.int32(block), np.int32(shift), np.int32(tile), np.int32(COST_ROWS)))
    else:            # 2 * block per (pixel, sample)
        ocl.launch(be, _kernel(be, "group_cost", lanes, ch), (-(-w // COST_TILE) * lanes, h), (lanes, 1),
                   [cl_, cr], [cost],
                   (cl_.data, cr.data, cost.data, np.int32(h), np.int32(w), np.int32(n), np.int32(first_step),
                    np.int32(steps), np.int32(block), np.int32(shift), np.int32(COST_TILE)))
    knl = _kernel(be, "group_paths", lanes, ch)
    for i, (dy, dx) in enumerate(_DIRECTIONS[:paths // 2]):
        lines = w if dx == 0 else h if dy == 0 else h + w - 1
        ocl.launch(be, knl, (lines * lanes,), (lanes,), [cost], [total],
                   (cost.data, total.data, np.int32(h), np.int32(w), np.int32(n), np.int32(dy), np.int32(dx),
                    np.int16(p1), np.int16(p2), np.int32(i > 0)))
    ocl.launch(be, _kernel(be, "group_select", lanes, ch), (h * lanes,), (lanes,), [total],
               [disp, disp_right, margin],
               (total.data, disp.data, disp_right.data, margin.data, np.int32(h), np.int32(w), np.int32(n),
                np.int32(first_step // steps), np.int32(steps), np.int32(uniqueness)))
    return disp, disp_right, margin
