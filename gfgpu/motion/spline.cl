// Helpers shared by the motion kernels (motion.cl, field_kernels/field.cl, polar_kernels/polar.cl),
// pasted into each source where it says #include "spline.cl" (gfgpu.backends.opencl.launch expands the
// include in Python, so PoCL's cache key is the whole text): the PoCL workarounds, the boundary
// extension of gfgpu._core.boundary, the cubic B-spline's pole and its powers, and the tap weights.
// Needs REAL, POS and the constants the launchers define (MODE_*, SPLINE_POLE, NEAR_A, NEAR_B).

// PoCL 3.0 (pocl-binary-distribution) calls its builtins out of line: min, max, floor, fabs,
// sqrt, vloadn and vstoren are function calls in the compiled kernels, and so are the helpers
// below unless forced inline; in the per-sample loops the calls cost more than the arithmetic.
// Hence IMIN / IMAX (ints, arguments without side effects), the compiler's own floor, fabs, fmin,
// fmax and sqrt under clang (one instruction each, the same values: exact, or correctly rounded
// as PoCL's), and INLINE on the helpers of the loops.
#define IMIN(a, b) ((a) < (b) ? (a) : (b))
#define IMAX(a, b) ((a) > (b) ? (a) : (b))
#ifdef __clang__
#define INLINE static inline __attribute__((always_inline))
#define POS_IS_DOUBLE_double 1
#define POS_IS_DOUBLE_float 0
#define IS_DOUBLE_(t) POS_IS_DOUBLE_##t
#define IS_DOUBLE(t) IS_DOUBLE_(t)
#if IS_DOUBLE(POS)
#define FLOOR_POS(x) __builtin_floor(x)
#else
#define FLOOR_POS(x) __builtin_floorf(x)
#endif
#if IS_DOUBLE(GRID)
#define SQRT_GRID(x) __builtin_sqrt(x)
#else
#define SQRT_GRID(x) __builtin_sqrtf(x)
#endif
#define FABSF(x) __builtin_fabsf(x)
#define FMAXF(a, b) __builtin_fmaxf(a, b)
#define FMINF(a, b) __builtin_fminf(a, b)
#else
#define INLINE static inline
#define FLOOR_POS(x) floor(x)
#define SQRT_GRID(x) sqrt(x)
#define FABSF(x) fabs(x)
#define FMAXF(a, b) fmax(a, b)
#define FMINF(a, b) fmin(a, b)
#endif

#ifndef GRID
#define GRID POS     // positions of spline2: the polar kernels may take float for float32 images
#endif

#define POLE ((POS)(SPLINE_POLE))     // sqrt(3) - 2
#define TWO_PI ((POS)6.283185307179586)

// the modes whose extension repeats with a period (gfgpu._core.boundary.PERIODIC_MODES)
#define IS_PERIODIC(mode) ((mode) == MODE_WRAP || (mode) == MODE_REFLECT || (mode) == MODE_MIRROR)

// index of sample i of a line of n extended by mode (-1: cval): gfgpu._core.boundary.extend_index
INLINE int extend(int i, const int n, const int mode)
{
    if (mode == MODE_CONSTANT)
        return (i < 0 || i >= n) ? -1 : i;
    if (mode == MODE_NEAREST)
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
    if (mode == MODE_WRAP) {
        int r = i % n;
        return r < 0 ? r + n : r;
    }
    if (mode == MODE_REFLECT) {
        int q = i % (2 * n);
        q = q < 0 ? q + 2 * n : q;
        return q >= n ? 2 * n - 1 - q : q;
    }
    if (n == 1)
        return 0;
    int q = i % (2 * n - 2);
    q = q < 0 ? q + 2 * n - 2 : q;
    return q >= n ? 2 * n - 2 - q : q;
}

// floor(x) as an int by conversion, |x| < 2^31: PoCL's floor() is a library call that stops the
// vectorisation across work-items (two of them cost more than the rest of the spline)
INLINE int ifloor(const GRID x)
{
    const int t = (int)x;
    return t - (x < (GRID)t);
}

// z^m for m >= 0, by the bits of m (branch-free: exp and pown are library calls that stop PoCL's
// vectorisation across work-items); 0 beyond m = 31, where |z|^m < 1e-18 (beside 1e-16 in double)
#define POLE_2 (POLE * POLE)
#define POLE_4 (POLE_2 * POLE_2)
#define POLE_8 (POLE_4 * POLE_4)

INLINE POS pole_power(const int m)
{
    return (m & 1 ? POLE : (POS)1) * (m & 2 ? POLE_2 : (POS)1) * (m & 4 ? POLE_4 : (POS)1)
           * (m & 8 ? POLE_8 : (POS)1) * (m & 16 ? POLE_8 * POLE_8 : (POS)1) * (m > 31 ? (POS)0 : (POS)1);
}

// weights in REAL from the fraction in REAL: positions need POS, a fraction in [0, 1) does not
INLINE REAL bweight(const REAL t, const int p)
{
    const REAL g = (REAL)1 - t;
    switch (p) {
    case 0: return g * g * g / (REAL)6;
    case 1: return ((REAL)3 * t * t * t - (REAL)6 * t * t + (REAL)4) / (REAL)6;
    case 2: return ((REAL)3 * g * g * g - (REAL)6 * g * g + (REAL)4) / (REAL)6;
    default: return t * t * t / (REAL)6;
    }
}
