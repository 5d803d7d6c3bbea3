/*
 * Two-sided steps on a CPU device (spec: gfgpu/_core/twosided.py, run_two_sided_reference).  Up to
 * two inputs X_i and two outputs Y_o along the columns of (B, N, M) arrays, output o reading IN(o):
 *     Y_o[k] = tap_o X[k] + sum_s Re(causal[o,s] F_s[k]) + sum_s Re(anticausal[o,s] G_s[k])
 * F_s, G_s: the unit states (F <- lam F + x) before sample k, forward and backward, started from the
 * boundary mode's initial state (omega, omega_c).  A work-item runs a band of columns, in two
 * phases so that each output is written once (one sweep down and up wrote it twice and read it
 * back from memory: a band of 4096 rows is beyond the caches): phases 0 and 1 below.
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

#define BAND_LOOP(v) _Pragma("unroll") for (int v = 0; v < BAND; ++v) if (v < vecs)
#define VALID(v) ((v) == vecs - 1 ? last : LANES)
/* the next block's rows are prefetched during a block's forward sweep (no hardware prefetcher
 * follows a few cache lines a row, a row apart) */
#if defined(__clang__)
#define PREFETCH(p) __builtin_prefetch((p), 0, 3)
#else
#define PREFETCH(p) do { } while (0)
#endif
/* vectors of a work-item's scratch in phase 1 */
#define SCRATCH_VECS(K) (NS * 2 * BAND + (K) * BAND * NOUT)
#define STATES_TO(t) _Pragma("unroll") for (int q = 0; q < NS * BAND; ++q) { t[2 * q] = fr[q]; t[2 * q + 1] = fi[q]; }
#define STATES_FROM(t) _Pragma("unroll") for (int q = 0; q < NS * BAND; ++q) { fr[q] = t[2 * q]; fi[q] = t[2 * q + 1]; }

/* carries: the backward states at the last row of each block, (B, NB, NS, 2 (re, im), M) */
#define CARRY(blk, q) (carry + (((long)b * NB + (blk)) * NS + (q)) * 2L * M + m0)

/* One work-item runs both phases on its band (phase 1 reads the band back from the cache).
 * Phase 0: the band's backward sweep, bottom to top, reading every input once (with the finite
 * check); the state before the last row of each block of K rows is stored as its carry, where
 * phase 1 restarts it (the same sweep: phase 1's states are bit for bit the same).
 * Phase 1: the band top to bottom, a block at a time: the block's backward sweep
 * from its carry (the inputs read into the nearer cache), its anticausal parts kept in this
 * work-item's scratch (reused by every block: it stays in the cache), then the forward sweep (the
 * inputs from the cache), each output written once as (tap_o X[k] + causal) + anticausal, the
 * order of the sum of the single sweep pair this replaced. */
__kernel void two_sided(__global const REAL *src0, __global const REAL *src1, __global REAL *dst0,
                        __global REAL *dst1, const long src0_off, const long src1_off,
                        const long dst0_off, const long dst1_off, __global const REAL *coef,
                        __global const REAL *omega, const int L, const REAL cval0, const REAL cval1,
                        const int B, const int N, const int M, const int nv, const int K,
                        const int stream, __global REAL *carry, __global VT *scratch,
                        __global int *flag)
{
    const int m0 = (int)get_global_id(0) * nv * LANES, b = (int)get_global_id(1);
    if (m0 >= M || b >= B)
        return;
    const int cols = IMIN(nv * LANES, M - m0), vecs = (cols + LANES - 1) / LANES;
    const int last = cols - (vecs - 1) * LANES, NB = (N + K - 1) / K;
    const long base = (long)b * N * M + m0;
    __global const REAL *src[2] = {src0 + src0_off + base, src1 + src1_off + base};
    __global REAL *dst[2] = {dst0 + dst0_off + base, dst1 + dst1_off + base};
    plan_t p;
    load_plan(&p, coef);
    VT fr[NS * BAND], fi[NS * BAND];
    {   /* phase 0 */
        VT chk = (VT)(0);
        initial_cols(&p, fr, fi, src, omega, L, 1, N, M, vecs, last, cval0, cval1);
        for (int k = N - 1; k >= 0; --k) {
            const long row = (long)k * M;
            if (k % K == K - 1 || k == N - 1) {
#pragma unroll
                for (int q = 0; q < NS; ++q) {
                    __global REAL *c = CARRY(k / K, q);
                    BAND_LOOP(v) {
                        store_cols(c + v * LANES, fr[q * BAND + v], VALID(v), 0);
#if !REAL_POLES
                        store_cols(c + M + v * LANES, fi[q * BAND + v], VALID(v), 0);
#endif
                    }
                }
            }
            BAND_LOOP(v) {
#pragma unroll
                for (int i = 0; i < NIN; ++i) {
                    const VT x = load_cols(src[i] + row + v * LANES, VALID(v));
#if CHECK
                    if (i == 0)
                        chk += RESIDUE(x);
#endif
                    advance(&p, fr, fi, i, x, v, BAND);
                }
            }
        }
#if CHECK
        if (lanes_nonzero(chk))
            atomic_or(flag, 1);
#endif
    }
    /* the scratch: the forward states between blocks (NS * 2 * BAND vectors), then the block's
     * anticausal parts (K * BAND * NOUT); one set of states in registers, the backward ones then
     * the forward ones (two sets spill more than the forward ones' wait in the scratch) */
    __global VT *fsave = scratch + ((long)b * get_global_size(0) + get_global_id(0)) * SCRATCH_VECS(K);
    __global VT *anti = fsave + NS * 2 * BAND;
    initial_cols(&p, fr, fi, src, omega, L, 0, N, M, vecs, last, cval0, cval1);
    STATES_TO(fsave)
    /* non-temporal stores: whole aligned vectors */
    int nt = stream && M % LANES == 0;
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        nt = nt && ((ulong)dst[o] % sizeof(VT)) == 0;
    for (int blk = 0; blk < NB; ++blk) {
        const int k0 = blk * K, k1 = IMIN(N, k0 + K);
#pragma unroll
        for (int q = 0; q < NS; ++q) {
            __global const REAL *c = CARRY(blk, q);
            BAND_LOOP(v) {
                fr[q * BAND + v] = load_cols(c + v * LANES, VALID(v));
#if !REAL_POLES
                fi[q * BAND + v] = load_cols(c + M + v * LANES, VALID(v));
#endif
            }
        }
        for (int k = k1 - 1; k >= k0; --k) {
            __global VT *a = anti + (long)(k - k0) * BAND * NOUT;
            BAND_LOOP(v) {
#pragma unroll
                for (int o = 0; o < NOUT; ++o)
                    a[v * NOUT + o] = readout(&p, fr, fi, o, 1, v, BAND);
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    advance(&p, fr, fi, i, load_cols(src[i] + (long)k * M + v * LANES, VALID(v)), v, BAND);
            }
        }
        STATES_FROM(fsave)
        for (int k = k0; k < k1; ++k) {
            const long row = (long)k * M;
            __global const VT *a = anti + (long)(k - k0) * BAND * NOUT;
            BAND_LOOP(v) {
                VT x[NIN];
#pragma unroll
                for (int i = 0; i < NIN; ++i) {
                    if (2 * k1 - 1 - k < N)    /* the next block's rows, bottom first */
                        PREFETCH(src[i] + (long)(2 * k1 - 1 - k) * M + v * LANES);
                    x[i] = load_cols(src[i] + row + v * LANES, VALID(v));
                }
#pragma unroll
                for (int o = 0; o < NOUT; ++o)
                    store_cols(dst[o] + row + v * LANES,
                               (p.tap[o] * x[IN(o)] + readout(&p, fr, fi, o, 0, v, BAND)) + a[v * NOUT + o],
                               VALID(v), nt);
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    advance(&p, fr, fi, i, x[i], v, BAND);
            }
        }
        STATES_TO(fsave)
    }
    if (nt)
        STREAM_FENCE();
}
