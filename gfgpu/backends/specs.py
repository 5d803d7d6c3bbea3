"""Executable numpy specifications of the fused kernels (census, SGM, selection, sweep, NMS).

Every backend's fused kernel must compute what the function here computes (integer kernels
bit for bit; float kernels to rounding); the numpy backend runs these functions themselves,
and ``tests/backends/test_fused.py`` checks every backend against them.  The applications
that need a kernel register it with :mod:`gfgpu.backends.fused` (``gfgpu.stereo.kernels``,
``gfgpu.edges.kernels``); these specifications know nothing about the applications.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SGM_PATHS", "NO_MATCH", "TIE_RTOL",
    "census_transform_reference", "census_cost_reference", "sgm_aggregate_reference",
    "select_disparity_reference", "sweep_update_reference", "suppress_nonmaxima_reference",
]

#: the 8 path directions (dy, dx) of semi-global aggregation; the first 4 are the axis paths
SGM_PATHS = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))

#: right-view disparity (in steps) of a pixel that no left pixel can match
NO_MATCH = -(2**31)

#: relative difference below which two magnitudes are a tie in non-maximum suppression
TIE_RTOL = 1e-5


def suppress_nonmaxima_reference(gy, gx):
    """Interpolated non-maximum suppression (numpy; the kernels' specification).

    Returns ``|g|`` where it is not smaller than the magnitudes interpolated at ``±g/|g|``
    (linear interpolation between the two pixels of the next row, if ``|gy| >= |gx|``, or
    column, that straddle the gradient line), else 0.  A tie with the ``-g`` (darker)
    neighbour keeps this pixel and a tie with the ``+g`` neighbour does not, so a symmetric
    two-pixel crest gives one edge pixel, on the brighter side; magnitudes within a relative
    ``TIE_RTOL`` (1e-5) count as tied, since a crest straddling two pixels is only equal up to
    the gradient's rounding.  Border pixels are 0.
    """
    gy = np.asarray(gy)
    gx = np.asarray(gx)
    mag = np.hypot(gy, gx)
    out = np.zeros_like(mag)
    if min(mag.shape) < 3:
        return out
    c = (slice(1, -1), slice(1, -1))
    vy, vx, m = gy[c], gx[c], mag[c]
    s = np.where(vy * vx < 0, -1, 1)
    ay, ax = np.abs(vy), np.abs(vx)
    steep = ay >= ax
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(steep, ax / ay, ay / ax)
    t = np.nan_to_num(t)
    ii, jj = np.meshgrid(np.arange(1, mag.shape[0] - 1), np.arange(1, mag.shape[1] - 1), indexing="ij")
    # neighbours on the +g side (a) and -g side (b): (row, column) offsets
    a1 = np.where(steep, mag[ii + 1, jj], mag[ii, jj + 1])
    a2 = np.where(steep, mag[ii + 1, np.clip(jj + s, 0, mag.shape[1] - 1)],
                  mag[np.clip(ii + s, 0, mag.shape[0] - 1), jj + 1])
    b1 = np.where(steep, mag[ii - 1, jj], mag[ii, jj - 1])
    b2 = np.where(steep, mag[ii - 1, np.clip(jj - s, 0, mag.shape[1] - 1)],
                  mag[np.clip(ii - s, 0, mag.shape[0] - 1), jj - 1])
    plus = (1 - t) * a1 + t * a2
    minus = (1 - t) * b1 + t * b2
    tol = TIE_RTOL * m
    out[c] = np.where((m > 0) & (m > plus + tol) & (m >= minus - tol), m, 0)
    return out



# --------------------------------------------------------------------------------------
# stereo
# --------------------------------------------------------------------------------------
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


def census_cost_reference(census_left, census_right, first_step, n_disp, steps, block, invalid):
    """Matching-cost volume: Hamming distances of census codes, summed over a block.

    ``cost[y, x, k]`` is the sum over the ``block x block`` window around ``(y, x)`` (clamped
    at the border) of ``popcount(L[y', x'] ^ R_f[y', x' - n])`` for the disparity
    ``d = (first_step + k) / steps = n + f / steps`` (``0 <= f < steps``), where ``R_f`` is the census
    of the right view shifted by ``+f / steps`` px (``census_right[f]``).  Where ``x' - n``
    falls outside the image the term is ``invalid``.

    Parameters
    ----------
    census_left : (H, W) uint64 ndarray
    census_right : (steps, H, W) uint64 ndarray
    first_step, n_disp, steps, block : int
        ``first_step = d_min * steps``; ``n_disp`` disparity samples; the block side (odd).
    invalid : int
        Cost of a comparison with no right pixel (the largest Hamming distance).

    Returns
    -------
    (H, W, n_disp) int16 ndarray
    """
    cl = np.asarray(census_left)
    cr = np.asarray(census_right)
    h, w = cl.shape
    cols = np.arange(w)
    ham = np.empty((h, w, n_disp), np.int32)
    for k in range(n_disp):
        n, f = divmod(first_step + k, steps)
        xr = cols - n
        inside = (xr >= 0) & (xr < w)
        ham[:, :, k] = invalid
        ham[:, inside, k] = np.bitwise_count(cl[:, inside] ^ cr[f][:, xr[inside]])
    if block > 1:
        r = block // 2
        rows = np.clip(np.arange(h)[:, None] + np.arange(-r, r + 1)[None], 0, h - 1)
        colsw = np.clip(cols[:, None] + np.arange(-r, r + 1)[None], 0, w - 1)
        ham = ham[rows].sum(axis=1)                      # (H, W, D): window rows summed
        ham = ham[:, colsw].sum(axis=2)
    return ham.astype(np.int16)


def _path_step(prev, cost, p1, p2):
    """One step of the path recursion, vectorised over lines: prev, cost are (lines, D) int32."""
    big = np.int32(1 << 24)
    m = prev.min(axis=1, keepdims=True)
    pad = np.full((prev.shape[0], 1), big, np.int32)
    lower = np.concatenate([pad, prev[:, :-1]], axis=1) + p1
    upper = np.concatenate([prev[:, 1:], pad], axis=1) + p1
    return cost + np.minimum(np.minimum(prev, np.minimum(lower, upper)), m + p2) - m


def sgm_aggregate_reference(cost, p1, p2, paths=8):
    """Semi-global aggregation: the sum over ``paths`` directions r of

    ``L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d±1) + P1, min_k L_r(p-r, k) + P2)
    - min_k L_r(p-r, k)``,

    with ``L_r(p, d) = C(p, d)`` where ``p - r`` lies outside the image (integer arithmetic,
    so every backend gives the same sums).

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
                cur = c[y] if prev is None else _path_step(prev, c[y], p1, p2)
                total[y] += cur
                prev = cur
            continue
        # stepping along columns; the predecessor of row y is row y - dy of the previous column
        order = range(w) if dx > 0 else range(w - 1, -1, -1)
        prev = None
        for x in order:
            cur = c[:, x]
            if prev is not None:
                if dy == 0:
                    cur = _path_step(prev, cur, p1, p2)
                elif dy > 0:
                    cur = np.concatenate([cur[:1], _path_step(prev[:-1], cur[1:], p1, p2)])
                else:
                    cur = np.concatenate([_path_step(prev[1:], cur[:-1], p1, p2), cur[-1:]])
            total[:, x] += cur
            prev = cur
    return total.astype(np.int16)


def select_disparity_reference(aggregated, d_min, steps, uniqueness):
    """Winner-take-all for both views, with a uniqueness test and a parabola fit.

    Left view: ``k* = argmin_k S[y, x, k]`` (the first minimum); rejected (NaN) unless every
    ``S`` more than one step away from ``k*`` exceeds ``S[k*] (1 + uniqueness/100)``;
    otherwise ``d = d_min + (k* + δ) / steps`` with the parabola vertex
    ``δ = (S[k*-1] - S[k*+1]) / (2 (S[k*-1] - 2 S[k*] + S[k*+1]))`` (0 at the range's ends or
    when the curvature is not positive).  Right view: the first minimum over k of
    ``S[y, xr + d_k, k]`` (index ``d_min*steps + k``, in steps), over the ``k`` whose left
    pixel ``xr + d_k`` (``d_k`` rounded down) lies inside; :data:`NO_MATCH` if none.

    Returns
    -------
    disp : (H, W) float32 ndarray
    disp_right : (H, W) int32 ndarray, in steps
    """
    s = np.asarray(aggregated).astype(np.int32)
    h, w, n = s.shape
    k = s.argmin(axis=2)
    best = np.take_along_axis(s, k[..., None], 2)[..., 0]
    ks = np.arange(n)[None, None]
    far = np.abs(ks - k[..., None]) > 1
    second = np.where(far, s, np.iinfo(np.int32).max).min(axis=2).astype(np.int64)
    unique = second * 100 > best.astype(np.int64) * (100 + uniqueness)
    sm = np.take_along_axis(s, np.maximum(k - 1, 0)[..., None], 2)[..., 0]
    sp = np.take_along_axis(s, np.minimum(k + 1, n - 1)[..., None], 2)[..., 0]
    den = (sm - 2 * best + sp).astype(np.float32)
    inner = (k > 0) & (k < n - 1) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(inner, (sm - sp).astype(np.float32) / (np.float32(2) * den), np.float32(0))
    disp = ((np.float32(d_min * steps) + k.astype(np.float32) + delta) / np.float32(steps)).astype(np.float32)
    disp[~unique] = np.nan
    right = np.full((h, w), NO_MATCH, np.int32)
    best_r = np.full((h, w), np.iinfo(np.int32).max, np.int64)
    cols = np.arange(w)
    for kk in range(n):
        xl = cols + (d_min * steps + kk) // steps
        ok = (xl >= 0) & (xl < w)
        val = np.full((h, w), np.iinfo(np.int32).max, np.int64)
        val[:, ok] = s[:, xl[ok], kk]
        better = val < best_r
        best_r[better] = val[better]
        right[better] = d_min * steps + kk
    return disp, right


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
    disparity).  ``state`` (5, H, W) float32 holds the best cost, its ``d``,
    the costs one step before and after it and the previous step's cost; it is updated in
    place (a new best takes the previous cost as "before").  Steps must come in increasing
    ``d``, one step apart.
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
    best, best_d, before, after, prev = state
    new = cost < best
    after_step = (~new) & np.isnan(after)   # the step right after the current best
    after[after_step] = cost[after_step]
    before[new] = prev[new]
    after[new] = np.nan
    best[new] = cost[new]
    best_d[new] = np.float32(d)
    prev[...] = cost
    return state
