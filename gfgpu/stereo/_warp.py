"""Warp kernels of the stereo matcher (float32 images, integer costs).

Executable specification: the ``*_reference`` functions of :mod:`gfgpu.stereo.spec`; the
OpenCL twins are in ``stereo.cl`` beside this module.  The ``launch_*`` functions at the end are
the launchers that :mod:`gfgpu.stereo.kernels` registers.
"""

# ruff: noqa: UP018 - int(0) / float(0.0) declare Warp's dynamic (mutable-in-loop) variables

import numpy as np
import warp as wp

from ..backends.warp import launch as wpl
from .spec import COST_MAX, NO_CANDIDATE, NO_MATCH, OUT_OF_VIEW, PATH_UNDEFINED, SGM_PATHS, cost_shift
from .workspace import empty as _empty

wp.set_module_options({"enable_backward": False})

# the specification's constants (gfgpu.stereo.spec), none retyped here
_COST_MAX = wp.constant(COST_MAX)
_NO_MATCH = wp.constant(NO_MATCH)
_OUT_OF_VIEW = wp.constant(OUT_OF_VIEW)
_UNDEF = wp.constant(PATH_UNDEFINED)         # path value of a sample out of view: never a minimum
_NO_CANDIDATE = wp.constant(NO_CANDIDATE)    # above every cost and path value (int32's largest)


@wp.func
def _popcount(v: wp.uint64):
    # SWAR bit count of a 64-bit word
    x = v - ((v >> wp.uint64(1)) & wp.uint64(0x5555555555555555))
    x = (x & wp.uint64(0x3333333333333333)) + ((x >> wp.uint64(2)) & wp.uint64(0x3333333333333333))
    x = (x + (x >> wp.uint64(4))) & wp.uint64(0x0F0F0F0F0F0F0F0F)
    return int((x * wp.uint64(0x0101010101010101)) >> wp.uint64(56))


@wp.func
def _floor_div(a: int, b: int):
    if a >= 0:
        return a / b
    return -((-a + b - 1) / b)


@wp.kernel
def census(img: wp.array2d(dtype=wp.float32), out: wp.array3d(dtype=wp.uint64), plane: int, radius: int):
    """Census transform into ``out[plane]`` (row-major window bits, centre skipped, edges repeated)."""
    y, x = wp.tid()
    h = img.shape[0]
    w = img.shape[1]
    c = img[y, x]
    code = wp.uint64(0)
    bit = wp.uint64(0)
    for dy in range(-radius, radius + 1):
        yy = wp.clamp(y + dy, 0, h - 1)
        for dx in range(-radius, radius + 1):
            if dy != 0 or dx != 0:
                xx = wp.clamp(x + dx, 0, w - 1)
                if img[yy, xx] < c:
                    code = code | (wp.uint64(1) << bit)
                bit = bit + wp.uint64(1)
    out[plane, y, x] = code


@wp.kernel
def census_cost(cl: wp.array3d(dtype=wp.uint64), cr: wp.array3d(dtype=wp.uint64),
                out: wp.array3d(dtype=wp.int16), first_step: int, steps: int, block: int, shift: int):
    """Block-summed Hamming distances for every disparity sample, -1 out of view; one thread per
    (pixel, sample) (see census_cost_reference)."""
    y, x, k = wp.tid()
    h = out.shape[0]
    w = out.shape[1]
    r = block / 2
    t = first_step + k
    n = _floor_div(t, steps)
    f = t - n * steps
    if x - n < r or x - n > w - 1 - r:
        out[y, x, k] = wp.int16(_OUT_OF_VIEW)
        return
    total = int(0)
    for v in range(-r, r + 1):
        yy = wp.clamp(y + v, 0, h - 1)
        for u in range(-r, r + 1):
            xx = wp.clamp(x + u, 0, w - 1)
            total = total + _popcount(cl[0, yy, xx] ^ cr[f, yy, xx - n])
    out[y, x, k] = wp.int16(wp.min(total >> shift, _COST_MAX))


@wp.kernel
def sgm_path(cost: wp.array3d(dtype=wp.int16), total: wp.array3d(dtype=wp.int16),
             scratch: wp.array2d(dtype=wp.int32), dy: int, dx: int, p1: int, p2: int, accumulate: int):
    """One path direction of semi-global aggregation; one thread per line entering the image.
    Samples out of view (cost < 0) have path value PATH_UNDEFINED and total OUT_OF_VIEW; one
    entering the view takes the predecessor's minimum as its own predecessor (L = C)."""
    i = wp.tid()
    h = cost.shape[0]
    w = cost.shape[1]
    nd = cost.shape[2]
    x = int(0)
    y = int(0)
    if dx == 0:
        if i >= w:
            return
        x = i
        y = 0
        if dy < 0:
            y = h - 1
    elif dy == 0 or i < h:
        if i >= h:
            return
        x = 0
        if dx < 0:
            x = w - 1
        y = i
    else:
        if i >= h + w - 1:
            return
        x = i - h + 1
        if dx < 0:
            x = w - 2 - (i - h)
        y = 0
        if dy < 0:
            y = h - 1
    prev = int(0)       # column offset of the previous step's costs in this line's scratch row
    cur = int(nd)
    mprev = int(0)
    first = int(1)
    while x >= 0 and x < w and y >= 0 and y < h:
        m = int(_NO_CANDIDATE)
        for d in range(nd):
            c = int(cost[y, x, d])
            v = c
            if c < 0:
                v = _UNDEF
                total[y, x, d] = wp.int16(_OUT_OF_VIEW)
            else:
                if first == 0:
                    stay = scratch[i, prev + d]
                    if stay >= _UNDEF:
                        stay = mprev
                    best = wp.min(stay, mprev + p2)
                    if d > 0:
                        best = wp.min(best, scratch[i, prev + d - 1] + p1)
                    if d < nd - 1:
                        best = wp.min(best, scratch[i, prev + d + 1] + p1)
                    v = c + best - mprev
                if accumulate != 0:
                    total[y, x, d] = wp.int16(int(total[y, x, d]) + v)
                else:
                    total[y, x, d] = wp.int16(v)
            scratch[i, cur + d] = v
            m = wp.min(m, v)
        tmp = prev
        prev = cur
        cur = tmp
        mprev = m
        first = 0
        x = x + dx
        y = y + dy


@wp.func
def _write_pick(agg: wp.array3d(dtype=wp.int16), disp: wp.array2d(dtype=wp.float32),
                margin: wp.array2d(dtype=wp.float32), y: int, x: int, kb: int, best: int, second: int,
                unique: bool, nd: int, steps: int, d_min: int):
    """Pixel (y, x)'s disparity and margin from its winner ``kb`` (spec.select_reference): the
    parabola through the winner's neighbours, or with half-pixel samples one baseline per phase."""
    sm = int(agg[y, x, wp.max(kb - 1, 0)])
    sp = int(agg[y, x, wp.min(kb + 1, nd - 1)])
    cut = (kb > 0 and sm < 0) or (kb < nd - 1 and sp < 0)
    den = float(sm - 2 * best + sp)
    delta = float(0.0)
    if kb > 0 and kb < nd - 1 and den > 0.0:
        delta = float(sm - sp) / (2.0 * den)
    if steps == 2 and kb >= 2 and kb <= nd - 3:
        # half-pixel samples: one baseline per phase (spec._half_pixel_fit)
        sm2 = int(agg[y, x, kb - 2])
        sp2 = int(agg[y, x, kb + 2])
        den2 = sm2 + sp2 - 2 * best
        if sm >= 0 and sp >= 0 and sm2 >= 0 and sp2 >= 0 and den2 > 0:
            delta = wp.min(wp.max(float(2 * (sm - sp) + sm2 - sp2) / (2.0 * float(den2)), -1.0), 1.0)
    if unique and not cut:
        disp[y, x] = (float(d_min * steps) + float(kb) + delta) / float(steps)
        margin[y, x] = float(second - best) / float(second)
    else:
        disp[y, x] = wp.nan
        margin[y, x] = 0.0


@wp.kernel
def select_disparity(agg: wp.array3d(dtype=wp.int16), disp: wp.array2d(dtype=wp.float32),
                     right: wp.array2d(dtype=wp.int32), margin: wp.array2d(dtype=wp.float32),
                     d_min: int, steps: int, uniqueness: int):
    """Winner-take-all for both views over the samples in view (NaN when none, when the minimum
    is cut by the image or not unique; parabola vertex; margin (S2 - S1) / S2)."""
    y, x = wp.tid()
    w = agg.shape[1]
    nd = agg.shape[2]
    best = int(_NO_CANDIDATE)
    kb = int(0)
    for k in range(nd):
        v = int(agg[y, x, k])
        if v >= 0 and v < best:
            best = v
            kb = k
    second = int(_NO_CANDIDATE)
    for k in range(nd):
        v = int(agg[y, x, k])
        if v >= 0 and wp.abs(k - kb) > 1 and v < second:
            second = v
    unique = best < _NO_CANDIDATE and second < _NO_CANDIDATE and \
        wp.int64(second) * wp.int64(100) > wp.int64(best) * wp.int64(100 + uniqueness)
    _write_pick(agg, disp, margin, y, x, kb, best, second, unique, nd, steps, d_min)
    best_r = int(_NO_CANDIDATE)
    kr = int(_NO_MATCH)
    for k in range(nd):
        t = d_min * steps + k
        xl = x + _floor_div(t, steps)
        if xl >= 0 and xl < w:
            v = int(agg[y, xl, k])
            if v >= 0 and v < best_r:
                best_r = v
                kr = t
    right[y, x] = kr


# ---- the GPU-shaped matcher: a block of threads per line, the disparity samples across its lanes ----
# Lane l of a block owns the samples l * GROUP_CHUNK .. l * GROUP_CHUNK + GROUP_CHUNK - 1 (a vector
# in registers); what it needs from the other lanes (d - 1 and d + 1 at its chunk's edges, the
# minimum over d, the selection's winners) goes through tiles (wp.tile, wp.tile_min,
# wp.tile_extract: shared memory and the block's barriers).  Each kernel is its own Warp module
# (module="unique"): a block width compiles that kernel alone, not the whole of this file.
#: samples per lane of the group kernels (the block width is ceil(n / GROUP_CHUNK))
GROUP_CHUNK = 8
#: columns and rows of the tiles and bands of census_cost_columns
COST_TILE = 32
COST_ROWS = 32
_Chunk = wp.types.vector(length=GROUP_CHUNK, dtype=wp.int32)
_GROUP_CHUNK = wp.constant(GROUP_CHUNK)
_COST_OUT = wp.constant(OUT_OF_VIEW & 0xFF)         # a byte cost out of view (255, above COST_MAX)
_NO_KEY = wp.constant(wp.uint32(0xFFFFFFFF))        # a (cost << 16 | k) key of no candidate


@wp.kernel
def census_cost_columns(cl: wp.array3d(dtype=wp.uint64), cr: wp.array3d(dtype=wp.uint64),
                        out: wp.array3d(dtype=wp.uint8), colsum: wp.array3d(dtype=wp.int16), first_step: int,
                        steps: int, block: int, shift: int, tile: int, rows: int):
    """census_cost's block costs as bytes (_COST_OUT out of view) from column sums: thread (gx, gy,
    k) takes sample k of the columns gx * tile .. and rows gy * rows .. (a tile and a band), keeping
    the sample's column sums over the block's rows for the tile's columns and the block's margin in
    ``colsum[tile index, i, k]`` (neighbouring threads: neighbouring k, coalesced), going down the
    band (+ the row entering the block, - the row leaving: rows clamped as the specification's
    window) and along each row (+ the column entering, - the column leaving): each Hamming distance
    about twice instead of block^2 times.  A distance whose right pixel is outside the image counts
    0, so the running sums are exact and the stored sums (in view) never met one."""
    gx, gy, k = wp.tid()
    h = out.shape[0]
    w = out.shape[1]
    r = block / 2
    x0 = gx * tile
    x1 = wp.min(w, x0 + tile)
    y0 = gy * rows
    y1 = wp.min(h, y0 + rows)
    g = gy * ((w + tile - 1) / tile) + gx
    t = first_step + k
    n = _floor_div(t, steps)
    f = t - n * steps
    for y in range(y0, y1):
        for i in range(x1 - x0 + 2 * r):            # position i: image column x0 - r + i, clamped
            xc = wp.clamp(x0 - r + i, 0, w - 1)
            xr = xc - n
            if y == y0:
                s = int(0)
                if xr >= 0 and xr < w:
                    for v in range(-r, r + 1):
                        yy = wp.clamp(y + v, 0, h - 1)
                        s = s + _popcount(cl[0, yy, xc] ^ cr[f, yy, xr])
                colsum[g, i, k] = wp.int16(s)
            elif xr >= 0 and xr < w:
                ya = wp.min(y + r, h - 1)
                yb = wp.max(y - 1 - r, 0)
                change = _popcount(cl[0, ya, xc] ^ cr[f, ya, xr]) - _popcount(cl[0, yb, xc] ^ cr[f, yb, xr])
                colsum[g, i, k] = wp.int16(int(colsum[g, i, k]) + change)
        s = int(0)
        for i in range(2 * r + 1):                  # the window at x0: positions 0 .. 2r
            s = s + int(colsum[g, i, k])
        for x in range(x0, x1):
            if x > x0:                              # + column x + r, - column x - 1 - r
                s = s + int(colsum[g, x - x0 + 2 * r, k]) - int(colsum[g, x - x0 - 1, k])
            if x - n < r or x - n > w - 1 - r:
                out[y, x, k] = wp.uint8(_COST_OUT)
            else:
                out[y, x, k] = wp.uint8(wp.min(s >> shift, _COST_MAX))


@wp.kernel(module="unique")
def group_paths(cost: wp.array3d(dtype=wp.uint8), total: wp.array3d(dtype=wp.int16), dy: int, dx: int,
                p1: int, p2: int, accumulate: int):
    """Path direction (dy, dx) and its opposite (sgm_aggregate_reference): block i sweeps the i-th
    line entering the image forward, then backward, adding L into ``total`` (set by the first
    direction when ``accumulate`` is 0); OUT_OF_VIEW where the cost is.  Path values in int32 with
    PATH_UNDEFINED out of view, as the specification's."""
    i, lane = wp.tid()
    h = cost.shape[0]
    w = cost.shape[1]
    nd = cost.shape[2]
    lanes = wp.block_dim()
    x0 = int(0)
    y0 = int(0)
    if dx == 0:                 # vertical: one line per column
        x0 = i
        if dy < 0:
            y0 = h - 1
    elif dy == 0 or i < h:      # horizontal, or diagonal entering through the first column
        if dx < 0:
            x0 = w - 1
        y0 = i
    else:                       # diagonal, entering through the first row
        x0 = i - h + 1
        if dx < 0:
            x0 = w - 2 - (i - h)
        if dy < 0:
            y0 = h - 1
    length = int(h + w)
    if dx > 0:
        length = wp.min(length, w - x0)
    if dx < 0:
        length = wp.min(length, x0 + 1)
    if dy > 0:
        length = wp.min(length, h - y0)
    if dy < 0:
        length = wp.min(length, y0 + 1)
    k0 = lane * _GROUP_CHUNK
    for sweep in range(2):
        x = int(x0)
        y = int(y0)
        sx = dx
        sy = dy
        if sweep == 1:
            x = x0 + (length - 1) * dx
            y = y0 + (length - 1) * dy
            sx = -dx
            sy = -dy
        prev = _Chunk()
        m = int(_UNDEF)             # the previous pixel's minimum over d
        below = int(_UNDEF)         # L'(d - 1) of this lane's first sample (the lane below's last)
        above = int(_UNDEF)         # L'(d + 1) of its last sample (the lane above's first)
        for t in range(length):
            cur = _Chunk()
            mv = int(_UNDEF)
            for j in range(GROUP_CHUNK):
                k = k0 + j
                v = int(_UNDEF)
                if k < nd:
                    c = int(cost[y, x, k])
                    if c == _COST_OUT:
                        total[y, x, k] = wp.int16(_OUT_OF_VIEW)
                    else:
                        v = c
                        if t > 0:
                            lower = below
                            if j > 0:
                                lower = prev[wp.max(j - 1, 0)]
                            upper = above
                            if j < GROUP_CHUNK - 1:
                                upper = prev[wp.min(j + 1, GROUP_CHUNK - 1)]
                            stay = prev[j]
                            if stay >= _UNDEF:
                                stay = m
                            v = c + wp.min(wp.min(stay, wp.min(lower, upper) + p1), m + p2) - m
                        if sweep == 1 or accumulate != 0:
                            total[y, x, k] = wp.int16(int(total[y, x, k]) + v)
                        else:
                            total[y, x, k] = wp.int16(v)
                cur[j] = v
                mv = wp.min(mv, v)
            prev = cur
            # every lane reaches these (the line's length is the block's): the minimum over d and the
            # neighbours' chunk edges for the next step
            m = wp.tile_extract(wp.tile_min(wp.tile(mv)), 0)
            below = wp.tile_extract(wp.tile(cur[GROUP_CHUNK - 1]), wp.max(lane - 1, 0))
            above = wp.tile_extract(wp.tile(cur[0]), wp.min(lane + 1, lanes - 1))
            if lane == 0:
                below = _UNDEF
            if lane == lanes - 1:
                above = _UNDEF
            x = x + sx
            y = y + sy


@wp.func
def _key(v: int, k: int):
    # (cost, k) as one key: the least cost, ties to the smaller k; no key out of view
    if v < 0:
        return _NO_KEY
    return (wp.uint32(v) << wp.uint32(16)) | wp.uint32(k)


@wp.kernel(module="unique")
def group_select(agg: wp.array3d(dtype=wp.int16), disp: wp.array2d(dtype=wp.float32),
                 right: wp.array2d(dtype=wp.int32), margin: wp.array2d(dtype=wp.float32), d_min: int,
                 steps: int, uniqueness: int):
    """select_disparity for a block per row: per pixel x each lane keys its samples, the block takes
    the least key of the left winner and of the right view's (pixel x), then the best cost more than
    one step from the winner; lane 0 tests and refines (select_disparity_reference)."""
    y, lane = wp.tid()
    w = agg.shape[1]
    nd = agg.shape[2]
    k0 = lane * _GROUP_CHUNK
    for x in range(w):
        kl = wp.uint32(_NO_KEY)
        kr = wp.uint32(_NO_KEY)
        vals = _Chunk()
        for j in range(GROUP_CHUNK):
            k = k0 + j
            v = int(-1)
            if k < nd:
                v = int(agg[y, x, k])
                xl = x + d_min + k / steps
                if xl >= 0 and xl < w:
                    kr = wp.min(kr, _key(int(agg[y, xl, k]), k))
            vals[j] = v
            kl = wp.min(kl, _key(v, k))
        best_key = wp.tile_extract(wp.tile_min(wp.tile(kl)), 0)
        right_key = wp.tile_extract(wp.tile_min(wp.tile(kr)), 0)
        kb = int(0)
        best = int(0)
        if best_key != _NO_KEY:
            kb = int(best_key & wp.uint32(0xFFFF))
            best = int(best_key >> wp.uint32(16))
        k2 = wp.uint32(_NO_KEY)
        for j in range(GROUP_CHUNK):
            if wp.abs(k0 + j - kb) > 1:
                k2 = wp.min(k2, _key(vals[j], 0))
        second_key = wp.tile_extract(wp.tile_min(wp.tile(k2)), 0)
        if lane == 0:
            if right_key == _NO_KEY:
                right[y, x] = _NO_MATCH
            else:
                right[y, x] = d_min * steps + int(right_key & wp.uint32(0xFFFF))
            second = int(second_key >> wp.uint32(16))
            unique = best_key != _NO_KEY and second_key != _NO_KEY and \
                wp.int64(second) * wp.int64(100) > wp.int64(best) * wp.int64(100 + uniqueness)
            _write_pick(agg, disp, margin, y, x, kb, best, second, unique, nd, steps, d_min)


@wp.kernel
def left_right(disp: wp.array2d(dtype=wp.float32), right: wp.array2d(dtype=wp.int32),
               margin: wp.array2d(dtype=wp.float32), steps: int, tol: wp.float64):
    """Left-right check in place, float64 as the specification (left_right_reference): NaN
    where the right view's winner at rint(x - d) is missing or more than tol px from d; the
    confidence times 1 - |d - d_R| / (2 tol)."""
    y, x = wp.tid()
    w = disp.shape[1]
    d = disp[y, x]
    ok = False
    diff = wp.float64(0.0)
    if not wp.isnan(d):
        dd = wp.float64(d)
        xr = wp.rint(wp.float64(x) - dd)
        if xr >= wp.float64(0.0) and xr <= wp.float64(w - 1):
            back = right[y, int(xr)]
            if back != _NO_MATCH:
                diff = wp.abs(wp.float64(back) / wp.float64(steps) - dd)
                ok = diff <= tol
    if ok:
        conf = wp.float64(margin[y, x]) * (wp.float64(1.0) - diff / (wp.float64(2.0) * tol))
        margin[y, x] = wp.float32(conf)
    else:
        disp[y, x] = wp.nan
        margin[y, x] = wp.float32(0.0)


@wp.kernel
def sweep_update(state: wp.array3d(dtype=wp.float32), ls: wp.array2d(dtype=wp.float32),
                 rs: wp.array2d(dtype=wp.float32), gl: wp.array(dtype=wp.float32),
                 gr: wp.array(dtype=wp.float32), offset: int, d: float, radius: int):
    """One step of the running-best sweep (see sweep_update_reference)."""
    y, x = wp.tid()
    h = ls.shape[0]
    w = ls.shape[1]
    cost = float(0.0)
    if x - offset < radius or x - offset > w - 1 - radius:
        cost = wp.inf        # not in view
    else:
        for v in range(-radius, radius + 1):
            yy = wp.clamp(y + v, 0, h - 1)
            for u in range(-radius, radius + 1):
                xl = wp.clamp(x + u, 0, w - 1)
                xr = xl - offset
                a = gl[xl] * ls[yy, xl] - gr[xr] * rs[yy, xr]
                cost = cost + a * a
    prev = state[4, y, x]
    older = state[6, y, x]
    if cost < state[0, y, x]:
        state[5, y, x] = older
        state[2, y, x] = prev
        state[3, y, x] = wp.nan
        state[0, y, x] = cost
        state[1, y, x] = d
    elif wp.isnan(state[3, y, x]):
        state[3, y, x] = cost
    elif cost < state[5, y, x]:
        state[5, y, x] = cost
    if prev < older:
        state[6, y, x] = prev
    state[4, y, x] = cost
    if cost < wp.inf:      # in view: the right pixel x - offset, one writer per right pixel
        if cost < state[7, y, x - offset]:
            state[7, y, x - offset] = cost
            state[8, y, x - offset] = d


# ---- launchers (registered by gfgpu.stereo.kernels) -------------------------------------
def launch_census(be, image, out, plane, radius):
    image = wpl.contiguous(be, image, "image")
    wpl.launch(be, census, dim=image.shape, inputs=[image, out, int(plane), int(radius)])
    return out

def launch_planes(be, right, out, steps):
    # float64 row recursions on the host (bit for bit the specification's), then to the device
    from .matching import subpixel_planes
    host = subpixel_planes(np.ascontiguousarray(right.numpy(), np.float32), steps)
    wp.copy(out, wp.array(host, dtype=wp.float32, device=out.device))
    return out


def launch_cost(be, census_left, census_right, out, first_step, steps, block):
    wpl.launch(be, census_cost, dim=out.shape,
               inputs=[census_left, census_right, out, int(first_step), int(steps), int(block),
                       cost_shift(int(block))])
    return out


def launch_sgm(be, cost, out, p1, p2, paths, workspace=None):
    h, w, n = cost.shape
    lines = h + w - 1
    scratch = _empty(be, workspace, "path_scratch", (lines, 2 * n), np.int32)
    for i, (dy, dx) in enumerate(SGM_PATHS[:paths]):
        count = w if dx == 0 else h if dy == 0 else lines
        wpl.launch(be, sgm_path, dim=count,
                   inputs=[cost, out, scratch, dy, dx, int(p1), int(p2), int(i > 0)])
    return out

def launch_select(be, aggregated, disp, disp_right, margin, d_min, steps, uniqueness):
    wpl.launch(be, select_disparity, dim=disp.shape,
               inputs=[aggregated, disp, disp_right, margin, int(d_min), int(steps), int(uniqueness)])
    return disp, disp_right, margin

def group_lanes(n, cuda=True):
    """Lanes (threads) per block of the group kernels for ``n`` samples: ``ceil(n / GROUP_CHUNK)``
    rounded up to a whole number of 32-thread warps on CUDA, to a power of two, at least 4, on the
    CPU (whose cooperative blocks, ``wp.config.enable_cpu_blocks``, only the tests use: few widths,
    each compiling the two block kernels once, and chunk edges between lanes even for 1 sample)."""
    lanes = -(-int(n) // GROUP_CHUNK)
    return -(-lanes // 32) * 32 if cuda else max(4, 1 << (lanes - 1).bit_length())


def _group_match(be, census_left, census_right, disp, disp_right, margin, first_step, n, steps, block, p1, p2,
                 paths, uniqueness, lanes, workspace):
    # byte costs, one int16 sum volume the paths add into, the selection a block per row
    h, w = disp.shape
    cost = _empty(be, workspace, "cost", (h, w, n), np.uint8)
    # block costs from column sums kept per (tile, band) in a scratch of int16: tiles x bands x
    # (COST_TILE + block - 1) x n (1 / COST_ROWS of the cost volume's size for a 3 x 3 block)
    tiles, bands = -(-w // COST_TILE), -(-h // COST_ROWS)
    colsum = _empty(be, workspace, "column_sums", (tiles * bands, COST_TILE + block - 1, n), np.int16)
    wpl.launch(be, census_cost_columns, dim=(tiles, bands, n),
               inputs=[census_left, census_right, cost, colsum, int(first_step), int(steps), int(block),
                       cost_shift(int(block)), COST_TILE, COST_ROWS])
    total = _empty(be, workspace, "sum", (h, w, n), np.int16)
    for i, (dy, dx) in enumerate(((0, 1), (1, 0), (1, 1), (1, -1))[:paths // 2]):
        lines = w if dx == 0 else h if dy == 0 else h + w - 1
        wp.launch(group_paths, dim=(lines, lanes), inputs=[cost, total, dy, dx, int(p1), int(p2), int(i > 0)],
                  block_dim=lanes, device=be.wp_device)
    wp.launch(group_select, dim=(h, lanes),
              inputs=[total, disp, disp_right, margin, int(first_step // steps), int(steps), int(uniqueness)],
              block_dim=lanes, device=be.wp_device)
    return disp, disp_right, margin


def launch_match(be, census_left, census_right, disp, disp_right, margin, first_step, n_disp, steps, block,
                 p1, p2, paths, uniqueness, budget=None, workspace=None):
    h, w = disp.shape
    n = int(n_disp)
    cuda = not be.wp_device.is_cpu
    lanes = group_lanes(n, cuda)
    if be.kind != "cpu" and lanes <= 1024 and (cuda or wp.config.enable_cpu_blocks) and disp.size:
        # GPUs: a block of threads per line, the samples across its lanes (a CPU device runs such
        # blocks only with wp.config.enable_cpu_blocks: the tests force it there)
        return _group_match(be, census_left, census_right, disp, disp_right, margin, first_step, n, steps, block,
                            p1, p2, paths, uniqueness, lanes, workspace)
    # whole (H, W, D) volumes: each path's lines in parallel (disparity() checks the memory before
    # allocating)
    cost = _empty(be, workspace, "cost", (h, w, n), np.int16)
    launch_cost(be, census_left, census_right, cost, first_step, steps, block)
    agg = _empty(be, workspace, "aggregated", (h, w, n), np.int16)
    launch_sgm(be, cost, agg, p1, p2, paths, workspace)
    del cost
    return launch_select(be, agg, disp, disp_right, margin, first_step // steps, steps, uniqueness)

def launch_left_right(be, disp, disp_right, margin, steps, tol):
    wpl.launch(be, left_right, dim=disp.shape, inputs=[disp, disp_right, margin, int(steps), float(tol)])
    return disp, margin

def launch_sweep(be, state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius):
    ls = wpl.contiguous(be, left_shifted, "left_shifted")
    rs = wpl.contiguous(be, right_shifted, "right_shifted")
    wpl.launch(be, sweep_update, dim=ls.shape,
               inputs=[state, ls, rs, gain_left, gain_right, int(offset), float(d), int(radius)])
    return state
