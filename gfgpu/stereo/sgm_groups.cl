// The GPU-shaped semi-global matcher of gfgpu.stereo (OpenCL 1.2): every line of work is processed
// by a work-group of LANES work-items with the disparity samples spread across them.  Lane l owns
// the contiguous samples k = l CH .. l CH + CH - 1 (in private memory); the samples n .. LANES CH - 1
// (past the range) are padding that no kernel stores.  What a lane needs from the others (d - 1 and
// d + 1 at its chunk's edges, the minimum over d) goes through local memory with barriers: OpenCL
// 1.2 guarantees no sub-group shuffles.
// Executable specification: gfgpu/stereo/spec.py (census_cost_reference, sgm_aggregate_reference,
// select_disparity_reference), bit for bit.  Launched by gfgpu/stereo/_opencl_groups.py, which
// defines LANES and CH (the only build options: the sample count n, the image size, the block,
// the sub-pixel steps and the penalties are arguments, so a new range within LANES * CH samples
// builds nothing) and the constants shared with the specification: OUT_OF_VIEW, COST_MAX,
// NO_MATCH, and PAD_COST, the int16 path value of a sample out of view (spec.PATH_UNDEFINED's
// role: above every path value in view, and still an int16 plus a penalty).
// Every kernel reaches every barrier with all its work-items: lanes without samples take part.

#if !defined(LANES) || !defined(CH) || !defined(NO_MATCH) || !defined(OUT_OF_VIEW) || !defined(COST_MAX) \
    || !defined(PAD_COST)
#error "sgm_groups.cl is built by gfgpu.stereo._opencl_groups, which defines its sizes and constants"
#endif
#pragma OPENCL FP_CONTRACT OFF      // the selection's float32 arithmetic as the specification's

#include "lines.cl"     // CLAMPI, IMIN, IMAX, floor_div, path_line
#define COST_OUT ((OUT_OF_VIEW) & 0xff)     // a byte cost out of view (255, above COST_MAX)
#if COST_OUT <= COST_MAX
#error "the out-of-view byte must lie above COST_MAX"
#endif
#ifdef __clang__
#define POPCOUNT(v) __builtin_popcountl(v)  // PoCL calls (does not inline) popcount()
#else
#define POPCOUNT(v) popcount(v)
#endif

// The group's reductions read every lane's value from local memory, 16 bytes per load (vload8 /
// vload4; a GPU broadcasts a load that all its lanes make to one address): the arrays hold whole
// vectors, the entries past LANES set to the reduction's neutral value once.
#define SHORT8S ((LANES + 7) / 8)
#define UINT4S ((LANES + 3) / 4)

static inline short min_of_lanes(__local const short *v)
{
    short8 m = vload8(0, v);
    for (int q = 1; q < SHORT8S; ++q) {
        const short8 u = vload8(q, v);
        m = m < u ? m : u;
    }
    const short4 a = m.lo < m.hi ? m.lo : m.hi;
    const short2 b = a.lo < a.hi ? a.lo : a.hi;
    return b.x < b.y ? b.x : b.y;
}

// ---------------------------------------------------------------------------------------------
// Block costs into a byte volume cost[y][x][k] (n bytes per pixel, COST_OUT out of view): a
// work-group per (row y, tile of `tile` columns), the samples across its lanes.  A lane walks the
// tile's columns keeping its samples' window sums, + the column entering the window, - the one
// leaving (columns clamped at the border, as the specification's window; a column's value is the
// sum over the block's clamped rows of popcount(L[y'][x'] ^ R_f[y'][x' - n]), 0 where x' - n is
// outside the image, so the running sums are exact for every sample and the stored ones, in view,
// never met such a column).  2 * block popcounts per (pixel, sample) instead of block^2.
static inline void add_column(int *s, __global const ulong *cl, __global const ulong *const *rbase,
                              const int *nn, const int y, const int xc, const int h, const int w, const int r,
                              const int sign)
{
    for (int v = -r; v <= r; ++v) {
        const size_t row = (size_t)CLAMPI(y + v, 0, h - 1) * w;
        const ulong lc = cl[row + xc];
        #pragma unroll
        for (int j = 0; j < CH; ++j) {
            const int xr = xc - nn[j];
            if (xr >= 0 && xr < w)
                s[j] += sign * (int)POPCOUNT(lc ^ rbase[j][row + xr]);
        }
    }
}

__kernel void group_cost(__global const ulong *cl, __global const ulong *cr, __global uchar *cost,
                         const int h, const int w, const int n, const int first_step, const int steps,
                         const int block, const int shift, const int tile)
{
    const int lane = get_local_id(0), y = get_group_id(1);
    const int x0 = get_group_id(0) * tile, x1 = IMIN(w, x0 + tile), r = block / 2;
    const int k0 = lane * CH;
    if (k0 >= n)          // no barrier in this kernel: a lane without samples may leave
        return;
    int nn[CH], s[CH];
    __global const ulong *rbase[CH];
    #pragma unroll
    for (int j = 0; j < CH; ++j) {
        // sample k = first_step + k0 + j = nn steps + f: the right plane f at column x - nn
        const int t = first_step + IMIN(k0 + j, n - 1);
        nn[j] = floor_div(t, steps);
        rbase[j] = cr + (size_t)(t - nn[j] * steps) * h * w;
        s[j] = 0;
    }
    for (int u = -r; u <= r; ++u)
        add_column(s, cl, rbase, nn, y, CLAMPI(x0 + u, 0, w - 1), h, w, r, 1);
    for (int x = x0; x < x1; ++x) {
        if (x > x0) {
            add_column(s, cl, rbase, nn, y, IMIN(x + r, w - 1), h, w, r, 1);
            add_column(s, cl, rbase, nn, y, IMAX(x - 1 - r, 0), h, w, r, -1);
        }
        __global uchar *dst = cost + ((size_t)y * w + x) * n;
        #pragma unroll
        for (int j = 0; j < CH; ++j) {
            const int in_view = x - nn[j] >= r && x - nn[j] <= w - 1 - r;
            if (k0 + j < n)
                dst[k0 + j] = in_view ? (uchar)IMIN(s[j] >> shift, COST_MAX) : (uchar)COST_OUT;
        }
    }
}

// The same costs with each (row, column, sample) Hamming distance taken about twice instead of
// 2 * block times: a work-group per (band of `rows` rows, tile of `tile` columns) keeps, for the
// tile's columns and the block's margin, every sample's column sum over the block's rows in local
// memory (`colsum`, (tile + 2r) * LANES * CH ushorts: at most 15 * 64 = 960 each) and walks down
// its band, + the row entering the block, - the row leaving (rows clamped at the border as the
// specification's window), then along each row as group_cost, reading the column sums.  A lane
// reads and writes only its own samples' entries (laid out lane-fastest: no bank conflicts): no
// barrier.  The launcher takes this kernel where `colsum` fits (COLSUM_ENTRIES, a build option: the
// device's local-memory budget), group_cost otherwise.
static inline void add_rows(__local ushort *col, __global const ulong *cl, __global const ulong *const *rbase,
                            const int *nn, const int yr, const int xc, const int w, const int sign)
{
    const size_t row = (size_t)yr * w;
    const ulong lc = cl[row + xc];
    #pragma unroll
    for (int j = 0; j < CH; ++j) {
        const int xr = xc - nn[j];
        if (xr >= 0 && xr < w)
            col[j * LANES] += (ushort)(sign * (int)POPCOUNT(lc ^ rbase[j][row + xr]));
    }
}

#ifndef COLSUM_ENTRIES
#error "sgm_groups.cl is built with -D COLSUM_ENTRIES (the column sums' local memory, in ushorts)"
#endif
__kernel void group_cost_columns(__global const ulong *cl, __global const ulong *cr, __global uchar *cost,
                                 const int h, const int w, const int n, const int first_step, const int steps,
                                 const int block, const int shift, const int tile, const int rows)
{
    __local ushort colsum[COLSUM_ENTRIES];
    const int lane = get_local_id(0);
    const int x0 = get_group_id(0) * tile, x1 = IMIN(w, x0 + tile), r = block / 2;
    const int y0 = get_group_id(1) * rows, y1 = IMIN(h, y0 + rows);
    const int k0 = lane * CH, cols = x1 - x0 + 2 * r;
    if (k0 >= n)          // no barrier in this kernel: a lane without samples may leave
        return;
    int nn[CH];
    __global const ulong *rbase[CH];
    #pragma unroll
    for (int j = 0; j < CH; ++j) {
        const int t = first_step + IMIN(k0 + j, n - 1);
        nn[j] = floor_div(t, steps);
        rbase[j] = cr + (size_t)(t - nn[j] * steps) * h * w;
    }
    // entry (i, j) of this lane: column position i (image column x0 - r + i, clamped), sample k0 + j
    __local ushort *mine = colsum + lane;
    for (int y = y0; y < y1; ++y) {
        for (int i = 0; i < cols; ++i) {
            __local ushort *col = mine + (size_t)i * CH * LANES;
            const int xc = CLAMPI(x0 - r + i, 0, w - 1);
            if (y == y0) {
                #pragma unroll
                for (int j = 0; j < CH; ++j)
                    col[j * LANES] = 0;
                for (int v = -r; v <= r; ++v)
                    add_rows(col, cl, rbase, nn, CLAMPI(y + v, 0, h - 1), xc, w, 1);
            } else {
                add_rows(col, cl, rbase, nn, IMIN(y + r, h - 1), xc, w, 1);
                add_rows(col, cl, rbase, nn, IMAX(y - 1 - r, 0), xc, w, -1);
            }
        }
        int s[CH];
        #pragma unroll
        for (int j = 0; j < CH; ++j)
            s[j] = 0;
        for (int i = 0; i < 2 * r + 1; ++i) {         // the window at x0: positions 0 .. 2r
            #pragma unroll
            for (int j = 0; j < CH; ++j)
                s[j] += mine[((size_t)i * CH + j) * LANES];
        }
        for (int x = x0; x < x1; ++x) {
            if (x > x0) {     // + position x - x0 + 2r (column x + r), - position x - x0 - 1 (x - 1 - r)
                #pragma unroll
                for (int j = 0; j < CH; ++j)
                    s[j] += (int)mine[((size_t)(x - x0 + 2 * r) * CH + j) * LANES] -
                            (int)mine[((size_t)(x - x0 - 1) * CH + j) * LANES];
            }
            __global uchar *dst = cost + ((size_t)y * w + x) * n;
            #pragma unroll
            for (int j = 0; j < CH; ++j) {
                const int in_view = x - nn[j] >= r && x - nn[j] <= w - 1 - r;
                if (k0 + j < n)
                    dst[k0 + j] = in_view ? (uchar)IMIN(s[j] >> shift, COST_MAX) : (uchar)COST_OUT;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Semi-global aggregation along direction (dy, dx) and its opposite: one work-group per line of
// pixels entering the image where (x - dx, y - dy) is outside (W, H or H + W - 1 groups, every
// line of the direction at once); the line is swept forward, then backward.  sum = L_r + L_-r
// (accumulate = 0) or sum + both; OUT_OF_VIEW where the cost is.  A pixel lies on one line of
// each direction and a lane reads and writes only its own samples of `sum`: no two work-items of
// a launch touch one value.  Per step a lane computes
//   L(d) = C(d) + min(L'(d), L'(d - 1) + P1, L'(d + 1) + P1, m' + P2) - m'
// for its samples, taking L'(d - 1) of its first and L'(d + 1) of its last sample from its
// neighbours' chunk edges and m' (the previous pixel's minimum) from every lane's minimum, both in
// local memory written at the previous step (two buffers by the step's parity: one barrier per
// step).  Samples out of view (cost byte COST_OUT) and padding have path value PAD_COST (never a
// minimum, no neighbour); a sample entering the view takes m' as its own predecessor (L = C).
__kernel void group_paths(__global const uchar *cost, __global short *sum, const int h, const int w,
                          const int n, const int dy, const int dx, const short p1, const short p2,
                          const int accumulate)
{
    __local short edge_lo[2][LANES], edge_hi[2][LANES];
    __local short minima[2][8 * SHORT8S];
    const int lane = get_local_id(0), i = get_group_id(0);
    const int k0 = lane * CH;
    for (int e = LANES + lane; e < 8 * SHORT8S; e += LANES)      // entries past LANES: no minimum
        for (int b = 0; b < 2; ++b)
            minima[b][e] = PAD_COST;
    int x, y;
    const int len = path_line(i, h, w, dy, dx, &y, &x);      // i < the direction's lines: len > 0
    const long stride = ((long)dy * w + dx) * n;
    const long first = ((long)y * w + x) * n + k0;
    const int cnt = CLAMPI(n - k0, 0, CH);         // this lane's samples
    for (int pass = 0; pass < 2; ++pass) {
        const long step = pass ? -stride : stride;
        const int add = pass || accumulate;
        long p = pass ? first + (len - 1) * stride : first;
        short prev[CH];
        short m = PAD_COST;
        // the next pixel's costs and sums are loaded a step ahead: their loads do not wait for
        // the recursion (a GPU's memory latency would otherwise add to every step of the line)
        int next_c[CH], next_s[CH];
        #pragma unroll
        for (int j = 0; j < CH; ++j) {
            next_c[j] = j < cnt ? (int)cost[p + j] : COST_OUT;
            next_s[j] = j < cnt && add ? sum[p + j] : 0;
        }
        for (int t = 0; t < len; ++t, p += step) {
            const int b = t & 1;
            int c[CH], s[CH];
            #pragma unroll
            for (int j = 0; j < CH; ++j) {
                c[j] = next_c[j];
                s[j] = next_s[j];
            }
            if (t + 1 < len) {
                #pragma unroll
                for (int j = 0; j < CH; ++j) {
                    next_c[j] = j < cnt ? (int)cost[p + step + j] : COST_OUT;
                    next_s[j] = j < cnt && add ? sum[p + step + j] : 0;
                }
            }
            // L'(d - 1) of the first sample, L'(d + 1) of the last: the neighbours' edges
            short below = PAD_COST, above = PAD_COST;
            if (t > 0) {
                below = lane > 0 ? edge_hi[b ^ 1][lane - 1] : (short)PAD_COST;
                above = lane < LANES - 1 ? edge_lo[b ^ 1][lane + 1] : (short)PAD_COST;
            }
            short cur[CH];
            short mv = PAD_COST;
            #pragma unroll
            for (int j = 0; j < CH; ++j) {
                int v = c[j];
                if (t > 0) {
                    const int lower = (j > 0 ? prev[j - 1] : below) + p1;
                    const int upper = (j < CH - 1 ? prev[j + 1] : above) + p1;
                    const int stay = prev[j] >= PAD_COST ? m : prev[j];
                    v = c[j] + IMIN(IMIN(stay, IMIN(lower, upper)), m + p2) - m;
                }
                cur[j] = c[j] == COST_OUT ? (short)PAD_COST : (short)v;
                mv = IMIN(mv, cur[j]);
            }
            #pragma unroll
            for (int j = 0; j < CH; ++j) {
                if (j < cnt)
                    sum[p + j] = cur[j] >= PAD_COST ? (short)OUT_OF_VIEW : (short)(s[j] + cur[j]);
                prev[j] = cur[j];
            }
            edge_lo[b][lane] = cur[0];
            edge_hi[b][lane] = cur[CH - 1];
            minima[b][lane] = mv;
            barrier(CLK_LOCAL_MEM_FENCE);
            m = min_of_lanes(minima[b]);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Winner-take-all for both views from the sum volume: one work-group per row, walking its pixels;
// per pixel x each lane reduces its samples, then the group: (cost, k) pairs as one uint key
// (cost << 16 | k: the least cost, ties to the smaller k, the specification's first minimum).
// Left view: the winner kb of S[y][x][k] over the samples in view (S >= 0), then the best cost
// more than one step from kb (a second reduction: uniqueness), then lane 0 tests and refines as
// select_disparity_reference.  Right view (pixel xr = x): the winner of S[y][xr + d_min +
// floor(k / steps)][k] over k whose left pixel lies inside and whose sample is in view, in steps
// (NO_MATCH if none).  Two barriers per pixel; the buffers of the two reductions are written and
// read in alternation, so none is overwritten before every lane has read it.
#define NO_KEY 0xffffffffu

static inline uint lane_key(const int v, const int k)
{
    return v >= 0 ? ((uint)v << 16) | (uint)k : NO_KEY;
}

static inline uint group_min(__local const uint *keys)
{
    uint4 m = vload4(0, keys);
    for (int q = 1; q < UINT4S; ++q) {
        const uint4 u = vload4(q, keys);
        m = m < u ? m : u;
    }
    const uint2 a = m.lo < m.hi ? m.lo : m.hi;
    return a.x < a.y ? a.x : a.y;
}

__kernel void group_select(__global const short *sum, __global float *disp, __global int *right,
                           __global float *margin, const int h, const int w, const int n, const int d_min,
                           const int steps, const int uniqueness)
{
    __local uint keys[3][4 * UINT4S];    // the left winner, the right winner, the left second
    const int lane = get_local_id(0), y = get_group_id(0);
    for (int e = LANES + lane; e < 4 * UINT4S; e += LANES)       // entries past LANES: no key
        for (int a = 0; a < 3; ++a)
            keys[a][e] = NO_KEY;
    const int k0 = lane * CH, cnt = CLAMPI(n - k0, 0, CH), t0 = d_min * steps;
    __global const short *row = sum + (size_t)y * w * n;
    for (int x = 0; x < w; ++x) {
        __global const short *s = row + (size_t)x * n;
        int v[CH];
        uint kl = NO_KEY, kr = NO_KEY;
        #pragma unroll
        for (int j = 0; j < CH; ++j) {
            const int k = k0 + j;
            v[j] = j < cnt ? s[k] : -1;
            kl = IMIN(kl, lane_key(v[j], k));
            const int xl = x + d_min + k / steps;
            if (j < cnt && xl >= 0 && xl < w)
                kr = IMIN(kr, lane_key(row[(size_t)xl * n + k], k));
        }
        keys[0][lane] = kl;
        keys[1][lane] = kr;
        barrier(CLK_LOCAL_MEM_FENCE);
        const uint best_key = group_min(keys[0]), right_key = group_min(keys[1]);
        const int has = best_key != NO_KEY;
        const int best = (int)(best_key >> 16), kb = has ? (int)(best_key & 0xffff) : 0;
        uint k2 = NO_KEY;
        #pragma unroll
        for (int j = 0; j < CH; ++j)
            if (k0 + j - kb > 1 || kb - (k0 + j) > 1)
                k2 = IMIN(k2, lane_key(v[j], 0));
        keys[2][lane] = k2;
        barrier(CLK_LOCAL_MEM_FENCE);
        const uint second_key = group_min(keys[2]);
        if (lane == 0) {      // the pixel's results
            right[(size_t)y * w + x] = right_key == NO_KEY ? NO_MATCH : t0 + (int)(right_key & 0xffff);
            const int second = (int)(second_key >> 16);
            const int unique = has && second_key != NO_KEY && (long)second * 100 > (long)best * (100 + uniqueness);
            const int km = kb > 0 ? kb - 1 : 0, kp = kb < n - 1 ? kb + 1 : n - 1;
            const int sm = s[km], sp = s[kp];
            const int cut = (kb > 0 && sm < 0) || (kb < n - 1 && sp < 0);
            const float den = (float)(sm - 2 * best + sp);
            float delta = 0.0f;
            if (kb > 0 && kb < n - 1 && den > 0.0f)
                delta = (float)(sm - sp) / (2.0f * den);
            if (steps == 2 && kb >= 2 && kb <= n - 3) {
                // half-pixel samples: one baseline per phase (spec._half_pixel_fit)
                const int sm2 = s[kb - 2], sp2 = s[kb + 2];
                const int den2 = sm2 + sp2 - 2 * best;
                if (sm >= 0 && sp >= 0 && sm2 >= 0 && sp2 >= 0 && den2 > 0) {
                    const float fit = (float)(2 * (sm - sp) + sm2 - sp2) / (2.0f * (float)den2);
                    delta = fit < -1.0f ? -1.0f : fit > 1.0f ? 1.0f : fit;
                }
            }
            const int keep = unique && !cut;
            disp[(size_t)y * w + x] = keep ? ((float)t0 + (float)kb + delta) / (float)steps : as_float(0x7fc00000u);
            margin[(size_t)y * w + x] = keep ? (float)(second - best) / (float)second : 0.0f;
        }
    }
}
