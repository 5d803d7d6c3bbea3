"""How the CPU band matcher of ``_opencl.py`` runs an image: rows per band, whether the byte
costs of the whole image are kept, and the bytes it allocates.

Plain host arithmetic (no device library), shared by the launcher and by
:func:`gfgpu.stereo.disparity_memory`, so that the memory estimate and the run take one decision.
"""

from __future__ import annotations

import math
import os

__all__ = ["TILE_BYTES", "MIN_BAND_ROWS", "BAND_BYTES", "WHOLE_BYTES", "padded_samples", "band_rows",
           "match_plan", "match_memory"]

#: the band sweeps' column tiles (4 paths): as many columns as hold this many bytes of vertical
#: path states, so that they stay in a core's L2 cache while the tile's rows are swept
TILE_BYTES = 128 * 2**10


def padded_samples(n):
    """A pixel's samples padded to whole short16 vectors (stereo.cl's NP)."""
    return -(-n // 16) * 16


#: rows of a band of the CPU matcher: at least this many (fewer launches) ...
MIN_BAND_ROWS = 16
#: ... and as many as fit this many bytes of band buffers (small images: one band, no
#: checkpointing sweep at all)
BAND_BYTES = 64 * 2**20


def band_rows(h, paths, w=1, n=1):
    """Rows per band of the CPU matcher for an (h, w) image and n disparity samples: the
    checkpoints (h / k of them, 1 or 4 state rows of ~2 bytes per sample each) and the band
    buffers (~7 bytes per sample of each of k rows) balance at k = sqrt(c h / 3.5), c the
    state rows; at least :data:`MIN_BAND_ROWS`, and as many as :data:`BAND_BYTES` hold."""
    c = 1 if paths == 4 else 4
    fit = BAND_BYTES // (7 * w * n)
    return int(min(h, max(MIN_BAND_ROWS, round(math.sqrt(c * h / 3.5)), fit)))


#: images whose band buffers for every row fit this many bytes (and the working set) run as one
#: band: no checkpointing up sweep and no band launches (teddy 9 % faster than bands of
#: BAND_BYTES; motorcycle, 314 MB of them, 11 %; same maps); larger ones stream bands
WHOLE_BYTES = 512 * 2**20


def match_plan(h, w, n, paths, block=3, budget=None):
    """How the CPU matcher runs an (h, w) image with n disparity samples within ``budget``
    bytes (None: no limit): ``(rows per band, keep the whole image's byte costs, bytes)``.
    One band where :data:`WHOLE_BYTES` and the budget allow, else bands of :func:`band_rows`
    with the costs kept if they fit, else recomputed per band (the least memory)."""
    if 7 * h * w * n <= WHOLE_BYTES:
        nbytes = match_memory(h, w, n, paths, True, block, rows=h)
        if budget is None or nbytes <= budget:
            return h, True, nbytes
    k = band_rows(h, paths, w, n)
    nbytes = match_memory(h, w, n, paths, True, block, rows=k)
    if budget is None or nbytes <= budget:
        return k, True, nbytes
    return k, False, match_memory(h, w, n, paths, False, block, rows=k)


def match_memory(h, w, n, paths, keep_cost, block=3, rows=None):
    """Bytes the CPU matcher allocates: the byte cost volume (``keep_cost``) or a band of it,
    the cost kernel's Hamming ring (``block`` rows and their column sums), the band's sums, the
    path states and their checkpoints, the horizontal paths' states at the column tiles' edges;
    bands of ``rows`` rows (default :func:`band_rows`)."""
    k = band_rows(h, paths, w, n) if rows is None else int(rows)
    cell = padded_samples(n) + 16                          # stereo.cl's CELL
    state_row = 2 * (16 + (w + 2) * cell)
    c = 1 if paths == 4 else 4
    checkpoints = -(-h // k) * c * (state_row + 2 * (w + 2))
    npix = padded_samples(n)                               # a pixel's samples in _padded
    cost = h * w * npix if keep_cost else k * w * npix
    splits = 2 * (os.cpu_count() or 1)                      # _cost_splits on a CPU device
    ring = splits * (block + 2) * (-(-w // splits) + block) * padded_samples(n)
    return cost + ring + 14 * w * n + 4 * k * w * npix + 10 * state_row + checkpoints + 4 * k * cell
