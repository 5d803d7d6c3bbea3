/*
 * The recursion primitive of gfgpu in OpenCL C 1.2 (spec: gfgpu/_core/recursion.py, run_reference).
 *
 * For each line I[0..n-1] (traversal order; reversed when `reverse`):
 *
 *     F_s = sum_{j<L} omega[s,j] I[j] + omega_c[s] cval                 (complex)
 *     for k in 0..n-1:
 *         y = sum_s Re F_s + tap I[k];   dst[k] = y   (dst[k] += y when accumulating)
 *         F_s = lam[s,k] F_s + kap[s,k] I[k]
 *
 * on a C-contiguous (B, N, M) array.  Specialised by -D defines only:
 *
 *   REAL           float or double
 *   SECTIONS       number of complex sections s (1 or 2 in practice)
 *   CONSTANT_COEF  1: lam/kap[s,0] hold for every k and are read once into registers
 *   LANES          lines per work-item, one vector lane each (1, 2, 4, 8 or 16)
 *   ROWS           0: lines along axis 1 ("columns": B*M lines of N samples, stride M)
 *                  1: lines along axis 2 ("rows": B*N contiguous lines of M samples)
 *
 * Columns: a work-item runs LANES adjacent columns; one step is one vector load/store of
 * LANES contiguous samples (a full cache line for LANES = 64 bytes / sizeof(REAL)).
 * Rows: a work-item runs LANES rows; LANES steps at a time it loads a LANES x LANES tile
 * (one vector per row), transposes it in registers so that each vector holds one sample of
 * every row, steps with vector arithmetic, transposes the outputs back and stores them.
 * On a GPU the host uses LANES = 1: one work-item per line, so for columns adjacent
 * work-items touch adjacent addresses (coalesced) and the tile code reduces to scalars.
 *
 * dst may alias src when not accumulating: every sample is read before its output is written.
 * Plan arrays are packed by PassPlan.packed: lam, kap (S, n, 2), omega (S, L, 2), omega_c (S, 2),
 * in traversal order.  No fast-math: results follow IEEE arithmetic (contraction to fma allowed).
 */

#ifdef cl_khr_fp64
/* harmless for float builds; the host never builds REAL=double for a device without fp64 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#ifndef REAL
#define REAL float
#endif
#ifndef SECTIONS
#define SECTIONS 1
#endif
#ifndef CONSTANT_COEF
#define CONSTANT_COEF 0
#endif
#ifndef LANES
#define LANES 1
#endif
#ifndef ROWS
#define ROWS 0
#endif

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

/* ---- lane vectors ------------------------------------------------------------------ */
#if LANES == 1
typedef REAL VT;
#define VLOAD(p) (*(p))
#define VSTORE(v, p) (*(p) = (v))
#elif LANES == 2 || LANES == 4
typedef CAT(REAL, LANES) VT;
#define VLOAD(p) CAT(vload, LANES)(0, (p))
#define VSTORE(v, p) CAT(vstore, LANES)((v), 0, (p))
#elif LANES == 8 || LANES == 16
/* In two halves: PoCL 3.0 on x86 crashes in code generation on 512-bit vloadn/vstoren
 * (float16, double8: "Do not know how to scalarize ..." or a segfault); the halves are
 * adjacent and compile to the same moves. */
#if LANES == 8
#define HALF 4
#else
#define HALF 8
#endif
typedef CAT(REAL, LANES) VT;
#define VLOAD(p) ((VT)(CAT(vload, HALF)(0, (p)), CAT(vload, HALF)(0, (p) + HALF)))
#define VSTORE(v, p) do { const VT v_ = (v); CAT(vstore, HALF)(v_.lo, 0, (p)); \
                          CAT(vstore, HALF)(v_.hi, 0, (p) + HALF); } while (0)
#else
#error "LANES must be 1, 2, 4, 8 or 16"
#endif

/* Interleave the low (ZIPLO) or high (ZIPHI) halves of two vectors: a0 b0 a1 b1 ... */
#if LANES == 2
#define LOG2_LANES 1
#define ZIPLO(a, b) ((VT)((a).s0, (b).s0))
#define ZIPHI(a, b) ((VT)((a).s1, (b).s1))
#elif LANES == 4
#define LOG2_LANES 2
#define ZIPLO(a, b) ((VT)((a).s0, (b).s0, (a).s1, (b).s1))
#define ZIPHI(a, b) ((VT)((a).s2, (b).s2, (a).s3, (b).s3))
#elif LANES == 8
#define LOG2_LANES 3
#define ZIPLO(a, b) ((VT)((a).s0, (b).s0, (a).s1, (b).s1, (a).s2, (b).s2, (a).s3, (b).s3))
#define ZIPHI(a, b) ((VT)((a).s4, (b).s4, (a).s5, (b).s5, (a).s6, (b).s6, (a).s7, (b).s7))
#elif LANES == 16
#define LOG2_LANES 4
#define ZIPLO(a, b) ((VT)((a).s0, (b).s0, (a).s1, (b).s1, (a).s2, (b).s2, (a).s3, (b).s3, \
                          (a).s4, (b).s4, (a).s5, (b).s5, (a).s6, (b).s6, (a).s7, (b).s7))
#define ZIPHI(a, b) ((VT)((a).s8, (b).s8, (a).s9, (b).s9, (a).sa, (b).sa, (a).sb, (b).sb, \
                          (a).sc, (b).sc, (a).sd, (b).sd, (a).se, (b).se, (a).sf, (b).sf))
#endif

/* In-place transpose of the LANES x LANES matrix whose rows are t[0..LANES-1].
 * Each round maps element (r, c) to the position whose index bits [r | c] are rotated left
 * by one; LOG2_LANES rounds give [c | r], the transpose.  Fully unrolled: registers only. */
static inline void transpose(VT *t)
{
#if LANES > 1
#pragma unroll
    for (int r = 0; r < LOG2_LANES; ++r) {
        VT u[LANES];
#pragma unroll
        for (int i = 0; i < LANES / 2; ++i) {
            u[2 * i] = ZIPLO(t[i], t[i + LANES / 2]);
            u[2 * i + 1] = ZIPHI(t[i], t[i + LANES / 2]);
        }
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            t[i] = u[i];
    }
#endif
}

/* ---- the recursion ------------------------------------------------------------------ */
typedef struct {
    REAL lr[SECTIONS], li[SECTIONS], kr[SECTIONS], ki[SECTIONS];
} coef_t;

static inline void load_coef(coef_t *c, __global const REAL *lam, __global const REAL *kap,
                             const int n, const int k)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const size_t o = 2 * ((size_t)s * n + k);
        c->lr[s] = lam[o];
        c->li[s] = lam[o + 1];
        c->kr[s] = kap[o];
        c->ki[s] = kap[o + 1];
    }
}

/* One step on LANES lines: returns y = sum_s Re F_s + tap v and advances the state
 * (named `advance`: `step` is an OpenCL builtin). */
static inline VT advance(VT *fr, VT *fi, const VT v, const REAL tap, const coef_t *c)
{
    VT y = fr[0];
#pragma unroll
    for (int s = 1; s < SECTIONS; ++s)
        y += fr[s];
    y += tap * v;
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const VT r = c->lr[s] * fr[s] - c->li[s] * fi[s] + c->kr[s] * v;
        const VT i = c->lr[s] * fi[s] + c->li[s] * fr[s] + c->ki[s] * v;
        fr[s] = r;
        fi[s] = i;
    }
    return y;
}

/* F_s += omega[s, j] v  (initial state, traversal position j < L) */
static inline void add_initial(VT *fr, VT *fi, const VT v, __global const REAL *omega,
                               const int L, const int j)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const size_t o = 2 * ((size_t)s * L + j);
        fr[s] += omega[o] * v;
        fi[s] += omega[o + 1] * v;
    }
}

/* F_s += omega_c[s] cval: the constant-mode part of the initial state, added after the sum */
static inline void add_cval(VT *fr, VT *fi, __global const REAL *omega_c, const REAL cval)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        fr[s] += omega_c[2 * s] * cval;
        fi[s] += omega_c[2 * s + 1] * cval;
    }
}

static inline void init_state(VT *fr, VT *fi)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        fr[s] = (VT)(0);
        fi[s] = (VT)(0);
    }
}

#if !ROWS
/* ---- columns: LANES adjacent lines of stride M ---------------------------------------- */

/* The LANES samples at p; a partial group (valid < LANES, the last columns of a row) loads
 * lane l from column min(l, valid - 1) so the extra lanes stay finite and in bounds. */
static inline VT load_cols(__global const REAL *p, const int valid, const int full)
{
    if (full)
        return VLOAD(p);
    REAL tmp[LANES];
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        tmp[l] = p[min(l, valid - 1)];
    return VLOAD(tmp);
}

static inline void store_cols(__global REAL *p, const VT y, const int valid, const int full,
                              const int accumulate)
{
    if (full) {
        VSTORE(accumulate ? VLOAD(p) + y : y, p);
        return;
    }
    REAL tmp[LANES];
    VSTORE(y, tmp);
    for (int l = 0; l < valid; ++l)
        p[l] = accumulate ? p[l] + tmp[l] : tmp[l];
}

/* `full` is a literal at each call site so the vector path has no per-step lane logic. */
static inline void run_columns(__global const REAL *src, __global REAL *dst,
                               __global const REAL *lam, __global const REAL *kap,
                               __global const REAL *omega, __global const REAL *omega_c,
                               const int L, const int n, const REAL cval, const REAL tap,
                               const int reverse, const int accumulate, const long stride,
                               const int valid, const int full)
{
    /* traversal position k lives at src + k * walk (reversed lines walk backwards) */
    const long walk = reverse ? -stride : stride;
    if (reverse) {
        src += (long)(n - 1) * stride;
        dst += (long)(n - 1) * stride;
    }
    VT fr[SECTIONS], fi[SECTIONS];
    init_state(fr, fi);
    for (int j = 0; j < L; ++j)
        add_initial(fr, fi, load_cols(src + j * walk, valid, full), omega, L, j);
    add_cval(fr, fi, omega_c, cval);

    coef_t c;
    load_coef(&c, lam, kap, n, 0);
    for (int k = 0; k < n; ++k) {
        const VT v = load_cols(src, valid, full);   /* read before dst (may alias) is written */
#if !CONSTANT_COEF
        load_coef(&c, lam, kap, n, k);
#endif
        store_cols(dst, advance(fr, fi, v, tap, &c), valid, full, accumulate);
        src += walk;
        dst += walk;
    }
}

/* Global size (ceil(M / LANES), B): work-item (g, b) runs columns g*LANES.. of image b. */
__kernel void recurse(__global const REAL *src, __global REAL *dst, const long src_off,
                      const long dst_off, __global const REAL *lam, __global const REAL *kap,
                      __global const REAL *omega, __global const REAL *omega_c, const int L,
                      const int n, const REAL cval, const REAL tap, const int reverse,
                      const int accumulate, const int B, const int N, const int M)
{
    const int m0 = (int)get_global_id(0) * LANES;
    const int b = (int)get_global_id(1);
    if (m0 >= M || b >= B)
        return;
    const long base = (long)b * N * M + m0;
    const int valid = min(LANES, M - m0);
    if (valid == LANES)
        run_columns(src + src_off + base, dst + dst_off + base, lam, kap, omega, omega_c, L, n,
                    cval, tap, reverse, accumulate, (long)M, LANES, 1);
    else
        run_columns(src + src_off + base, dst + dst_off + base, lam, kap, omega, omega_c, L, n,
                    cval, tap, reverse, accumulate, (long)M, valid, 0);
}

#else
/* ---- rows: LANES contiguous lines of n samples, transposed tile by tile --------------- */

/* w[i] = samples of every lane at traversal position k0 + i, i < cnt.  A full chunk is a
 * tile load + transpose; a partial one (cnt < LANES, the end of the line) is gathered.
 * Lanes past the last row (valid < LANES) repeat the last row: loads stay in bounds. */
static inline void load_chunk(VT *w, __global const REAL *src, const int n, const int valid,
                              const int k0, const int cnt, const int reverse)
{
    if (cnt == LANES) {
        VT t[LANES];
        const int p0 = reverse ? n - k0 - LANES : k0;   /* natural start of the tile */
#pragma unroll
        for (int l = 0; l < LANES; ++l)
            t[l] = VLOAD(src + (long)min(l, valid - 1) * n + p0);
        transpose(t);
        /* t[j] is natural position p0 + j; traversal runs backwards when reversed */
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            w[i] = reverse ? t[LANES - 1 - i] : t[i];
        return;
    }
    /* unrolled with guards, not `i < cnt`: constant indices keep w[] in registers */
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        if (i < cnt) {
            const int p = reverse ? n - 1 - (k0 + i) : k0 + i;
            REAL tmp[LANES];
#pragma unroll
            for (int l = 0; l < LANES; ++l)
                tmp[l] = src[(long)min(l, valid - 1) * n + p];
            w[i] = VLOAD(tmp);
        }
    }
}

/* Write y[i] (traversal position k0 + i, i < cnt) of the `valid` real lanes. */
static inline void store_chunk(VT *y, __global REAL *dst, const int n, const int valid,
                               const int k0, const int cnt, const int reverse,
                               const int accumulate)
{
    if (cnt == LANES) {
        VT t[LANES];
        const int p0 = reverse ? n - k0 - LANES : k0;
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            t[i] = reverse ? y[LANES - 1 - i] : y[i];
        transpose(t);   /* back to one vector per row */
#pragma unroll
        for (int l = 0; l < LANES; ++l) {
            if (l < valid) {
                __global REAL *p = dst + (long)l * n + p0;
                VSTORE(accumulate ? VLOAD(p) + t[l] : t[l], p);
            }
        }
        return;
    }
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        if (i < cnt) {
            const int p = reverse ? n - 1 - (k0 + i) : k0 + i;
            REAL tmp[LANES];
            VSTORE(y[i], tmp);
#pragma unroll
            for (int l = 0; l < LANES; ++l) {
                if (l < valid) {
                    __global REAL *q = dst + (long)l * n + p;
                    *q = accumulate ? *q + tmp[l] : tmp[l];
                }
            }
        }
    }
}

/* `reverse` is a literal at each call site, so the tile's traversal order is static. */
static inline void run_rows(__global const REAL *src, __global REAL *dst,
                            __global const REAL *lam, __global const REAL *kap,
                            __global const REAL *omega, __global const REAL *omega_c,
                            const int L, const int n, const REAL cval, const REAL tap,
                            const int accumulate, const int valid, const int reverse)
{
    VT fr[SECTIONS], fi[SECTIONS], w[LANES];
    init_state(fr, fi);
    for (int k0 = 0; k0 < L; k0 += LANES) {
        load_chunk(w, src, n, valid, k0, min(LANES, n - k0), reverse);
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            if (k0 + i < L)
                add_initial(fr, fi, w[i], omega, L, k0 + i);
    }
    add_cval(fr, fi, omega_c, cval);

    coef_t c;
    load_coef(&c, lam, kap, n, 0);
    int k0 = 0;
    for (; k0 + LANES <= n; k0 += LANES) {
        load_chunk(w, src, n, valid, k0, LANES, reverse);   /* whole tile read before written */
#pragma unroll
        for (int i = 0; i < LANES; ++i) {
#if !CONSTANT_COEF
            load_coef(&c, lam, kap, n, k0 + i);
#endif
            w[i] = advance(fr, fi, w[i], tap, &c);
        }
        store_chunk(w, dst, n, valid, k0, LANES, reverse, accumulate);
    }
    if (k0 < n) {   /* scalar tail: the last n % LANES steps */
        const int cnt = n - k0;
        load_chunk(w, src, n, valid, k0, cnt, reverse);
#pragma unroll
        for (int i = 0; i < LANES; ++i) {
            if (i < cnt) {
#if !CONSTANT_COEF
                load_coef(&c, lam, kap, n, k0 + i);
#endif
                w[i] = advance(fr, fi, w[i], tap, &c);
            }
        }
        store_chunk(w, dst, n, valid, k0, cnt, reverse, accumulate);
    }
}

/* Global size ceil(B*N / LANES): work-item g runs rows g*LANES.. (lines of M samples). */
__kernel void recurse(__global const REAL *src, __global REAL *dst, const long src_off,
                      const long dst_off, __global const REAL *lam, __global const REAL *kap,
                      __global const REAL *omega, __global const REAL *omega_c, const int L,
                      const int n, const REAL cval, const REAL tap, const int reverse,
                      const int accumulate, const int B, const int N, const int M)
{
    const long rows = (long)B * N;
    const long r0 = (long)get_global_id(0) * LANES;
    if (r0 >= rows)
        return;
    const int valid = (int)min((long)LANES, rows - r0);
    const long base = r0 * M;
    if (reverse)
        run_rows(src + src_off + base, dst + dst_off + base, lam, kap, omega, omega_c, L, n,
                 cval, tap, accumulate, valid, 1);
    else
        run_rows(src + src_off + base, dst + dst_off + base, lam, kap, omega, omega_c, L, n,
                 cval, tap, accumulate, valid, 0);
}
#endif

/* ---- gather: out[i] = index[i] >= 0 ? src[index[i]] : cval ----------------------------- */
__kernel void gather(__global const REAL *src, const long src_off, __global const int *index,
                     __global REAL *out, const long out_off, const REAL cval, const long size)
{
    const long i = (long)get_global_id(0);
    if (i >= size)
        return;
    const int j = index[i];
    out[out_off + i] = j >= 0 ? src[src_off + j] : cval;
}

/* x - x is +0 for every finite x and NaN for NaN and infinities (IEEE arithmetic: the programs are
 * built without fast-math); unlike isfinite() it vectorises on CPU devices */
#define NONFINITE(x) (((x) - (x)) != (REAL)0)

/* ---- any_nonfinite: *flag |= 1 if some x[i] (i < size) is NaN or infinite ------------------
 * Work-item g reads x[g*first + j*stride], j < count: contiguous chunks on a CPU
 * (first = chunk, stride = 1), a grid-stride loop on a GPU (first = 1, stride = items). */
__kernel void any_nonfinite(__global const REAL *x, const long off, const long size,
                            const long first, const long stride, const long count,
                            __global int *flag)
{
    long i = (long)get_global_id(0) * first;
    int bad = 0;
    if (stride == 1) {   /* a counted loop over one chunk: vectorised */
        const long end = min(i + count, size);
        for (long k = i; k < end; ++k)
            bad |= NONFINITE(x[off + k]);
    } else {
        for (long j = 0; j < count && i < size; ++j, i += stride)
            bad |= NONFINITE(x[off + i]);
    }
    if (bad)
        atomic_or(flag, 1);
}

/* ---- translate: an integer translation of lines, one index per position -------------------
 * The data are rows of m samples (B*N rows).  Along rows (along_rows = 1), out[r, j] =
 * src[r, index[j]]; positions lo <= j < hi are the interior, where index[j] = j - shift (a
 * contiguous copy the compiler vectorises).  Along columns, row r = b*n + k of out is row
 * b*n + index[k] of src.  index < 0 means cval.  Work-item (s, r) writes segment s (seg
 * samples) of row r; with CHECK it also tests the src samples at its own positions, which the
 * copy has just brought into the cache: every sample of src is tested once, one read in all. */
__kernel void translate(__global const REAL *src, const long src_off, __global const int *index,
                        __global REAL *out, const long out_off, const REAL cval, const int n,
                        const int m, const int along_rows, const int seg, const int lo, const int hi,
                        const int shift, __global int *flag)
{
    const int j0 = (int)get_global_id(0) * seg;
    if (j0 >= m)
        return;
    const int j1 = min(j0 + seg, m);
    const long r = (long)get_global_id(1);
    __global const REAL *line = src + src_off + r * m;
    __global REAL *o = out + out_off + r * m;
    if (along_rows) {
        const int a = max(j0, lo), z = max(a, min(j1, hi));
        for (int j = j0; j < min(j1, a); ++j) {
            const int i = index[j];
            o[j] = i >= 0 ? line[i] : cval;
        }
        for (int j = a; j < z; ++j)
            o[j] = line[j - shift];
        for (int j = z; j < j1; ++j) {
            const int i = index[j];
            o[j] = i >= 0 ? line[i] : cval;
        }
    } else {
        const int k = (int)(r % n);
        const int i = index[k];
        if (i >= 0) {
            __global const REAL *from = src + src_off + (r - k + i) * m;
            for (int j = j0; j < j1; ++j)
                o[j] = from[j];
        } else {
            for (int j = j0; j < j1; ++j)
                o[j] = cval;
        }
    }
#if CHECK
    int bad = 0;
    for (int j = j0; j < j1; ++j)
        bad |= NONFINITE(line[j]);
    if (bad)
        atomic_or(flag, 1);
#endif
}
