// Per-pixel velocity fields of gfgpu.motion (spec: gfgpu.motion.spec.field_blur_reference; Warp
// twin in gfgpu/motion/field_kernels/_warp.py): only field code, so the first field call builds only
// this.  Built with -D REAL=float|double and -D POS=float|double (positions and weights: double
// wherever the device has it).  The launcher (gfgpu/motion/field_kernels/_opencl.py) defines the
// constants of the Python definitions, none retyped here: the mode codes MODE_CONSTANT .. MODE_MIRROR
// (gfgpu._core.boundary.MODE_CODES); SPLINE_POLE, NEAR_A, NEAR_B (gfgpu._core.bspline); the PSF codes
// PSF_BOX, PSF_GREEN, PSF_BOX_CENTRED, PSF_GREEN_CENTRED (spec.PSF_CODES) and the quadrature constants.

#if !defined(MODE_MIRROR) || !defined(SPLINE_POLE) || !defined(PSF_GREEN_CENTRED)
#error "field.cl is built by gfgpu.motion.field_kernels._opencl, which defines the constants of the Python definitions"
#endif

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#include "spline.cl"    // the PoCL workarounds, boundary extension and cubic B-spline helpers

#include "spline2d.cl"  // coef_taps and spline2: the 2-D cubic B-spline at a point

#define FMAXABS(a, b) (fabs(a) > fabs(b) ? fabs(a) : fabs(b))
#define OFF REAL        // offsets along a path from its pixel: the image's type (spline_inside)

static inline void support(const int psf, POS *t0, POS *t1)
{
    const POS tail = (POS)GREEN_TAIL;
    // spec.psf_support
    *t0 = psf == PSF_BOX ? (POS)0 : psf == PSF_GREEN ? (POS)0 : psf == PSF_BOX_CENTRED ? (POS)-0.5 : -tail / 2;
    *t1 = psf == PSF_BOX ? (POS)1 : psf == PSF_GREEN ? tail : psf == PSF_BOX_CENTRED ? (POS)0.5 : tail / 2;
}

// spec.psf_cdf
static inline POS cdf(const int psf, const POS t, const POS t0, const POS t1)
{
    if (t <= t0)
        return 0;
    if (t >= t1)
        return 1;
    if (psf == PSF_BOX || psf == PSF_BOX_CENTRED)
        return (t - t0) / (t1 - t0);
    if (psf == PSF_GREEN)
        return (POS)1 - exp(-t) * (sin(t) + cos(t));
    const POS s = (POS)2 * fabs(t);
    const POS c = (POS)0.5 * ((POS)1 - exp(-s) * cos(s));
    return t < 0 ? (POS)0.5 - c : (POS)0.5 + c;
}

// G_u's density at t (spec.psf_density; psf PSF_GREEN or PSF_GREEN_CENTRED)
static inline POS density(const int psf, const POS t)
{
    if (psf == PSF_GREEN)
        return (POS)2 * exp(-t) * sin(t);
    const POS s = (POS)2 * fabs(t);
    return exp(-s) * (cos(s) + sin(s));
}

// One work-item per output pixel: its own path x - t v(x), in cells of three Gauss-Legendre nodes
// (at most `most` cells where most > 0).
__kernel void field_blur(__global const REAL *coef, __global const REAL *field, __global REAL *out, const int h,
                         const int w, const int planes, const int psf, const POS density_px, const int mode,
                         const REAL cval, const long out_off, const int most)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const long pix = (long)y * w + x, hw = (long)h * w;
    const POS vy = (POS)field[pix], vx = (POS)field[hw + pix];
    POS t0, t1;
    support(psf, &t0, &t1);
    const POS span = t1 - t0, length = fmax(fabs(vy), fabs(vx));
    const int fewest = psf == PSF_GREEN ? MIN_CELLS_G : (psf == PSF_GREEN_CENTRED ? MIN_CELLS_CG : 1);
    int n = length > 0 ? max(fewest, (int)ceil(length * span * density_px - (POS)1e-9)) : 1;
    if (most > 0 && length > 0)     // the budget: longer paths get longer cells
        n = min(n, most);
    const POS u[3] = {(POS)GAUSS_U0, (POS)GAUSS_U1, (POS)GAUSS_U2};
    const POS g[3] = {(POS)GAUSS_W0, (POS)GAUSS_W1, (POS)GAUSS_W2};
    for (int b = 0; b < planes; ++b) {
        REAL acc = 0;
        POS prev = 0;
        for (int k = 0; k < n; ++k) {
            const POS ta = t0 + span * (POS)k / (POS)n, tb = t0 + span * (POS)(k + 1) / (POS)n;
            const POS c = cdf(psf, tb, t0, t1), mass = c - prev;
            prev = c;
            POS t[3], wt[3];
            for (int i = 0; i < 3; ++i)
                t[i] = ta + u[i] * (tb - ta);
            if (psf == PSF_BOX || psf == PSF_BOX_CENTRED) {
                for (int i = 0; i < 3; ++i)
                    wt[i] = g[i] * mass;
            } else {          // Gauss-Legendre on the density, the cell's exact mass restored
                for (int i = 0; i < 3; ++i)
                    wt[i] = (tb - ta) * g[i] * density(psf, t[i]);
                const POS rest = mass - (wt[0] + wt[1] + wt[2]);
                for (int i = 0; i < 3; ++i)
                    wt[i] += g[i] * rest;
            }
            for (int i = 0; i < 3; ++i)
                acc += (REAL)wt[i] * spline2(coef, b * hw, h, w, (POS)y - t[i] * vy, (POS)x - t[i] * vx, mode, mode, cval);
        }
        out[out_off + b * hw + pix] = acc;
    }
}

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define REAL4 CAT(REAL, 4)
#define REAL8 CAT(REAL, 8)
#define REAL16 CAT(REAL, 16)
// floor in the image's type: one rounding instruction under clang (vectorised over the two axes)
#ifdef __clang__
#if IS_DOUBLE(REAL)
#define FLOOR_REAL(x) __builtin_floor(x)
#else
#define FLOOR_REAL(x) __builtin_floorf(x)
#endif
#else
#define FLOOR_REAL(x) floor(x)
#endif

// 6 times the four cubic B-spline weights of the fraction tx (lanes 0-3) and of ty (lanes 4-7), by Horner on
// the weights' polynomials (6 w0 = (1 - t)^3, 6 w1 = 3t^3 - 6t^2 + 4, 6 w2 = -3t^3 + 3t^2 + 3t + 1, 6 w3 = t^3)
INLINE REAL8 weights6(const REAL tx, const REAL ty)
{
    const REAL8 t = (REAL8)(tx, tx, tx, tx, ty, ty, ty, ty);
    const REAL8 a = (REAL8)(-1, 3, -3, 1, -1, 3, -3, 1), b = (REAL8)(3, -6, 3, 0, 3, -6, 3, 0);
    const REAL8 c = (REAL8)(-3, 0, 3, 0, -3, 0, 3, 0), d = (REAL8)(1, 4, 1, 0, 1, 4, 1, 0);
    return ((a * t + b) * t + c) * t + d;
}

// The 16 terms of 36 times the 2-D cubic B-spline of one plane at (y + oy, x + ox), all 16 coefficients
// inside (no extension), from the coefficient at (y - 1, x - 1), `corner`: lane 4p + q is 6 wy[p] times
// 6 wx[q] times coefficient (p, q) of the 4 x 4 window.  The caller sums the lanes once for a whole path
// (its nodes' weights times these, added lane by lane) and divides by 36.  Four rows of four adjacent
// coefficients in one 16-lane vector: the outer product of the weights and one multiply-add per node,
// not a multiply-add and a broadcast per row.  The offsets from the pixel in OFF (float for float32
// images: an offset of a few hundred pixels keeps 1e-5 px, where a float position at 2000 px would keep
// 1e-4).
INLINE REAL16 spline_inside(__global const REAL *corner, const int w, const OFF oy, const OFF ox)
{
    const OFF fy = FLOOR_REAL(oy), fx = FLOOR_REAL(ox);
    const REAL8 wt = weights6(ox - fx, oy - fy);
    __global const REAL *line = corner + (long)(int)fy * w + (int)fx;
    const REAL4 c0 = (REAL4)(line[0], line[1], line[2], line[3]);
    line += w;
    const REAL4 c1 = (REAL4)(line[0], line[1], line[2], line[3]);
    line += w;
    const REAL4 c2 = (REAL4)(line[0], line[1], line[2], line[3]);
    line += w;
    const REAL4 c3 = (REAL4)(line[0], line[1], line[2], line[3]);
    return wt.s0123012301230123 * wt.s4444555566667777 * (REAL16)(c0, c1, c2, c3);
}

// index i of a line of n extended by a periodic mode (wrap, reflect, mirror): by one reflection or shift
// within a period of the line (no division), else extend()
INLINE int fold(const int i, const int n, const int mode)
{
    if ((unsigned)i < (unsigned)n)
        return i;
    if (i <= 1 - n || i >= 2 * n - 2)
        return extend(i, n, mode);
    if (mode == MODE_WRAP)
        return i < 0 ? i + n : i - n;
    if (mode == MODE_REFLECT)
        return i < 0 ? -1 - i : 2 * n - 1 - i;
    return i < 0 ? -i : 2 * n - 2 - i;
}

// Coefficient j (any integer) of one row of w coefficients extended along the row by `mode`: the coefficient
// itself inside, else w0 c[j0] + w1 c[j1] + (1 - w0 - w1) base (coef_taps; base: cval in constant mode, else 0)
INLINE POS row_extended(__global const REAL *row, const int w, const int j, const int mode, const POS base)
{
    if ((unsigned)j < (unsigned)w || IS_PERIODIC(mode))
        return row[fold(j, w, mode)];
    POS g0, g1;
    int j1;
    const int j0 = coef_taps(j, w, mode, &g0, &j1, &g1);
    return base + g0 * ((POS)row[j0] - base) + g1 * ((POS)row[j1] - base);
}

// The coefficients' rows side by side in pairs, for field_rule, on a margin of `pad` coefficients of the image
// extended by `mode` around each plane: pairs[((b ph + Y) pw + X) 2 + r] = coefficient (Y - pad + r, X - pad) of
// plane b, extended as spline2 weighs it (coef_taps along each axis; ph = h + 2 pad, pw = w + 2 pad, r = 0, 1),
// rounded once.  A window's four rows are then two loads of
// eight contiguous values, two cache lines or three where there were four or more (the kernel's time is in those
// loads: 15-30 % less CPU with the pass included, twice the coefficients' memory), and a path that leaves the image
// by at most the margin samples as one inside it (paths across the border, tested and extended node by node, took
// a fifth of G_u's kernel time on the benchmark field, where 6 % of them leave the image: 12 % less CPU now).
// Work-item (c, Y, b) writes columns c chunk .. c chunk + chunk - 1 of row Y of plane b (a CPU device: one
// work-item a row; a GPU: one a pair): two rows of the image (a periodic mode's rows beyond the border are rows of
// the image) interleaved by a plain loop, the margin's columns extended; a row beyond the border in constant or
// nearest mode as two rows of the image
__kernel void pair_rows(__global const REAL *coef, __global REAL *pairs, const int h, const int w, const int pad,
                        const int mode, const REAL cval, const int chunk)
{
    const int c = get_global_id(0), y = get_global_id(1), b = get_global_id(2);
    const int pw = w + 2 * pad, ph = h + 2 * pad;
    const int x0 = c * chunk, x1 = IMIN(x0 + chunk, pw);
    if (y >= ph || x0 >= pw)
        return;
    __global const REAL *src = coef + (long)b * h * w;
    __global REAL *dst = pairs + 2 * ((long)b * ph + y) * pw;
    const int ia = y - pad, ib = y + 1 - pad;
    const POS base = mode == MODE_CONSTANT ? (POS)cval : (POS)0;
    if (IS_PERIODIC(mode) || ((unsigned)ia < (unsigned)h && (unsigned)ib < (unsigned)h)) {
        __global const REAL *ra = src + (long)fold(ia, h, mode) * w, *rb = src + (long)fold(ib, h, mode) * w;
        const int m0 = IMAX(x0, pad), m1 = IMIN(x1, pad + w);     // the image's columns
        for (int x = m0; x < m1; ++x) {
            dst[2 * x] = ra[x - pad];
            dst[2 * x + 1] = rb[x - pad];
        }
        for (int x = x0; x < IMIN(x1, pad); ++x) {
            dst[2 * x] = (REAL)row_extended(ra, w, x - pad, mode, base);
            dst[2 * x + 1] = (REAL)row_extended(rb, w, x - pad, mode, base);
        }
        for (int x = IMAX(x0, pad + w); x < x1; ++x) {
            dst[2 * x] = (REAL)row_extended(ra, w, x - pad, mode, base);
            dst[2 * x + 1] = (REAL)row_extended(rb, w, x - pad, mode, base);
        }
        return;
    }
    // a row beyond the border in constant or nearest mode: two rows of the image, h0 and h1 of them (coef_taps;
    // a row inside is itself), each extended along the row, in POS, rounded once
    POS ha0, ha1, hb0, hb1;
    int ia1, ib1;
    const int ia0 = coef_taps(ia, h, mode, &ha0, &ia1, &ha1), ib0 = coef_taps(ib, h, mode, &hb0, &ib1, &hb1);
    __global const REAL *a0 = src + (long)ia0 * w, *a1 = src + (long)ia1 * w;
    __global const REAL *b0 = src + (long)ib0 * w, *b1 = src + (long)ib1 * w;
    const int a_in = (unsigned)ia < (unsigned)h, b_in = (unsigned)ib < (unsigned)h;
    for (int x = x0; x < x1; ++x) {
        const int j = x - pad;
        const POS ea = row_extended(a0, w, j, mode, base), eb = row_extended(b0, w, j, mode, base);
        dst[2 * x] = (REAL)(a_in ? ea : base + ha0 * (ea - base) + ha1 * (row_extended(a1, w, j, mode, base) - base));
        dst[2 * x + 1] = (REAL)(b_in ? eb : base + hb0 * (eb - base) + hb1 * (row_extended(b1, w, j, mode, base) - base));
    }
}

// A node's weight `g` times spline_inside's 16 terms added to the two 8-lane sums of a path, `up` (the upper pair
// of the window's rows) and `low` (the lower), from the paired rows (pair_rows, `pw` pairs a row; `pcorner` the
// pair of the window's corner at the pixel), lanes in the pairs' order (column-major within each pair of rows):
// the weight folded into the four x weights, each pair added by one multiply-add (two 8-lane sums, not one of 16
// lanes: no 16-lane vector to assemble from halves, 7-9 % less CPU for G_u; the same sums, bit for bit)
INLINE void spline_pairs(REAL8 *up, REAL8 *low, const REAL g, __global const REAL *pcorner, const int pw, const OFF oy,
                         const OFF ox)
{
    const OFF fy = FLOOR_REAL(oy), fx = FLOOR_REAL(ox);
    const REAL8 wt = weights6(ox - fx, oy - fy);
    __global const REAL *line = pcorner + 2 * ((long)(int)fy * pw + (int)fx);
    const REAL4 gx = wt.lo * g;
    const REAL8 wx = gx.s00112233;
    *up = fma(wx * wt.s45454545, vload8(0, line), *up);
    *low = fma(wx * wt.s67676767, vload8(0, line + 4 * (long)pw), *low);
}

// the 4 x 4 window of one plane at rows y0 .. y0 + 3 and columns x0 .. x0 + 3 of the image extended by a
// periodic mode, in spline_inside's lane order: in such a mode a coefficient beyond the border is one
// coefficient of the image (gfgpu._core.bspline.coef_taps)
INLINE REAL16 window_periodic(__global const REAL *src, const int h, const int w, const int y0, const int x0,
                              const int mode)
{
    __global const REAL *r0 = src + (long)fold(y0, h, mode) * w, *r1 = src + (long)fold(y0 + 1, h, mode) * w;
    __global const REAL *r2 = src + (long)fold(y0 + 2, h, mode) * w, *r3 = src + (long)fold(y0 + 3, h, mode) * w;
    if (w >= 4 && (unsigned)x0 <= (unsigned)(w - 4)) {   // columns inside (a path across the top or bottom)
        r0 += x0;
        r1 += x0;
        r2 += x0;
        r3 += x0;
        return (REAL16)(r0[0], r0[1], r0[2], r0[3], r1[0], r1[1], r1[2], r1[3], r2[0], r2[1], r2[2], r2[3], r3[0],
                        r3[1], r3[2], r3[3]);
    }
    const int c0 = fold(x0, w, mode), c1 = fold(x0 + 1, w, mode), c2 = fold(x0 + 2, w, mode),
              c3 = fold(x0 + 3, w, mode);
    return (REAL16)(r0[c0], r0[c1], r0[c2], r0[c3], r1[c0], r1[c1], r1[c2], r1[c3], r2[c0], r2[c1], r2[c2], r2[c3],
                    r3[c0], r3[c1], r3[c2], r3[c3]);
}

// the sum of a path's 16 lanes (spline_inside) over 36
INLINE REAL lanes_sum(const REAL16 lanes)
{
    const REAL8 a = lanes.lo + lanes.hi;
    const REAL4 b = a.lo + a.hi;
    return (b.s0 + b.s1 + b.s2 + b.s3) * (REAL)(1.0 / 36.0);
}

// spec.rule_length: the Euclidean length (euclid: G_u) or the dominant component (box); the squares not fused
// with the sum (a float64 field's count then matches numpy's to the bit; a float32 field's squares are exact)
static inline POS rule_length(const POS vy, const POS vx, const int euclid)
{
#pragma OPENCL FP_CONTRACT OFF
    if (!euclid)
        return FMAXABS(vy, vx);
    const POS yy = vy * vy, xx = vx * vx;
    return sqrt(yy + xx);
}

// The fields' default rule (spec: gfgpu.motion.spec.field_rule_reference): one work-item per pixel, whose
// path x - t v(x) takes the rule of n nodes (box) or intervals (G_u), n = max(first, ceil(L per_px - 1e-9)
// + extra) at most `most`, L = rule_length; the rules' nodes and weights are the host's float64
// tables (spec.rule_table), rule n at offsets[n - first] .. offsets[n - first + 1], nodes ascending: no
// transcendental function and no per-cell arithmetic in the loop, only the samples.  A path whose two end
// nodes (hence all, on a straight line) have their 16 coefficients inside the paired rows where the launcher
// built them (`paired`: the image and a margin of `pad` extended coefficients, pair_rows) samples them by
// spline_pairs; else one inside the image samples without the boundary extension (spline_inside); a path that
// leaves both tests each node and extends only at the nodes that need it (spline_inside there).  A still pixel
// is the spline at itself.  The field (2, h, w) starts at element
// field_off of its buffer (a host array read in place), the tables' nodes come in POS (the extension's
// positions) and in the image's type (tnear: offsets from the pixel).
__kernel void field_rule(__global const REAL *coef, __global const REAL *pairs, const int paired, const int pad,
                         __global const REAL *field, const long field_off,
                         __global REAL *out, const int h, const int w, const int planes, const POS per_px,
                         const int extra, const int first, const int most, const int euclid,
                         __global const int *offsets,
                         __global const POS *nodes,
                         __global const REAL *weights, __global const OFF *tnear, const int mode, const REAL cval,
                         const long out_off)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const long pix = (long)y * w + x, hw = (long)h * w;
    const POS vy = (POS)field[field_off + pix], vx = (POS)field[field_off + hw + pix];
    const POS length = rule_length(vy, vx, euclid);
    // ceil by integer conversion (PoCL's ceil() is a library call; the argument is >= -1e-9, < 2^31)
    const POS c = length * per_px - (POS)1e-9;
    int m = (int)c;
    m += c > (POS)m;
    const int n = IMIN(IMAX(first, m + extra), most);
    const int k0 = length > 0 ? offsets[n - first] : 0, k1 = length > 0 ? offsets[n - first + 1] : 1;
    const int roomy = h >= 4 && w >= 4;
    const OFF ny = -(OFF)vy, nx = -(OFF)vx;     // a node t is at (y, x) + t (ny, nx)
    // inside: the end nodes' windows (hence all: floor is monotonic along the line) lie in the image, tested
    // on the offsets the samples take (tnear in the image's type), not on positions in POS: a tiny velocity
    // at row or column 1 puts y - t vy at 1.0 in POS but its offset's floor at -1 (a window one row or
    // column before the image, read out of bounds)
    const int kb = length > 0 ? k1 - 1 : k0;
    const OFF oya = tnear[k0] * ny, oyb = tnear[kb] * ny, oxa = tnear[k0] * nx, oxb = tnear[kb] * nx;
    const int top = y + (int)FLOOR_REAL(fmin(oya, oyb)), bottom = y + (int)FLOOR_REAL(fmax(oya, oyb));
    const int left = x + (int)FLOOR_REAL(fmin(oxa, oxb)), right = x + (int)FLOOR_REAL(fmax(oxa, oxb));
    const int inside = length > 0 && top >= 1 && bottom <= h - 3 && left >= 1 && right <= w - 3;
    const int in_pairs = paired && length > 0 && top >= 1 - pad && bottom <= h - 3 + pad && left >= 1 - pad
                         && right <= w - 3 + pad;
    // the window's corner at the pixel, (y - 1, x - 1): the samples inside add only their offset
    __global const REAL *corner = coef + ((long)y - 1) * w + (x - 1);
    const int pw = w + 2 * pad;
    const long phw = (long)(h + 2 * pad) * pw;
    __global const REAL *pcorner = pairs + 2 * (((long)y - 1 + pad) * pw + (x - 1 + pad));
    for (int b = 0; b < planes; ++b) {
        REAL acc = 0;
        if (length == 0)
            acc = spline2(coef, b * hw, h, w, (POS)y, (POS)x, mode, mode, cval);
        else if (in_pairs) {
            REAL8 up = 0, low = 0;
            for (int k = k0; k < k1; ++k)
                spline_pairs(&up, &low, weights[k], pcorner + 2 * b * phw, pw, tnear[k] * ny, tnear[k] * nx);
            acc = lanes_sum((REAL16)(up, low));
        }
        else if (inside) {
            REAL16 lanes = 0;
            for (int k = k0; k < k1; ++k)
                lanes += weights[k] * spline_inside(corner + b * hw, w, tnear[k] * ny, tnear[k] * nx);
            acc = lanes_sum(lanes);
        }
        else {      // a path that leaves the image: its samples with 16 coefficients inside still sample so,
                    // the others of a periodic mode gather their window's extended indices, the rest extend
            REAL16 lanes = 0;
            for (int k = k0; k < k1; ++k) {
                const OFF oy = tnear[k] * ny, ox = tnear[k] * nx;
                const OFF fy = FLOOR_REAL(oy), fx = FLOOR_REAL(ox);
                const int y0 = y + (int)fy - 1, x0 = x + (int)fx - 1;
                if (roomy && (unsigned)y0 <= (unsigned)(h - 4) && (unsigned)x0 <= (unsigned)(w - 4))
                    lanes += weights[k] * spline_inside(corner + b * hw, w, oy, ox);
                else if (IS_PERIODIC(mode)) {
                    const REAL8 wt = weights6(ox - fx, oy - fy);
                    lanes += weights[k] * (wt.s0123012301230123 * wt.s4444555566667777
                                           * window_periodic(coef + b * hw, h, w, y0, x0, mode));
                }
                else
                    acc += weights[k] * spline2(coef, b * hw, h, w, (POS)y - nodes[k] * vy, (POS)x - nodes[k] * vx,
                                                mode, mode, cval);
            }
            acc += lanes_sum(lanes);
        }
        out[out_off + b * hw + pix] = acc;
    }
}
