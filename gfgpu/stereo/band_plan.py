"""How the CPU band matcher of ``_opencl.py`` runs an image: rows per band, whether the byte
costs of the whole image are kept, and the bytes it allocates.

Plain host arithmetic (no device library), shared by the launcher and by
:func:`gfgpu.stereo.disparity_memory`, so that the memory estimate and the run take one decision.
"""

from __future__ import annotations

import math
import os
from typing import NamedTuple

__all__ = ["TILE_BYTES", "MIN_BAND_ROWS", "BAND_BYTES", "WHOLE_BYTES", "KEEP_BYTES", "FINE_ROWS", "MIN_FINE_ROWS",
           "BUCKET_VECTORS", "MatchPlan", "padded_samples", "sample_bucket", "band_rows", "coarse_rows", "fine_rows",
           "match_plan", "match_memory"]

#: the band sweeps' column tiles (4 paths): as many columns as hold this many bytes of vertical
#: path states, so that they stay in a core's L2 cache while the tile's rows are swept
TILE_BYTES = 128 * 2**10


def padded_samples(n):
    """A pixel's samples padded to whole short16 vectors (stereo.cl's NP)."""
    return -(-n // 16) * 16


def _bucket_ladder():
    # every count of vectors up to 12, then steps of at most 1/6 (less than 1/9 of the samples
    # swept are padding) through 32 and 64, where stereo.cl's loops stop unrolling: every even
    # count to 32 and every 4th to 64, so that OpenCV-style ranges (num_disp a multiple of 16 to
    # 256, of 32 to 512) with half-pixel samples (n = 2 num_disp - 1) have no padding at all
    ladder = list(range(1, 13)) + list(range(14, 33, 2)) + list(range(36, 65, 4))
    while ladder[-1] < 1025:         # MAX_RANGE * 4 + 1 samples = 1025 vectors
        ladder.append(-(-ladder[-1] * 9 // 8))
    return tuple(ladder)


#: the bucket sizes of the CPU band matcher, in short16 vectors (16 samples) per pixel: a range
#: of n samples runs in the smallest that holds it (30 buckets up to 1024 samples, 36 up to 2048:
#: max_disparity 1024 with half-pixel samples)
BUCKET_VECTORS = _bucket_ladder()


def sample_bucket(n):
    """The build of the CPU band matcher that runs ``n`` disparity samples: ``(samples, full)``,
    its padded sample count (stereo.cl's ``N_DISP``, a multiple of 16) and the vectors that hold
    only samples below every count of the bucket (``NV_FULL``: no lane test there).  The true
    ``n`` is a kernel argument, so every ``n`` of a bucket shares one build of the kernels.

    Examples
    --------
    >>> sample_bucket(383)       # 1000 x 1500, max_disparity 191, half-pixel samples: 24 vectors
    (384, 22)
    >>> sample_bucket(321)
    (352, 20)
    """
    nv = -(-int(n) // 16)
    for i, size in enumerate(BUCKET_VECTORS):
        if size >= nv:
            return 16 * size, BUCKET_VECTORS[i - 1] if i else 0
    raise ValueError(f"{n} disparity samples exceed the largest bucket ({16 * BUCKET_VECTORS[-1]})")


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

#: larger images keep the byte costs of the whole image between the two sweeps where they take at
#: most this many bytes (and the working set allows); above it each coarse band computes its
#: costs again (1000 x 1500 x 383 samples: 576 MB of costs, the process's peak 1.1 GB; recomputed,
#: about a fifth more time)
KEEP_BYTES = 128 * 2**20


#: rows of the fine bands where the costs are recomputed (at most): their sums are the largest
#: buffers left (1000 x 1500 x 383: 27.6 MB at 12 rows, 39 MB at band_rows' 17)
FINE_ROWS = 12

#: ... and at least this many, else two per core (the selection runs one row per work-item):
#: the band's two sums must still be in the last-level cache when the selection reads them
#: right after the sweeps (1000 x 1500 x 383 on 2 cores: 9.2 MB at 4 rows; at 12 rows, 27.6 MB,
#: the selection took 2.1x as long, 300 against 120 us of CPU per row with the sums in cache)
MIN_FINE_ROWS = 4


def fine_rows():
    """Rows of the fine bands where the costs are recomputed: two per core of the host (an
    OpenCL CPU device runs on it), :data:`MIN_FINE_ROWS` .. :data:`FINE_ROWS`."""
    return min(FINE_ROWS, max(MIN_FINE_ROWS, 2 * (os.cpu_count() or 1)))


class MatchPlan(NamedTuple):
    """How the CPU matcher runs an image (:func:`match_plan`)."""

    #: rows per band of the two sweeps and the selection
    rows: int
    #: the byte costs of the whole image are kept (else computed per coarse band, twice)
    keep: bool
    #: bytes the matcher allocates (:func:`match_memory`)
    nbytes: int
    #: rows per coarse band (a multiple of ``rows``; the image's height where ``keep``)
    coarse: int


def coarse_rows(h, paths, k, w=1, n=1):
    """Rows per coarse band of the CPU matcher when it recomputes the costs: a multiple of the
    band rows ``k`` that balances the coarse checkpoints (h / K state rows of ~2 bytes per sample,
    c of them: 1 for 4 paths, 4 for 8) against the coarse band's byte costs and its fine
    checkpoints (K (1 + 2 c / k) bytes per sample of a row): K = sqrt(2 c h / (1 + 2 c / k))."""
    c = 1 if paths == 4 else 4
    best = math.sqrt(2 * c * h / (1 + 2 * c / k))
    return int(min(h, max(k, k * round(best / k))))


def match_plan(h, w, n, paths, block=3, budget=None):
    """How the CPU matcher runs an (h, w) image with n disparity samples within ``budget``
    bytes (None: no limit), a :class:`MatchPlan`.  One band where :data:`WHOLE_BYTES` and the
    budget allow, else bands of :func:`band_rows` with the whole image's byte costs kept where
    they fit :data:`KEEP_BYTES` and the budget, else coarse bands of :func:`coarse_rows` whose
    costs are computed in each of the two sweeps (the least memory)."""
    if 7 * h * w * n <= WHOLE_BYTES:
        nbytes = match_memory(h, w, n, paths, True, block, rows=h)
        if budget is None or nbytes <= budget:
            return MatchPlan(h, True, nbytes, h)
    k = band_rows(h, paths, w, n)
    if h * w * sample_bucket(n)[0] <= KEEP_BYTES:
        nbytes = match_memory(h, w, n, paths, True, block, rows=k)
        if budget is None or nbytes <= budget:
            return MatchPlan(k, True, nbytes, h)
    k = min(k, fine_rows())
    return MatchPlan(k, False, match_memory(h, w, n, paths, False, block, rows=k), coarse_rows(h, paths, k, w, n))


def match_memory(h, w, n, paths, keep_cost, block=3, rows=None):
    """Bytes the CPU matcher allocates: the byte cost volume (``keep_cost``) or a coarse band of
    it, the cost kernel's Hamming ring (``block`` rows and their column sums), the band's sums,
    the path states and their checkpoints (coarse and fine where the costs are recomputed), the
    horizontal paths' states at the column tiles' edges; bands of ``rows`` rows (default
    :func:`band_rows`, at most :func:`fine_rows` where the costs are recomputed)."""
    if rows is None:
        k = band_rows(h, paths, w, n) if keep_cost else min(band_rows(h, paths, w, n), fine_rows())
    else:
        k = int(rows)
    nb = sample_bucket(n)[0]                               # the build's padded samples
    cell = nb + 16                                         # stereo.cl's CELL
    state_row = 2 * (16 + (w + 2) * cell)
    c = 1 if paths == 4 else 4
    checkpoint = c * (state_row + 2 * (w + 2))
    npix = nb                                              # a pixel's samples in _padded
    if keep_cost:
        cost, checkpoints, coarse = h * w * npix, -(-h // k) * checkpoint, k
    else:
        coarse = coarse_rows(h, paths, k, w, n)
        cost = coarse * w * npix
        checkpoints = (-(-h // coarse) + -(-coarse // k)) * checkpoint
    splits = 2 * (os.cpu_count() or 1)                      # _cost_splits on a CPU device
    ring = splits * (block * (-(-w // splits) + 2 * (block // 2)) + 2 * (block + 1)) * nb
    return cost + ring + 14 * w * n + 4 * k * w * npix + 10 * state_row + checkpoints + 4 * max(k, coarse) * cell
