// Interpolated non-maximum suppression for the edge detector (-D REAL=float|double).
// Executable specification: gfgpu.edges.spec.suppress_nonmaxima_reference.
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

// static inline: some drivers reject plain inline without optimisation
INLINE REAL magnitude_at(__global const REAL *gy, __global const REAL *gx, size_t p)
{
    const REAL a = gy[p], b = gx[p];
    return SQRT(a * a + b * b);
}

// out = |g| where |g| is a maximum along the gradient line (neighbours interpolated between
// the two pixels straddling it), else 0; a tie with the -g neighbour keeps the pixel, a tie with
// the +g neighbour does not (one pixel per symmetric crest, on the brighter side).  Interior
// pixels only: work-item (j, i) is pixel (i + 1, j + 1); zero_border writes the border.
// Every work-item computes the magnitudes of all 8 neighbours (loads at fixed offsets) and
// selects the 4 it interpolates: no branch and no data-dependent address, so PoCL vectorises a
// work-group across its work-items (2-3x faster on a CPU device than reading only the 4
// neighbours, at data-dependent offsets, in two branches; the arithmetic of each selected
// value and of the interpolation is unchanged, so the output is bit for bit the same).
__kernel void suppress_nonmaxima(__global const REAL *gy, __global const REAL *gx,
                                 __global REAL *out, const int h, const int w)
{
    const long j = get_global_id(0) + 1, i = get_global_id(1) + 1;
    if (i >= h - 1 || j >= w - 1) return;
    const size_t p = (size_t)(i * w + j), up = p - (size_t)w, down = p + (size_t)w;
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
    out[p] = (m > (REAL)0 && m > plus + tol && m >= minus - tol) ? m : (REAL)0;
}

// The border of out (rows 0 and h - 1, columns 0 and w - 1) set to 0: work-item k writes pixel
// k of each border row (k < w) and of each border column (k < h).
__kernel void zero_border(__global REAL *out, const int h, const int w)
{
    const long k = get_global_id(0);
    if (k < w) {
        out[k] = (REAL)0;
        out[(size_t)(h - 1) * w + k] = (REAL)0;
    }
    if (k < h) {
        out[(size_t)k * w] = (REAL)0;
        out[(size_t)k * w + w - 1] = (REAL)0;
    }
}
