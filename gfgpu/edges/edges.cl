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

// static inline: some drivers reject plain inline without optimisation; size_t: > 2^31 pixels
INLINE REAL magnitude_at(__global const REAL *gy, __global const REAL *gx, long i, long j, long w)
{
    const size_t p = (size_t)(i * w + j);
    const REAL a = gy[p], b = gx[p];
    return SQRT(a * a + b * b);
}

// out = |g| where |g| is a maximum along the gradient line (neighbours interpolated between
// the two pixels straddling it), else 0; a tie with the -g neighbour keeps the pixel, a tie with
// the +g neighbour does not (one pixel per symmetric crest, on the brighter side); border pixels 0.
__kernel void suppress_nonmaxima(__global const REAL *gy, __global const REAL *gx,
                                 __global REAL *out, const int h, const int w)
{
    const long j = get_global_id(0), i = get_global_id(1);
    if (i >= h || j >= w) return;
    const size_t p = (size_t)(i * w + j);
    if (i == 0 || j == 0 || i == h - 1 || j == w - 1) { out[p] = (REAL)0; return; }
    const REAL vy = gy[p], vx = gx[p];
    const REAL m = SQRT(vy * vy + vx * vx);
    if (m == (REAL)0) { out[p] = (REAL)0; return; }
    const long s = (vy * vx < (REAL)0) ? -1 : 1;
    REAL plus, minus;
    if (FABS(vy) >= FABS(vx)) {
        const REAL t = FABS(vx) / FABS(vy);
        plus = ((REAL)1 - t) * magnitude_at(gy, gx, i + 1, j, w) + t * magnitude_at(gy, gx, i + 1, j + s, w);
        minus = ((REAL)1 - t) * magnitude_at(gy, gx, i - 1, j, w) + t * magnitude_at(gy, gx, i - 1, j - s, w);
    } else {
        const REAL t = FABS(vy) / FABS(vx);
        plus = ((REAL)1 - t) * magnitude_at(gy, gx, i, j + 1, w) + t * magnitude_at(gy, gx, i + s, j + 1, w);
        minus = ((REAL)1 - t) * magnitude_at(gy, gx, i, j - 1, w) + t * magnitude_at(gy, gx, i - s, j - 1, w);
    }
    const REAL tol = (REAL)TIE_RTOL * m;   // -D TIE_RTOL (gfgpu.edges.spec): equal up to rounding is a tie
    out[p] = (m > plus + tol && m >= minus - tol) ? m : (REAL)0;
}
