// Motion-blur kernels of gfgpu.motion (spec: gfgpu/backends/specs_motion.py; Warp twins in
// backends/warp/motion.py).  Built with -D REAL=float|double and -D POS=float|double (the type of
// positions and weights: double wherever the device has it, since a ring of 10^4 samples needs
// more than float's 24 bits to place a sample to 1e-4 px).  Samples accumulate in REAL.
// Mode codes (specs_motion.MODE_CODES): 0 constant, 1 nearest, 2 wrap, 3 reflect, 4 mirror.
// PSF codes (PSF_CODES): 0 box, 1 G_u, 2 centred box, 3 centred G_u.

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
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
    for (int m = abs(i - j); m > 0; --m)
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
                        const POS a1, const POS b0, const POS b1, const int mode, const REAL cval, const int total)
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
            dst[start + (long)k * step] = v;
            continue;
        }
        REAL pa = 0, pb = 0;
        for (int p = 0; p < 4; ++p) {
            pa += bintegral(fa, p) * coef_at(src, start, step, n, ia + p - 1, mode, cval);
            pb += bintegral(fb, p) * coef_at(src, start, step, n, ib + p - 1, mode, cval);
        }
        dst[start + (long)k * step] = ((sum - comp) + pb - pa) / (REAL)width;
    }
}

// the 2-D cubic B-spline of one plane (h x w, at `plane`) at (py, px)
static inline REAL spline2(__global const REAL *src, const long plane, const int h, const int w, const POS py,
                           const POS px, const int mode_y, const int mode_x, const REAL cval)
{
    const POS fy = floor(py), fx = floor(px);
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
                         const REAL cval)
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
        out[b * hw + pix] = acc;
    }
}

// One work-item per polar sample (ring i, angle j) of every plane; trig[2j], trig[2j+1] = cos, sin
// of angle j (computed once on the host: a sine per sample would dominate the kernel).
__kernel void to_polar(__global const REAL *coef, __global REAL *out, __global const POS *trig, const int h,
                       const int w, const int n_r, const int n_phi, const int planes, const POS cy, const POS cx,
                       const int mode, const REAL cval)
{
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= n_phi || i >= n_r)
        return;
    const POS r = (POS)i;
    const POS py = cy - r * trig[2 * j + 1], px = cx + r * trig[2 * j];
    for (int b = 0; b < planes; ++b)
        out[((long)b * n_r + i) * n_phi + j] = spline2(coef, (long)b * h * w, h, w, py, px, mode, mode, cval);
}

// One work-item per pixel: radius and angle on the polar grid (angle wraps, radius mirrors).
__kernel void from_polar(__global const REAL *pcoef, __global REAL *out, const int h, const int w, const int n_r,
                         const int n_phi, const int planes, const POS cy, const POS cx)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const POS dy = cy - (POS)y, dx = (POS)x - cx;
    const POS r = sqrt(dx * dx + dy * dy);
    POS phi = atan2(dy, dx);
    phi = phi < 0 ? phi + TWO_PI : phi;
    const POS jf = phi * (POS)n_phi / TWO_PI;
    for (int b = 0; b < planes; ++b)
        out[((long)b * h + y) * w + x] = spline2(pcoef, (long)b * n_r * n_phi, n_r, n_phi, r, jf, 4, 2, (REAL)0);
}
