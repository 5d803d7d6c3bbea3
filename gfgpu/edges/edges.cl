// Interpolated non-maximum suppression for the edge detector (-D REAL=float|double).
// Executable specifications: gfgpu.edges.spec.suppress_nonmaxima_reference (out: the suppressed
// magnitude, REAL) and, built with -D CLASSES, suppress_classes_reference (out: uchar classes of
// it against the hysteresis thresholds, arguments lo, hi, strict after w).
#ifdef GFGPU_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

// PoCL calls its builtins out of line (sqrt, fabs: a call each, several per pixel): under clang
// the compiler's own, one instruction each (sqrt correctly rounded as PoCL's; fabs exact)
#if defined(__clang__) && defined(GFGPU_DOUBLE)
#define SQRT(v) __builtin_sqrt(v)
#define FABS(v) __builtin_fabs(v)
#define INLINE static inline __attribute__((always_inline))
#elif defined(__clang__)
#define SQRT(v) __builtin_sqrtf(v)
#define FABS(v) __builtin_fabsf(v)
#define INLINE static inline __attribute__((always_inline))
#else
#define SQRT(v) sqrt(v)
#define FABS(v) fabs(v)
#define INLINE static inline
#endif

#ifdef CLASSES
#define OUT uchar
#define CLASS_ARGS , const REAL lo, const REAL hi, const int strict
// 1: a candidate (v > lo if strict, else v >= lo), 3: a candidate >= hi too, else 0
#define STORE(v) classify(v, lo, hi, strict)
#else
#define OUT REAL
#define CLASS_ARGS
#define STORE(v) (v)
#endif

// static inline: some drivers reject plain inline without optimisation
INLINE uchar classify(const REAL v, const REAL lo, const REAL hi, const int strict)
{
    const int weak = strict ? v > lo : v >= lo;
    return weak ? (v >= hi ? 3 : 1) : 0;
}

INLINE REAL magnitude_at(__global const REAL *gy, __global const REAL *gx, size_t p)
{
    const REAL a = gy[p], b = gx[p];
    return SQRT(a * a + b * b);
}

// out = |g| where |g| is a maximum along the gradient line (neighbours interpolated between
// the two pixels straddling it), else 0; a tie with the -g neighbour keeps the pixel, a tie with
// the +g neighbour does not (one pixel per symmetric crest, on the brighter side).  Interior
// pixel p of a row of w.  The magnitudes of all 8 neighbours are computed (loads at fixed
// offsets) and the 4 it interpolates selected: no branch and no data-dependent address, so
// work-items of one group take one path (PoCL vectorises them: 2-3x faster than reading only
// the 4 neighbours at data-dependent offsets in two branches, the same bits).
INLINE REAL suppress_one(__global const REAL *gy, __global const REAL *gx, const size_t p, const size_t w)
{
    const size_t up = p - w, down = p + w;
    const REAL vy = gy[p], vx = gx[p];
    const REAL m = SQRT(vy * vy + vx * vx);
    const REAL ay = FABS(vy), ax = FABS(vx);
    const int steep = ay >= ax;                 // interpolate along the next row, else column
    const REAL t = steep ? ax / ay : ay / ax;   // NaN only where m = 0 (then out is 0)
    const int same = !(vy * vx < (REAL)0);      // gy, gx of one sign: the diagonal (+1, +1)
    const REAL n = magnitude_at(gy, gx, up), s = magnitude_at(gy, gx, down);
    const REAL e = magnitude_at(gy, gx, p + 1), wst = magnitude_at(gy, gx, p - 1);
    const REAL ne = magnitude_at(gy, gx, up + 1), nw = magnitude_at(gy, gx, up - 1);
    const REAL se = magnitude_at(gy, gx, down + 1), sw = magnitude_at(gy, gx, down - 1);
    // +g side: (i+1, j) and (i+1, j±1) if steep, else (i, j+1) and (i±1, j+1); -g mirrored
    const REAL a1 = steep ? s : e, b1 = steep ? n : wst;
    const REAL a2 = same ? se : (steep ? sw : ne);
    const REAL b2 = same ? nw : (steep ? ne : sw);
    const REAL plus = ((REAL)1 - t) * a1 + t * a2;
    const REAL minus = ((REAL)1 - t) * b1 + t * b2;
    const REAL tol = (REAL)TIE_RTOL * m;   // -D TIE_RTOL (gfgpu.edges.spec): equal up to rounding is a tie
    return (m > (REAL)0 && m > plus + tol && m >= minus - tol) ? m : (REAL)0;
}

// One pixel per work-item (a GPU's shape: neighbouring work-items read neighbouring samples):
// work-item (j, i) is interior pixel (i + 1, j + 1); zero_border writes the border.
__kernel void suppress_nonmaxima(__global const REAL *gy, __global const REAL *gx,
                                 __global OUT *out, const int h, const int w CLASS_ARGS)
{
    const long j = get_global_id(0) + 1, i = get_global_id(1) + 1;
    if (i >= h - 1 || j >= w - 1) return;
    const size_t p = (size_t)(i * w + j);
    out[p] = STORE(suppress_one(gy, gx, p, (size_t)w));
}

#ifdef GFGPU_DOUBLE
#define REAL8 double8
#define MASK8 long8
#else
#define REAL8 float8
#define MASK8 int8
#endif
#ifndef BAND
#define BAND 8
#endif
#ifndef NV
#define NV 8
#endif
#define RUN (8 * NV)

// the vector square root inline and correctly rounded, as SQRT (PoCL: one vsqrtps per 8 lanes)
#if defined(__clang__) && defined(__has_builtin)
#if __has_builtin(__builtin_elementwise_sqrt)
#define SQRT8(v) __builtin_elementwise_sqrt(v)
#endif
#endif
#ifndef SQRT8
#define SQRT8(v) sqrt(v)
#endif

INLINE REAL8 magnitudes8(const REAL8 a, const REAL8 b)
{
    return SQRT8(a * a + b * b);
}

// ring[c + 1] = |g| at columns j0 + c of the row at q (= its column j0), c = -1 .. 8 nv
INLINE void ring_row(__private REAL *ring, __global const REAL *gy, __global const REAL *gx,
                     const size_t q, const long j0, const int nv)
{
    for (int k = 0; k < nv; ++k)
        vstore8(magnitudes8(vload8(k, gy + q), vload8(k, gx + q)), 0, ring + 1 + 8 * k);
    ring[0] = j0 ? magnitude_at(gy, gx, q - 1) : (REAL)0;    // column -1: absent (column 0 is the border)
    ring[8 * nv + 1] = magnitude_at(gy, gx, q + 8 * nv);
}

// The same suppression on CPU devices: work-item (g, b) owns columns RUN g .. RUN g + RUN - 1
// (RUN = 8 NV) of the BAND rows of band b and walks down them with the magnitudes of three rows
// (and of one column either side) in a private ring, one new row per step: RUN + 2 square roots
// per RUN pixels where suppress_nonmaxima takes 9 per pixel (the square roots bound it), loads
// and stores of whole 8-wide vectors, and runs of a row (RUN values) before the next row (8
// columns per work-item and row were a third slower at 2048²).  Every selected
// value, the interpolation and the comparisons are suppress_nonmaxima's expressions lane by
// lane, so the output is bit for bit the same.  Column 0 is written 0 here, the border rows
// and column w - 1 by zero_border; the last run holds the vectors whose right neighbour is in
// the image and does the few columns left (< 8) one at a time, as suppress_nonmaxima.
__kernel void suppress_nonmaxima_runs(__global const REAL *gy, __global const REAL *gx,
                                      __global OUT *out, const int h, const int w CLASS_ARGS)
{
    const long j0 = RUN * (long)get_global_id(0);
    const long i0 = 1 + (long)BAND * get_global_id(1);
    if (j0 >= w - 1 || i0 >= h - 1) return;
    const long i1 = min(i0 + (long)BAND, (long)h - 1);
    const long j1 = min(j0 + RUN, (long)w - 1);     // this run's columns end (interior)
    const int nv = (int)((j1 - j0) / 8);            // whole vectors, right neighbour inside
    const size_t W = (size_t)w;
    REAL ring[3][RUN + 2];
    int ru = 0, rc = 1, rd = 2;
    if (nv) {
        ring_row(ring[ru], gy, gx, (size_t)(i0 - 1) * W + j0, j0, nv);
        ring_row(ring[rc], gy, gx, (size_t)i0 * W + j0, j0, nv);
    }
    for (long i = i0; i < i1; ++i) {
        const size_t p = (size_t)i * W + j0;
        if (nv)
            ring_row(ring[rd], gy, gx, p + W, j0, nv);
        for (int k = 0; k < nv; ++k) {
            const int c = 8 * k;
            const REAL8 n = vload8(0, ring[ru] + 1 + c), s = vload8(0, ring[rd] + 1 + c);
            const REAL8 e = vload8(0, ring[rc] + 2 + c), wst = vload8(0, ring[rc] + c);
            const REAL8 ne = vload8(0, ring[ru] + 2 + c), nw = vload8(0, ring[ru] + c);
            const REAL8 se = vload8(0, ring[rd] + 2 + c), sw = vload8(0, ring[rd] + c);
            const REAL8 m = vload8(0, ring[rc] + 1 + c);
            const REAL8 vy = vload8(k, gy + p), vx = vload8(k, gx + p);
            const REAL8 ay = fabs(vy), ax = fabs(vx);
            const MASK8 steep = ay >= ax;
            const REAL8 t = select(ay, ax, steep) / select(ax, ay, steep);
            const MASK8 same = !(vy * vx < (REAL8)0);
            const REAL8 a1 = select(e, s, steep), b1 = select(wst, n, steep);
            const REAL8 a2 = select(select(ne, sw, steep), se, same);
            const REAL8 b2 = select(select(sw, ne, steep), nw, same);
            const REAL8 plus = ((REAL8)1 - t) * a1 + t * a2;
            const REAL8 minus = ((REAL8)1 - t) * b1 + t * b2;
            const REAL8 tol = (REAL8)TIE_RTOL * m;
            REAL8 res = select((REAL8)0, m, (m > (REAL8)0) & (m > plus + tol) & (m >= minus - tol));
            if (j0 == 0 && k == 0)
                res.s0 = (REAL)0;       // column 0: the border
#ifdef CLASSES
            const MASK8 weak = strict ? res > (REAL8)lo : res >= (REAL8)lo;
            const MASK8 strong = weak & (res >= (REAL8)hi);
            vstore8(convert_uchar8((weak & (MASK8)1) | (strong & (MASK8)2)), k, out + p);
#else
            vstore8(res, k, out + p);
#endif
        }
        for (long j = max(j0 + 8 * nv, 1L); j < j1; ++j)      // the last run's few columns left
            out[p - j0 + j] = STORE(suppress_one(gy, gx, p - j0 + j, W));
        const int r0 = ru; ru = rc; rc = rd; rd = r0;
    }
}

// The border of out (rows 0 and h - 1, columns 0 and w - 1) set to 0 (its class): work-item k writes pixel
// k of each border row (k < w) and of each border column (k < h).
__kernel void zero_border(__global OUT *out, const int h, const int w CLASS_ARGS)
{
    const long k = get_global_id(0);
    const OUT zero = STORE((REAL)0);
    if (k < w) {
        out[k] = zero;
        out[(size_t)(h - 1) * w + k] = zero;
    }
    if (k < h) {
        out[(size_t)k * w] = zero;
        out[(size_t)k * w + w - 1] = zero;
    }
}
