// Polar resampling of gfgpu.motion's spin and zoom blurs (spec: gfgpu.motion.spec.to_polar_reference,
// from_polar_reference, add_rows_reference; Warp twins in gfgpu/motion/polar_kernels/_warp.py): only
// polar code, so a spin or zoom builds only this.  Built with -D REAL=float|double, -D POS=float|double
// (positions: double wherever the device has it) and GRID (the type of the polar positions: float for
// float32 images).  The launcher (gfgpu/motion/polar_kernels/_opencl.py) defines the constants of the
// Python definitions, none retyped here: the mode codes MODE_CONSTANT .. MODE_MIRROR
// (gfgpu._core.boundary.MODE_CODES); SPLINE_POLE, NEAR_A, NEAR_B (gfgpu._core.bspline); and PAD (the
// coefficients pad_coef adds beyond each border).  Sizes are arguments: a new shape builds nothing.

#if !defined(MODE_MIRROR) || !defined(SPLINE_POLE) || !defined(PAD)
#error "polar.cl is built by gfgpu.motion.polar_kernels._opencl, which defines the constants of the Python definitions"
#endif

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#ifndef INLINE_ANGLE
#define INLINE_ANGLE 0      // 1: from_polar computes each pixel's angle (float positions), no angle map
#endif
#if INLINE_ANGLE && !GRID_IS_FLOAT
#error "INLINE_ANGLE takes float positions (the polynomial arctangent of angle_of)"
#endif

#ifndef CHUNK
#define CHUNK 1      // angles per work-item in to_polar
#endif

#include "spline.cl"    // the PoCL workarounds, boundary extension and cubic B-spline helpers

// the four cubic B-spline weights at fraction t, multiplications only (bweight's values)
INLINE void bweights4(const REAL t, REAL *wt)
{
    const REAL sixth = (REAL)1 / (REAL)6, t2 = t * t, g = (REAL)1 - t;
    const REAL t3 = t2 * t;
    wt[0] = g * g * g * sixth;
    wt[1] = ((REAL)0.5 * t3 - t2) + (REAL)2 / (REAL)3;
    wt[2] = (REAL)0.5 * (t + t2 - t3) + sixth;
    wt[3] = t3 * sixth;
}

#include "spline2d.cl"  // coef_taps and spline2: the 2-D cubic B-spline at a point

#ifdef MODE_X
// spline2 for the polar kernels, with the modes as build constants (MODE_Y along the rows, MODE_X
// along the columns: nearest, on coefficients that pad_coef extended by PAD beyond every border;
// or a periodic mode) and every coefficient index within one period or reflection of the line (the
// launcher checks): branch-free index arithmetic, so PoCL vectorises across work-items.
#if MODE_X == MODE_CONSTANT || MODE_Y == MODE_CONSTANT
#error "spline2_near: constant mode runs on coefficients extended by pad_coef, as nearest"
#endif
INLINE int near_index(const int i, const int n, const int mode)
{
    if (mode == MODE_NEAREST)
        return i < 0 ? 0 : (i >= n ? n - 1 : i);      // clamp(): a library call in PoCL
    if (mode == MODE_WRAP)
        return i < 0 ? i + n : (i >= n ? i - n : i);
    if (mode == MODE_REFLECT)
        return i < 0 ? -1 - i : (i >= n ? 2 * n - 1 - i : i);
    return n == 1 ? 0 : (i < 0 ? -i : (i >= n ? 2 * n - 2 - i : i));
}

static inline REAL spline2_near(__global const REAL *src, const long plane, const int h, const int w, const GRID py,
                                const GRID px)
{
    const int iy = ifloor(py), ix = ifloor(px);
    REAL wx[4], wy[4];
    bweights4((REAL)(px - (GRID)ix), wx);
    bweights4((REAL)(py - (GRID)iy), wy);
    REAL acc = 0;
    if (ix >= 1 && ix + 2 < w) {      // the four columns inside: contiguous loads
        for (int p = 0; p < 4; ++p) {
            __global const REAL *line = src + plane + (long)near_index(iy + p - 1, h, MODE_Y) * w + (ix - 1);
            acc += wy[p] * (wx[0] * line[0] + wx[1] * line[1] + wx[2] * line[2] + wx[3] * line[3]);
        }
        return acc;
    }
    int rx[4];
    for (int q = 0; q < 4; ++q)
        rx[q] = near_index(ix + q - 1, w, MODE_X);
    for (int p = 0; p < 4; ++p) {
        __global const REAL *line = src + plane + (long)near_index(iy + p - 1, h, MODE_Y) * w;
        acc += wy[p] * (wx[0] * line[rx[0]] + wx[1] * line[rx[1]] + wx[2] * line[rx[2]] + wx[3] * line[rx[3]]);
    }
    return acc;
}
#define SPLINE_POLAR(src, plane, h, w, py, px, my, mx, cval) spline2_near(src, plane, h, w, py, px)
#else
#define SPLINE_POLAR(src, plane, h, w, py, px, my, mx, cval) spline2(src, plane, h, w, py, px, my, mx, cval)
#endif

// The coefficients of (h, w) planes extended by constant or nearest mode (gfgpu._core.bspline.coef_taps,
// along the rows and the columns) on (h + 2 PAD, w + 2 PAD), one work-item per element: to_polar then
// reads them clamped (nearest), which is the extension to z^PAD (below 1e-18).
__kernel void pad_coef(__global const REAL *src, __global REAL *dst, const int h, const int w, const int planes,
                       const int mode, const REAL cval)
{
    const int x = get_global_id(0), y = get_global_id(1), wp = w + 2 * PAD, hp = h + 2 * PAD;
    if (x >= wp || y >= hp)
        return;
    POS gy0, gy1, gx0, gx1;
    int ry1, rx1;
    const int ry0 = coef_taps(y - PAD, h, mode, &gy0, &ry1, &gy1), rx0 = coef_taps(x - PAD, w, mode, &gx0, &rx1, &gx1);
    const REAL base = mode == MODE_CONSTANT ? cval : (REAL)0;
    for (int b = 0; b < planes; ++b) {
        __global const REAL *c = src + (long)b * h * w;
        const REAL r0 = (REAL)gx0 * (c[(long)ry0 * w + rx0] - base) + (REAL)gx1 * (c[(long)ry0 * w + rx1] - base);
        const REAL r1 = (REAL)gx0 * (c[(long)ry1 * w + rx0] - base) + (REAL)gx1 * (c[(long)ry1 * w + rx1] - base);
        dst[((long)b * hp + y) * wp + x] = base + (REAL)gy0 * r0 + (REAL)gy1 * r1;
    }
}

// One work-item per CHUNK angles of one ring (radius r0 + i) of every plane, layout (B, n_r, n_phi):
// adjacent work-items are adjacent angles.  trig[2j], trig[2j+1] = cos, sin of angle j (computed once on the
// host: a sine per sample would dominate the kernel).  Positions in GRID (float for float32 images:
// r cos phi to 1e-7 relative, 1e-4 px on a ring of radius 1500; double for float64 ones).
__kernel void to_polar(__global const REAL *coef, __global REAL *out, const long out_off, __global const GRID *trig,
                       const int h, const int w, const int n_r, const int n_phi, const int planes, const GRID cy,
                       const GRID cx, const int r0, const int mode, const REAL cval)
{
    const int i = get_global_id(1);
    if (i >= n_r)
        return;
    const GRID r = (GRID)(r0 + i);
    const int j0 = get_global_id(0) * CHUNK, j1 = IMIN(j0 + CHUNK, n_phi);
    for (int j = j0; j < j1; ++j) {
        const GRID py = cy - r * trig[2 * j + 1], px = cx + r * trig[2 * j];
        for (int b = 0; b < planes; ++b)
            out[out_off + ((long)b * n_r + i) * n_phi + j] = SPLINE_POLAR(coef, (long)b * h * w, h, w, py, px, mode,
                                                                        mode, cval);
    }
}

// The angle of (dx, dy) in [0, 2 pi).  float: Cephes' atanf polynomial after reduction to
// |t| <= tan(pi/8) (about 1e-7 rad, 1e-3 of an angular sample on a ring of 10^4); PoCL's atan2
// costs more than the whole spline.  double: the built-in atan2 (float64 results match to 1e-11).
static inline GRID angle_of(const GRID dy, const GRID dx)
{
#if GRID_IS_FLOAT
    const float ax = FABSF(dx), ay = FABSF(dy);
    const float hi = FMAXF(ax, ay), lo = FMINF(ax, ay);
    float t = hi > 0.0f ? lo / hi : 0.0f;           // in [0, 1]
    const int big = t > 0.41421356237309503f;
    t = big ? (t - 1.0f) / (t + 1.0f) : t;
    const float z = t * t;
    float a = ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z - 3.33329491539e-1f) * z)
              * t + t;
    a = big ? a + 0.78539816339744831f : a;
    a = ay > ax ? 1.5707963267948966f - a : a;
    a = dx < 0.0f ? 3.1415926535897932f - a : a;
    return dy < 0.0f ? 6.2831853071795865f - a : a;
#else
    const GRID phi = atan2(dy, dx);
    return phi < 0 ? phi + (GRID)6.283185307179586 : phi;
#endif
}

// The angle in [0, 2 pi) of every pixel about (cy, cx), one work-item per pixel (from_polar reads it:
// computed once per image shape and centre, the launcher keeps it).
__kernel void angle_map(__global GRID *angles, const int h, const int w, const GRID cy, const GRID cx)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    angles[(long)y * w + x] = angle_of(cy - (GRID)y, (GRID)x - cx);
}

// One work-item per pixel of the box (x0, y0) + (bw, bh): where the pixel's radius r lies in [r_lo, r_hi),
// base weighted by the ring weights' radial spline plus the polar spline of a band of rings from r0, at
// the pixel's ring (rows, mirrored at the band's ends) and angle (columns, wrapped); elsewhere base
// itself (copy = 1) or nothing (copy = 0: out keeps its values, bands of rings that split the radii each
// write their own pixels).  Only the band's pixels pay for the angle and the 16 taps (the launcher limits
// the box to the band's radii); each pixel's angle is computed (INLINE_ANGLE: the CPU's vector kernel, float
// positions) or read from angles (angle_map: every band of every call about one centre reads the same).
// wcoef holds the weights' coefficients with their mirror extension, one
// before ring 0 and two beyond ring n_r - 1 (the launcher pads them: no index arithmetic here).
// from_polar's work at pixel (x, y) (its angle in angles[y * w + x])
INLINE void from_polar_pixel(__global const REAL *pcoef, __global const REAL *base, __global REAL *out,
                             const long out_off, const int h, const int w, const int n_r, const int n_phi,
                             const int planes, const GRID cy, const GRID cx, const int r0, const GRID r_lo,
                             const GRID r_hi, const int x, const int y, const long base_off,
                             __global const REAL *wcoef, const int weighted, const int copy,
                             __global const GRID *angles)
{
    const GRID dy = cy - (GRID)y, dx = (GRID)x - cx;
    const GRID r = SQRT_GRID(dx * dx + dy * dy);
    if (!(r >= r_lo && r < r_hi)) {
        if (copy)
            for (int b = 0; b < planes; ++b) {
                const long pix = ((long)b * h + y) * w + x;
                out[out_off + pix] = base[base_off + pix];
            }
        return;
    }
#if INLINE_ANGLE
    GRID jf = angle_of(dy, dx) * ((GRID)n_phi / (GRID)6.283185307179586);   // computed here (no angle map)
#else
    GRID jf = angles[(long)y * w + x] * ((GRID)n_phi / (GRID)6.283185307179586);   // read (angle_map)
#endif
    jf = jf >= (GRID)n_phi ? jf - (GRID)n_phi : jf;     // rounding at 2 pi
    const GRID ring = r - (GRID)r0;
    REAL weight = (REAL)1;
    if (weighted) {       // the ring weights' radial spline: what the resampling gives them
        const int ir = ifloor(ring);
        REAL wr[4];
        bweights4((REAL)(ring - (GRID)ir), wr);
        weight = wr[0] * wcoef[ir] + wr[1] * wcoef[ir + 1] + wr[2] * wcoef[ir + 2] + wr[3] * wcoef[ir + 3];
    }
    for (int b = 0; b < planes; ++b) {
        const long pix = ((long)b * h + y) * w + x;
        const REAL change = SPLINE_POLAR(pcoef, (long)b * n_r * n_phi, n_r, n_phi, ring, jf, MODE_MIRROR, MODE_WRAP,
                                         (REAL)0);
        out[out_off + pix] = weight * base[base_off + pix] + change;
    }
}

__kernel void from_polar(__global const REAL *pcoef, __global const REAL *base, __global REAL *out, const long out_off,
                         const int h, const int w, const int n_r, const int n_phi, const int planes, const GRID cy,
                         const GRID cx, const int r0, const GRID r_lo, const GRID r_hi, const int x0, const int y0,
                         const int bw, const int bh, const long base_off, __global const REAL *wcoef,
                         const int weighted, const int copy, __global const GRID *angles)
{
    const int gx = get_global_id(0), gy = get_global_id(1);
    if (gx >= bw || gy >= bh)
        return;
    from_polar_pixel(pcoef, base, out, out_off, h, w, n_r, n_phi, planes, cy, cx, r0, r_lo, r_hi, x0 + gx, y0 + gy,
                     base_off, wcoef, weighted, copy, angles);
}

// dst += scale[i] src on (B, N, M) arrays, one work-item per element (dst may be src): columns on
// axis 0, the B N rows on axis 1 (no 64-bit division per element)
__kernel void add_rows(__global const REAL *src, __global REAL *dst, const long dst_off, __global const REAL *scale,
                       const int n, const int m, const int rows, const long src_off)
{
    const int j = get_global_id(0), row = get_global_id(1);
    if (j >= m || row >= rows)
        return;
    const long t = (long)row * m + j;
    dst[dst_off + t] += scale[row % n] * src[src_off + t];
}


#ifdef MODE_X
// Vector types of REAL and GRID: REALV / GRIDV / INTV are VW lanes (8), for the kernels that run VW
// adjacent samples per work-item in explicit vectors (PoCL 3.1 does not vectorise these kernels across
// work-items: its loop vectoriser refuses the work-item loop, so the scalar kernels run one sample
// per instruction).
#define VW 8
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define REALV CAT(REAL, 8)
#define GRIDV CAT(GRID, 8)
#define INTV int8
#define GRID16 CAT(GRID, 16)
#define TO_REALV(x) CAT(convert_, REALV)(x)
#define TO_GRIDV(x) CAT(convert_, GRIDV)(x)
#define TO_INTV(x) CAT(convert_int8, _rtz)(x)
// the lanes of a comparison of GRIDV (and REALV: GRID is REAL's type wherever a kernel has both)
#if GRID_IS_FLOAT
#define MASKV int8
#else
#define MASKV long8
#endif

// floor as int lanes (|x| < 2^31): truncation, minus one where it rounded up (a true comparison
// is -1 in every lane)
INLINE INTV ifloor_v(const GRIDV x)
{
    const INTV t = TO_INTV(x);
    return t + CAT(convert_, INTV)(x < TO_GRIDV(t));
}

// near_index on lanes, branch-free (selects)
INLINE INTV near_index_v(const INTV i, const int n, const int mode)
{
    if (mode == MODE_NEAREST)
        return select(select(i, (INTV)(n - 1), i >= n), (INTV)0, i < 0);
    if (mode == MODE_WRAP)
        return select(select(i, i - n, i >= n), i + n, i < 0);
    if (mode == MODE_REFLECT)
        return select(select(i, 2 * n - 1 - i, i >= n), -1 - i, i < 0);
    if (n == 1)
        return (INTV)0;
    return select(select(i, 2 * n - 2 - i, i >= n), -i, i < 0);
}

// the cubic B-spline weights (bweights4) on lanes
INLINE void bweights4_v(const REALV t, REALV *w0, REALV *w1, REALV *w2, REALV *w3)
{
    const REAL sixth = (REAL)1 / (REAL)6;
    const REALV t2 = t * t, g = (REAL)1 - t;
    const REALV t3 = t2 * t;
    *w0 = g * g * g * sixth;
    *w1 = ((REAL)0.5 * t3 - t2) + (REAL)2 / (REAL)3;
    *w2 = (REAL)0.5 * (t + t2 - t3) + sixth;
    *w3 = t3 * sixth;
}

#if INLINE_ANGLE
// angle_of on lanes (float positions): the same operations in the same order, as selects, so every lane
// is the scalar's angle to the bit (fabs, fmax and fmin of non-NaN values are exact whichever way they
// are written; the quotients of lanes with hi = 0 are discarded)
INLINE GRIDV angle_of_v(const GRID dy1, const GRIDV dx)
{
    const GRIDV dy = (GRIDV)dy1;
    const GRIDV ax = as_float8(as_int8(dx) & 0x7fffffff), ay = as_float8(as_int8(dy) & 0x7fffffff);
    const GRIDV hi = select(ay, ax, ax > ay), lo = select(ax, ay, ax > ay);
    GRIDV t = select((GRIDV)0.0f, lo / hi, hi > 0.0f);
    const MASKV big = t > 0.41421356237309503f;
    t = select(t, (t - 1.0f) / (t + 1.0f), big);
    const GRIDV z = t * t;
    GRIDV a = ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z - 3.33329491539e-1f) * z)
              * t + t;
    a = select(a, a + 0.78539816339744831f, big);
    a = select(a, 1.5707963267948966f - a, ay > ax);
    a = select(a, 3.1415926535897932f - a, dx < 0.0f);
    return select(a, 6.2831853071795865f - a, dy < 0.0f);
}
#endif

// the lanes' values at the lanes' indices (PoCL makes the loads; a gather on AVX-512)
#define GATHER8(p, i) ((REALV)((p)[(i).s0], (p)[(i).s1], (p)[(i).s2], (p)[(i).s3], (p)[(i).s4], (p)[(i).s5], \
                               (p)[(i).s6], (p)[(i).s7]))

// the 4 x VW values of 4 adjacent columns from column c[k] of row a[k] - c[k] of each lane k, as 4 lanes of
// columns (one 4-wide load per lane, transposed: PoCL makes 8 loads of 16 bytes instead of 32 of 4)
#define ROW4(p, a, k) vload4(0, (p) + (a).k)
INLINE void rows4(__global const REAL *src, const INTV a, REALV *q0, REALV *q1, REALV *q2, REALV *q3)
{
    const CAT(REAL, 4) v0 = ROW4(src, a, s0), v1 = ROW4(src, a, s1), v2 = ROW4(src, a, s2), v3 = ROW4(src, a, s3);
    const CAT(REAL, 4) v4 = ROW4(src, a, s4), v5 = ROW4(src, a, s5), v6 = ROW4(src, a, s6), v7 = ROW4(src, a, s7);
    *q0 = (REALV)(v0.s0, v1.s0, v2.s0, v3.s0, v4.s0, v5.s0, v6.s0, v7.s0);
    *q1 = (REALV)(v0.s1, v1.s1, v2.s1, v3.s1, v4.s1, v5.s1, v6.s1, v7.s1);
    *q2 = (REALV)(v0.s2, v1.s2, v2.s2, v3.s2, v4.s2, v5.s2, v6.s2, v7.s2);
    *q3 = (REALV)(v0.s3, v1.s3, v2.s3, v3.s3, v4.s3, v5.s3, v6.s3, v7.s3);
}

// spline2_near on VW points at once (positions (py, px) in lanes): the same taps in the same order
INLINE REALV spline2_near_v(__global const REAL *src, const int h, const int w, const GRIDV py, const GRIDV px)
{
    const INTV iy = ifloor_v(py), ix = ifloor_v(px);
    REALV wx0, wx1, wx2, wx3, wy0, wy1, wy2, wy3;
    bweights4_v(TO_REALV(px - TO_GRIDV(ix)), &wx0, &wx1, &wx2, &wx3);
    bweights4_v(TO_REALV(py - TO_GRIDV(iy)), &wy0, &wy1, &wy2, &wy3);
    REALV acc = (REALV)0;
    if (all(ix >= 1 && ix + 2 < w)) {    // every lane's 4 columns inside: 4 adjacent values per lane and row
#define SPLINE_ROW4(p, wy)                                                                                  \
        {                                                                                                   \
            REALV q0, q1, q2, q3;                                                                           \
            rows4(src, near_index_v(iy + (p - 1), h, MODE_Y) * w + ix - 1, &q0, &q1, &q2, &q3);             \
            acc += wy * (wx0 * q0 + wx1 * q1 + wx2 * q2 + wx3 * q3);                                        \
        }
        SPLINE_ROW4(0, wy0)
        SPLINE_ROW4(1, wy1)
        SPLINE_ROW4(2, wy2)
        SPLINE_ROW4(3, wy3)
#undef SPLINE_ROW4
        return acc;
    }
    const INTV c0 = near_index_v(ix - 1, w, MODE_X), c1 = near_index_v(ix, w, MODE_X);
    const INTV c2 = near_index_v(ix + 1, w, MODE_X), c3 = near_index_v(ix + 2, w, MODE_X);
#define SPLINE_ROW(p, wy)                                                                                   \
    {                                                                                                       \
        const INTV row = near_index_v(iy + (p - 1), h, MODE_Y) * w;                                         \
        const INTV a0 = row + c0, a1 = row + c1, a2 = row + c2, a3 = row + c3;                              \
        acc += wy * (wx0 * GATHER8(src, a0) + wx1 * GATHER8(src, a1) + wx2 * GATHER8(src, a2)               \
                     + wx3 * GATHER8(src, a3));                                                              \
    }
    SPLINE_ROW(0, wy0)
    SPLINE_ROW(1, wy1)
    SPLINE_ROW(2, wy2)
    SPLINE_ROW(3, wy3)
#undef SPLINE_ROW
    return acc;
}

// to_polar with VW adjacent angles of RB adjacent rings per work-item (n_phi is a multiple of 16 and
// n_r of 8: whole vectors and blocks): ring after ring at the same angles, the 4 x 4 taps of one move
// by about a pixel from the last one's, so 3 of the 4 rows a ring reads are in the L1 cache (ring after
// ring around the whole circle, every ring read the image afresh from memory: half the kernel's time)
#ifndef RB
#define RB 8
#endif
__kernel void to_polar_vec(__global const REAL *coef, __global REAL *out, const long out_off,
                           __global const GRID *trig, const int h, const int w, const int n_r, const int n_phi,
                           const int planes, const GRID cy, const GRID cx, const int r0)
{
    const int i0 = get_global_id(1) * RB, j0 = get_global_id(0) * VW;
    if (i0 >= n_r || j0 >= n_phi)
        return;
    const GRID16 cs = vload16(0, trig + 2 * j0);
    const GRIDV sn = cs.odd, cn = cs.even;
    for (int b = 0; b < planes; ++b)
        for (int i = i0; i < i0 + RB; ++i) {
            const GRID r = (GRID)(r0 + i);
            vstore8(spline2_near_v(coef + (long)b * h * w, h, w, cy - r * sn, cx + r * cn), 0,
                    out + out_off + ((long)b * n_r + i) * n_phi + j0);
        }
}

#define SQRT8(v) ((GRIDV)(SQRT_GRID((v).s0), SQRT_GRID((v).s1), SQRT_GRID((v).s2), SQRT_GRID((v).s3), \
                          SQRT_GRID((v).s4), SQRT_GRID((v).s5), SQRT_GRID((v).s6), SQRT_GRID((v).s7)))

// from_polar with VW adjacent pixels of a row per work-item, RB rows after rows (the polar taps of the
// next row lie about a pixel from this row's: in the L1 cache); the last columns of a box that VW does
// not divide pixel by pixel, in the same build (no second kernel to build on a new shape).  angles has
// rows of `astride` (>= w) values.  copy: pixels beyond the band's radii take base (0: they keep out's values,
// and groups of VW pixels all beyond them are not touched).
__kernel void from_polar_vec(__global const REAL *pcoef, __global const REAL *base, __global REAL *out,
                             const long out_off, const int h, const int w, const int n_r, const int n_phi,
                             const int planes, const GRID cy, const GRID cx, const int r0, const GRID r_lo,
                             const GRID r_hi, const int x0, const int y0, const int bw, const int bh,
                             const long base_off, __global const REAL *wcoef, const int weighted,
                             __global const GRID *angles, const int astride, const int copy)
{
    const int gx = get_global_id(0) * VW, gy0 = get_global_id(1) * RB;
    if (gx >= bw || gy0 >= bh)
        return;
    const int x = x0 + gx;
    if (gx + VW > bw) {     // the box's last columns, fewer than VW: pixel by pixel (copy: a no-op in place)
        for (int y = y0 + gy0; y < y0 + IMIN(gy0 + RB, bh); ++y)
            for (int xl = x; xl < x0 + bw; ++xl)
                from_polar_pixel(pcoef, base, out, out_off, h, w, n_r, n_phi, planes, cy, cx, r0, r_lo, r_hi, xl, y,
                                 base_off, wcoef, weighted, copy, angles);
        return;
    }
    const GRIDV dx = TO_GRIDV((INTV)(0, 1, 2, 3, 4, 5, 6, 7) + x) - cx;
    const GRID scale = (GRID)n_phi / (GRID)6.283185307179586;
    for (int y = y0 + gy0; y < y0 + IMIN(gy0 + RB, bh); ++y) {
        const GRID dy = cy - (GRID)y;
        const GRIDV r = SQRT8(dx * dx + dy * dy);
        const MASKV inside = r >= r_lo && r < r_hi;
        if (!any(inside)) {
            if (!copy)      // in place: the pixels keep their values (no load and store of each)
                continue;
            for (int b = 0; b < planes; ++b) {
                const long pix = ((long)b * h + y) * w + x;
                vstore8(vload8(0, base + base_off + pix), 0, out + out_off + pix);    // a no-op in place
            }
            continue;
        }
#if INLINE_ANGLE
        GRIDV jf = angle_of_v(dy, dx) * scale;
#else
        GRIDV jf = vload8(0, angles + (long)y * astride + x) * scale;
#endif
        jf = select(jf, jf - (GRID)n_phi, jf >= (GRID)n_phi);
        // pixels beyond the band's radii read a clamped ring (in range) and keep base
        GRIDV ring = r - (GRID)r0;
        ring = select(select(ring, (GRIDV)0, ring < (GRID)0), (GRIDV)(n_r - 1), ring > (GRID)(n_r - 1));
        REALV weight = (REALV)1;
        if (weighted) {
            // each lane's four ring weights: one 4-wide load per lane, transposed (rows4; 32 scalar
            // loads before, the same values in the same sum)
            const INTV ir = ifloor_v(ring);
            REALV w0, w1, w2, w3, q0, q1, q2, q3;
            bweights4_v(TO_REALV(ring - TO_GRIDV(ir)), &w0, &w1, &w2, &w3);
            rows4(wcoef, ir, &q0, &q1, &q2, &q3);
            weight = w0 * q0 + w1 * q1 + w2 * q2 + w3 * q3;
        }
        for (int b = 0; b < planes; ++b) {
            const long pix = ((long)b * h + y) * w + x;
            const REALV value = vload8(0, base + base_off + pix);
            const REALV change = spline2_near_v(pcoef + (long)b * n_r * n_phi, n_r, n_phi, ring, jf);
            // lanes beyond the band: base, or (copy = 0) what out holds (base itself in place)
            const REALV keep = copy ? value : vload8(0, out + out_off + pix);
            vstore8(select(keep, weight * value + change, inside), 0, out + out_off + pix);
        }
    }
}
#endif

// add_rows with 64 adjacent elements of one row per work-item (on a CPU: the scale read and the row's
// index computed once per work-item, not per element as add_rows does; explicit vectors of 8)
__kernel void add_rows_vec(__global const REAL *src, __global REAL *dst, const long dst_off,
                           __global const REAL *scale, const int n, const int m, const int rows, const long src_off)
{
    const int j0 = get_global_id(0) * 64, row = get_global_id(1);
    if (j0 >= m || row >= rows)
        return;
    const REAL f = scale[row % n];
    const long t = (long)row * m + j0;
    __global const REAL *a = src + src_off + t;
    __global REAL *d = dst + dst_off + t;
    if (j0 + 64 <= m) {
        for (int k = 0; k < 64; k += 8)
            vstore8(vload8(0, d + k) + f * vload8(0, a + k), 0, d + k);
        return;
    }
    for (int k = 0; k < m - j0; ++k)
        d[k] += f * a[k];
}
