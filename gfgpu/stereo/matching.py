"""Dense disparity maps of rectified stereo pairs (chapter §5).

Three methods share one entry point, :func:`disparity`:

``"sgm"`` (default)
    Census matching cost over the disparity range, optionally sampled below the pixel with
    exact Green's-function shifts of the right view (``subpixel_steps``), semi-global
    aggregation (Hirschmüller 2008; 4 paths by default, 8 on request), winner-take-all with a
    uniqueness test and a sub-pixel fit (with half-pixel samples one fitted to their two
    phases, :func:`gfgpu.stereo.spec.select_disparity_reference`), and a left-right
    consistency check.  On CPU devices
    (OpenCL) the matcher streams bands of rows through two concurrent sweeps and never holds
    an (H, W, D) volume of sums (``disparity_memory``).
``"uniform"``
    The chapter's sweep: for each disparity ``d = n + f`` the left view is shifted by ``-f/2``
    and the right view by ``+f/2`` with the exact discrete G_u shift (:func:`gfgpu.shift`),
    the integer part ``n`` is an index offset, windowed squared differences are compared and
    a per-pixel running best is kept (memory O(H·W)).
``"affine"``
    The same sweep with the chapter's G_U^(2) (eq. 14, σ fixed, x_U swept as
    ``x_U = -σ²/s`` for a shift ``s``), each filtered image divided by the filtered constant
    image to undo its gain ramp.  Point-sampled, G_U^(2) shifts by about ``s + 1/(6s)``
    rather than ``s`` (never less than 0.86 px; ``docs/derivations.md``, "G_U^(2)"), so this
    method's sub-pixel values are biased (measured in ``docs/stereo.md``).

Each stage runs on the backend: census, matching cost, path aggregation, selection and the
sweep's running best are fused kernels (:mod:`gfgpu.stereo.kernels`), whose executable numpy
specifications are the ``*_reference`` functions of :mod:`gfgpu.stereo.spec`.  The
left-right check and the input handling run on the host (O(H·W)).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .. import greens
from .._core.arrays import as_kind, host_array, kind_of
from .._core.strips import get_working_set
from .._core.validation import finite_scalar, flag, positive
from ..backends import resolve_backend
from ..filters import green_filter, shift
from . import kernels, postfilter
from . import spec as specs
from .spec import COST_MAX, SWEEP_PLANES
from .workspace import empty as _empty

__all__ = ["disparity", "default_penalties", "matching_views", "disparity_work", "disparity_memory",
           "estimate_max_disparity", "METHODS", "fill_holes", "random_dot_stereogram", "sweep_finish"]

#: smallest disparity step of the chapter's sweeps (px)
MIN_SWEEP_STEP = 1.0 / 64

METHODS = ("sgm", "uniform", "affine")

#: largest census radius: (2r+1)^2 - 1 comparison bits must fit one uint64
MAX_CENSUS_RADIUS = 3

#: aggregated costs are int16 on every backend: 8 paths of at most (max cost + P2) each
_INT16_MAX = 32767

#: weights of the luminance that colour views are matched on (Rec. 601, as OpenCV's grey)
LUMA = (0.299, 0.587, 0.114)

#: left-right check: largest disagreement (px) between the two views' winners
LR_TOLERANCE = 1.0

#: largest disparity range (max_disparity - min_disparity) in pixels
MAX_RANGE = 4096

# --------------------------------------------------------------------------------------
# host helpers
# --------------------------------------------------------------------------------------
def sweep_finish(state, step, return_margin=False):
    """Disparity of a finished sweep (numpy, O(H·W)).

    The best ``d`` plus the parabola vertex; NaN where no candidate was in view, where the
    best is cut by the image (a neighbouring step was out of view: cost ``+inf``), or where it
    is not unique (no cost more than one step away, or the best of those does not exceed it:
    ties).  With ``return_margin``, also ``(second - best) / second`` (0 where NaN).

    Parameters
    ----------
    state : (9, H, W) array_like
        The sweep's state (:func:`gfgpu.stereo.spec.sweep_update_reference`).
    step : float
        The sweep's disparity step (px).
    return_margin : bool, optional

    Returns
    -------
    (H, W) float32 ndarray, or a pair of them

    Examples
    --------
    >>> import numpy as np
    >>> state = np.array([[[1.0]], [[3.0]], [[2.0]], [[4.0]], [[4.0]], [[5.0]], [[2.0]], [[1.0]], [[3.0]]])
    >>> float(sweep_finish(state, 0.5)[0, 0])     # vertex at 3 - 0.5 * 0.25
    2.875
    """
    best, best_d, before, after, _, second = (np.asarray(p, np.float64) for p in state[:6])
    den = before - 2 * best + after
    ok = np.isfinite(before) & np.isfinite(after) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(ok, (before - after) / (2 * den), 0.0)
        margin = (second - best) / second
    keep = np.isfinite(best) & np.isfinite(second) & (second > best) & (before != np.inf) & (after != np.inf)
    disp = np.where(keep, best_d + step * delta, np.nan).astype(np.float32)
    if return_margin:
        return disp, np.where(keep, margin, 0.0).astype(np.float32)
    return disp


def fill_holes(disp, *, edges="row"):
    """Fill NaN pixels from the nearest valid pixel on the same row, the smaller of the two.

    The smaller disparity is the background's, which is what an occlusion hides (the
    Middlebury evaluation's hole filling, also used by ``benchmarks/stereo.py`` for every
    method).  Rows without any valid pixel become 0.

    Parameters
    ----------
    disp : (H, W) float ndarray with NaN holes
    edges : {'row', 'smooth'}, optional
        Holes open to the image's left or right edge (the bands where the match lies outside
        the other view) have a valid pixel on one side only.  ``"row"`` (the evaluation's
        rule) copies it along the row, which leaves horizontal streaks; ``"smooth"`` fills
        them with a normalised Gaussian average of the valid pixels around (widths 2, 4, 8,
        ... px, the smallest whose weight reaches 0.3), so neighbouring rows blend.

    Returns
    -------
    (H, W) ndarray, a filled copy

    Examples
    --------
    >>> import numpy as np
    >>> fill_holes(np.array([[np.nan, 3.0, np.nan, 1.0, np.nan]], np.float32))
    array([[3., 3., 1., 1., 1.]], dtype=float32)
    """
    if edges not in ("row", "smooth"):
        raise ValueError(f"edges must be 'row' or 'smooth', got {edges!r}")
    d = np.array(disp, dtype=np.float32, copy=True)
    holes = ~np.isfinite(d)
    if not holes.any():
        return d
    h, w = d.shape
    idx = np.broadcast_to(np.arange(w), (h, w))
    left = np.maximum.accumulate(np.where(holes, -1, idx), axis=1)
    right = np.minimum.accumulate(np.where(holes, w, idx)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(h)[:, None]
    lv = np.where(left >= 0, d[rows, np.maximum(left, 0)], np.inf)
    rv = np.where(right < w, d[rows, np.minimum(right, w - 1)], np.inf)
    fill = np.minimum(lv, rv)
    open_edge = holes & ~(np.isfinite(lv) & np.isfinite(rv))
    fill[~np.isfinite(fill)] = 0
    d[holes] = fill[holes]
    if edges == "smooth" and open_edge.any() and (~holes).any():
        from scipy import ndimage
        known = (~holes).astype(np.float64)
        vals = np.where(holes, 0.0, d).astype(np.float64)
        todo = open_edge.copy()
        sigma = 2.0
        while todo.any() and sigma < 4 * max(h, w):
            wsum = ndimage.gaussian_filter(known, sigma, mode="nearest")
            vsum = ndimage.gaussian_filter(vals, sigma, mode="nearest")
            ok = todo & (wsum >= 0.3)
            d[ok] = (vsum[ok] / wsum[ok]).astype(np.float32)
            todo &= ~ok
            sigma *= 2
    return d


def grey_image(image, name):
    arr = host_array(image, name)     # any array kind, moved to the host once (disparity's docstring)
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a real numeric image, got dtype {arr.dtype}")
    integer = arr.dtype.kind in "biu"         # always finite, also as float32
    # int32/uint32/int64/uint64 beyond float32's exact integers (2**24) stay float64 here, so
    # that no value is lost: _exact_views moves the pair to float32 exactly or keeps float64;
    # so do float64 images beyond float32's range (cast, they overflowed to inf and were refused
    # as "NaN or infinite", or flushed to an all-zero image)
    real = np.float64 if _wide_integers(arr) or _beyond_float32(arr) else np.float32
    if arr.ndim == 3 and arr.shape[-1] in (1, 3, 4):
        if arr.shape[-1] == 4:
            arr = arr[..., :3]     # alpha is not image content
        # Rec. 601 luminance (OpenCV's grey): measured better than the channel mean and than
        # a census per channel on every Middlebury scene of benchmarks/stereo.py (docs/stereo.md)
        chans = arr.astype(real)
        if chans.shape[-1] == 1:
            arr = chans[..., 0]
        else:
            arr = (chans[..., 0] * real(LUMA[0]) + chans[..., 1] * real(LUMA[1])
                   + chans[..., 2] * real(LUMA[2]))
    elif arr.ndim != 2:
        raise ValueError(f"{name} must be (H, W) grey or (H, W, C) colour with C in 1, 3, 4; "
                         f"got shape {arr.shape}")
    if real is np.float64 and arr.dtype.kind in "iu":
        # grey wide integers stay integers: _exact_views takes the pair's offset in integer
        # arithmetic, exact also beyond float64's 2**53 (int64, uint64)
        return np.ascontiguousarray(arr, dtype=np.int64 if arr.dtype.kind == "i" else np.uint64)
    out = np.ascontiguousarray(arr, dtype=real)
    if not integer and not np.isfinite(out).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return out


#: the largest magnitude below which every integer is a float32
_FLOAT32_EXACT = 2**24


def _wide_integers(arr):
    """Whether ``arr`` holds integers that float32 cannot hold exactly (int32/uint32/int64/uint64
    values of magnitude 2**24 or more)."""
    if arr.dtype.kind not in "iu" or arr.dtype.itemsize < 4 or arr.size == 0:
        return False
    return int(arr.max()) >= _FLOAT32_EXACT or int(arr.min()) <= -_FLOAT32_EXACT


def _beyond_float32(arr):
    """Whether ``arr`` is a float image wider than float32 whose largest magnitude float32 cannot
    hold as a normal number (above its largest finite value, or nonzero below its smallest normal
    one); such an image keeps float64 (an infinite one too, refused by :func:`grey_image`)."""
    if arr.dtype.kind != "f" or arr.dtype.itemsize <= 4 or arr.size == 0:
        return False
    top = float(np.fmax.reduce(np.abs(arr), axis=None))     # NaN ignored (refused after the cast)
    info = np.finfo(np.float32)
    return top > float(info.max) or 0.0 < top < float(info.tiny)


def _exact_views(left, right):
    """A pair from :func:`grey_image` in the precision that loses no value: float32 views as they
    are; wide integers (grey: int64/uint64; colour: float64 luminance) and float64 images beyond
    float32's range (:func:`_beyond_float32`) moved by their joint minimum (exact in integer
    arithmetic), then
    float32 where that holds them exactly (every integer below 2**24: values near 2e9 that differ
    by 3 keep their difference) and float64 otherwise (the census is then taken on the host, in
    float64: :func:`_sgm`)."""
    if left.dtype == np.float32 and right.dtype == np.float32:
        return left, right
    if left.dtype.kind in "iu" and right.dtype.kind in "iu":
        # v - low in uint64 arithmetic (modulo 2**64, and 0 <= v - low < 2**64): exact
        low = np.uint64(min(int(left.min()), int(right.min())) % 2**64)
        lft, rgt = ((v.astype(np.uint64) - low).astype(np.float64) for v in (left, right))
    else:
        lft, rgt = np.asarray(left, np.float64), np.asarray(right, np.float64)
        top = max(float(np.abs(lft).max()), float(np.abs(rgt).max()))
        if top > 2.0**1000:
            # float64 images near float64's largest values (_beyond_float32): scaled down by a
            # power of two first (exact; matching_views scales the views again), so that the
            # differences from the minimum cannot overflow
            lft, rgt = np.ldexp(lft, -64), np.ldexp(rgt, -64)
        low = min(float(lft.min()), float(rgt.min()))
        lft, rgt = lft - low, rgt - low
    top = max(float(lft.max()), float(rgt.max()))
    if top < _FLOAT32_EXACT and (lft == np.round(lft)).all() and (rgt == np.round(rgt)).all():
        return lft.astype(np.float32), rgt.astype(np.float32)
    return lft, rgt


def _int_arg(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    return int(value)


#: the left-right check on the host (the sweeps' maps): ``(disp, right, steps, tol,
#: return_difference=False)``, right in steps (``steps`` an int) or in px (``steps=None``)
left_right_check = specs.left_right_check_reference


# --------------------------------------------------------------------------------------
# the methods
# --------------------------------------------------------------------------------------
def _largest_cost(census_radius, block):
    return min((((2 * census_radius + 1) ** 2 - 1) * block * block) >> specs.cost_shift(block), COST_MAX)


def _largest_p2(census_radius, block, paths):
    """The largest P2 whose aggregated costs fit int16: ``paths * (largest cost + P2) < 32767``."""
    return (_INT16_MAX - 1) // paths - _largest_cost(census_radius, block)


def default_penalties(window, paths=4, census_radius=3):
    """The default penalties ``(P1, P2)`` of ``"sgm"`` for a block side ``window``.

    ``6 window²`` and ``64 window²`` in units of the block's summed Hamming distance (measured
    on the Middlebury scenes of ``benchmarks/stereo.py`` at the default window 3), divided by
    the ``2**cost_shift(window)`` by which the block sums are shifted before they saturate
    (:func:`gfgpu.stereo.spec.cost_shift`), so that they scale with the costs; both lowered by
    one factor where ``P2`` would not let the aggregated costs fit int16 (``paths * (largest
    cost + P2) < 32767``), so that every documented window runs with the defaults.

    Examples
    --------
    >>> default_penalties(3)
    (54, 576)
    >>> default_penalties(15)          # block sums shifted by 5 bits
    (42, 450)
    """
    scale = 2 ** specs.cost_shift(window)
    p1, p2 = 6 * window**2 // scale, 64 * window**2 // scale
    top = _largest_p2(census_radius, window, paths)
    if p2 > top:
        p1, p2 = p1 * top // p2, top
    return p1, p2


#: float32's smallest normal number: smaller magnitudes are flushed to 0 on the host (devices
#: flush subnormals, numpy does not)
_TINY = np.float32(np.finfo(np.float32).tiny)


def _flush(image):
    """``image`` (a float32 array of the caller's own) with its subnormals and -0 set to +0, in
    place: a zero exponent field is |x| < _TINY (one integer pass, no temporaries)."""
    bits = image.view(np.uint32)
    bits[(bits & np.uint32(0x7F800000)) == 0] = 0
    return image


def matching_views(left, right, steps):
    """The images the census of ``"sgm"`` reads, computed on the host the same way for every
    backend (so that every backend sees the same bits and returns the same map).

    Both views are scaled by one power of two (exact) so that the largest magnitude lies in
    [1, 2) (a pair in float32 subnormals is matched as its normal-range copy), and each right
    plane ``f`` is the right view moved by ``+f / steps`` px with the exact discrete Green
    shift (:func:`gfgpu.shift`, nearest extension) in float64, rounded to float32.  Magnitudes
    below float32's smallest normal number are then flushed to 0: devices flush subnormals
    (the G_f shift's geometric tails reach them beside flat regions), numpy does not.  A shift
    computed on each device in float32 rounded differently per backend, and census compares
    of near-equal neighbours (flat regions of boolean or 8-bit images) flipped with it.

    Parameters
    ----------
    left, right : (H, W) float32 ndarray
        Finite grey views (:func:`grey_image`).
    steps : int
        Sub-pixel samples per pixel, 1..4.

    Returns
    -------
    left : (H, W) float32 ndarray
    right : (steps, H, W) float32 ndarray
    """
    if left.dtype != np.float64:
        lft, rgt = _scaled_views(left, right)
        return lft, subpixel_planes(rgt, steps)
    # wide integers (_exact_views): float64 views and planes, no flush (the census of float64
    # views runs on the host, the same bits for every backend)
    exp = _scale_exponent(left, right)
    lft, rgt = np.ldexp(left, exp), np.ldexp(right, exp)
    planes = np.empty((steps,) + rgt.shape, np.float64)
    planes[0] = rgt
    for f in range(1, steps):
        moved = _green_shift_rows(rgt, f / steps)
        if 2 * f == steps:
            moved = 0.5 * (moved + _green_shift_rows(rgt, -0.5, 1))
        planes[f] = moved
    return lft, planes


def _scale_exponent(left, right):
    """The power of two that brings the pair's largest magnitude into [1, 2) (0 for a zero pair)."""
    top = max(float(np.abs(left).max(initial=0.0)), float(np.abs(right).max(initial=0.0)))
    return 1 - math.frexp(top)[1] if top > 0 else 0


def _scaled_views(left, right):
    """Both float32 views scaled as :func:`matching_views` scales them, subnormals flushed."""
    exp = _scale_exponent(left, right)
    return _flush(_scale2(left, exp)), _flush(_scale2(right, exp))


def subpixel_planes(rgt, steps):
    """The right view's sub-pixel planes of :func:`matching_views` from the scaled right view
    ``rgt`` ((H, W) float32): (steps, H, W) float32, plane 0 ``rgt`` itself (the host's batched
    form of :func:`gfgpu.stereo.spec.subpixel_planes_reference`, bit for bit)."""
    planes = np.empty((steps,) + rgt.shape, np.float32)
    planes[0] = rgt
    # the shifts run on blocks of rows (each row is its own recursion: the same values), so that
    # their float64 temporaries stay a few hundred kB: whole images of them (~5 per plane, 57 MB
    # at 1000 x 1500) stayed in the process's heap after the call and added to its peak memory
    # the sub-pixel disparity samples of the cost volume; the half-pixel plane: the mean of the
    # causal G_{1/2} shift and of the anticausal G_{-1/2} shift moved by one pixel, a kernel
    # symmetric about the half-pixel point.  The causal shift alone blurs to one side: samples
    # half a pixel below and above a whole-pixel match cost unequally, and an exact 8 px shift
    # came out 7.95 (median).  All shifts of a block of rows run as one batch.
    jobs = [job for plane in specs.subpixel_jobs(steps) for job in plane]
    for r0 in range(0, rgt.shape[0], _SHIFT_ROWS):
        shifted = iter(_green_shifts(rgt[r0:r0 + _SHIFT_ROWS].astype(np.float64), jobs)) if jobs else None
        for f in range(1, steps):
            moved = next(shifted)
            if 2 * f == steps:
                moved += next(shifted)
                moved *= 0.5
            planes[f, r0:r0 + _SHIFT_ROWS] = moved      # rounded to float32 as astype rounds
    for f in range(1, steps):
        _flush(planes[f])
    return planes


#: rows per block of the right view's sub-pixel shifts in :func:`matching_views`
_SHIFT_ROWS = 256


def _scale2(image, exp):
    """``np.ldexp(image, exp)`` in float32: one multiplication by the power of two where it is a
    normal float32 (the same correctly rounded values, bit for bit; ldexp took 14 ms per view at
    1000x1500, the product 1-2 ms)."""
    out = _page_aligned(image.shape, np.float32)
    if -126 <= exp <= 126:
        return np.multiply(image, np.float32(2.0**exp), out=out)
    return np.ldexp(image, exp, out=out, dtype=np.float32)


def _page_aligned(shape, dtype):
    """An uninitialised C-contiguous array starting on a page boundary: a CPU OpenCL device
    reads such a view in place (``host_view``: no copy and no blocking upload; an array at an
    offset within its buffer would be copied by the kernels' launchers)."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    raw = np.empty(nbytes + _PAGE, np.uint8)
    start = -raw.ctypes.data % _PAGE
    return raw[start:start + nbytes].view(dtype).reshape(shape)


_PAGE = 4096


def _green_shift_rows(rows, amount, offset=0):
    """The rows of ``rows`` (float64) moved by ``amount`` px with the discrete Green shift
    (:func:`gfgpu.shift`'s G_f, nearest extension) and then by ``offset`` whole px.

    One real second-order recursion per row (the section ``y = tap x + Re F``, ``F[x+1] = λ F[x]
    + κ x[x]``, as one rational filter, :func:`_rational_rows`), started in the steady state of
    the edge value (the nearest extension from infinity): the values of :func:`gfgpu.shift` on
    the numpy backend to ~1e-13, in about half its time."""
    return _green_shifts(rows, [(amount, offset)])[0]


def _green_shifts(rows, jobs):
    """``[_green_shift_rows(rows, amount, offset) for amount, offset in jobs]``, the recursions of
    all jobs run as one batch of rows (one step per column for all of them)."""
    rows = np.asarray(rows, np.float64)
    h, w = rows.shape
    srcs, coefs, layout = [], [], []
    for amount, offset in jobs:
        # the result at x is the filtered line at x - n
        b, a, _, n, reverse = specs.shift_recursion(amount, offset)
        src = rows
        if n > 0:                           # the extension's first n columns are needed
            src = np.concatenate([np.repeat(rows[:, :1], n, axis=1), rows], axis=1)
        if reverse:
            src = src[:, ::-1]
        srcs.append(src)
        coefs.append((b, a))
        layout.append((n, reverse, src.shape[1]))
    # one batch: every job's rows, as long as the longest (a recursion is causal: the columns
    # appended after a shorter job's end change none of its outputs), written transposed (the
    # recursion's layout)
    length = max(src.shape[1] for src in srcs)
    batch_t = np.empty((length, len(jobs) * h))
    for q, src in enumerate(srcs):
        batch_t[:src.shape[1], q * h:(q + 1) * h] = src.T
        batch_t[src.shape[1]:, q * h:(q + 1) * h] = src[:, -1]
    b = np.repeat(np.array([c[0] for c in coefs]).T, h, axis=1)      # (3, jobs * h): per row
    a = np.repeat(np.array([c[1] for c in coefs]).T, h, axis=1)
    filtered = _rational_rows(b, a, batch_t.T, overwrite=True)
    outs = []
    for q, (n, reverse, size) in enumerate(layout):
        out = filtered[q * h:(q + 1) * h, :size]
        if reverse:
            out = out[:, ::-1]
        if n < 0:
            out = np.concatenate([out[:, -n:], np.repeat(out[:, -1:], -n, axis=1)], axis=1)
        outs.append(out[:, :w] if n > 0 else out)
    return outs


def _rational_rows(b, a, src, overwrite=False):
    """Each row of ``src`` (R, N) float64 filtered by ``b(z) / a(z)`` (three taps each, a[0] = 1;
    ``b``, ``a`` of shape (3,), or (3, R) for a filter per row), started in the steady state of its
    first value: the values of ``scipy.signal.lfilter(b, a, src, axis=1, zi=lfilter_zi(b, a) *
    src[:, :1])`` bit for bit (its transposed direct form, the same operations in the same order;
    tested), without importing scipy.signal (~40 MB of the process's memory).  One step per column
    over all rows at once (the columns of a transposed copy: contiguous; ``overwrite``: ``src`` is
    the transpose of a C-contiguous array that may be overwritten, used in place)."""
    b = np.asarray(b, np.float64)
    a = np.asarray(a, np.float64)
    r = src.shape[0]
    if b.ndim == 1:
        b, a = np.repeat(b[:, None], r, axis=1), np.repeat(a[:, None], r, axis=1)
    # lfilter_zi: zi = (I - A)^-1 B with A the companion matrix of a, solved as it solves it (a
    # 2 x 2 system per distinct filter)
    zi = np.empty((2, r))
    for ab in np.unique(np.concatenate([b, a]), axis=1).T:
        bq, aq = ab[:3], ab[3:]
        rows = np.all(b == bq[:, None], axis=0) & np.all(a == aq[:, None], axis=0)
        zi[:, rows] = np.linalg.solve(np.array([[1.0 + aq[1], -1.0], [aq[2], 1.0]]),
                                      bq[1:] - aq[1:] * bq[0])[:, None]
    src_t = src.T if overwrite and src.T.flags.c_contiguous else np.ascontiguousarray(src.T)
    a1, a2 = a[1], a[2]
    z0, z1 = zi[0] * src_t[0], zi[1] * src_t[0]
    # the input's products for every column at once (the same products): 6 calls per column
    bx1, bx2 = src_t * b[1], src_t * b[2]
    out = np.multiply(src_t, b[0], out=src_t if overwrite else None)
    t = np.empty_like(z0)
    for y, p1, p2 in zip(out, bx1, bx2):
        y += z0                             # y = z0 + b0 x
        np.add(z1, p1, out=t)               # z0 = (z1 + x b1) - y a1
        np.multiply(y, a1, out=z0)
        np.subtract(t, z0, out=z0)
        np.multiply(y, a2, out=z1)          # z1 = x b2 - y a2
        np.subtract(p2, z1, out=z1)
    return out.T


def _sgm_scalars(subpixel_steps, census_radius, p1, p2, paths, uniqueness):
    """The ``"sgm"`` options that do not depend on the window, checked whatever the method (a
    sweep refuses them too rather than ignore a typo): ``(steps, radius, p1, p2, paths,
    uniqueness)``, the penalties None where not given."""
    steps = _int_arg(subpixel_steps, "subpixel_steps")
    if not 1 <= steps <= 4:
        raise ValueError(f"subpixel_steps must be 1..4, got {steps}")
    radius = _int_arg(census_radius, "census_radius")
    if not 1 <= radius <= MAX_CENSUS_RADIUS:
        raise ValueError(f"census_radius must be 1..{MAX_CENSUS_RADIUS}, got {radius}")
    if isinstance(paths, bool) or paths not in (4, 8):
        raise ValueError(f"paths must be 4 or 8, got {paths!r}")
    p1 = None if p1 is None else _int_arg(p1, "p1")
    p2 = None if p2 is None else _int_arg(p2, "p2")
    uniq = _int_arg(uniqueness, "uniqueness")
    if not 0 <= uniq <= 100:
        raise ValueError(f"uniqueness must be 0..100 (percent), got {uniq}")
    return steps, radius, p1, p2, int(paths), uniq


def _sweep_scalars(sweep_step, sigma):
    """The sweeps' options, checked whatever the method: ``(step, sigma or None)``."""
    step = finite_scalar("sweep_step", sweep_step)
    if not MIN_SWEEP_STEP <= step <= 1:
        # below 1/64 px the sweep's cost grows without a gain: its sub-pixel parabola already
        # resolves a fraction of the step
        raise ValueError(f"sweep_step must lie in [{MIN_SWEEP_STEP:g}, 1] px, got {sweep_step!r}")
    return step, (None if sigma is None else positive("sigma", sigma))   # names it for a string or a bool


def _sgm_options(window, subpixel_steps, census_radius, p1, p2, paths, uniqueness):
    """``disparity``'s ``"sgm"`` options checked (a clear error naming each), the defaults
    filled in: ``(window, steps, radius, p1, p2, paths, uniqueness)``."""
    window = 3 if window is None else _int_arg(window, "window")
    if window < 1 or window % 2 == 0 or window > 15:
        raise ValueError(f"window must be odd, 1..15, for method 'sgm'; got {window}")
    steps, radius, p1, p2, paths, uniq = _sgm_scalars(subpixel_steps, census_radius, p1, p2, paths, uniqueness)
    auto = default_penalties(window, paths, radius)
    p1 = auto[0] if p1 is None else p1
    p2 = auto[1] if p2 is None else p2
    if not 0 <= p1 <= p2:
        raise ValueError(f"penalties must satisfy 0 <= p1 <= p2, got p1={p1}, p2={p2}")
    top = _largest_p2(radius, window, paths)
    if p2 > top:
        raise ValueError(f"p2 = {p2} is too large: aggregated costs must fit int16 "
                         f"(paths * (largest cost + p2) < {_INT16_MAX}: p2 <= {top} for window {window}, "
                         f"census_radius {radius} and {paths} paths)")
    return window, steps, radius, p1, p2, paths, uniq


def _planes_on_device(be, dtype, steps):
    """Whether the right view's sub-pixel planes are computed on the device (``kernels.planes``):
    OpenCL with fp64 and float32 views (the host's values bit for bit; at 1000 x 1500 they took
    ~60-120 ms of one host core while the device waited).  Elsewhere on the host
    (:func:`matching_views`; wide-integer views are float64 and their census runs on the host)."""
    return dtype == np.float32 and steps > 1 and be.name == "opencl" and be.supports_float64


def _device_speckles(be, shape, post, subpixel):
    """Whether :func:`disparity` runs the speckle filter of ``post`` (:func:`postfilter.check_postfilter`)
    on the device, in the matcher's launch (``kernels.match``'s ``speckles``: ``_opencl.launch_speckles``,
    the host's map bit for bit): OpenCL CPU devices with fp64, a sub-pixel map (whole-pixel maps
    are rounded on the host first) and no confidence threshold (applied before the filter, on the
    host).  A union-find on one core per half of the rows: 1.1 against the host's 1.5 ms on
    tsukuba's map, 12 against 13.5 ms at 1000 x 1500 (docs/stereo.md, "Speckles on the device")."""
    return (post[0] > 0 and post[2] == 0 and subpixel and be.name == "opencl" and be.kind == "cpu"
            and be.supports_float64 and shape[0] * shape[1] < 2**31 - 1)


def _sgm(be, left, right, d_min, d_max, steps, census_radius, block, p1, p2, paths, uniqueness,
         lr_check, progress, buffers=None, workspace=None, speckles=None):
    h, w = left.shape
    n_disp = (d_max - d_min) * steps + 1
    one_shot = buffers is None
    if one_shot:
        # disparity()'s own call: the buffers of the last call of this size and range where they
        # were small (_KEPT_BYTES), else new ones
        kept_key = (h, w, n_disp, steps, block, paths)
        buffers = workspace = _kept_buffers(be, kept_key)
    views = _exact_views(left, right)
    if _planes_on_device(be, views[0].dtype, steps):
        # the right view first: its planes run on the device while the host scales the left view
        # (the device's first launch came after both views were scaled)
        exp = _scale_exponent(*views)
        rgt = _flush(_scale2(views[1], exp))
        planes = _empty(be, buffers, "planes", (steps, h, w), np.float32)
        # host_view: a CPU device reads the (page-aligned) host view in place, no blocking upload
        kernels.planes(be, be.host_view(rgt), planes, steps)
        del rgt
        lft = _flush(_scale2(views[0], exp))
    else:
        lft, planes = matching_views(*views, steps)
    on_device = not isinstance(planes, np.ndarray)
    if lft.dtype == np.float64:
        # wide integers that float32 cannot hold: the census of the float64 views on the host
        # (its numpy specification), the same codes for every backend
        cen_l = be.asarray(specs.census_transform_reference(lft, census_radius)[None])
        cen_r = be.asarray(np.stack([specs.census_transform_reference(p, census_radius) for p in planes]))
    else:
        cen_l = _empty(be, buffers, "census_left", (1, h, w), np.uint64)
        kernels.census(be, be.host_view(lft), cen_l, 0, census_radius)
        cen_r = _empty(be, buffers, "census_right", (steps, h, w), np.uint64)
        for f in range(steps):
            kernels.census(be, planes[f] if on_device else be.host_view(planes[f]), cen_r, f, census_radius)
    # the views are not read again: released before the matcher's buffers are allocated (the
    # process's peak memory)
    del lft, planes
    progress(1)
    # one-shot results: arrays that to_host returns without a copy where the device shares the
    # host's memory (a StereoMatcher's buffers are kept and copied out instead)
    result = (lambda name, dt: be.host_result((h, w), dt)) if one_shot else \
        (lambda name, dt: _empty(be, buffers, name, (h, w), dt))
    disp = result("disp", np.float32)
    right_steps = _empty(be, buffers, "disp_right", (h, w), np.int32)
    margin = result("margin", np.float32)
    # cost, aggregation and selection in one fused kernel: on CPUs it streams bands of rows
    # (memory O(band x W x D)), on GPUs it holds (H, W, D) volumes
    budget = _budget(be)
    extra = {} if workspace is None else {"workspace": workspace}
    # OpenCL: the matcher checks the maps left against right itself (the CPU band matcher in its
    # selection, row by row: one launch and one pass over the maps fewer)
    fused_check = lr_check and be.name == "opencl"
    if fused_check:
        extra["left_right"] = LR_TOLERANCE
    if speckles is not None:
        # (size, range): the speckle filter of the finished maps on the device (_device_speckles)
        extra["speckles"] = speckles
    kernels.match(be, cen_l, cen_r, disp, right_steps, margin, d_min * steps, n_disp, steps, block, p1, p2,
                  paths, uniqueness, None if budget is None else budget - _sgm_base((h, w), steps), **extra)
    progress(1)
    if lr_check and not fused_check:
        # NaN where the views disagree; the confidence times the left-right agreement (1 where
        # both views agree exactly, 1/2 at the tolerance)
        kernels.left_right(be, disp, right_steps, margin, steps, LR_TOLERANCE)
    progress(1)
    if not one_shot:      # the next frame writes these buffers again: the results are copies
        return np.array(be.to_host(disp), copy=True), np.array(be.to_host(margin), copy=True)
    out = be.to_host(disp), be.to_host(margin)     # (the queue is in order: every kernel is done)
    _keep_buffers(be, kept_key, buffers)
    return out


#: disparity() keeps the device buffers of its last call on each backend (census codes, the band
#: matcher's volumes and states) for the next call of the same size and range where they take at
#: most this many bytes: their ~15 allocations cost 1-2 ms of a 20 ms call at 384 x 288.  Was
#: 64 MiB: the 1000 x 1500 x 192 call's ~150 MB were made anew at each call, their fresh pages
#: faulted in by the first kernel to touch them (sgm_guards: 41 of 1372 ms), and the peak RSS of
#: repeated calls then depends on the host pool's reuse (docs/stereo.md, "Speckles on the device":
#: 401 -> 411 MB with one pool, 493 -> 442 MB with another that allocates 2x a request)
_KEPT_BYTES = 256 * 2**20

_KEPT = {}          # backend -> (key, {buffers}): taken by one call at a time
os.register_at_fork(after_in_child=_KEPT.clear)     # a forked child has devices of its own


def _kept_buffers(be, key):
    """The buffers :func:`_keep_buffers` kept on ``be`` under ``key``, taken (a concurrent
    call finds none and makes its own), or a new empty dict."""
    kept = _KEPT.pop(be, None)
    return kept[1] if kept is not None and kept[0] == key else {}


def _keep_buffers(be, key, buffers):
    """Keep ``buffers`` (a finished call's) for the next call with ``key`` where they are small
    (:data:`_KEPT_BYTES`); they replace what was kept."""
    if sum(_nbytes(b) for b in buffers.values()) <= _KEPT_BYTES:
        _KEPT[be] = (key, buffers)


def _nbytes(array):
    """Bytes of a backend's array (Warp arrays give them as ``capacity``)."""
    n = getattr(array, "nbytes", None)
    return int(array.capacity if n is None else n)


def _green_shift(be, image, amount, method, sigma):
    """``image`` (device) moved by ``amount`` px along x, and the gain to apply to it (host, (W,)).

    ``"uniform"``: the exact discrete G_u shift, unit gain.  ``"affine"``: G_U^(2) (eq. 14)
    with ``x_U = -σ²/amount`` (causal) or its mirror beyond the line's end (anticausal), whose
    gain ramp is undone by dividing by the filtered constant row (``docs/derivations.md``).
    """
    w = image.shape[1]
    ones = np.ones(w, np.float32)
    if amount == 0:
        return image, ones
    if method == "uniform":
        return shift(image, (0.0, float(amount)), mode="nearest", backend=be), ones
    if amount > 0:
        kernel, anti = greens.AffineGreenApprox(sigma, -sigma**2 / amount), False
    else:
        kernel, anti = greens.AffineGreenApprox(sigma, (w - 1) + sigma**2 / -amount), True
    moved = green_filter(image, kernel, axis=1, mode="nearest", anticausal=anti, backend=be)
    den = green_filter(np.ones((1, w)), kernel, axis=1, mode="nearest", anticausal=anti,
                       backend="numpy")[0]
    return moved, (1.0 / den).astype(np.float32)


def _sweep(be, left, right, d_min, d_max, step, method, radius, sigma, lr_check, progress):
    h, w = left.shape
    # the sweeps run in float32 on every backend: wide integers moved by the pair's minimum first
    # (exact below 2**24 of range), then rounded; float64 pairs beyond float32's range
    # (_beyond_float32) first scaled by a power of two into it (the largest magnitude in [1, 2))
    views = _exact_views(left, right)
    top = max(float(np.abs(v).max()) for v in views)
    info = np.finfo(np.float32)
    if top > float(info.max) or 0.0 < top < float(info.tiny):
        views = tuple(np.ldexp(v, _scale_exponent(*views)) for v in views)
    left, right = (np.asarray(v, np.float32) for v in views)
    lft, rgt = be.asarray(left), be.asarray(right)
    init = np.full((SWEEP_PLANES, h, w), np.nan, np.float32)
    init[[0, 5, 6, 7]] = np.inf         # best, second, older, the right view's best
    state = be.asarray(init)
    for k in range(int(round((d_max - d_min) / step)) + 1):
        d = d_min + k * step
        # integer part by indexing, fractional part by symmetric Green half-shifts: the shifts
        # stay below half a pixel, where the second-order matching equation holds
        offset = math.floor(d)
        ls, gain_l = _green_shift(be, lft, -(d - offset) / 2, method, sigma)
        rs, gain_r = _green_shift(be, rgt, (d - offset) / 2, method, sigma)
        kernels.sweep(be, state, ls, rs, be.asarray(gain_l), be.asarray(gain_r), offset, d, radius)
        progress(1)
    state = be.to_host(state)
    disp, margin = sweep_finish(state, step, return_margin=True)
    if lr_check:
        disp, diff = left_right_check(disp, state[8], None, LR_TOLERANCE, return_difference=True)
        margin = margin * (1 - np.nan_to_num(diff, nan=2 * LR_TOLERANCE) / (2 * LR_TOLERANCE))
    return disp, np.where(np.isfinite(disp), margin, 0).astype(np.float32)


def disparity(left, right, max_disparity, *, min_disparity=0, method="sgm", window=None,
              subpixel=True, lr_check=True, subpixel_steps=2, census_radius=3, p1=None, p2=None,
              paths=4, uniqueness=10, sweep_step=0.5, sigma=None, return_confidence=False,
              speckle_size=None, speckle_range=postfilter.SPECKLE_RANGE, min_confidence=0.0, progress=None,
              backend=None, device=None):
    """Disparity map of the left view of a rectified stereo pair.

    A left pixel at column ``x`` of row ``y`` matches the right pixel at column ``x - d`` of the
    same row; ``d`` is returned in pixels, NaN where no match is established:

    - no candidate in view: every disparity of the range puts some column of the matching
      window (``x' - d`` for ``x'`` in the window around ``x``) outside the right image — the
      left band ``x < d`` for positive disparities, the right band for negative ones, and
      everything on images narrower than the disparities searched;
    - the minimum is cut by the image: the best candidate's neighbour disparity is out of view,
      so the true minimum may lie beyond the edge;
    - no unique minimum: no candidate more than one step from the best, or the best of those
      within ``uniqueness`` percent of it (``"sgm"``) or equal to it (sweeps) — flat regions
      and exact ties;
    - (``lr_check``) the right view's match points back more than 1 px away.

    Out-of-view candidates take no part in the aggregation either (they are not given a
    large cost, which would bias the paths towards the disparities that stay in view).

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) array_like
        The rectified pair, grey or colour (C = 3 or 4, channels in RGB(A) order, as
        imageio/skimage read them; colour is matched on its Rec. 601 luminance, alpha ignored;
        OpenCV's BGR arrays: reverse the channels, ``img[..., ::-1]``, for the same
        luminance).  Integer images are converted to float32; NaN/inf are rejected.
    max_disparity : int
        Largest disparity searched (px), ``min_disparity < max_disparity <= min_disparity +
        4096``; it may reach or exceed the width (those candidates are never in view).
    min_disparity : int, optional
        Smallest disparity searched (px, may be negative), ``|min_disparity| <= 16384``.
    method : {'sgm', 'uniform', 'affine'}, optional
        See the module docstring.  ``"sgm"`` is the accurate one.
    window : int, optional
        Odd window side: the block over which census Hamming distances are summed for
        ``"sgm"`` (default 3; 1..15, the sums shifted right by
        :func:`gfgpu.stereo.spec.cost_shift` bits before they saturate at 254), the
        squared-difference window for the sweeps (default 9).
    subpixel : bool, optional
        Refine the winner with a fit through its neighbours' costs (``"sgm"`` with half-pixel
        samples: through the samples one and two steps away, one baseline per phase; else a
        parabola).
    lr_check : bool, optional
        Reject pixels whose right-view match points back more than 1 px away (for the sweeps
        the right view's running best is kept in the same pass).
    subpixel_steps : int, optional
        (``"sgm"``) Disparity samples per pixel, 1 to 4: the right view is shifted by
        ``f / subpixel_steps`` px with the exact discrete G_u shift for each ``f`` (on the
        host, :func:`matching_views`; the half-pixel plane by the mean of the causal and the
        anticausal shift, symmetric about the half pixel).  Default 2:
        measured more accurate than whole-pixel samples on 14 of the 15 (scene, noise) cases of
        ``docs/stereo.md`` (Middlebury with added noise σ = 0, 2, 5; bad-2 5.8 → 4.8 % on
        average) and sub-pixel values 92 % → 100 % within 0.25 px on a random-dot square; 1 is the
        fast mode (~1.5-2.7× faster, half the memory) for clean images.
    census_radius : int, optional
        (``"sgm"``) Census window ``2r+1`` square, r in 1..3.
    p1, p2 : int, optional
        (``"sgm"``) Penalties of semi-global aggregation for one-step and larger changes, in
        units of the block's summed Hamming distance; default ``6 window²`` and
        ``64 window²`` (measured on the Middlebury scenes of ``benchmarks/stereo.py``), scaled
        down together where the aggregated costs would not fit int16 (windows 13 and 15 with
        4 paths, 9 to 15 with 8: :func:`default_penalties`).  A ``p2`` above that bound raises
        ``ValueError``.
    paths : {4, 8}, optional
        (``"sgm"``) Aggregation directions: 4 (rows and columns, both ways; the default:
        measured as accurate as 8 or better on the Middlebury scenes of
        ``benchmarks/stereo.py`` with these penalties, at ~40 % of the time) or 8 (adds the
        diagonals).
    uniqueness : int, optional
        (``"sgm"``) Margin in percent by which the best cost must beat every cost more than
        one step away (0 disables).
    sweep_step : float, optional
        (``"uniform"``, ``"affine"``) Disparity step of the sweep, in px, within [1/64, 1].
    sigma : float, optional
        (``"affine"``) σ of G_U^(2); default ``4 sqrt(W (|d|max + 1))`` so that
        ``|x_U| = σ²/s`` stays well outside the line (``|x_U| >> W``, where eq. 14's
        first-order behaviour holds; ``docs/derivations.md``).
    speckle_size, speckle_range : int, float, optional
        Speckle filter (OpenCV's ``filterSpeckles``, :func:`gfgpu.stereo.postfilter.filter_speckles`):
        4-connected regions of similar disparity (neighbours at most ``speckle_range`` px apart)
        of at most ``speckle_size`` pixels are set to NaN; 0 turns it off.  Default: 25 px and
        0.5 px for ``"sgm"`` (chosen on training scenes, and on held-out ones it lowered the mean
        absolute error, holes filled, on 9 of 9 pairs and 5 of 6 fresh ones, the density by ~2
        points: ``docs/stereo.md``, "Low texture"), off for the sweeps (not measured).  Larger
        regions (``speckle_size=200, speckle_range=1``) help noisy and low-contrast pairs more
        but hurt clean ones.
    min_confidence : float, optional
        Set to NaN the pixels whose confidence (below) is under this value, in [0, 1]; default 0
        (off: measured no help on the training scenes).  Applied before the speckle filter.
    return_confidence : bool, optional
        Also return a confidence per pixel in [0, 1], 0 where NaN: the uniqueness margin
        ``(S2 - S1) / S2`` of the winner's cost ``S1`` against the best cost ``S2`` more
        than one step away (aggregated costs for ``"sgm"``, window costs for the sweeps),
        times, with ``lr_check``, the left-right agreement
        ``1 - |d - d_right| / 2`` (1 when both views agree exactly, 1/2 at the 1 px
        tolerance).  With the default ``uniqueness=10`` a kept ``"sgm"`` pixel has at least
        ``0.09 * 0.5``.
    progress : callable, optional
        Called with a number of completed units of work (for progress bars);
        :func:`disparity_work` gives the total.
    backend, device : optional
        Where the kernels run (default: the resolution rule of :mod:`gfgpu.backends`, with
        ``left``'s device: a CUDA tensor is matched on its GPU).  ``left`` and ``right`` may be
        of any array kind (numpy, torch, CuPy, JAX, any ``__dlpack__`` array, Warp, pyopencl):
        they are read on the host, device memory copied there once.

    Returns
    -------
    disparity : (H, W) float32 array
        In px, NaN where no match is established; of ``left``'s kind (torch in, torch out, on
        its device; numpy for numpy, Warp and pyopencl inputs).
    confidence : (H, W) float32 array
        Only with ``return_confidence=True``; the same kind.

    Raises
    ------
    ValueError
        Shape mismatch, an empty or over-long disparity range (see ``max_disparity``), NaN/inf input, or a
        parameter outside its range (named in the message).
    TypeError
        Non-numeric images or non-integer disparity bounds.

    Notes
    -----
    The chapter (§5) matches the left view shifted one way against the right view shifted
    the other while sweeping the shift, with G_U^(2) at σ fixed.  G_U^(2) shifts uniformly
    by σ²/|x_U| with a gain ramp (``docs/derivations.md``), and large Green shifts blur the
    images and shift textures by more than their first moment (third cumulant ``-u³``: a
    G_u shift by 2 px moves a σ = 1 px random-dot texture by 2.09 px, by 3 px 2.76 px), so the
    sweeps apply the Green shifts to the sub-pixel remainder only (half of it to each view,
    at most 0.5 px each) and the integer part as an index offset.  The cost then belongs to
    the left pixel within half a pixel of the window's centre (exact on fronto-parallel
    surfaces).  They stay worse than ``"sgm"`` on real scenes (``docs/stereo.md``).
    ``"sgm"`` uses the Green shift where it is exact and cheap: the fractional disparity
    samples of the cost volume (``subpixel_steps > 1``).  Census cost, path aggregation and
    the left-right check follow Hirschmüller (2008); matching costs saturate at
    :data:`gfgpu.stereo.spec.COST_MAX` (254) so that a cost fits a byte.

    References
    ----------
    .. [1] Torreão et al., "Green's Functions of Matching Equations", 2007, §5, eq. 9, 14.
    .. [2] H. Hirschmüller, "Stereo processing by semiglobal matching and mutual
       information", IEEE PAMI 30(2), 2008.
    .. [3] R. Zabih, J. Woodfill, "Non-parametric local transforms for computing visual
       correspondence", ECCV 1994.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.stereo import disparity
    >>> rng = np.random.default_rng(0)
    >>> right = rng.random((48, 96)).astype(np.float32)
    >>> left = np.roll(right, 5, axis=1)     # left pixel x matches right pixel x - 5
    >>> d = disparity(left, right, 12, backend="numpy")
    >>> round(float(np.nanmedian(d[:, 20:])))
    5
    >>> bool(np.isnan(d[:, :5]).all())      # the left band: its matches are outside the right view
    True
    >>> d, conf = disparity(left, right, 12, return_confidence=True, backend="numpy")
    >>> bool(((conf > 0) == np.isfinite(d)).all() and conf.max() <= 1)
    True
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    lft = grey_image(left, "left")
    rgt = grey_image(right, "right")
    if lft.shape != rgt.shape:
        raise ValueError(f"left and right must have one shape, got {np.shape(left)} and {np.shape(right)}")
    h, w = lft.shape
    if min(h, w) < 2:
        raise ValueError(f"images must be at least 2x2, got {h}x{w}")
    d_max = _int_arg(max_disparity, "max_disparity")
    d_min = _int_arg(min_disparity, "min_disparity")
    if not -4 * MAX_RANGE <= d_min <= 4 * MAX_RANGE:
        raise ValueError(f"min_disparity must satisfy |min_disparity| <= {4 * MAX_RANGE}; got {d_min}")
    if not d_min < d_max <= d_min + MAX_RANGE:
        raise ValueError(f"max_disparity must satisfy min_disparity ({d_min}) < max_disparity <= "
                         f"min_disparity + {MAX_RANGE}; got {d_max}")
    if not isinstance(return_confidence, (bool, np.bool_)):
        raise TypeError(f"return_confidence must be True or False, got {return_confidence!r}")
    if speckle_size is None:
        speckle_size = postfilter.SPECKLE_SIZE if method == "sgm" else 0
    post = postfilter.check_postfilter(speckle_size, speckle_range, min_confidence)
    lr_check = flag("lr_check", lr_check)       # not truthiness: 'False' is an error, not True
    subpixel = flag("subpixel", subpixel)
    be = resolve_backend(backend, device, left)     # a CUDA tensor: matched on its GPU
    report = progress if progress is not None else (lambda n: None)
    step, sigma = _sweep_scalars(sweep_step, sigma)     # every argument checked, used or not
    if method == "sgm":
        window, steps, radius, p1, p2, paths, uniq = _sgm_options(window, subpixel_steps, census_radius, p1, p2,
                                                                  paths, uniqueness)
        _check_memory(be, lft.shape, d_max, d_min, method, steps, paths, window)
        # the speckle filter on the device where it can run there (the same map): not a serial
        # host step after the kernels
        on_device = _device_speckles(be, lft.shape, post, subpixel)
        disp, conf = _sgm(be, lft, rgt, d_min, d_max, steps, radius, window, p1, p2, paths,
                          uniq, lr_check, report, speckles=post[:2] if on_device else None)
        if on_device:
            post = (0, post[1], post[2])
        if not subpixel:
            disp = np.rint(disp * steps) / steps
        disp = disp.astype(np.float32)
        return _finish(disp, conf, post, return_confidence, left)
    window = 9 if window is None else _int_arg(window, "window")
    if window < 1 or window % 2 == 0 or window > 31:
        raise ValueError(f"window must be odd, 1..31, for the sweeps; got {window}")
    _sgm_scalars(subpixel_steps, census_radius, p1, p2, paths, uniqueness)
    if sigma is None:
        sigma = 4.0 * math.sqrt(w * (max(abs(d_min), abs(d_max)) + 1))
    disp, conf = _sweep(be, lft, rgt, d_min, d_max, step, method, window // 2, float(sigma), bool(lr_check),
                        report)
    if not subpixel:
        disp = (np.rint((disp - d_min) / step) * step + d_min).astype(np.float32)
    return _finish(disp, conf, post, return_confidence, left)


def _finish(disp, conf, post, return_confidence, left):
    # the post-filters on the host (the same numpy code for every backend's map), then the
    # caller's array kind
    if post[0] or post[2]:
        # the confidence is filtered only where it is returned or thresholded (a pass and a copy
        # of the map fewer)
        keep_conf = return_confidence or post[2] > 0
        disp, filtered = postfilter.apply_postfilter(disp, conf if keep_conf else None, *post)
        conf = filtered if keep_conf else conf
    return as_kind((disp, conf) if return_confidence else disp, kind_of(left), left)


#: bytes per pixel and disparity sample of the "sgm" method where whole volumes are held: the
#: numpy specification's int32/int64 temporaries (40, measured: ru_maxrss growth of a 300x450,
#: 96-disparity call); the uint8 cost and one int16 sum of the OpenCL GPU matcher (3,
#: _opencl_groups.py); the int16 cost and aggregate of Warp (4)
_SGM_BYTES = {"numpy": 40, "opencl": 3}
_SGM_BYTES_DEFAULT = 4


def _streams_bands(be):
    # the OpenCL matcher on CPU devices streams bands of rows (_opencl.py, planned by band_plan.py)
    return be.name == "opencl" and be.kind == "cpu"


def disparity_memory(shape, max_disparity, *, min_disparity=0, method="sgm", subpixel_steps=2, paths=4,
                     window=None, backend=None, device=None):
    """Peak working memory of :func:`disparity` in bytes (an estimate, within ~10 %).

    ``"sgm"`` on OpenCL CPU devices streams bands of ``k ≈ sqrt(H/2)`` rows through its two
    sweeps: it keeps the byte costs of the whole image (1 byte per pixel and disparity sample,
    ``D = (max - min) * subpixel_steps + 1``) when they take at most 128 MiB and the working set
    allows, plus O((H/k)·W·D) path-state checkpoints; else it recomputes them per coarse band of
    ``K ≈ sqrt(2H)`` rows (O(K·W·D) bytes and O((H/K + K/k)·W·D) checkpoints); plus O(k·W·D)
    band buffers and the cost kernel's ring of ``window`` rows of Hamming distances
    (O(window·W·D) bytes).  On OpenCL GPUs
    it holds a uint8 cost and one int16 sum (H, W, D) volume (3 bytes per sample), on Warp two
    int16 volumes (4 bytes), on the numpy specification ~40.  Plus O(H·W) images and census
    codes; the sweeps hold O(H·W).  :func:`disparity` refuses (a ``ValueError`` before
    allocating anything) a request above the working set: the device's budget (half a GPU's
    memory), :func:`gfgpu.working_set` / ``GFGPU_WORKING_SET`` if set, and on CPU devices half
    the host's physical memory.

    Parameters
    ----------
    shape : (H, W) or (H, W, C) tuple of int
        Shape of one view.
    max_disparity, min_disparity, method, subpixel_steps, paths, window, backend, device
        As for :func:`disparity` (``window`` matters to ``"sgm"`` on CPU devices only).

    Returns
    -------
    int

    Raises
    ------
    ValueError
        ``shape`` not 2 or 3 positive integers, an empty disparity range, or ``window`` not odd
        in 1..15 (``"sgm"``).
    TypeError
        ``window`` not an integer.

    Examples
    --------
    >>> round(disparity_memory((1000, 1500), 191, backend="warp") / 2**30, 2)   # GiB
    2.26
    """
    shp = tuple(int(v) for v in shape)
    if len(shp) not in (2, 3) or min(shp) < 1:
        raise ValueError(f"shape must be (H, W) or (H, W, C) of positive integers, got {shape!r}")
    if not max_disparity > min_disparity:
        raise ValueError(f"max_disparity must exceed min_disparity, got {max_disparity} <= {min_disparity}")
    px = shp[0] * shp[1]
    if method != "sgm":
        return px * 4 * (SWEEP_PLANES + 12)
    block = 3 if window is None else _int_arg(window, "window")
    if block < 1 or block % 2 == 0 or block > 15:
        raise ValueError(f"window must be odd, 1..15, for method 'sgm'; got {window}")
    be = resolve_backend(backend, device)
    return _sgm_memory(be, shp[:2], (int(max_disparity) - int(min_disparity)) * int(subpixel_steps) + 1,
                       int(subpixel_steps), paths, _budget(be), block=block)


def _sgm_base(shape, steps):
    # images, census codes (left and ``steps`` right planes), maps and the host's checks
    return shape[0] * shape[1] * (16 * (1 + steps) + 40)


def _sgm_memory(be, shape, n, steps, paths, budget, keep=None, block=3):
    h, w = shape
    base = _sgm_base(shape, steps)
    if _streams_bands(be):
        from .band_plan import match_memory, match_plan
        if keep is None:     # as the matcher plans it
            return base + match_plan(h, w, n, paths, block, None if budget is None else budget - base)[2]
        return base + match_memory(h, w, n, paths, keep, block)
    return base + h * w * n * _SGM_BYTES.get(be.name, _SGM_BYTES_DEFAULT)


def _size(nbytes):
    return f"{nbytes / 2**30:.3f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.2f} MiB"


def _host_memory():
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def _budget(be):
    """Working memory disparity may use on ``be``: the working set (gfgpu.working_set,
    GFGPU_WORKING_SET, a GPU's budget), else half the host's physical memory."""
    budget = get_working_set(be)
    if budget is None:
        host = _host_memory()
        budget = None if host is None else host // 2
    return budget


def _check_memory(be, shape, d_max, d_min, method, steps, paths=4, block=3):
    n = (d_max - d_min) * (steps if method == "sgm" else 1) + 1
    budget = _budget(be)
    if method == "sgm":
        # the least this request can run in (the band matcher recomputes costs when short)
        need = _sgm_memory(be, shape, n, steps, paths, budget, keep=False, block=block)
    else:
        need = disparity_memory(shape, d_max, min_disparity=d_min, method=method, backend=be)
    if budget is not None and need > budget:
        where = "the working set" if get_working_set(be) is not None else "half the host's memory"
        raise ValueError(
            f"disparity needs about {_size(need)} for {shape[1]}x{shape[0]} px and {n} disparity samples, "
            f"more than {where} ({_size(budget)} on {be.name}); lower max_disparity - min_disparity, "
            f"subpixel_steps or the image size, or raise the working set (gfgpu.working_set, "
            f"GFGPU_WORKING_SET)")


def estimate_max_disparity(left, right, *, min_disparity=0, factor=4, margin=8, backend=None,
                           device=None):
    """A search range for a pair of unknown range: a coarse ``"sgm"`` pass at ``1/factor`` size.

    Both views are reduced by ``factor`` (area averaging), matched over
    ``min_disparity / factor .. W / (2 factor)`` (half the reduced width), and the 99.5th
    percentile of the valid coarse disparities, scaled back and raised by ``margin`` px, is
    rounded up to ``16 k - 1`` (OpenCV's multiples of 16).  The coarse pass costs about 1/64 of
    the full one.  A pair whose coarse pass finds nothing (too small, flat) gets ``W // 4``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) array_like
        The rectified pair, as for :func:`disparity`.
    min_disparity : int, optional
        The smallest disparity that will be searched.
    factor : int, optional
        Reduction of the coarse pass (2..8).
    margin : int, optional
        Pixels added to the coarse estimate (>= 0).
    backend, device : optional
        Where the coarse pass runs.

    Returns
    -------
    int
        ``max_disparity`` for :func:`disparity`, at most ``W - 1``.

    Raises
    ------
    ValueError
        As for :func:`disparity`, or ``factor``/``margin`` outside their ranges.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.full((96, 256), 21.0)
    >>> left, right = random_dot_stereogram(truth, seed=2)
    >>> estimate_max_disparity(left, right, backend="numpy")
    31
    """
    lft = grey_image(left, "left")
    rgt = grey_image(right, "right")
    if lft.shape != rgt.shape:
        raise ValueError(f"left and right must have one shape, got {np.shape(left)} and {np.shape(right)}")
    f = _int_arg(factor, "factor")
    if not 2 <= f <= 8:
        raise ValueError(f"factor must be 2..8, got {f}")
    extra = _int_arg(margin, "margin")
    if extra < 0:
        raise ValueError(f"margin must be >= 0, got {extra}")
    d_min = _int_arg(min_disparity, "min_disparity")
    h, w = lft.shape
    fallback = max(1, min(w - 1, w // 4))
    hc, wc = h // f, w // f
    if min(hc, wc) < 16:
        return fallback
    def reduce(img):
        return img[:hc * f, :wc * f].reshape(hc, f, wc, f).mean(axis=(1, 3))
    lo = math.floor(d_min / f)
    hi = max(lo + 2, wc // 2)
    coarse = disparity(reduce(lft), reduce(rgt), hi, min_disparity=lo, subpixel_steps=1,
                       backend=backend, device=device)
    valid = coarse[np.isfinite(coarse)]
    if valid.size < 0.05 * coarse.size:
        return fallback
    top = float(np.percentile(valid, 99.5)) * f + extra
    top = max(top, d_min + 1)
    return int(min(16 * math.ceil((top + 1) / 16) - 1, w - 1))


def disparity_work(max_disparity, *, min_disparity=0, method="sgm", sweep_step=0.5, **_):
    """Units of work :func:`disparity` reports through ``progress`` (for a progress bar)."""
    if method == "sgm":
        return 3
    return int(round((max_disparity - min_disparity) / float(sweep_step))) + 1


def random_dot_stereogram(disparity_map, seed=0):
    """Rectified random-dot pair with a known left-view disparity (the chapter's Fig. 8).

    The right view is a smoothed random-dot field (Gaussian, σ = 1 px) scaled to [0, 255];
    row ``y`` of the left view samples row ``y`` of the right view at column ``x - d[y, x]``
    (cubic interpolation, nearest extension), so a left pixel at column ``x`` matches the
    right pixel at column ``x - d`` of the same row.

    Parameters
    ----------
    disparity_map : (H, W) array_like
        True disparity of the left view, in pixels (any real values).
    seed : int
        Seed of the dot field.

    Returns
    -------
    left, right : (H, W) float32 ndarrays

    Examples
    --------
    >>> import numpy as np
    >>> left, right = random_dot_stereogram(np.full((32, 48), 3.0))
    >>> left.shape, left.dtype.name
    ((32, 48), 'float32')
    """
    from scipy import ndimage
    d = np.asarray(disparity_map, np.float64)
    if d.ndim != 2 or d.size == 0 or not np.isfinite(d).all():
        raise ValueError(f"disparity_map must be a finite, non-empty 2-D array, got shape {d.shape}")
    h, w = d.shape
    rng = np.random.default_rng(seed)
    right = ndimage.gaussian_filter(rng.random((h, w)), 1.0)
    right = (right - right.min()) / np.ptp(right) * 255
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    left = ndimage.map_coordinates(right, [yy, xx - d], order=3, mode="nearest")
    return left.astype(np.float32), right.astype(np.float32)
