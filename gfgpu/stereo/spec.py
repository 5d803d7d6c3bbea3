"""Executable numpy specifications of the stereo matcher's fused kernels.

Census, matching cost, semi-global aggregation, disparity selection, the left-right check and the
chapter's sweep.  Every backend's kernel (``_warp.py``, ``stereo.cl`` through ``_opencl.py``) must
compute what the function here computes (integer kernels bit for bit; float kernels to rounding);
the numpy backend runs these functions themselves (``_numpy.py``), and ``tests/stereo`` checks every
backend against them.  They are written in terms of arrays only.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SGM_PATHS", "NO_MATCH", "OUT_OF_VIEW", "COST_MAX", "PATH_UNDEFINED", "NO_CANDIDATE", "SWEEP_PLANES",
    "census_transform_reference", "in_view_reference", "cost_shift", "census_cost_reference", "sgm_aggregate_reference",
    "select_disparity_reference", "left_right_check_reference", "left_right_reference",
    "semi_global_match_reference", "sweep_update_reference", "subpixel_jobs", "shift_recursion",
    "subpixel_planes_reference",
]

#: the 8 path directions (dy, dx) of semi-global aggregation; the first 4 are the axis paths
SGM_PATHS = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))

#: right-view disparity (in steps) of a pixel that no left pixel can match
NO_MATCH = -(2**31)

#: cost of a sample that is no candidate of the disparity selection (out of view, or no left pixel):
#: int32's largest, above every aggregated cost
NO_CANDIDATE = 2**31 - 1


def census_transform_reference(image, radius):
    """Census transform: bit ``b`` set where neighbour ``b`` is darker than the centre.

    Neighbours are the ``(2r+1)^2 - 1`` offsets of the square window, row-major, skipping the
    centre; pixels beyond the border repeat the nearest edge pixel.

    Parameters
    ----------
    image : (H, W) float ndarray
    radius : int
        1 to 3.

    Returns
    -------
    (H, W) uint64 ndarray
    """
    img = np.asarray(image)
    h, w = img.shape
    pad = np.pad(img, radius, mode="edge")
    code = np.zeros((h, w), np.uint64)
    bit = 0
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            if dy == 0 and dx == 0:
                continue
            nb = pad[radius + dy:radius + dy + h, radius + dx:radius + dx + w]
            code |= (nb < img).astype(np.uint64) << np.uint64(bit)
            bit += 1
    return code


def in_view_reference(w, first_step, n_disp, steps, radius):
    """Which disparity samples have their whole matching window inside the other view.

    Sample ``k`` (disparity ``d = (first_step + k) / steps = n + f / steps``, ``0 <= f <
    steps``) of left column ``x`` is *in view* when the right pixel's whole window lies inside
    the image: ``radius <= x - n <= w - 1 - radius``.  Then every column of the (border-clamped)
    left window has its right column inside, and every right pixel that can be matched at all
    sees its whole disparity range (what makes the left-right check decisive at the image's
    edges).  For every ``x`` the samples in view are one contiguous run of ``k`` (possibly
    empty).

    Returns
    -------
    (w, n_disp) bool ndarray
    """
    xr = np.arange(w)[:, None] - (first_step + np.arange(n_disp))[None] // steps
    return (xr >= radius) & (xr <= w - 1 - radius)


#: cost and aggregated cost of a disparity sample that is not in view (no right pixel to match)
OUT_OF_VIEW = -1

#: largest matching cost: block sums saturate here, so that a cost and the out-of-view mark fit
#: one byte (CPU kernels keep a whole (H, W, D) cost volume of bytes).  Saturation changes no
#: winner that matters: bad-2 on the Middlebury scenes of benchmarks/stereo.py is unchanged to
#: 0.01 % (a cap at 127 costs up to 1 %: docs/stereo.md)
COST_MAX = 254


def cost_shift(block):
    """Bits by which a ``block x block`` sum of Hamming distances is shifted right before it
    saturates at :data:`COST_MAX`: ``round(2 log2(block / 3))``, at least 0 (0 for blocks 1
    and 3, 1 for 5, 2 for 7, 3 for 9, 4 for 11 and 13, 5 for 15).  The costs of every block
    then span about the 3 x 3 block's range: unshifted, the sums of blocks from 7 x 7 up
    saturated on correct matches as well (Hamming distances of a few bits per pixel times 49 to
    225 pixels) and ties left most pixels without a unique minimum (bad-2 19-100 % on the
    Middlebury scenes of ``benchmarks/stereo.py``)."""
    return max(0, int(round(2 * np.log2(block / 3)))) if block > 3 else 0


def census_cost_reference(census_left, census_right, first_step, n_disp, steps, block):
    """Matching-cost volume: Hamming distances of census codes, summed over a block, shifted
    right by :func:`cost_shift` bits and at most :data:`COST_MAX`.

    ``cost[y, x, k]`` is the sum over the ``block x block`` window around ``(y, x)`` (clamped
    at the border) of ``popcount(L[y', x'] ^ R_f[y', x' - n])`` for the disparity
    ``d = (first_step + k) / steps = n + f / steps`` (``0 <= f < steps``), where ``R_f`` is the census
    of the right view shifted by ``+f / steps`` px (``census_right[f]``).  Samples that are not
    in view (:func:`in_view_reference` with ``radius = block // 2``: the right pixel's block
    is not inside the image) are :data:`OUT_OF_VIEW` (-1): there is nothing to match.

    Parameters
    ----------
    census_left : (H, W) uint64 ndarray
    census_right : (steps, H, W) uint64 ndarray
    first_step, n_disp, steps, block : int
        ``first_step = d_min * steps``; ``n_disp`` disparity samples; the block side (odd).

    Returns
    -------
    (H, W, n_disp) int16 ndarray
    """
    cl = np.asarray(census_left)
    cr = np.asarray(census_right)
    h, w = cl.shape
    cols = np.arange(w)
    ham = np.zeros((h, w, n_disp), np.int32)
    for k in range(n_disp):
        n, f = divmod(first_step + k, steps)
        xr = cols - n
        inside = (xr >= 0) & (xr < w)
        ham[:, inside, k] = np.bitwise_count(cl[:, inside] ^ cr[f][:, xr[inside]])
    if block > 1:
        r = block // 2
        rows = np.clip(np.arange(h)[:, None] + np.arange(-r, r + 1)[None], 0, h - 1)
        colsw = np.clip(cols[:, None] + np.arange(-r, r + 1)[None], 0, w - 1)
        ham = ham[rows].sum(axis=1)                      # (H, W, D): window rows summed
        ham = ham[:, colsw].sum(axis=2)
    ham = np.minimum(ham >> cost_shift(block), COST_MAX)
    view = in_view_reference(w, first_step, n_disp, steps, block // 2)
    ham[:, ~view] = OUT_OF_VIEW
    return ham.astype(np.int16)


#: path value (int32) of a sample that is not in view in the aggregation's recursion: above every
#: path value in view (a cost plus at most P2), so never a minimum
PATH_UNDEFINED = 1 << 24


def _path_start(cost):
    return np.where(cost < 0, np.int32(PATH_UNDEFINED), cost)


def _path_step(prev, cost, p1, p2):
    """One step of the path recursion, vectorised over lines: prev, cost are (lines, D) int32.

    Samples out of view have cost < 0 and path value :data:`PATH_UNDEFINED`; a sample whose
    predecessor is out of view (it enters the view here) starts afresh: its "stay" term is the
    predecessor's minimum ``m`` (so ``L = C`` there, no penalty), and a predecessor with nothing in
    view is no predecessor (``m = PATH_UNDEFINED`` gives ``L = C``)."""
    undefined = np.int32(PATH_UNDEFINED)
    m = prev.min(axis=1, keepdims=True)
    pad = np.full((prev.shape[0], 1), undefined, np.int32)
    lower = np.concatenate([pad, prev[:, :-1]], axis=1) + p1
    upper = np.concatenate([prev[:, 1:], pad], axis=1) + p1
    stay = np.where(prev >= undefined, m, prev)
    cur = cost + np.minimum(np.minimum(stay, np.minimum(lower, upper)), m + p2) - m
    return np.where(cost < 0, undefined, cur)


def sgm_aggregate_reference(cost, p1, p2, paths=8):
    """Semi-global aggregation: the sum over ``paths`` directions r of

    ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d±1) + P1, min_k L_r(p-r, k) + P2)
    - min_k L_r(p-r, k)``,

    with ``L_r(p, d) = C(p, d)`` where ``p - r`` lies outside the image (integer arithmetic,
    so every backend gives the same sums).  Samples out of view (``C < 0``, see
    :func:`census_cost_reference`) take no part: the minima run over the samples in view of
    ``p - r``, a missing ``d ± 1`` is no candidate, a sample entering the view at ``p`` takes
    ``min_k L_r(p-r, k)`` as its own predecessor (it starts afresh, ``L = C``), and their
    aggregated cost is :data:`OUT_OF_VIEW` (-1).

    Parameters
    ----------
    cost : (H, W, D) int16 ndarray
    p1, p2 : int
        Penalties for disparity changes of one step and of more than one step.
    paths : {4, 8}
        The first 4 (axis) or all 8 of :data:`SGM_PATHS`.

    Returns
    -------
    (H, W, D) int16 ndarray
    """
    c = np.asarray(cost).astype(np.int32)
    h, w, _ = c.shape
    total = np.zeros(c.shape, np.int32)
    for dy, dx in SGM_PATHS[:paths]:
        if dx == 0:       # vertical: one line per column, stepping along rows
            order = range(h) if dy > 0 else range(h - 1, -1, -1)
            prev = None
            for y in order:
                cur = _path_start(c[y]) if prev is None else _path_step(prev, c[y], p1, p2)
                total[y] += np.where(c[y] < 0, 0, cur)
                prev = cur
            continue
        # stepping along columns; the predecessor of row y is row y - dy of the previous column
        order = range(w) if dx > 0 else range(w - 1, -1, -1)
        prev = None
        for x in order:
            cur = _path_start(c[:, x])
            if prev is not None:
                if dy == 0:
                    cur = _path_step(prev, c[:, x], p1, p2)
                elif dy > 0:
                    cur = np.concatenate([cur[:1], _path_step(prev[:-1], c[1:, x], p1, p2)])
                else:
                    cur = np.concatenate([_path_step(prev[1:], c[:-1, x], p1, p2), cur[-1:]])
            total[:, x] += np.where(c[:, x] < 0, 0, cur)
            prev = cur
    total[c < 0] = OUT_OF_VIEW
    return total.astype(np.int16)


def select_disparity_reference(aggregated, d_min, steps, uniqueness):
    """Winner-take-all for both views, with validity tests and a parabola fit.

    Left view, over the samples in view (``S >= 0``; :data:`OUT_OF_VIEW` entries are no
    candidates): ``k* = argmin_k S[y, x, k]`` (the first minimum).  The pixel is rejected
    (NaN) when

    - no sample is in view;
    - the minimum is cut by the image: ``k* - 1`` or ``k* + 1`` lies inside the range but is
      out of view (the true minimum may lie beyond the image's edge);
    - it is not unique: no sample in view lies more than one step from ``k*``, or the best of
      them, ``S2``, does not exceed ``S[k*] (1 + uniqueness/100)`` (so exact ties are
      rejected even with ``uniqueness = 0``).

    Otherwise ``d = d_min + (k* + δ) / steps`` with the parabola vertex ``δ = (S[k*-1] -
    S[k*+1]) / (2 (S[k*-1] - 2 S[k*] + S[k*+1]))`` (0 at the range's ends or when the
    curvature is not positive; with ``steps = 2`` the two-phase fit of :func:`_half_pixel_fit`
    where ``k* ± 2`` are in view), and ``margin = (S2 - S[k*]) / S2`` (float32; 1 where ``S2 =
    0`` cannot occur for a kept pixel, 0 where rejected).  Right view: the first minimum over
    ``k`` of ``S[y, xr + d_k, k]`` (index ``d_min*steps + k``, in steps) over the ``k`` whose
    left pixel ``xr + d_k`` (``d_k`` rounded down) lies inside and whose sample is in view;
    :data:`NO_MATCH` if none.

    Returns
    -------
    disp : (H, W) float32 ndarray
    disp_right : (H, W) int32 ndarray, in steps
    margin : (H, W) float32 ndarray, in [0, 1]
    """
    s = np.asarray(aggregated).astype(np.int64)
    h, w, n = s.shape
    big = np.int64(NO_CANDIDATE)
    view = s >= 0
    sv = np.where(view, s, big)
    k = sv.argmin(axis=2)
    best = np.take_along_axis(sv, k[..., None], 2)[..., 0]
    has = best < big
    ks = np.arange(n)[None, None]
    far = np.abs(ks - k[..., None]) > 1
    second = np.where(far, sv, big).min(axis=2)
    unique = has & (second < big) & (second * 100 > best * (100 + uniqueness))
    sm = np.take_along_axis(s, np.maximum(k - 1, 0)[..., None], 2)[..., 0]
    sp = np.take_along_axis(s, np.minimum(k + 1, n - 1)[..., None], 2)[..., 0]
    cut = ((k > 0) & (sm < 0)) | ((k < n - 1) & (sp < 0))
    den = (sm - 2 * best + sp).astype(np.float32)
    inner = (k > 0) & (k < n - 1) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(inner, (sm - sp).astype(np.float32) / (np.float32(2) * den), np.float32(0))
    if steps == 2:
        delta = _half_pixel_fit(s, k, best, sm, sp, delta)
    disp = ((np.float32(d_min * steps) + k.astype(np.float32) + delta) / np.float32(steps)).astype(np.float32)
    keep = unique & ~cut
    disp[~keep] = np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        margin = ((second - best).astype(np.float32) / second.astype(np.float32)).astype(np.float32)
    margin = np.where(keep, margin, np.float32(0)).astype(np.float32)
    right = np.full((h, w), NO_MATCH, np.int32)
    best_r = np.full((h, w), big, np.int64)
    cols = np.arange(w)
    for kk in range(n):
        xl = cols + (d_min * steps + kk) // steps
        ok = (xl >= 0) & (xl < w)
        val = np.full((h, w), big, np.int64)
        val[:, ok] = sv[:, xl[ok], kk]
        better = val < best_r
        best_r[better] = val[better]
        right[better] = d_min * steps + kk
    return disp, right, margin


def _half_pixel_fit(s, k, best, sm, sp, delta):
    """The refinement of half-pixel samples (``steps = 2``): the winner's neighbours one step
    away come from the other phase (the half-pixel plane, blurred by its Green shift, or the
    unshifted one), those two steps away from its own, so a parabola through ``k* ± 1`` mixes
    two baselines.  Fitted instead: ``S[k* + j] = A (j/2 - δ)^2 + B_(j mod 2)`` through ``k* -
    2 .. k* + 2``, one curvature and one baseline per phase, ``δ = (2 (S₋₁ - S₊₁) + S₋₂ - S₊₂) /
    (2 (S₋₂ + S₊₂ - 2 S₀))`` in steps, clipped to [-1, 1] (float32; the parabola where ``k* ± 2``
    is outside the range or out of view, or the curvature is not positive)."""
    n = s.shape[2]
    sm2 = np.take_along_axis(s, np.maximum(k - 2, 0)[..., None], 2)[..., 0]
    sp2 = np.take_along_axis(s, np.minimum(k + 2, n - 1)[..., None], 2)[..., 0]
    den = sm2 + sp2 - 2 * best
    ok = (k >= 2) & (k <= n - 3) & (sm >= 0) & (sp >= 0) & (sm2 >= 0) & (sp2 >= 0) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        fit = (2 * (sm - sp) + sm2 - sp2).astype(np.float32) / (np.float32(2) * den.astype(np.float32))
    fit = np.minimum(np.maximum(fit, np.float32(-1)), np.float32(1))
    return np.where(ok, fit, delta).astype(np.float32)


def left_right_check_reference(disp, right, steps, tol, return_difference=False):
    """NaN where the right view's winner at ``x - d`` disagrees with ``d`` by more than ``tol`` px.

    ``xr = rint(x - d)`` (float64, ties to even) must lie inside the row; ``right`` is the
    right view's winner in steps (:data:`NO_MATCH` where none), or, with ``steps=None``, in px
    (NaN where none), and ``|right[y, xr] / steps - d| <= tol`` (float64).  With
    ``return_difference``, also ``|d - d_right|`` in px (float64; NaN where rejected).
    """
    h, w = disp.shape
    xr = np.rint(np.arange(w, dtype=np.float64) - disp)      # NaN where disp is
    ok = (xr >= 0) & (xr <= w - 1)                           # NaN compares False
    idx = np.where(ok, xr, 0).astype(np.intp)
    idx += np.arange(0, h * w, w, dtype=np.intp)[:, None]
    back = np.asarray(right).ravel().take(idx)
    if steps is None:
        back_px = back.astype(np.float64, copy=False)        # NaN where no match
    else:
        ok &= back != NO_MATCH
        back_px = back / steps
    diff = np.abs(back_px - disp)
    ok &= diff <= tol
    out = np.where(ok, disp, np.nan).astype(disp.dtype, copy=False)
    if return_difference:
        return out, np.where(ok, diff, np.nan)
    return out


def left_right_reference(disp, disp_right, margin, steps, tol):
    """The matcher's left-right check of its maps (the ``stereo.left_right`` kernel).

    ``disp`` (H, W) float32 (NaN where rejected), ``disp_right`` (H, W) int32 in steps and
    ``margin`` (H, W) float32 as :func:`select_disparity_reference` returns them.  Returns
    ``disp`` with NaN where :func:`left_right_check_reference` rejects, and the confidence
    ``margin * (1 - |d - d_R| / (2 tol))`` (float64 product rounded to float32; 1 where both
    views agree exactly, 1/2 at the tolerance), 0 where ``disp`` is NaN.
    """
    out, diff = left_right_check_reference(np.asarray(disp, np.float32), disp_right, steps, tol,
                                           return_difference=True)
    conf = np.asarray(margin, np.float32) * (1 - np.where(np.isnan(diff), 2 * tol, diff) / (2 * tol))
    return out, np.where(np.isnan(out), 0, conf).astype(np.float32)


def semi_global_match_reference(census_left, census_right, first_step, n_disp, steps, block, p1, p2, paths,
                                uniqueness):
    """The whole semi-global matcher after the census: cost, aggregation and selection,
    ``select_disparity_reference(sgm_aggregate_reference(census_cost_reference(...)))``.

    Its device launchers never hold the two volumes at once where memory is short (the CPU
    OpenCL launcher streams bands of rows, O(band x W x D)); every backend returns these values
    exactly (integer costs).

    Parameters
    ----------
    census_left : (H, W) uint64 ndarray
    census_right : (steps, H, W) uint64 ndarray
    first_step, n_disp, steps, block
        As for :func:`census_cost_reference` (``first_step = d_min * steps``).
    p1, p2, paths
        As for :func:`sgm_aggregate_reference`.
    uniqueness
        As for :func:`select_disparity_reference`.

    Returns
    -------
    disp, disp_right, margin
        As :func:`select_disparity_reference` returns them.
    """
    cost = census_cost_reference(census_left, census_right, first_step, n_disp, steps, block)
    return select_disparity_reference(sgm_aggregate_reference(cost, p1, p2, paths), first_step // steps,
                                      steps, uniqueness)


#: planes of the sweep's state (float32): best cost, its disparity, the cost one step before the
#: best, one step after it, the previous step's cost, the best cost more than one step from the
#: best (for the uniqueness test), the minimum over all steps but the last one, and the right
#: view's best cost and its disparity (for the left-right check)
SWEEP_PLANES = 9


def sweep_update_reference(state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius):
    """One step of the running-best sweep (methods ``"uniform"`` and ``"affine"``).

    The cost of disparity ``d = offset + f`` at left pixel ``(y, x)`` is the sum over the
    ``(2 radius + 1)^2`` window of ``(gain_left[x'] left_shifted[y', x'] -
    gain_right[x' - offset] right_shifted[y', x' - offset])^2`` around ``(y, x)`` (indices
    clamped at the border; the gains are (W,) rows, ones for G_u, the inverse filtered
    constant row for G_U^(2)).  The caller shifted the left view by ``-f/2`` and the right
    view by ``+f/2`` (``0 <= f < 1``), so the window compares left ``x' + f/2`` with right
    ``x' + f/2 - d``: the cost of the left pixel within half a pixel of ``x'`` (exact on
    fronto-parallel surfaces; on a slope s the position error is at most ``s/2`` px of
    disparity).  Where the right window around ``x - offset`` is not inside the image (not in
    view, :func:`in_view_reference` with ``n = offset``) the cost is ``+inf``: no candidate.

    ``state`` (:data:`SWEEP_PLANES`, H, W) float32 holds the best cost, its ``d``, the costs
    one step before and after it, the previous step's cost, ``second`` (the best cost more
    than one step from the best), ``older`` (the minimum over the steps before the previous
    one), and for the right view's pixel ``xr`` its best cost and ``d``; initialise best,
    second, older and the right best cost to ``+inf``, the others to NaN.  It is updated in
    place: a cost below the best makes a new best (its "before" is the previous cost, its
    "second" is ``older``); otherwise the cost is the best's "after" if that is still NaN,
    else it enters ``second``.  The cost at left pixel ``x`` is also the cost of right pixel
    ``xr = x - offset`` (one left pixel per right pixel and step): a cost below the right
    view's best makes a new one.  Steps must come in increasing ``d``, one step apart.
    """
    ls = np.asarray(left_shifted, np.float64) * np.asarray(gain_left, np.float64)
    rs = np.asarray(right_shifted, np.float64) * np.asarray(gain_right, np.float64)
    h, w = ls.shape
    cols = np.arange(w)
    rs = rs[:, np.clip(cols - offset, 0, w - 1)]           # right pixel x - offset at column x
    sq = (ls - rs) ** 2
    rows = np.clip(np.arange(h)[:, None] + np.arange(-radius, radius + 1)[None], 0, h - 1)
    win = np.clip(cols[:, None] + np.arange(-radius, radius + 1)[None], 0, w - 1)
    cost = sq[rows].sum(axis=1)[:, win].sum(axis=2).astype(np.float32)
    view = in_view_reference(w, offset, 1, 1, radius)[:, 0]
    cost[:, ~view] = np.inf
    best, best_d, before, after, prev, second, older, best_r, best_rd = state
    xr = cols - offset                      # in view: inside the image, one x per xr
    better = view[None] & (cost < best_r[:, np.clip(xr, 0, w - 1)])
    yy, xx = np.nonzero(better)
    best_r[yy, xr[xx]] = cost[yy, xx]
    best_rd[yy, xr[xx]] = np.float32(d)
    new = cost < best
    after_step = (~new) & np.isnan(after)   # the step right after the current best
    rest = (~new) & ~after_step
    after[after_step] = cost[after_step]
    second[rest] = np.minimum(second[rest], cost[rest])
    second[new] = older[new]
    before[new] = prev[new]
    after[new] = np.nan
    best[new] = cost[new]
    best_d[new] = np.float32(d)
    older[...] = np.fmin(older, prev)       # prev is NaN before the first step
    prev[...] = cost
    return state


def subpixel_jobs(steps):
    """The Green shifts of the right view's sub-pixel planes 1 .. steps - 1: per plane ``f`` a
    tuple of ``(amount, offset)`` shifts whose mean it is (:func:`subpixel_planes_reference`):
    ``((f / steps, 0),)``, and for the half-pixel plane (``2 f = steps``) also ``(-1/2, 1)``, the
    anticausal shift moved by one pixel (a kernel symmetric about the half-pixel point)."""
    return [((f / steps, 0),) + (((-0.5, 1),) if 2 * f == steps else ()) for f in range(1, steps)]


def shift_recursion(amount, offset):
    """The row recursion of the discrete Green shift by ``amount`` px then ``offset`` whole px
    (:func:`gfgpu.shift`'s G_f, nearest extension): ``(b, a, zi, n, reverse)``.

    A row, extended by ``n`` copies of its first value where ``n > 0`` and reversed where
    ``reverse``, is filtered by ``b(z) / a(z)`` (three taps each, ``a[0] = 1``; the section
    ``y = tap x + Re F``, ``F[x+1] = lam F[x] + kap x[x]``) from the steady state ``zi`` times its
    first value (``scipy.signal.lfilter_zi``'s, solved as it solves it); reversed back, the
    result at x is the filtered line at x - n (n < 0: its last value repeated at the end)."""
    from ..greens import translation_passes
    lp, = translation_passes(amount)
    (sec,) = lp.sections
    lam, kap, tap = complex(sec.lam), complex(sec.kap), float(lp.tap)
    a = np.array([1.0, -2 * lam.real, abs(lam) ** 2])
    b = np.array([tap, tap * a[1] + kap.real, tap * a[2] - (kap * lam.conjugate()).real])
    zi = np.linalg.solve(np.array([[1.0 + a[1], -1.0], [a[2], 1.0]]), b[1:] - a[1:] * b[0])
    return b, a, zi, lp.offset + offset, bool(lp.reverse)


def _shift_row_reference(row, amount, offset):
    # one row (float64) through shift_recursion's filter, one sample at a time
    b, a, zi, n, reverse = shift_recursion(amount, offset)
    src = np.concatenate([np.full(max(n, 0), row[0]), row])
    if reverse:
        src = src[::-1]
    out = np.empty_like(src)
    z0, z1 = zi[0] * src[0], zi[1] * src[0]
    for i, x in enumerate(src):
        # lfilter's transposed direct form II, its operations in its order
        y = x * b[0] + z0
        z0 = (z1 + x * b[1]) - y * a[1]
        z1 = x * b[2] - y * a[2]
        out[i] = y
    if reverse:
        out = out[::-1]
    w = row.size
    return np.concatenate([out[-n:], np.full(-n, out[-1])]) if n < 0 else out[:w]


def subpixel_planes_reference(right, steps):
    """The right view's sub-pixel planes of the matcher's census (``"sgm"``'s views): plane 0 is
    ``right`` (float32, already scaled by :func:`gfgpu.stereo.matching.matching_views`), plane f
    the mean of the Green shifts of :func:`subpixel_jobs` (each :func:`shift_recursion` in float64,
    row by row), rounded to float32, with magnitudes below float32's smallest normal (and -0) set
    to +0 (devices flush subnormals; numpy does not).  Returns (steps, H, W) float32."""
    right = np.asarray(right, np.float32)
    planes = np.empty((steps,) + right.shape, np.float32)
    planes[0] = right
    for f, jobs in enumerate(subpixel_jobs(steps), start=1):
        for y, row in enumerate(right.astype(np.float64)):
            moved = _shift_row_reference(row, *jobs[0])
            if len(jobs) == 2:
                moved = (moved + _shift_row_reference(row, *jobs[1])) * 0.5
            planes[f, y] = moved
        bits = planes[f].view(np.uint32)
        bits[(bits & np.uint32(0x7F800000)) == 0] = 0
    return planes
