// Box-window kernels of gfgpu.motion (spec: gfgpu/motion/spec.py; Warp twins in
// gfgpu/motion/_warp.py).  Built with -D REAL=float|double and -D POS=float|double (the type of
// positions and weights: double wherever the device has it).  Samples accumulate in REAL.
// The launcher (gfgpu/motion/_opencl.py) defines the constants of the Python definitions, none
// retyped here: the mode codes MODE_CONSTANT .. MODE_MIRROR, SPLINE_POLE, NEAR_A, NEAR_B
// (gfgpu.backends.opencl.launch.spline_defines) and NARROW (spec.NARROW).  Velocity fields are in
// field_kernels/field.cl, the polar resampling of the spin and zoom blurs in polar_kernels/polar.cl.

#if !defined(MODE_MIRROR) || !defined(SPLINE_POLE) || !defined(NARROW)
#error "motion.cl is built by gfgpu.motion._opencl, which defines the constants of the Python definitions"
#endif

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#include "spline.cl"    // the PoCL workarounds, boundary extension and cubic B-spline helpers

// sum_{k=1}^{m} z^k, m >= 0 (gfgpu._core.bspline.pole_series)
INLINE POS geometric(const int m)
{
    return POLE * ((POS)1 - pole_power(m)) / ((POS)1 - POLE);
}

// period of the coefficients of a line extended by a periodic mode (gfgpu._core.boundary.period)
INLINE int period_of(const int n, const int mode)
{
    return mode == MODE_WRAP ? n : (mode == MODE_REFLECT ? 2 * n : IMAX(2 * n - 2, 1));
}

// The spline coefficients of a line (at `start`, stride `step`) beyond its ends
// (gfgpu._core.bspline.coef_taps), and their sums over index ranges (spec._coef_prefix), for one
// line (T = REAL, LOAD a plain read) and for LANES lines in vector lanes (T = VT, LOAD = VGET; `ls`
// the stride between the lanes): one body, two instances.
//   P##edge(right): the extension's value beyond the left or right end: cval, or for 'nearest' the
//                   edge sample NEAR_A c[end] + NEAR_B c[end -+ 1]
//   P##at(i):       coefficient i: inside as stored; periodic modes as the samples; constant and
//                   nearest e + z^m (c[end] - e), m samples beyond the end
//   P##run(A, B):   sum over [A, B) by a compensated loop
//   P##sum(A, B):   the same in O(n) whatever B - A: whole periods, or the geometric tails, in
//                   closed form
#define EXTENSION(T, P, LOAD)                                                                             \
INLINE T P##edge(__global const REAL *src, const long start, const long step, const long ls,       \
                        const int n, const int right, const int mode, const REAL cval)                     \
{                                                                                                         \
    if (mode != MODE_NEAREST)                                                                             \
        return (T)cval;                                                                                   \
    const int j = right ? n - 1 : 0, j1 = right ? IMAX(n - 2, 0) : IMIN(1, n - 1);                       \
    return (REAL)NEAR_A * LOAD(src + start + (long)j * step, ls)                                          \
           + (REAL)NEAR_B * LOAD(src + start + (long)j1 * step, ls);                                      \
}                                                                                                         \
                                                                                                          \
INLINE T P##at(__global const REAL *src, const long start, const long step, const long ls,         \
                      const int n, const int i, const int mode, const REAL cval)                           \
{                                                                                                         \
    if ((unsigned)i < (unsigned)n)        /* inside the line: no extension (the common case) */           \
        return LOAD(src + start + (long)i * step, ls);                                                    \
    if (IS_PERIODIC(mode))                                                                                \
        return LOAD(src + start + (long)extend(i, n, mode) * step, ls);                                   \
    const int right = i >= n;                                                                             \
    const T c = LOAD(src + start + (long)(right ? n - 1 : 0) * step, ls);                                 \
    const T e = P##edge(src, start, step, ls, n, right, mode, cval);                                      \
    return e + (REAL)pole_power(right ? i - n + 1 : -i) * (c - e);                                        \
}                                                                                                         \
                                                                                                          \
static inline T P##run(__global const REAL *src, const long start, const long step, const long ls,        \
                       const int n, const int a, const int b, const int mode, const REAL cval)             \
{                                                                                                         \
    T sum = 0, comp = 0;                                                                                  \
    for (int i = a; i < b; ++i) {                                                                         \
        const T y = P##at(src, start, step, ls, n, i, mode, cval) - comp;                                 \
        const T s = sum + y;                                                                              \
        comp = (s - sum) - y;                                                                             \
        sum = s;                                                                                          \
    }                                                                                                     \
    return sum - comp;                                                                                    \
}                                                                                                         \
                                                                                                          \
static inline T P##sum(__global const REAL *src, const long start, const long step, const long ls,        \
                       const int n, const int a, const int b, const int mode, const REAL cval)             \
{                                                                                                         \
    if (b <= a)                                                                                           \
        return (T)0;                                                                                      \
    if (IS_PERIODIC(mode)) {                                                                              \
        const int per = period_of(n, mode);                                                               \
        if ((long)b - a <= 3L * per)                                                                      \
            return P##run(src, start, step, ls, n, a, b, mode, cval);                                     \
        const int a1 = a + ((-a) % per + per) % per, b1 = b - (b % per + per) % per;  /* whole periods */ \
        return P##run(src, start, step, ls, n, a, a1, mode, cval)                                         \
               + P##run(src, start, step, ls, n, b1, b, mode, cval)                                       \
               + (REAL)((b1 - a1) / per) * P##run(src, start, step, ls, n, 0, per, mode, cval);           \
    }                                                                                                     \
    T total = 0;                                                                                          \
    if (a < 0) {          /* c[i] = e + z^-i (c[0] - e) for a <= i < min(b, 0) */                        \
        const int top = IMIN(b, 0);                                                                       \
        const T e = P##edge(src, start, step, ls, n, 0, mode, cval);                                      \
        total += (REAL)(top - a) * e                                                                      \
                 + (REAL)(geometric(-a) - geometric(-top)) * (LOAD(src + start, ls) - e);                 \
    }                                                                                                     \
    if (IMAX(a, 0) < IMIN(b, n))                                                                          \
        total += P##run(src, start, step, ls, n, IMAX(a, 0), IMIN(b, n), mode, cval);                     \
    if (b > n) {          /* c[i] = e + z^(i-n+1) (c[n-1] - e) for max(a, n) <= i < b */                 \
        const int bottom = IMAX(a, n);                                                                    \
        const T e = P##edge(src, start, step, ls, n, 1, mode, cval);                                      \
        total += (REAL)(b - bottom) * e + (REAL)(geometric(b - n) - geometric(bottom - n))                 \
                                          * (LOAD(src + start + (long)(n - 1) * step, ls) - e);           \
    }                                                                                                     \
    return total;                                                                                         \
}

#define SLOAD(p, ls) (*(p))
EXTENSION(REAL, coef_, SLOAD)

INLINE REAL bintegral(const REAL f, const int p)
{
    const REAL f2 = f * f, f4 = f2 * f2, g = (REAL)1 - f;
    switch (p) {
    case 0: return ((REAL)1 - g * g * g * g) / (REAL)24;
    case 1: return ((REAL)0.75 * f4 - (REAL)2 * f2 * f + (REAL)4 * f) / (REAL)6;
    case 2: return ((REAL)-0.75 * f4 + f2 * f + (REAL)1.5 * f2 + f) / (REAL)6;
    default: return f4 / (REAL)24;
    }
}

INLINE REAL cell(__global const REAL *src, const long start, const long step, const int n, const int j,
                        const int mode, const REAL cval)
{
    return (coef_at(src, start, step, 0, n, j - 1, mode, cval) + (REAL)11 * coef_at(src, start, step, 0, n, j, mode, cval)
            + (REAL)11 * coef_at(src, start, step, 0, n, j + 1, mode, cval)
            + coef_at(src, start, step, 0, n, j + 2, mode, cval)) / (REAL)24;
}

// the sum of the spline's whole cells j in [a, b): the coefficients' sum plus three at each end
// (the cells' weights (1, 11, 11, 1)/24 telescope; gfgpu._core.bspline.PREFIX_ENDS)
static inline REAL cells(__global const REAL *src, const long start, const long step, const int n, const int a,
                         const int b, const int mode, const REAL cval)
{
    return coef_sum(src, start, step, 0, n, a, b, mode, cval)
           + (coef_at(src, start, step, 0, n, a - 1, mode, cval) - (REAL)12 * coef_at(src, start, step, 0, n, a, mode, cval)
              - coef_at(src, start, step, 0, n, a + 1, mode, cval) - coef_at(src, start, step, 0, n, b - 1, mode, cval)
              + (REAL)12 * coef_at(src, start, step, 0, n, b, mode, cval)
              + coef_at(src, start, step, 0, n, b + 1, mode, cval)) / (REAL)24;
}

// LESS = 1: the box kernels subtract less[] from their means (dst may be less: each element is read
// before it is written, by the same work-item)
#if LESS
#define LESS_AT(i) less[i]
#define VLESS_AT(p, ls) VGET(p, ls)
#else
#define LESS_AT(i) (REAL)0
#define VLESS_AT(p, ls) (VT)0
#endif

// Box windows [a0 + a1 k, b0 + b1 k] along the lines of a (B, N, M) array: one work-item per
// line; the first window's sum of whole cells in closed form, then one compensated running sum of
// whole spline cells plus the two partial cells.
__kernel void box_lines(__global const REAL *src, __global REAL *dst, const int n,
                        const long batch_stride, const long line_stride, const long step, const POS a0,
                        const POS a1, const POS b0, const POS b1, const int mode, const REAL cval, const int total,
                        const long dst_off, __global const REAL *less, const long less_off, const int line0,
                        const int run)
{
    // lines line0 .. line0 + run - 1 of each plane (all of them, or the partial lane group that
    // box_vec leaves); total = planes * run
    const int t = get_global_id(0);
    if (t >= total)
        return;
    const int b = t / run;
    const long start = b * batch_stride + (long)(line0 + t - b * run) * line_stride;
    int ia = (int)FLOOR_POS(a0), ib = (int)FLOOR_POS(b0);
    REAL sum = cells(src, start, step, n, ia, ib, mode, cval), comp = 0;
    for (int k = 0; k < n; ++k) {
        const POS a = a0 + a1 * (POS)k, e = b0 + b1 * (POS)k;
        const int na = (int)FLOOR_POS(a), nb = (int)FLOOR_POS(e);
        for (; ib < nb; ++ib) {
            const REAL y = cell(src, start, step, n, ib, mode, cval) - comp;
            const REAL s = sum + y;
            comp = (s - sum) - y;
            sum = s;
        }
        for (; ia < na; ++ia) {
            const REAL y = -cell(src, start, step, n, ia, mode, cval) - comp;
            const REAL s = sum + y;
            comp = (s - sum) - y;
            sum = s;
        }
        const REAL fa = (REAL)(a - (POS)ia), fb = (REAL)(e - (POS)ib);
        const POS width = e - a;
        if (width < (POS)NARROW) {     // the spline at the middle (spec.NARROW)
            const POS m = (POS)0.5 * (a + e), fm = FLOOR_POS(m);
            const int im = (int)fm;
            const REAL tm = (REAL)(m - fm);
            REAL v = 0;
            for (int p = 0; p < 4; ++p)
                v += bweight(tm, p) * coef_at(src, start, step, 0, n, im + p - 1, mode, cval);
            dst[dst_off + start + (long)k * step] = v - LESS_AT(less_off + start + (long)k * step);
            continue;
        }
        REAL pa = 0, pb = 0;
        for (int p = 0; p < 4; ++p) {
            pa += bintegral(fa, p) * coef_at(src, start, step, 0, n, ia + p - 1, mode, cval);
            pb += bintegral(fb, p) * coef_at(src, start, step, 0, n, ib + p - 1, mode, cval);
        }
        dst[dst_off + start + (long)k * step] = ((sum - comp) + pb - pa) / (REAL)width
                                                - LESS_AT(less_off + start + (long)k * step);
    }
}

// box_lines for windows of fixed width (a1 = b1 = 1, width >= NARROW; the host's
// gfgpu.motion.kernels.fixed_width), one line per work-item as box_lines (the GPU launch shapes,
// and on a CPU the lines that no vector group holds): the whole cells' running sum telescopes to
// one of the coefficients over [a + k, b + k) plus four taps at each end with fixed weights (the
// partial cells' integrals: wa, wb from the host), slid along in registers, so two coefficients
// are read per step instead of sixteen (box_shift below, in scalars)
__kernel void box_shift_lines(__global const REAL *src, __global REAL *dst, const int n, const long batch_stride,
                              const long line_stride, const long step, const int a, const int b, const REAL wa0,
                              const REAL wa1, const REAL wa2, const REAL wa3, const REAL wb0, const REAL wb1,
                              const REAL wb2, const REAL wb3, const REAL inv_width, const int mode, const REAL cval,
                              const int total, const long dst_off, __global const REAL *less, const long less_off,
                              const int line0, const int run)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
    const int p = t / run;
    const long start = p * batch_stride + (long)(line0 + t - p * run) * line_stride;
    REAL sum = coef_sum(src, start, step, 0, n, a, b, mode, cval), comp = 0;
    REAL am = coef_at(src, start, step, 0, n, a - 1, mode, cval), ac = coef_at(src, start, step, 0, n, a, mode, cval);
    REAL ap = coef_at(src, start, step, 0, n, a + 1, mode, cval), aq = coef_at(src, start, step, 0, n, a + 2, mode, cval);
    REAL bm = coef_at(src, start, step, 0, n, b - 1, mode, cval), bc = coef_at(src, start, step, 0, n, b, mode, cval);
    REAL bp = coef_at(src, start, step, 0, n, b + 1, mode, cval), bq = coef_at(src, start, step, 0, n, b + 2, mode, cval);
    for (int k = 0; k < n; ++k) {
        const long at = start + (long)k * step;
        const REAL ends = (wb0 * bm + wb1 * bc + wb2 * bp + wb3 * bq) - (wa0 * am + wa1 * ac + wa2 * ap + wa3 * aq);
        dst[dst_off + at] = ((sum - comp) + ends) * inv_width - LESS_AT(less_off + at);
        const REAL y = (bc - ac) - comp;        // slide: c[b + k] enters, c[a + k] leaves
        const REAL s = sum + y;
        comp = (s - sum) - y;
        sum = s;
        am = ac; ac = ap; ap = aq; aq = coef_at(src, start, step, 0, n, a + k + 3, mode, cval);
        bm = bc; bc = bp; bp = bq; bq = coef_at(src, start, step, 0, n, b + k + 3, mode, cval);
    }
}

#ifdef LANES
#ifndef VECS
#define VECS 1      // vectors of adjacent columns per box_shift work-item (the launcher's band)
#endif
// box_lines with LANES lines per work-item and vector arithmetic.  The window [a0 + a1 k, b0 + b1 k]
// is the same on every line, so the cell indices and partial-cell weights are scalars.  ROWS = 0:
// adjacent columns (axis 1, M a multiple of LANES), each load one contiguous vector; ROWS = 1:
// LANES consecutive rows (axis 2, B N a multiple of LANES): box_shift reads LANES steps of every
// row at a time as a LANES x LANES tile, one vector load per row, and transposes it in registers
// (a vector per step, a lane per row; its outputs likewise back); box_vec and the tiles that
// reach beyond a line's ends gather each vector across the rows (VGET).
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
typedef CAT(REAL, LANES) VT;
#if defined(__clang__)
// a vector of the element's alignment: one unaligned load or store, not a vloadn call
typedef REAL VTU __attribute__((ext_vector_type(LANES), aligned(sizeof(REAL))));
#define VLOADU(p) ((VT)(*(__global const VTU *)(p)))
#define VSTOREU(v, p) (*(__global VTU *)(p) = (VTU)(v))
#else
#define VLOADU(p) CAT(vload, LANES)(0, (p))
#define VSTOREU(v, p) CAT(vstore, LANES)((v), 0, (p))
#endif
#if ROWS
// lane l of the vector at p is p[l ls]: the same element of LANES rows ls apart
INLINE VT vgather(__global const REAL *p, const long ls)
{
    VT v;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        v[l] = p[l * ls];
    return v;
}

INLINE void vscatter(const VT v, __global REAL *p, const long ls)
{
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        p[l * ls] = v[l];
}
#define VGET(p, ls) vgather((p), (ls))
#define VPUT(v, p, ls) vscatter((v), (p), (ls))

// the in-place register transpose of a LANES x LANES tile (transpose_tile), as recurse.cl's
#if LANES != 4 && LANES != 8 && LANES != 16
#error "the row tiles need LANES 4, 8 or 16"
#endif
#define TILE_LANES LANES
#define TILE_VT VT
#include "backends/opencl/tile.cl"

// w[i] = LANES rows' samples p + i, i < LANES, of the array at `base` (rows ls apart): where all
// lie on the line (0 <= p, p + LANES <= n) one tile, LANES vector loads transposed
INLINE int load_tile(VT *w, __global const REAL *base, const long ls, const int n, const int p)
{
    if (p < 0 || p > n - LANES)
        return 0;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        w[l] = VLOADU(base + l * ls + p);
    transpose_tile(w);
    return 1;
}
#else
#define VGET(p, ls) VLOADU(p)
#define VPUT(v, p, ls) VSTOREU((v), (p))
#endif

// Work-item t's lines: the first one's first element `start`, the step along a line and between
// lanes; columns in bands of `width` adjacent columns per work-item, `groups` bands per plane
#if ROWS
#define LANE_GROUP(t, n, m, groups, width) const long start = (long)(t) * LANES * (m), step = 1, ls = (m)
#else
#define LANE_GROUP(t, n, m, groups, width)                                                               \
    const int plane_ = (t) / (groups), band_ = (t) - plane_ * (groups);                                  \
    const long start = (long)plane_ * (n) * (m) + (long)band_ * (width), step = (m), ls = 1
#endif

EXTENSION(VT, vcoef_, VGET)

#if ROWS
// c[p + i] of the lane group's rows for i < LANES in w[i]: a tile inside the line, the
// extension's coefficients (one gathered vector each) where it reaches beyond an end
INLINE void coef_steps(VT *w, __global const REAL *src, const long start, const long ls, const int n,
                              const int p, const int mode, const REAL cval)
{
    if (load_tile(w, src + start, ls, n, p))
        return;
#pragma unroll
    for (int i = 0; i < LANES; ++i)
        w[i] = vcoef_at(src, start, 1, ls, n, p + i, mode, cval);
}
#endif

static inline VT vcells(__global const REAL *src, const long start, const long step, const long ls, const int n,
                        const int a, const int b, const int mode, const REAL cval)
{
    return vcoef_sum(src, start, step, ls, n, a, b, mode, cval)
           + (vcoef_at(src, start, step, ls, n, a - 1, mode, cval)
              - (REAL)12 * vcoef_at(src, start, step, ls, n, a, mode, cval)
              - vcoef_at(src, start, step, ls, n, a + 1, mode, cval) - vcoef_at(src, start, step, ls, n, b - 1, mode, cval)
              + (REAL)12 * vcoef_at(src, start, step, ls, n, b, mode, cval)
              + vcoef_at(src, start, step, ls, n, b + 1, mode, cval)) / (REAL)24;
}

// c[i - 1 .. i + 2] of a lane group in w[0 .. 3]: what the cell i and the partial cell [i, i + f)
// read (box_vec keeps one such window at each end of its box and slides it along)
INLINE void vwindow(VT *w, __global const REAL *src, const long start, const long step, const long ls, const int n,
                    const int i, const int mode, const REAL cval)
{
#pragma unroll
    for (int q = 0; q < 4; ++q)
        w[q] = vcoef_at(src, start, step, ls, n, i + q - 1, mode, cval);
}

// the window of i + 1 from that of i: one new coefficient, c[i + 3]
INLINE void vslide(VT *w, __global const REAL *src, const long start, const long step, const long ls, const int n,
                   const int i, const int mode, const REAL cval)
{
    w[0] = w[1]; w[1] = w[2]; w[2] = w[3];
    w[3] = vcoef_at(src, start, step, ls, n, i + 3, mode, cval);
}

// n samples per line, lines `step` apart along them; cols: m = M (groups = M / LANES per plane),
// rows: m = M too (groups = B N / LANES, one plane).  Each end of the box keeps the four coefficients
// that its cell and its partial cell read in registers (vwindow) and slides them as the end moves on
// (vslide: one load per cell crossed; every step read the cells crossed and both partial cells afresh,
// sixteen loads, before): the same values in the same expressions, so the same results bit for bit.
__kernel void box_vec(__global const REAL *src, __global REAL *dst, const long dst_off, const int n, const int m,
                      const int groups, const POS a0, const POS a1, const POS b0, const POS b1, const int mode,
                      const REAL cval, const int total, __global const REAL *less, const long less_off)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
    LANE_GROUP(t, n, m, groups, LANES);
    int ia = (int)FLOOR_POS(a0), ib = (int)FLOOR_POS(b0);
    VT sum = vcells(src, start, step, ls, n, ia, ib, mode, cval), comp = 0;
    VT wa[4], wb[4];
    vwindow(wa, src, start, step, ls, n, ia, mode, cval);
    vwindow(wb, src, start, step, ls, n, ib, mode, cval);
    for (int k = 0; k < n; ++k) {
        const POS a = a0 + a1 * (POS)k, e = b0 + b1 * (POS)k;
        const int na = (int)FLOOR_POS(a), nb = (int)FLOOR_POS(e);
        for (; ib < nb; ++ib) {
            // the cell ib's integral, from the window
            const VT y = (wb[0] + (REAL)11 * wb[1] + (REAL)11 * wb[2] + wb[3]) / (REAL)24 - comp;
            const VT s = sum + y;
            comp = (s - sum) - y;
            sum = s;
            vslide(wb, src, start, step, ls, n, ib, mode, cval);
        }
        for (; ia < na; ++ia) {
            const VT y = -((wa[0] + (REAL)11 * wa[1] + (REAL)11 * wa[2] + wa[3]) / (REAL)24) - comp;
            const VT s = sum + y;
            comp = (s - sum) - y;
            sum = s;
            vslide(wa, src, start, step, ls, n, ia, mode, cval);
        }
        __global REAL *o = dst + dst_off + start + (long)k * step;
        const POS width = e - a;
        if (width < (POS)NARROW) {
            const POS mid = (POS)0.5 * (a + e), fm = FLOOR_POS(mid);
            const int im = (int)fm;
            const REAL tt = (REAL)(mid - fm);
            VT v = 0;
            for (int p = 0; p < 4; ++p)
                v += bweight(tt, p) * vcoef_at(src, start, step, ls, n, im + p - 1, mode, cval);
            VPUT(v - VLESS_AT(less + less_off + start + (long)k * step, ls), o, ls);
            continue;
        }
        const REAL fa = (REAL)(a - (POS)ia), fb = (REAL)(e - (POS)ib);
        VT part = 0;
#pragma unroll
        for (int p = 0; p < 4; ++p)
            part += bintegral(fb, p) * wb[p] - bintegral(fa, p) * wa[p];
        VPUT(((sum - comp) + part) / (VT)((REAL)width) - VLESS_AT(less + less_off + start + (long)k * step, ls), o, ls);
    }
}

// box_vec for windows of fixed width (a1 = b1 = 1, width >= NARROW): the cells' running sum
// telescopes to a running sum T of the coefficients over [A, B) (A = k + floor(a0), B = k + floor(b0))
// plus four taps at each end, whose weights (the partial cells' integrals, precomputed on the host:
// wa, wb) do not change along the line:
//     width * out[k] = T + sum_q wb[q] c[B - 1 + q] - sum_q wa[q] c[A - 1 + q]
// The four coefficients at each end slide along in registers: two new ones per step.

// one line group's state: T (compensated: sum, comp) and the coefficients c[A-1 .. A+2], c[B-1 .. B+2]
typedef struct {
    VT sum, comp, am, a0, ap, aq, bm, b0, bp, bq;
} shift_t;

INLINE void shift_start(shift_t *w, __global const REAL *src, const long start, const long step, const long ls,
                        const int n, const int a, const int b, const int mode, const REAL cval)
{
    w->sum = vcoef_sum(src, start, step, ls, n, a, b, mode, cval);
    w->comp = 0;
    w->am = vcoef_at(src, start, step, ls, n, a - 1, mode, cval);
    w->a0 = vcoef_at(src, start, step, ls, n, a, mode, cval);
    w->ap = vcoef_at(src, start, step, ls, n, a + 1, mode, cval);
    w->aq = vcoef_at(src, start, step, ls, n, a + 2, mode, cval);
    w->bm = vcoef_at(src, start, step, ls, n, b - 1, mode, cval);
    w->b0 = vcoef_at(src, start, step, ls, n, b, mode, cval);
    w->bp = vcoef_at(src, start, step, ls, n, b + 1, mode, cval);
    w->bq = vcoef_at(src, start, step, ls, n, b + 2, mode, cval);
}

// The output of the current step, then the window one step on: c[B] enters the sum, c[A] leaves
// it, and na = c[A + 3], nb = c[B + 3] join the taps
#define SHIFT_WEIGHTS const REAL wa0, const REAL wa1, const REAL wa2, const REAL wa3, const REAL wb0, \
                      const REAL wb1, const REAL wb2, const REAL wb3, const REAL inv_width
INLINE VT shift_step(shift_t *w, const VT na, const VT nb, const VT less_k, SHIFT_WEIGHTS)
{
    const VT ends = (wb0 * w->bm + wb1 * w->b0 + wb2 * w->bp + wb3 * w->bq)
                    - (wa0 * w->am + wa1 * w->a0 + wa2 * w->ap + wa3 * w->aq);
    const VT out = ((w->sum - w->comp) + ends) * inv_width - less_k;
    const VT y = (w->b0 - w->a0) - w->comp;
    const VT s = w->sum + y;
    w->comp = (s - w->sum) - y;
    w->sum = s;
    w->am = w->a0; w->a0 = w->ap; w->ap = w->aq; w->aq = na;
    w->bm = w->b0; w->b0 = w->bp; w->bp = w->bq; w->bq = nb;
    return out;
}

// ROWS: LANES rows per work-item (groups, vecs unused); columns: VECS vectors of LANES adjacent
// columns side by side per work-item (a band: one step touches one stretch of a row, not VECS
// far apart; fewer pages and cache lines), the last band of a plane `vecs - band * VECS` of them
__kernel void box_shift(__global const REAL *src, __global REAL *dst, const long dst_off, const int n, const int m,
                        const int groups, const int a, const int b, const REAL wa0, const REAL wa1, const REAL wa2,
                        const REAL wa3, const REAL wb0, const REAL wb1, const REAL wb2, const REAL wb3,
                        const REAL inv_width, const int mode, const REAL cval, const int total,
                        __global const REAL *less, const long less_off, const int vecs)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
#if ROWS
    LANE_GROUP(t, n, m, groups, LANES);
    shift_t w;
    shift_start(&w, src, start, step, ls, n, a, b, mode, cval);
    // LANES steps at a time: the coefficients entering at both ends (c[a + k + 3], c[b + k + 3])
    // and the subtracted samples as tiles, the outputs transposed back into one; lane by lane the
    // same operations in the same order as one step at a time
    for (int k0 = 0; k0 < n; k0 += LANES) {
        VT na[LANES], nb[LANES], y[LANES];
        coef_steps(na, src, start, ls, n, a + k0 + 3, mode, cval);
        coef_steps(nb, src, start, ls, n, b + k0 + 3, mode, cval);
        const int cnt = IMIN(LANES, n - k0);
#if LESS
        VT lv[LANES];
        if (!load_tile(lv, less + less_off + start, ls, n, k0)) {
#pragma unroll
            for (int i = 0; i < LANES; ++i)
                lv[i] = i < cnt ? vgather(less + less_off + start + k0 + i, ls) : (VT)0;
        }
#define LESS_STEP(i) lv[i]
#else
#define LESS_STEP(i) (VT)0
#endif
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            y[i] = shift_step(&w, na[i], nb[i], LESS_STEP(i), wa0, wa1, wa2, wa3, wb0, wb1, wb2, wb3, inv_width);
#undef LESS_STEP
        __global REAL *o = dst + dst_off + start + k0;
        if (cnt == LANES) {
            transpose_tile(y);       // back to one vector per row
#pragma unroll
            for (int l = 0; l < LANES; ++l)
                VSTOREU(y[l], o + l * ls);
        } else {
#pragma unroll
            for (int i = 0; i < LANES; ++i)
                if (i < cnt)
                    vscatter(y[i], o + i, ls);
        }
    }
#else
    LANE_GROUP(t, n, m, groups, LANES * VECS);
    const int nv = IMIN(VECS, vecs - band_ * VECS);
    shift_t w[VECS];
#pragma unroll
    for (int v = 0; v < VECS; ++v)
        if (v < nv)
            shift_start(&w[v], src, start + v * LANES, step, ls, n, a, b, mode, cval);
    for (int k = 0; k < n; ++k) {
        const long at = start + (long)k * step;
#pragma unroll
        for (int v = 0; v < VECS; ++v) {
            if (v < nv) {
                const VT na = vcoef_at(src, start + v * LANES, step, ls, n, a + k + 3, mode, cval);
                const VT nb = vcoef_at(src, start + v * LANES, step, ls, n, b + k + 3, mode, cval);
                VSTOREU(shift_step(&w[v], na, nb, VLESS_AT(less + less_off + at + v * LANES, ls), wa0, wa1, wa2,
                                   wa3, wb0, wb1, wb2, wb3, inv_width), dst + dst_off + at + v * LANES);
            }
        }
    }
#endif
}
#endif
