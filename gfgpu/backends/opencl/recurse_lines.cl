/*
 * The per-line recursion primitive (spec: gfgpu/_core/recursion.py, run_reference_lines): one
 * shift-invariant single-section pass per line, each line with its own coefficients.
 *
 * For line i of a C-contiguous (B, N, M) array (traversal reversed where reverse[i]):
 *
 *     F = sum_{j<L} omega[i,j] I[j] + omega_c[i] cval                  (complex)
 *     for k in 0..n-1:
 *         dst[k] = Re F + tap[i] I[k];   F = lam[i] F + kap[i] I[k]
 *
 * Lines along axis 2 (rows: line_stride M, step 1) or axis 1 (columns: line_stride 1,
 * step M).  recurse_lines: one work-item per line.  recurse_lines_lanes (-D LANES=4|8, CPUs):
 * LANES adjacent lines per work-item in vector lanes, each lane with its own coefficients, when
 * the LANES lines share `reverse` (else, and for a last group of fewer lines, one line after the
 * other): a line's recursion is one chain of dependent multiply-adds, so one line per work-item
 * leaves the CPU's vector units and most of its pipeline idle.  -D ROWS=1: lines along axis 2,
 * each lane's samples gathered (line_stride apart); ROWS=0: columns, one contiguous vector.
 * The lanes do each line's operations in the scalar kernel's order: the same values.
 * Packed arrays: lam, kap (m, 2), tap (m), reverse (m), omega (m, L, 2), omega_c (m, 2).
 * -D REAL=float|double.
 */

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#ifndef REAL
#define REAL float
#endif

/* line i (of batch b) from s to d: the whole recursion of the header */
static inline __attribute__((always_inline)) void one_line(
    __global const REAL *src, __global REAL *dst, const long src_off, const long dst_off,
    __global const REAL *lam, __global const REAL *kap, __global const REAL *tap, __global const int *reverse,
    __global const REAL *omega, __global const REAL *omega_c, const int L, const int n, const int i,
    const long b, const long line_stride, const long step, const long plane, const REAL cval)
{
    const long base = b * plane + i * line_stride;
    __global const REAL *s = src + src_off + base;
    __global REAL *d = dst + dst_off + base;
    const int rev = reverse[i];
    const long first = rev ? (long)(n - 1) * step : 0;
    const long stride = rev ? -step : step;

    REAL fr = omega_c[2 * i] * cval, fi = omega_c[2 * i + 1] * cval;
    __global const REAL *om = omega + 2L * L * i;
    for (int j = 0; j < L; ++j) {
        const REAL v = s[first + j * stride];
        fr += om[2 * j] * v;
        fi += om[2 * j + 1] * v;
    }
    const REAL lr = lam[2 * i], li = lam[2 * i + 1], kr = kap[2 * i], ki = kap[2 * i + 1];
    const REAL t = tap[i];
    for (int k = 0; k < n; ++k) {
        const long x = first + k * stride;
        const REAL v = s[x];                 /* read before written: dst may alias src */
        d[x] = fr + t * v;
        const REAL nr = lr * fr - li * fi + kr * v;
        fi = lr * fi + li * fr + ki * v;
        fr = nr;
    }
}

__kernel void recurse_lines(__global const REAL *src, __global REAL *dst, const long src_off,
                            const long dst_off, __global const REAL *lam, __global const REAL *kap,
                            __global const REAL *tap, __global const int *reverse,
                            __global const REAL *omega, __global const REAL *omega_c, const int L,
                            const int n, const int lines, const long line_stride, const long step,
                            const long plane, const REAL cval)
{
    const int i = get_global_id(0);
    const long b = get_global_id(1);
    if (i >= lines)
        return;
    one_line(src, dst, src_off, dst_off, lam, kap, tap, reverse, omega, omega_c, L, n, i, b, line_stride,
             step, plane, cval);
}

#ifdef LANES
#ifndef VECS
#define VECS 2       /* vectors per work-item: 2 x 32 bytes, a cache line of adjacent columns */
#endif
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
typedef CAT(REAL, LANES) VT;
/* lanes p[0], p[ls], ... (per-lane coefficients, rows' samples); PoCL calls vloadn and
 * vstoren out of line: plain element accesses, or (clang) a vector of the element's alignment */
#if LANES == 4
#define GATHER(p, ls) ((VT)((p)[0], (p)[ls], (p)[2 * (ls)], (p)[3 * (ls)]))
#define SCATTER(v, p, ls) do { const VT v_ = (v); (p)[0] = v_.s0; (p)[ls] = v_.s1; (p)[2 * (ls)] = v_.s2; \
    (p)[3 * (ls)] = v_.s3; } while (0)
#elif LANES == 8
#define GATHER(p, ls) ((VT)((p)[0], (p)[ls], (p)[2 * (ls)], (p)[3 * (ls)], (p)[4 * (ls)], (p)[5 * (ls)], \
                           (p)[6 * (ls)], (p)[7 * (ls)]))
#define SCATTER(v, p, ls) do { const VT v_ = (v); (p)[0] = v_.s0; (p)[ls] = v_.s1; (p)[2 * (ls)] = v_.s2; \
    (p)[3 * (ls)] = v_.s3; (p)[4 * (ls)] = v_.s4; (p)[5 * (ls)] = v_.s5; (p)[6 * (ls)] = v_.s6; \
    (p)[7 * (ls)] = v_.s7; } while (0)
#else
#error "LANES must be 4 or 8"
#endif
#if ROWS
#define LOADV(p) GATHER(p, line_stride)
#define STOREV(v, p) SCATTER(v, p, line_stride)
#elif defined(__clang__)
typedef REAL VTU __attribute__((ext_vector_type(LANES), aligned(sizeof(REAL))));
#define LOADV(p) ((VT)(*(__global const VTU *)(p)))
#define STOREV(v, p) (*(__global VTU *)(p) = (VTU)(v))
#else
#define LOADV(p) CAT(vload, LANES)(0, (p))
#define STOREV(v, p) CAT(vstore, LANES)((v), 0, (p))
#endif

/* nv (1 or VECS, a constant after inlining) vectors of LANES lines from line i0, all of
 * direction rev: independent chains, so the CPU overlaps their multiply-adds */
static inline __attribute__((always_inline)) void lanes_run(
    __global const REAL *src, __global REAL *dst, const long src_off, const long dst_off,
    __global const REAL *lam, __global const REAL *kap, __global const REAL *tap,
    __global const REAL *omega, __global const REAL *omega_c, const int L, const int n, const int i0,
    const int nv, const int rev, const long b, const long line_stride, const long step, const long plane,
    const REAL cval)
{
    const long base = b * plane + i0 * line_stride;
    __global const REAL *s = src + src_off + base;
    __global REAL *d = dst + dst_off + base;
    const long first = rev ? (long)(n - 1) * step : 0;
    const long stride = rev ? -step : step;
    const long lane_om = 2L * L, vec = LANES * line_stride;    /* lanes' omega rows; vector q's lines */
    VT fr[VECS], fi[VECS], lr[VECS], li[VECS], kr[VECS], ki[VECS], t[VECS];
#pragma unroll
    for (int q = 0; q < nv; ++q) {
        const int i = i0 + q * LANES;
        fr[q] = GATHER(omega_c + 2 * i, 2) * cval;
        fi[q] = GATHER(omega_c + 2 * i + 1, 2) * cval;
        lr[q] = GATHER(lam + 2 * i, 2);
        li[q] = GATHER(lam + 2 * i + 1, 2);
        kr[q] = GATHER(kap + 2 * i, 2);
        ki[q] = GATHER(kap + 2 * i + 1, 2);
        t[q] = GATHER(tap + i, 1);
    }
    for (int j = 0; j < L; ++j) {
#pragma unroll
        for (int q = 0; q < nv; ++q) {
            __global const REAL *om = omega + lane_om * (i0 + q * LANES);
            const VT v = LOADV(s + q * vec + first + j * stride);
            fr[q] += GATHER(om + 2 * j, lane_om) * v;
            fi[q] += GATHER(om + 2 * j + 1, lane_om) * v;
        }
    }
    for (int k = 0; k < n; ++k) {
        const long x = first + k * stride;
#pragma unroll
        for (int q = 0; q < nv; ++q) {
            const VT v = LOADV(s + q * vec + x);       /* read before written: dst may alias src */
            STOREV(fr[q] + t[q] * v, d + q * vec + x);
            const VT nr = lr[q] * fr[q] - li[q] * fi[q] + kr[q] * v;
            fi[q] = lr[q] * fi[q] + li[q] * fr[q] + ki[q] * v;
            fr[q] = nr;
        }
    }
}

/* whether lines i0 .. i0 + count - 1 exist and share reverse[i0] */
static inline __attribute__((always_inline)) int one_direction(__global const int *reverse, const int i0,
                                                               const int count, const int lines)
{
    int same = i0 + count <= lines;
    for (int l = 1; l < count && same; ++l)
        same = reverse[i0 + l] == reverse[i0];
    return same;
}

/* VECS LANES lines per work-item (the launcher's group); a vector of lines of both directions,
 * or the last, partial one, runs line by line */
__kernel void recurse_lines_lanes(__global const REAL *src, __global REAL *dst, const long src_off,
                                  const long dst_off, __global const REAL *lam, __global const REAL *kap,
                                  __global const REAL *tap, __global const int *reverse,
                                  __global const REAL *omega, __global const REAL *omega_c, const int L,
                                  const int n, const int lines, const long line_stride, const long step,
                                  const long plane, const REAL cval)
{
    const int g0 = get_global_id(0) * (VECS * LANES);
    const long b = get_global_id(1);
    if (g0 >= lines)
        return;
    if (one_direction(reverse, g0, VECS * LANES, lines)) {
        lanes_run(src, dst, src_off, dst_off, lam, kap, tap, omega, omega_c, L, n, g0, VECS, reverse[g0], b,
                  line_stride, step, plane, cval);
        return;
    }
    for (int i0 = g0; i0 < lines && i0 < g0 + VECS * LANES; i0 += LANES) {
        if (one_direction(reverse, i0, LANES, lines))
            lanes_run(src, dst, src_off, dst_off, lam, kap, tap, omega, omega_c, L, n, i0, 1, reverse[i0], b,
                      line_stride, step, plane, cval);
        else
            for (int i = i0; i < lines && i < i0 + LANES; ++i)
                one_line(src, dst, src_off, dst_off, lam, kap, tap, reverse, omega, omega_c, L, n, i, b,
                         line_stride, step, plane, cval);
    }
}
#endif

/*
 * The shears of an oblique pass (spec: gfgpu/_core/oblique.py, run_oblique_lines), each one kernel:
 *
 *   shear_in:  layout[q, t] = A_t(column t of the image read at base[q + shift[t]])   (anticausal)
 *   shear_out: image[q + start[t], t] = A_t(layout column t)                           (causal)
 *
 * A_t the cascade of the column's two allpass sections, one complex pair (lam, kap, tap) and one
 * real pole (p, k, tapb), both started at the steady state of the line's first sample
 * ("nearest": the layout's margin makes the start irrelevant at the lines read back).  The gather
 * is index arithmetic on a table of O(H + W) numbers: no whole-image index array and no
 * intermediate layout between the gather and the sections.  Layout sample (q, t) at
 * q * qs + t * ts; image pixel (minor c, step t) at c * stride + t * tstride (base holds
 * c * stride, -1 for cval).
 *
 * A work-item runs nv vectors of SHEAR_LANES adjacent columns (a band of nv * SHEAR_LANES
 * columns: on a CPU each step of the walk down the columns touches whole cache lines of one row),
 * one vector after the other at each step; the states wait in private arrays.  Coefficients come
 * grouped per vector, coef[g][j][lane] (g = t / SHEAR_LANES, j < NCOEF): lam re, im, kap re, im,
 * tap, g re, im (= kap / (1 - lam)), p, k, tapb, gb (= k / (1 - p)); columns past the last repeat
 * it (computed, never written).
 */
#ifndef SHEAR_LANES
#define SHEAR_LANES 1
#endif
#ifndef MAXV
#define MAXV 16
#endif
#define NCOEF 11
#define CAT2_(a, b) a##b
#define CAT2(a, b) CAT2_(a, b)

#define SMIN(a, b) ((a) < (b) ? (a) : (b))     /* PoCL calls min() out of line */
#if SHEAR_LANES == 1
typedef REAL SVT;
#define CVEC(p) (*(p))
#elif defined(__clang__)
typedef CAT2(REAL, SHEAR_LANES) SVT;
/* a vector of the element's alignment: rows of the layout start anywhere */
typedef REAL SVTU __attribute__((ext_vector_type(SHEAR_LANES), aligned(sizeof(REAL))));
#define CVEC(p) ((SVT)(*(__global const SVTU *)(p)))
#else
typedef CAT2(REAL, SHEAR_LANES) SVT;
#define CVEC(p) CAT2(vload, SHEAR_LANES)(0, (p))
#endif
typedef union { SVT v; REAL s[SHEAR_LANES]; } shear_lanes;

#define COEFS(g)                                                                                  \
    __global const REAL *c_ = coef + (long)(g) * (NCOEF * SHEAR_LANES);                          \
    const SVT lr = CVEC(c_), li = CVEC(c_ + SHEAR_LANES), kr = CVEC(c_ + 2 * SHEAR_LANES),        \
        ki = CVEC(c_ + 3 * SHEAR_LANES), ta = CVEC(c_ + 4 * SHEAR_LANES),                          \
        pp = CVEC(c_ + 7 * SHEAR_LANES), kb = CVEC(c_ + 8 * SHEAR_LANES), tb = CVEC(c_ + 9 * SHEAR_LANES)

#define START(g, v0, k) do {                                                                       \
        __global const REAL *c0_ = coef + (long)(g) * (NCOEF * SHEAR_LANES);                       \
        far[k] = CVEC(c0_ + 5 * SHEAR_LANES) * (v0);                                               \
        fai[k] = CVEC(c0_ + 6 * SHEAR_LANES) * (v0);                                               \
        fb[k] = CVEC(c0_ + 10 * SHEAR_LANES) * (v0);                                               \
    } while (0)

/* one step of the cascade on every lane of vector k: input v, output y */
#define CASCADE(k, v, y) do {                                                                      \
        const SVT fr_ = far[k], fi_ = fai[k], fb_ = fb[k];                                         \
        const SVT ya_ = fr_ + ta * (v);                                                            \
        far[k] = lr * fr_ - li * fi_ + kr * (v);                                                   \
        fai[k] = lr * fi_ + li * fr_ + ki * (v);                                                   \
        (y) = fb_ + tb * ya_;                                                                      \
        fb[k] = pp * fb_ + kb * ya_;                                                               \
    } while (0)

/* lane l of vector k of this work-item: column t (clamped to the last) */
#define COLUMN(k, l) SMIN(t0 + (k) * SHEAR_LANES + (l), steps - 1)

static inline __attribute__((always_inline)) SVT read_in(
    __global const REAL *s, __global const int *base, __global const int *shift, const int q, const int t0,
    const int k, const int steps, const long tstride, const REAL cval)
{
    shear_lanes v;
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l) {
        const int t = COLUMN(k, l);
        const int row = base[q + shift[t]];
        v.s[l] = row >= 0 ? s[row + t * tstride] : cval;
    }
    return v.v;
}

__kernel void shear_in(__global const REAL *src, const long src_off, __global REAL *dst, const long dst_off,
                       __global const REAL *coef, __global const int *base, __global const int *shift,
                       const int lines, const int steps, const long qs, const long ts, const long tstride,
                       const long src_plane, const long dst_plane, const REAL cval, const int nv)
{
    const int t0 = get_global_id(0) * (nv * SHEAR_LANES);
    const long b = get_global_id(1);
    if (t0 >= steps)
        return;
    const int g0 = t0 / SHEAR_LANES;
    const int vecs = SMIN(nv, (steps - t0 + SHEAR_LANES - 1) / SHEAR_LANES);
    __global const REAL *s = src + src_off + b * src_plane;
    __global REAL *d = dst + dst_off + b * dst_plane;
    SVT far[MAXV], fai[MAXV], fb[MAXV];
    for (int k = 0; k < vecs; ++k) {
        const SVT v0 = read_in(s, base, shift, lines - 1, t0, k, steps, tstride, cval);
        START(g0 + k, v0, k);
    }
    for (int q = lines - 1; q >= 0; --q) {
        for (int k = 0; k < vecs; ++k) {
            COEFS(g0 + k);
            const SVT v = read_in(s, base, shift, q, t0, k, steps, tstride, cval);
            shear_lanes y;
            CASCADE(k, v, y.v);
            const int tk = t0 + k * SHEAR_LANES;
            __global REAL *out = d + q * qs + (long)tk * ts;
            if (ts == 1 && tk + SHEAR_LANES <= steps) {
#pragma unroll
                for (int l = 0; l < SHEAR_LANES; ++l)
                    out[l] = y.s[l];
            } else {
#pragma unroll
                for (int l = 0; l < SHEAR_LANES; ++l)
                    if (tk + l < steps)
                        out[l * ts] = y.s[l];
            }
        }
    }
}

__kernel void shear_out(__global const REAL *src, const long src_off, __global REAL *dst, const long dst_off,
                        __global const REAL *coef, __global const int *start, const int lines, const int steps,
                        const int across, const long qs, const long ts, const long stride, const long tstride,
                        const long src_plane, const long dst_plane, const int nv)
{
    const int t0 = get_global_id(0) * (nv * SHEAR_LANES);
    const long b = get_global_id(1);
    if (t0 >= steps)
        return;
    const int g0 = t0 / SHEAR_LANES;
    const int vecs = SMIN(nv, (steps - t0 + SHEAR_LANES - 1) / SHEAR_LANES);
    __global const REAL *s = src + src_off + b * src_plane;
    __global REAL *d = dst + dst_off + b * dst_plane;
    /* no pixel lies beyond line across - the least start: those lines are not read */
    int lo = start[t0];
    for (int t = t0 + 1; t < SMIN(t0 + vecs * SHEAR_LANES, steps); ++t)
        lo = SMIN(lo, start[t]);
    const int last = SMIN(lines, across - lo);
    SVT far[MAXV], fai[MAXV], fb[MAXV];
    for (int k = 0; k < vecs; ++k) {
        shear_lanes v0;
#pragma unroll
        for (int l = 0; l < SHEAR_LANES; ++l)
            v0.s[l] = s[(long)COLUMN(k, l) * ts];
        START(g0 + k, v0.v, k);
    }
    for (int q = 0; q < last; ++q) {
        for (int k = 0; k < vecs; ++k) {
            COEFS(g0 + k);
            const int tk = t0 + k * SHEAR_LANES;
            shear_lanes v;
            if (ts == 1 && tk + SHEAR_LANES <= steps) {
                v.v = CVEC(s + q * qs + tk);
            } else {
#pragma unroll
                for (int l = 0; l < SHEAR_LANES; ++l)
                    v.s[l] = s[q * qs + (long)COLUMN(k, l) * ts];
            }
            shear_lanes y;
            CASCADE(k, v.v, y.v);
#pragma unroll
            for (int l = 0; l < SHEAR_LANES; ++l) {
                const int t = tk + l;
                const int m = q + start[SMIN(t, steps - 1)];
                if (t < steps && m >= 0 && m < across)
                    d[m * stride + t * tstride] = y.s[l];
            }
        }
    }
}
