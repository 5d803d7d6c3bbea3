// Motion-blur kernels of gfgpu.motion (spec: gfgpu/backends/specs_motion.py; Warp twins in
// backends/warp/motion.py).  Built with -D REAL=float|double and -D POS=float|double (the type of
// positions and weights: double wherever the device has it, since a ring of 10^4 samples needs
// more than float's 24 bits to place a sample to 1e-4 px).  Samples accumulate in REAL.
// Mode codes (specs_motion.MODE_CODES): 0 constant, 1 nearest, 2 wrap, 3 reflect, 4 mirror.
// PSF codes (PSF_CODES): 0 box, 1 G_u, 2 centred box, 3 centred G_u.

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#ifndef CHUNK
#define CHUNK 1      // rings per work-item in to_polar
#endif

#ifndef GRID
#define GRID POS     // positions of spline2: the polar kernels may take float for float32 images
#endif

#define SPLINE_POLE ((POS)-0.2679491924311228)     // sqrt(3) - 2
#define TWO_PI ((POS)6.283185307179586)

static inline int extend(int i, const int n, const int mode)
{
    if (mode == 0)
        return (i < 0 || i >= n) ? -1 : i;
    if (mode == 1)
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
    if (mode == 2) {
        int r = i % n;
        return r < 0 ? r + n : r;
    }
    if (mode == 3) {
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

// index of spline coefficient i and its factor: constant mode continues geometrically (z^m
// times the end coefficient minus cval), the other modes extend the coefficients as samples
static inline int coef_index(const int i, const int n, const int mode, POS *factor)
{
    *factor = (POS)1;
    if (mode != 0)
        return extend(i, n, mode);
    const int j = i < 0 ? 0 : (i >= n ? n - 1 : i);
    for (int m = min((int)abs(i - j), 64); m > 0; --m)     // z^64 < 1e-36: zero in float and beside 1e-11 in double
        *factor *= SPLINE_POLE;
    return j;
}

static inline REAL coef_at(__global const REAL *src, const long start, const long step, const int n,
                           const int i, const int mode, const REAL cval)
{
    if ((unsigned)i < (unsigned)n)        // inside the line: no extension (the common case)
        return src[start + (long)i * step];
    POS f;
    const int j = coef_index(i, n, mode, &f);
    const REAL v = src[start + (long)j * step];
    return mode == 0 ? cval + (REAL)f * (v - cval) : v;
}

// weights in REAL from the fraction in REAL: positions need POS, a fraction in [0, 1) does not
static inline REAL bweight(const REAL t, const int p)
{
    const REAL g = (REAL)1 - t;
    switch (p) {
    case 0: return g * g * g / (REAL)6;
    case 1: return ((REAL)3 * t * t * t - (REAL)6 * t * t + (REAL)4) / (REAL)6;
    case 2: return ((REAL)3 * g * g * g - (REAL)6 * g * g + (REAL)4) / (REAL)6;
    default: return t * t * t / (REAL)6;
    }
}

static inline REAL bintegral(const REAL f, const int p)
{
    const REAL f2 = f * f, f4 = f2 * f2, g = (REAL)1 - f;
    switch (p) {
    case 0: return ((REAL)1 - g * g * g * g) / (REAL)24;
    case 1: return ((REAL)0.75 * f4 - (REAL)2 * f2 * f + (REAL)4 * f) / (REAL)6;
    case 2: return ((REAL)-0.75 * f4 + f2 * f + (REAL)1.5 * f2 + f) / (REAL)6;
    default: return f4 / (REAL)24;
    }
}

static inline REAL cell(__global const REAL *src, const long start, const long step, const int n, const int j,
                        const int mode, const REAL cval)
{
    return (coef_at(src, start, step, n, j - 1, mode, cval) + (REAL)11 * coef_at(src, start, step, n, j, mode, cval)
            + (REAL)11 * coef_at(src, start, step, n, j + 1, mode, cval)
            + coef_at(src, start, step, n, j + 2, mode, cval)) / (REAL)24;
}

// Box windows [a0 + a1 k, b0 + b1 k] along the lines of a (B, N, M) array: one work-item per
// line, one compensated running sum of whole spline cells plus the two partial cells.
__kernel void box_lines(__global const REAL *src, __global REAL *dst, const int n, const int lines,
                        const long batch_stride, const long line_stride, const long step, const POS a0,
                        const POS a1, const POS b0, const POS b1, const int mode, const REAL cval, const int total,
                        const long dst_off)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
    const int b = t / lines;
    const long start = b * batch_stride + (long)(t - b * lines) * line_stride;
    int ia = (int)floor(a0), ib = (int)floor(b0);
    REAL sum = 0, comp = 0;
    for (int j = ia; j < ib; ++j) {
        const REAL y = cell(src, start, step, n, j, mode, cval) - comp;
        const REAL s = sum + y;
        comp = (s - sum) - y;
        sum = s;
    }
    for (int k = 0; k < n; ++k) {
        const POS a = a0 + a1 * (POS)k, e = b0 + b1 * (POS)k;
        const int na = (int)floor(a), nb = (int)floor(e);
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
        if (width < (POS)NARROW) {     // the spline at the middle (specs_motion.NARROW)
            const POS m = (POS)0.5 * (a + e), fm = floor(m);
            const int im = (int)fm;
            const REAL t = (REAL)(m - fm);
            REAL v = 0;
            for (int p = 0; p < 4; ++p)
                v += bweight(t, p) * coef_at(src, start, step, n, im + p - 1, mode, cval);
            dst[dst_off + start + (long)k * step] = v;
            continue;
        }
        REAL pa = 0, pb = 0;
        for (int p = 0; p < 4; ++p) {
            pa += bintegral(fa, p) * coef_at(src, start, step, n, ia + p - 1, mode, cval);
            pb += bintegral(fb, p) * coef_at(src, start, step, n, ib + p - 1, mode, cval);
        }
        dst[dst_off + start + (long)k * step] = ((sum - comp) + pb - pa) / (REAL)width;
    }
}

// the 2-D cubic B-spline of one plane (h x w, at `plane`) at (py, px)
static inline REAL spline2(__global const REAL *src, const long plane, const int h, const int w, const GRID py,
                           const GRID px, const int mode_y, const int mode_x, const REAL cval)
{
    const GRID fy = floor(py), fx = floor(px);
    const int iy = (int)fy, ix = (int)fx;
    const REAL ty = (REAL)(py - fy), tx = (REAL)(px - fx);
    REAL wx[4], wy[4];
    for (int q = 0; q < 4; ++q) {
        wx[q] = bweight(tx, q);
        wy[q] = bweight(ty, q);
    }
    if (iy >= 1 && iy + 2 < h && ix >= 1 && ix + 2 < w) {    // all 16 coefficients inside: no extension
        __global const REAL *line = src + plane + (long)(iy - 1) * w + (ix - 1);
        REAL acc = 0;
        for (int p = 0; p < 4; ++p, line += w)
            acc += wy[p] * (wx[0] * line[0] + wx[1] * line[1] + wx[2] * line[2] + wx[3] * line[3]);
        return acc;
    }
    const REAL base = mode_x == 0 ? cval : (REAL)0;
    int rx[4];
    for (int q = 0; q < 4; ++q) {
        POS g;
        rx[q] = coef_index(ix + q - 1, w, mode_x, &g);
        wx[q] *= (REAL)g;
    }
    REAL acc = 0;
    for (int p = 0; p < 4; ++p) {
        POS g;
        const int ry = coef_index(iy + p - 1, h, mode_y, &g);
        REAL row = 0;
        __global const REAL *line = src + plane + (long)ry * w;
        for (int q = 0; q < 4; ++q)
            row += wx[q] * (((ry >= 0 && rx[q] >= 0) ? line[rx[q]] : base) - base);
        acc += wy[p] * (REAL)g * row;
    }
    return acc + base;
}

static inline void support(const int psf, POS *t0, POS *t1)
{
    const POS tail = (POS)GREEN_TAIL;
    *t0 = psf == 0 ? (POS)0 : psf == 1 ? (POS)0 : psf == 2 ? (POS)-0.5 : -tail / 2;
    *t1 = psf == 0 ? (POS)1 : psf == 1 ? tail : psf == 2 ? (POS)0.5 : tail / 2;
}

static inline POS cdf(const int psf, const POS t, const POS t0, const POS t1)
{
    if (t <= t0)
        return 0;
    if (t >= t1)
        return 1;
    if (psf == 0 || psf == 2)
        return (t - t0) / (t1 - t0);
    if (psf == 1)
        return (POS)1 - exp(-t) * (sin(t) + cos(t));
    const POS s = (POS)2 * fabs(t);
    const POS c = (POS)0.5 * ((POS)1 - exp(-s) * cos(s));
    return t < 0 ? (POS)0.5 - c : (POS)0.5 + c;
}

// One work-item per output pixel: the samples of its own path x - t v(x).
__kernel void field_blur(__global const REAL *coef, __global const REAL *field, __global REAL *out, const int h,
                         const int w, const int planes, const int psf, const POS density, const int mode,
                         const REAL cval, const long out_off)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const long pix = (long)y * w + x, hw = (long)h * w;
    const POS vy = (POS)field[pix], vx = (POS)field[hw + pix];
    POS t0, t1;
    support(psf, &t0, &t1);
    const POS span = t1 - t0;
    const int n = max(1, (int)ceil(fmax(fabs(vy), fabs(vx)) * span * density - (POS)1e-9));
    for (int b = 0; b < planes; ++b) {
        REAL acc = 0;
        POS prev = 0;
        for (int k = 0; k < n; ++k) {
            const POS ta = t0 + span * (POS)k / (POS)n, tb = t0 + span * (POS)(k + 1) / (POS)n;
            const POS c = cdf(psf, tb, t0, t1), tm = (POS)0.5 * (ta + tb);
            acc += (REAL)(c - prev) * spline2(coef, b * hw, h, w, (POS)y - tm * vy, (POS)x - tm * vx, mode, mode, cval);
            prev = c;
        }
        out[out_off + b * hw + pix] = acc;
    }
}

#ifdef MODE_X
// spline2 for the polar kernels, with the modes as build constants (MODE_Y along the rows, MODE_X
// along the columns) and every coefficient index within one period or reflection of the line
// (the launcher checks): branch-free index arithmetic, so PoCL vectorises across work-items.
static inline int near_index(const int i, const int n, const int mode)
{
    if (mode == 0 || mode == 1)
        return clamp(i, 0, n - 1);
    if (mode == 2)
        return i < 0 ? i + n : (i >= n ? i - n : i);
    if (mode == 3)
        return i < 0 ? -1 - i : (i >= n ? 2 * n - 1 - i : i);
    return n == 1 ? 0 : (i < 0 ? -i : (i >= n ? 2 * n - 2 - i : i));
}

static inline REAL near_factor(const int i, const int n, const int mode)
{
    if (mode != 0)
        return (REAL)1;
    const int m = i < 0 ? -i : (i >= n ? i - n + 1 : 0);
    // z^m, z = sqrt(3) - 2 < 0: |z|^m = exp(m ln|z|) (vectorises, unlike pown), sign (-1)^m
    const REAL mag = m == 0 ? (REAL)1 : exp((REAL)min(m, 64) * (REAL)-1.3169578969248166);
    return (m & 1) ? -mag : mag;
}

// the four cubic B-spline weights at fraction t, multiplications only (bweight's values)
static inline void bweights4(const REAL t, REAL *wt)
{
    const REAL sixth = (REAL)1 / (REAL)6, t2 = t * t, g = (REAL)1 - t;
    const REAL t3 = t2 * t;
    wt[0] = g * g * g * sixth;
    wt[1] = ((REAL)0.5 * t3 - t2) + (REAL)2 / (REAL)3;
    wt[2] = (REAL)0.5 * (t + t2 - t3) + sixth;
    wt[3] = t3 * sixth;
}

static inline REAL spline2_near(__global const REAL *src, const long plane, const int h, const int w, const GRID py,
                                const GRID px, const REAL cval)
{
    const GRID fy = floor(py), fx = floor(px);
    const int iy = (int)fy, ix = (int)fx;
    const REAL base = MODE_X == 0 ? cval : (REAL)0;
    REAL wx[4], wy[4];
    bweights4((REAL)(px - fx), wx);
    bweights4((REAL)(py - fy), wy);
    REAL acc = 0;
    if (ix >= 1 && ix + 2 < w) {      // the four columns inside: contiguous loads
        for (int p = 0; p < 4; ++p) {
            const int ry = near_index(iy + p - 1, h, MODE_Y);
            __global const REAL *line = src + plane + (long)ry * w + (ix - 1);
            const REAL row = wx[0] * (line[0] - base) + wx[1] * (line[1] - base) + wx[2] * (line[2] - base)
                             + wx[3] * (line[3] - base);
            acc += wy[p] * near_factor(iy + p - 1, h, MODE_Y) * row;
        }
        return acc + base;
    }
    int rx[4];
    for (int q = 0; q < 4; ++q) {
        wx[q] *= near_factor(ix + q - 1, w, MODE_X);
        rx[q] = near_index(ix + q - 1, w, MODE_X);
    }
    for (int p = 0; p < 4; ++p) {
        const int ry = near_index(iy + p - 1, h, MODE_Y);
        __global const REAL *line = src + plane + (long)ry * w;
        const REAL row = wx[0] * (line[rx[0]] - base) + wx[1] * (line[rx[1]] - base) + wx[2] * (line[rx[2]] - base)
                         + wx[3] * (line[rx[3]] - base);
        acc += wy[p] * near_factor(iy + p - 1, h, MODE_Y) * row;
    }
    return acc + base;
}
#define SPLINE_POLAR(src, plane, h, w, py, px, my, mx, cval) spline2_near(src, plane, h, w, py, px, cval)
#else
#define SPLINE_POLAR(src, plane, h, w, py, px, my, mx, cval) spline2(src, plane, h, w, py, px, my, mx, cval)
#endif

// One work-item per polar sample (angle j, ring i) of every plane, layout (B, n_phi, n_r): adjacent
// work-items are adjacent rings.  trig[2j], trig[2j+1] = cos, sin of angle j (computed once on the
// host: a sine per sample would dominate the kernel).  Positions in GRID (float for float32 images:
// r cos phi to 1e-7 relative, 1e-4 px on a ring of radius 1500; double for float64 ones).
__kernel void to_polar(__global const REAL *coef, __global REAL *out, const long out_off, __global const GRID *trig,
                       const int h, const int w, const int n_r, const int n_phi, const int planes, const GRID cy,
                       const GRID cx, const int mode, const REAL cval)
{
    const int j = get_global_id(1);
    if (j >= n_phi)
        return;
    const GRID sn = trig[2 * j + 1], cs = trig[2 * j];
    const int i0 = get_global_id(0) * CHUNK, i1 = min(i0 + CHUNK, n_r);
    for (int i = i0; i < i1; ++i) {        // CHUNK rings along the ray per work-item
        const GRID r = (GRID)i;
        const GRID py = cy - r * sn, px = cx + r * cs;
        for (int b = 0; b < planes; ++b)
            out[out_off + ((long)b * n_phi + j) * n_r + i] = SPLINE_POLAR(coef, (long)b * h * w, h, w, py, px, mode,
                                                                        mode, cval);
    }
}

// The angle of (dx, dy) in [0, 2 pi).  float: Cephes' atanf polynomial after reduction to
// |t| <= tan(pi/8) (about 1e-7 rad, 1e-3 of an angular sample on a ring of 10^4); PoCL's atan2
// costs more than the whole spline.  double: the built-in atan2 (float64 results match to 1e-11).
static inline GRID angle_of(const GRID dy, const GRID dx)
{
#if GRID_IS_FLOAT
    const float ax = fabs(dx), ay = fabs(dy);
    const float hi = fmax(ax, ay), lo = fmin(ax, ay);
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

// One work-item per pixel: angle (wraps, axis 1) and radius (mirrors, axis 2) on the polar grid.
__kernel void from_polar(__global const REAL *pcoef, __global REAL *out, const long out_off, const int h, const int w,
                         const int n_r, const int n_phi, const int planes, const GRID cy, const GRID cx)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const GRID dy = cy - (GRID)y, dx = (GRID)x - cx;
    const GRID r = sqrt(dx * dx + dy * dy);
    GRID jf = angle_of(dy, dx) * ((GRID)n_phi / (GRID)6.283185307179586);
    jf = jf >= (GRID)n_phi ? jf - (GRID)n_phi : jf;     // rounding at 2 pi
    for (int b = 0; b < planes; ++b)
        out[out_off + ((long)b * h + y) * w + x] = SPLINE_POLAR(pcoef, (long)b * n_r * n_phi, n_phi, n_r, jf, r, 2, 4,
                                                                (REAL)0);
}

#ifdef LANES
// box_lines with LANES lines per work-item and vector arithmetic.  The window [a0 + a1 k, b0 + b1 k]
// is the same on every line, so the cell indices and partial-cell weights are scalars.  ROWS = 0:
// adjacent columns (axis 1, M a multiple of LANES), each load one contiguous vector; ROWS = 1:
// LANES consecutive rows (axis 2, B N a multiple of LANES), each load gathered across the rows.
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
typedef CAT(REAL, LANES) VT;
#if ROWS
#if LANES == 8
#define VGET(p, ls) ((VT)((p)[0], (p)[ls], (p)[2 * (ls)], (p)[3 * (ls)], (p)[4 * (ls)], (p)[5 * (ls)], \
                          (p)[6 * (ls)], (p)[7 * (ls)]))
#define VPUT(v, p, ls) do { const VT v_ = (v); (p)[0] = v_.s0; (p)[ls] = v_.s1; (p)[2 * (ls)] = v_.s2; \
    (p)[3 * (ls)] = v_.s3; (p)[4 * (ls)] = v_.s4; (p)[5 * (ls)] = v_.s5; (p)[6 * (ls)] = v_.s6; \
    (p)[7 * (ls)] = v_.s7; } while (0)
#else
#define VGET(p, ls) ((VT)((p)[0], (p)[ls], (p)[2 * (ls)], (p)[3 * (ls)]))
#define VPUT(v, p, ls) do { const VT v_ = (v); (p)[0] = v_.s0; (p)[ls] = v_.s1; (p)[2 * (ls)] = v_.s2; \
    (p)[3 * (ls)] = v_.s3; } while (0)
#endif
#else
#define VGET(p, ls) CAT(vload, LANES)(0, (p))
#define VPUT(v, p, ls) CAT(vstore, LANES)((v), 0, (p))
#endif

static inline VT vcoef(__global const REAL *src, const long start, const long step, const long ls, const int n,
                       const int i, const int mode, const REAL cval)
{
    if ((unsigned)i < (unsigned)n)
        return VGET(src + start + (long)i * step, ls);
    POS f;
    const int j = coef_index(i, n, mode, &f);
    const VT v = VGET(src + start + (long)j * step, ls);
    return mode == 0 ? (VT)cval + (VT)((REAL)f) * (v - (VT)cval) : v;
}

static inline VT vcell(__global const REAL *src, const long start, const long step, const long ls, const int n,
                       const int j, const int mode, const REAL cval)
{
    return (vcoef(src, start, step, ls, n, j - 1, mode, cval) + (REAL)11 * vcoef(src, start, step, ls, n, j, mode, cval)
            + (REAL)11 * vcoef(src, start, step, ls, n, j + 1, mode, cval)
            + vcoef(src, start, step, ls, n, j + 2, mode, cval)) / (REAL)24;
}

// n samples per line, lines `step` apart along them; cols: m = M (groups = M / LANES per plane),
// rows: m = M too (groups = B N / LANES, one plane)
__kernel void box_vec(__global const REAL *src, __global REAL *dst, const long dst_off, const int n, const int m,
                      const int groups, const POS a0, const POS a1, const POS b0, const POS b1, const int mode,
                      const REAL cval, const int total)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
#if ROWS
    const long start = (long)t * LANES * m, step = 1, ls = m;
#else
    const int b = t / groups;
    const long start = (long)b * n * m + (long)(t - b * groups) * LANES, step = m, ls = 1;
#endif
    int ia = (int)floor(a0), ib = (int)floor(b0);
    VT sum = 0, comp = 0;
    for (int j = ia; j < ib; ++j) {
        const VT y = vcell(src, start, step, ls, n, j, mode, cval) - comp;
        const VT s = sum + y;
        comp = (s - sum) - y;
        sum = s;
    }
    for (int k = 0; k < n; ++k) {
        const POS a = a0 + a1 * (POS)k, e = b0 + b1 * (POS)k;
        const int na = (int)floor(a), nb = (int)floor(e);
        for (; ib < nb; ++ib) {
            const VT y = vcell(src, start, step, ls, n, ib, mode, cval) - comp;
            const VT s = sum + y;
            comp = (s - sum) - y;
            sum = s;
        }
        for (; ia < na; ++ia) {
            const VT y = -vcell(src, start, step, ls, n, ia, mode, cval) - comp;
            const VT s = sum + y;
            comp = (s - sum) - y;
            sum = s;
        }
        __global REAL *o = dst + dst_off + start + (long)k * step;
        const POS width = e - a;
        if (width < (POS)NARROW) {
            const POS mid = (POS)0.5 * (a + e), fm = floor(mid);
            const int im = (int)fm;
            const REAL tt = (REAL)(mid - fm);
            VT v = 0;
            for (int p = 0; p < 4; ++p)
                v += bweight(tt, p) * vcoef(src, start, step, ls, n, im + p - 1, mode, cval);
            VPUT(v, o, ls);
            continue;
        }
        const REAL fa = (REAL)(a - (POS)ia), fb = (REAL)(e - (POS)ib);
        VT part = 0;
        for (int p = 0; p < 4; ++p)
            part += bintegral(fb, p) * vcoef(src, start, step, ls, n, ib + p - 1, mode, cval)
                    - bintegral(fa, p) * vcoef(src, start, step, ls, n, ia + p - 1, mode, cval);
        VPUT(((sum - comp) + part) / (VT)((REAL)width), o, ls);
    }
}

// box_vec for windows of fixed width (a1 = b1 = 1, width >= NARROW): the cells' running sum
// telescopes to a running sum T of the coefficients over [A, B) (A = k + floor(a0), B = k + floor(b0))
// plus four taps at each end, whose weights (the partial cells' integrals, precomputed on the host:
// wa, wb) do not change along the line:
//     width * out[k] = T + sum_q wb[q] c[B - 1 + q] - sum_q wa[q] c[A - 1 + q]
__kernel void box_shift(__global const REAL *src, __global REAL *dst, const long dst_off, const int n, const int m,
                        const int groups, const int a, const int b, const REAL wa0, const REAL wa1, const REAL wa2,
                        const REAL wa3, const REAL wb0, const REAL wb1, const REAL wb2, const REAL wb3,
                        const REAL inv_width, const int mode, const REAL cval, const int total)
{
    const int t = get_global_id(0);
    if (t >= total)
        return;
#if ROWS
    const long start = (long)t * LANES * m, step = 1, ls = m;
#else
    const int pl = t / groups;
    const long start = (long)pl * n * m + (long)(t - pl * groups) * LANES, step = m, ls = 1;
#endif
    VT sum = 0, comp = 0;
    for (int j = a; j < b; ++j) {
        const VT y = vcoef(src, start, step, ls, n, j, mode, cval) - comp;
        const VT s = sum + y;
        comp = (s - sum) - y;
        sum = s;
    }
    // the four coefficients at each end, slid along in registers: two loads per step
    VT am = vcoef(src, start, step, ls, n, a - 1, mode, cval), a0 = vcoef(src, start, step, ls, n, a, mode, cval);
    VT ap = vcoef(src, start, step, ls, n, a + 1, mode, cval), aq = vcoef(src, start, step, ls, n, a + 2, mode, cval);
    VT bm = vcoef(src, start, step, ls, n, b - 1, mode, cval), b0 = vcoef(src, start, step, ls, n, b, mode, cval);
    VT bp = vcoef(src, start, step, ls, n, b + 1, mode, cval), bq = vcoef(src, start, step, ls, n, b + 2, mode, cval);
    for (int k = 0; k < n; ++k) {
        const VT ends = (wb0 * bm + wb1 * b0 + wb2 * bp + wb3 * bq) - (wa0 * am + wa1 * a0 + wa2 * ap + wa3 * aq);
        VPUT(((sum - comp) + ends) * inv_width, dst + dst_off + start + (long)k * step, ls);
        const VT y = (b0 - a0) - comp;      // slide: c[B] enters, c[A] leaves
        const VT s = sum + y;
        comp = (s - sum) - y;
        sum = s;
        am = a0; a0 = ap; ap = aq; aq = vcoef(src, start, step, ls, n, a + k + 3, mode, cval);
        bm = b0; b0 = bp; bp = bq; bq = vcoef(src, start, step, ls, n, b + k + 3, mode, cval);
    }
}
#endif
