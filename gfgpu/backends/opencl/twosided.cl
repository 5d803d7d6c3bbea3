/*
 * Two-sided steps on a CPU device (spec: gfgpu/_core/twosided.py, run_two_sided_reference).  Up to
 * two inputs X_i and two outputs Y_o along the columns of (B, N, M) arrays, output o reading IN(o):
 *     Y_o[k] = tap_o X[k] + sum_s Re(causal[o,s] F_s[k]) + sum_s Re(anticausal[o,s] G_s[k])
 * F_s, G_s: the unit states (F <- lam F + x) before sample k, forward and backward, started from the
 * boundary mode's initial state (omega, omega_c).  A work-item runs a band of columns down (the
 * causal part written) and up (read back from the cache, the anticausal part added).
 * Defines: REAL, LANES (a cache line per vector), SECTIONS (poles per input), NIN, NOUT (1 or 2),
 * REAL_POLES (real poles and weights: real states), BAND (most vectors per work-item), CHECK (OR
 * flag with 1 if a sample of input 0 is NaN, infinite or beyond the range limit).  coef, omega:
 * TwoSidedPlan.packed.  No overlaps between arrays.  No fast-math (contraction to fma allowed).
 */
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#define INLINE static inline __attribute__((always_inline))
#define IMIN(a, b) ((a) < (b) ? (a) : (b))
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

typedef CAT(REAL, LANES) VT;      /* LANES 2, 4, 8 or 16 */
typedef REAL VTU __attribute__((ext_vector_type(LANES), aligned(sizeof(REAL))));
#define VLOAD(p) ((VT)(*(__global const VTU *)(p)))
#define VSTORE(v, p) (*(__global VTU *)(p) = (VTU)(v))
#define LANE(v, l) ((v)[l])

#if NIN == 2
#define IN(o) (o)
#else
#define IN(o) 0
#endif
#define NS (NIN * SECTIONS)

/* the finite and range check of recurse.cl: x * 2^(emax/2) - itself is 0 exactly for a sample in
 * range, NaN otherwise (inf - inf); the residues are summed per lane as the sweep reads (a NaN
 * survives the sum) and the lanes once at the end */
#define RANGE_SCALE (sizeof(REAL) == 8 ? (REAL)0x1p512 : (REAL)0x1p64f)
#define RESIDUE(x) ((x) * RANGE_SCALE - (x) * RANGE_SCALE)
INLINE int lanes_nonzero(const VT z)
{
    REAL t = 0;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        t += LANE(z, l);
    return t != (REAL)0;
}

/* non-temporal store of a final output vector (aligned `p` only), else a plain one */
#if defined(__clang__)
#define STORE_NT(v, p) __builtin_nontemporal_store((v), (__global VT *)(p))
#else
#define STORE_NT(v, p) VSTORE((v), (p))
#endif
#if defined(__clang__) && defined(__x86_64__)
#define STREAM_FENCE() __builtin_ia32_sfence()
#else
#define STREAM_FENCE() do { } while (0)
#endif

typedef struct {
    REAL lr[NS], li[NS];
    REAL cr[NOUT * SECTIONS], ci[NOUT * SECTIONS], ar[NOUT * SECTIONS], ai[NOUT * SECTIONS];
    REAL tap[NOUT];
    REAL ocr[NIN * 2 * SECTIONS], oci[NIN * 2 * SECTIONS];
} plan_t;

INLINE void load_plan(plan_t *p, __global const REAL *c)
{
#pragma unroll
    for (int q = 0; q < NS; ++q) {
        p->lr[q] = c[2 * q];
        p->li[q] = c[2 * q + 1];
    }
    c += 2 * NS;
#pragma unroll
    for (int q = 0; q < NOUT * SECTIONS; ++q) {
        p->cr[q] = c[2 * q];
        p->ci[q] = c[2 * q + 1];
        p->ar[q] = c[2 * NOUT * SECTIONS + 2 * q];
        p->ai[q] = c[2 * NOUT * SECTIONS + 2 * q + 1];
    }
    c += 4 * NOUT * SECTIONS;
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        p->tap[o] = c[o];
    c += NOUT;
#pragma unroll
    for (int q = 0; q < NIN * 2 * SECTIONS; ++q) {
        p->ocr[q] = c[2 * q];
        p->oci[q] = c[2 * q + 1];
    }
}

/* states fr, fi: state (i, s) of vector v at (i * SECTIONS + s) * W + v */
/* y = sum_s Re(w[o, s] F_(IN(o), s)) for output o, vector v (anti: the anticausal weights) */
INLINE VT readout(const plan_t *p, const VT *fr, const VT *fi, const int o, const int anti,
                  const int v, const int W)
{
    VT y = (VT)(0);
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const int q = (IN(o) * SECTIONS + s) * W + v;
        const REAL wr = anti ? p->ar[o * SECTIONS + s] : p->cr[o * SECTIONS + s];
#if REAL_POLES
        y += wr * fr[q];
#else
        const REAL wi = anti ? p->ai[o * SECTIONS + s] : p->ci[o * SECTIONS + s];
        y += wr * fr[q] - wi * fi[q];
#endif
    }
    return y;
}

/* F <- lam F + x for the sections of input i, vector v */
INLINE void advance(const plan_t *p, VT *fr, VT *fi, const int i, const VT x, const int v, const int W)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const int q = (i * SECTIONS + s) * W + v;
        const int c = i * SECTIONS + s;
#if REAL_POLES
        fr[q] = p->lr[c] * fr[q] + x;
#else
        const VT r = p->lr[c] * fr[q] - p->li[c] * fi[q] + x;
        fi[q] = p->lr[c] * fi[q] + p->li[c] * fr[q];
        fr[q] = r;
#endif
    }
}

/* F_(i, s) += omega[i, d, s, j] x (vector v) */
INLINE void add_initial(VT *fr, VT *fi, __global const REAL *omega, const int L, const int i,
                        const int d, const int j, const VT x, const int v, const int W)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const int q = (i * SECTIONS + s) * W + v;
        const size_t o = 2 * ((((size_t)i * 2 + d) * SECTIONS + s) * L + j);
        fr[q] += omega[o] * x;
#if !REAL_POLES
        fi[q] += omega[o + 1] * x;
#endif
    }
}

/* F_(i, s) = omega_c[i, d, s] cval_i for every input (vector v) */
INLINE void start_states(const plan_t *p, VT *fr, VT *fi, const int d, const REAL cval0,
                         const REAL cval1, const int v, const int W)
{
#pragma unroll
    for (int i = 0; i < NIN; ++i) {
        const REAL cv = i == 0 ? cval0 : cval1;
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            const int q = (i * SECTIONS + s) * W + v;
            fr[q] = (VT)(p->ocr[(i * 2 + d) * SECTIONS + s] * cv);
            fi[q] = (VT)(p->oci[(i * 2 + d) * SECTIONS + s] * cv);
        }
    }
}

/* ---- columns: a band of nv vectors of LANES adjacent columns, N rows ------------------------ */
#ifndef BAND
#define BAND 1
#endif

INLINE VT load_cols(__global const REAL *p, const int valid)
{
    if (valid == LANES)
        return VLOAD(p);
    VT v;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        LANE(v, l) = p[IMIN(l, valid - 1)];
    return v;
}

INLINE void store_cols(__global REAL *p, const VT y, const int valid, const int nt)
{
    if (valid == LANES) {
        if (nt)
            STORE_NT(y, p);
        else
            VSTORE(y, p);
        return;
    }
    for (int l = 0; l < valid; ++l)
        p[l] = LANE(y, l);
}

/* one row of the band: forward (d = 0, outputs written) or backward (d = 1, added to them) */
INLINE void column_step(const plan_t *p, VT *fr, VT *fi, __global const REAL *const *src,
                        __global REAL *const *dst, const long row, const int vecs, const int last,
                        const int d, const int nt, VT *chk)
{
#pragma unroll
    for (int v = 0; v < BAND; ++v) {
        if (v < vecs) {
            const int valid = v == vecs - 1 ? last : LANES;
            VT x[NIN];
#pragma unroll
            for (int i = 0; i < NIN; ++i)
                x[i] = load_cols(src[i] + row + v * LANES, valid);
#if CHECK
            if (!d)
                *chk += RESIDUE(x[0]);
#endif
#pragma unroll
            for (int o = 0; o < NOUT; ++o) {
                __global REAL *q = dst[o] + row + v * LANES;
                if (d)
                    store_cols(q, load_cols(q, valid) + readout(p, fr, fi, o, 1, v, BAND), valid, nt);
                else
                    store_cols(q, p->tap[o] * x[IN(o)] + readout(p, fr, fi, o, 0, v, BAND), valid, 0);
            }
#pragma unroll
            for (int i = 0; i < NIN; ++i)
                advance(p, fr, fi, i, x[i], v, BAND);
        }
    }
}

INLINE void initial_cols(const plan_t *p, VT *fr, VT *fi, __global const REAL *const *src,
                         __global const REAL *omega, const int L, const int d, const int N,
                         const int M, const int vecs, const int last, const REAL cval0, const REAL cval1)
{
#pragma unroll
    for (int v = 0; v < BAND; ++v)
        start_states(p, fr, fi, d, cval0, cval1, v, BAND);
    for (int j = 0; j < L; ++j) {
        const long row = (long)(d ? N - 1 - j : j) * M;
#pragma unroll
        for (int v = 0; v < BAND; ++v) {
            if (v < vecs) {
                const int valid = v == vecs - 1 ? last : LANES;
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    add_initial(fr, fi, omega, L, i, d, j, load_cols(src[i] + row + v * LANES, valid), v, BAND);
            }
        }
    }
}

__kernel void two_sided(__global const REAL *src0, __global const REAL *src1, __global REAL *dst0,
                        __global REAL *dst1, const long src0_off, const long src1_off,
                        const long dst0_off, const long dst1_off, __global const REAL *coef,
                        __global const REAL *omega, const int L, const REAL cval0, const REAL cval1,
                        const int B, const int N, const int M, const int nv, const int stream,
                        __global int *flag)
{
    const int m0 = (int)get_global_id(0) * nv * LANES;
    const int b = (int)get_global_id(1);
    if (m0 >= M || b >= B)
        return;
    const int cols = IMIN(nv * LANES, M - m0);
    const int vecs = (cols + LANES - 1) / LANES;
    const int last = cols - (vecs - 1) * LANES;
    const long base = (long)b * N * M + m0;
    __global const REAL *src[2] = {src0 + src0_off + base, src1 + src1_off + base};
    __global REAL *dst[2] = {dst0 + dst0_off + base, dst1 + dst1_off + base};
    plan_t p;
    load_plan(&p, coef);
    VT fr[NS * BAND], fi[NS * BAND];
    VT chk = (VT)(0);
    initial_cols(&p, fr, fi, src, omega, L, 0, N, M, vecs, last, cval0, cval1);
    for (int k = 0; k < N; ++k)
        column_step(&p, fr, fi, src, dst, (long)k * M, vecs, last, 0, 0, &chk);
    initial_cols(&p, fr, fi, src, omega, L, 1, N, M, vecs, last, cval0, cval1);
    /* non-temporal final stores: whole aligned vectors */
    int nt = stream && M % LANES == 0;
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        nt = nt && ((ulong)dst[o] % sizeof(VT)) == 0;
    for (int k = N - 1; k >= 0; --k)
        column_step(&p, fr, fi, src, dst, (long)k * M, vecs, last, 1, nt, &chk);
    if (nt)
        STREAM_FENCE();
#if CHECK
    if (lanes_nonzero(chk))
        atomic_or(flag, 1);
#else
    (void)chk;
#endif
}
