/*
 * Two-sided steps on a CPU device (spec: gfgpu/_core/twosided.py, run_two_sided_reference).  Up to
 * two inputs X_i and two outputs Y_o along the lines of (B, N, M) arrays, output o reading IN(o):
 *     Y_o[k] = tap_o X[k] + sum_s Re(causal[o,s] F_s[k]) + sum_s Re(anticausal[o,s] G_s[k])
 * F_s, G_s: the unit states (F <- lam F + x) before sample k, forward and backward, started from the
 * boundary mode's initial state (omega, omega_c).  A work-item's backward sweep stores the
 * anticausal parts of its lines in its scratch, its forward sweep writes each output once: lines
 * along columns (two_sided) or, with ROWS=1, along rows (two_sided_rows).  Work-items take the next
 * lines from the counter flag[1] (zero at launch).
 * Defines: REAL, LANES (columns: a cache line per vector; rows: a 256-bit vector), SECTIONS (poles
 * per input), NIN, NOUT (1 or 2), REAL_POLES (real poles and weights: real states), BAND, AHEAD
 * (columns), ROWS, CHECK (OR flag[0] with 1 if a sample of input 0 is NaN, infinite or beyond the
 * range limit).  coef, omega: TwoSidedPlan.packed.  No overlaps between arrays.  No fast-math
 * (contraction to fma allowed; the recursions and readouts are explicit fma chains).
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

/* states fr, fi: state (i, s) of vector v at (i * SECTIONS + s) * W + v.  The sums are written as
 * explicit fma chains: contraction alone left a multiply, an fma and an add per complex term (the
 * row kernel is bound by its floating-point operations: 4096^2 float32, A/B in one process, the
 * chains ran its steps in 0.87-0.9x the CPU time; the column kernel, bound by memory, alike) */
/* init + sum_s Re(w[o, s] F_(IN(o), s)) for output o, vector v (anti: the anticausal weights) */
INLINE VT readout(const plan_t *p, const VT *fr, const VT *fi, const int o, const int anti,
                  const int v, const int W, VT y)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const int q = (IN(o) * SECTIONS + s) * W + v;
        const REAL wr = anti ? p->ar[o * SECTIONS + s] : p->cr[o * SECTIONS + s];
        y = fma((VT)(wr), fr[q], y);
#if !REAL_POLES
        const REAL wi = anti ? p->ai[o * SECTIONS + s] : p->ci[o * SECTIONS + s];
        y = fma((VT)(-wi), fi[q], y);
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
        fr[q] = fma((VT)(p->lr[c]), fr[q], x);
#else
        const VT r = fma((VT)(p->lr[c]), fr[q], fma((VT)(-p->li[c]), fi[q], x));
        fi[q] = fma((VT)(p->lr[c]), fi[q], p->li[c] * fr[q]);
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

#ifndef ROWS
#define ROWS 0
#endif
#if !ROWS
/* ---- columns: bands of BAND vectors of LANES adjacent columns (a cache line each), N rows -------
 * A work-item takes the next band of the next image from the counter flag[1] until none is left (a
 * core slowed by other work takes fewer).  Its backward sweep reads the band from memory (rows
 * AHEAD steps ahead are prefetched: no hardware prefetcher follows a few cache lines a row, a row
 * apart), with the check, and keeps the band's anticausal parts in the work-item's scratch (N x
 * BAND x NOUT vectors, reused by its next band: in the caches); the forward sweep reads the band
 * again from the caches and writes each output once as (tap_o X[k] + causal) + anticausal, the
 * causal readout chained onto tap_o X[k] (the blocked kernel it replaced, a backward sweep storing
 * states every 32 rows, then blocks restarting it, ran a third sweep: 1.3-1.7x this one's CPU time
 * at 4096^2 float32). */
#ifndef BAND
#define BAND 1
#endif
#ifndef AHEAD
#define AHEAD 8
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
#if defined(__clang__)
#define PREFETCH(p) __builtin_prefetch((p), 0, 3)
#else
#define PREFETCH(p) do { } while (0)
#endif

__kernel void two_sided(__global const REAL *src0, __global const REAL *src1, __global REAL *dst0,
                        __global REAL *dst1, const long src0_off, const long src1_off,
                        const long dst0_off, const long dst1_off, __global const REAL *coef,
                        __global const REAL *omega, const int L, const REAL cval0, const REAL cval1,
                        const int B, const int N, const int M, const int stream, __global VT *scratch,
                        __global int *flag)
{
    plan_t p;
    load_plan(&p, coef);
    __global VT *anti = scratch + (long)get_global_id(0) * N * BAND * NOUT;
    const int bands = (M + BAND * LANES - 1) / (BAND * LANES);
    VT fr[NS * BAND], fi[NS * BAND], chk = (VT)(0);
    for (long g = atomic_inc(flag + 1); g < (long)B * bands; g = atomic_inc(flag + 1)) {
        const int b = (int)(g / bands), m0 = (int)(g % bands) * BAND * LANES;
        const int cols = IMIN(BAND * LANES, M - m0), vecs = (cols + LANES - 1) / LANES;
        const int last = cols - (vecs - 1) * LANES;
        const long base = (long)b * N * M + m0;
        __global const REAL *src[2] = {src0 + src0_off + base, src1 + src1_off + base};
        __global REAL *dst[2] = {dst0 + dst0_off + base, dst1 + dst1_off + base};
        int nt = stream && M % LANES == 0;
#pragma unroll
        for (int o = 0; o < NOUT; ++o)
            nt = nt && ((ulong)dst[o] % sizeof(VT)) == 0;
        initial_cols(&p, fr, fi, src, omega, L, 1, N, M, vecs, last, cval0, cval1);
        for (int k = N - 1; k >= 0; --k) {
            const long row = (long)k * M;
            __global VT *a = anti + (long)k * BAND * NOUT;
            BAND_LOOP(v) {
                if (k >= AHEAD)
#pragma unroll
                    for (int i = 0; i < NIN; ++i)
                        PREFETCH(src[i] + row - AHEAD * (long)M + v * LANES);
#pragma unroll
                for (int o = 0; o < NOUT; ++o)
                    a[v * NOUT + o] = readout(&p, fr, fi, o, 1, v, BAND, (VT)(0));
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
        initial_cols(&p, fr, fi, src, omega, L, 0, N, M, vecs, last, cval0, cval1);
        for (int k = 0; k < N; ++k) {
            const long row = (long)k * M;
            __global const VT *a = anti + (long)k * BAND * NOUT;
            BAND_LOOP(v) {
                VT x[NIN];
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    x[i] = load_cols(src[i] + row + v * LANES, VALID(v));
#pragma unroll
                for (int o = 0; o < NOUT; ++o)
                    store_cols(dst[o] + row + v * LANES,
                               readout(&p, fr, fi, o, 0, v, BAND, p.tap[o] * x[IN(o)]) + a[v * NOUT + o],
                               VALID(v), nt);
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    advance(&p, fr, fi, i, x[i], v, BAND);
            }
        }
    }
    if (stream)
        STREAM_FENCE();
#if CHECK
    if (lanes_nonzero(chk))
        atomic_or(flag, 1);
#endif
}
#endif

/* ---- rows (ROWS=1): LANES rows per work-item (a 256-bit vector: 8 float, 4 double), M samples --
 * A work-item takes the next LANES rows from the counter flag[1] until none is left.  Backward:
 * tiles of LANES x LANES samples loaded and transposed in registers (a vector a step: a sample of
 * every row), the check on the way, the anticausal readouts and the transposed samples stored to
 * the work-item's scratch (M x (NOUT + NIN) vectors, time major, reused: in the cache; 4096 float32
 * rows: 256 KiB); forward: from the scratch (re-reading and transposing the rows instead took 1.5x
 * the CPU time), each output = (tap X + causal) + anticausal as the column kernel sums it,
 * transposed back and written once: with `stream`, a row's whole cache line at a time by
 * non-temporal stores (no read for ownership; 4096^2 float32, A/B in one process: 0.92-0.98x the CPU
 * time of plain stores with one output, 0.75-0.78x with two; streamed 32 bytes of 8 rows at a time
 * instead ran 1.3-1.7x slower).  More vectors of rows side by side per work-item (2: independent
 * chains) ran no faster, 4 spilled (1.5x).  The interior runs in chunks of a cache line of every
 * row (CH steps), aligned to dst0 where every row shares its alignment (M a multiple of CH); the
 * ends go sample by sample. */
#if ROWS
#define TILE_LANES LANES
#define TILE_VT VT
#include "tile.cl"
#define CH (64 / (int)sizeof(REAL))
#define ROW(x, l) ((x) + (long)IMIN((l), valid - 1) * M)
#define SS (NOUT + NIN)     /* scratch vectors a step: the anticausal parts, then the samples */

/* x[i]: the samples at position k of the rows of input i (gathered: the lines' ends) */
INLINE void gather_step(VT *x, __global const REAL *const *src, const int valid, const long M, const int k)
{
#pragma unroll
    for (int i = 0; i < NIN; ++i)
#pragma unroll
        for (int l = 0; l < LANES; ++l)
            x[i][l] = ROW(src[i], l)[k];
}

/* t[i * CH + j]: positions c0 + j of the rows of input i, a chunk of whole tiles */
INLINE void load_chunk(VT *t, __global const REAL *const *src, const int valid, const long M, const int c0)
{
#pragma unroll
    for (int i = 0; i < NIN; ++i)
#pragma unroll
        for (int h = 0; h < CH; h += LANES) {
#pragma unroll
            for (int l = 0; l < LANES; ++l)
                t[i * CH + h + l] = VLOAD(ROW(src[i], l) + c0 + h);
            rows_transpose(t + i * CH + h);
        }
}

INLINE void back_step(const plan_t *p, VT *fr, VT *fi, __global VT *a, const VT *x, VT *chk)
{
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        a[o] = readout(p, fr, fi, o, 1, 0, 1, (VT)(0));
#pragma unroll
    for (int i = 0; i < NIN; ++i)
        advance(p, fr, fi, i, x[i], 0, 1);
#pragma unroll
    for (int i = 0; i < NIN; ++i)
        a[NOUT + i] = x[i];
#if CHECK
    *chk += RESIDUE(x[0]);
#endif
}

/* y[o]: the outputs at a position whose anticausal parts are at a */
INLINE void fwd_step(const plan_t *p, VT *fr, VT *fi, __global const VT *a, const VT *x, VT *y)
{
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        y[o] = readout(p, fr, fi, o, 0, 0, 1, p->tap[o] * x[IN(o)]) + a[o];
#pragma unroll
    for (int i = 0; i < NIN; ++i)
        advance(p, fr, fi, i, x[i], 0, 1);
}

__kernel void two_sided_rows(__global const REAL *src0, __global const REAL *src1, __global REAL *dst0,
                             __global REAL *dst1, const long src0_off, const long src1_off,
                             const long dst0_off, const long dst1_off, __global const REAL *coef,
                             __global const REAL *omega, const int L, const REAL cval0, const REAL cval1,
                             const int B, const int N, const int M, const int stream, __global VT *scratch,
                             __global int *flag)
{
    plan_t p;
    load_plan(&p, coef);
    __global VT *anti = scratch + (long)get_global_id(0) * M * SS;
    const long rows = (long)B * N;
    /* the chunks: [lead, tail), CH-aligned in dst0 where every row shares the alignment */
    const int lead = M % CH ? 0 : IMIN(M, (int)((CH - ((ulong)(dst0 + dst0_off) / sizeof(REAL)) % CH) % CH));
    const int tail = lead + (M - lead) / CH * CH;
    VT chk = (VT)(0), fr[NS], fi[NS], x[NIN], y[NOUT], t[(NIN > NOUT ? NIN : NOUT) * CH];
    /* streamed chunks: a large output (`stream`) whose chunks start on a cache line in every output
     * and row */
    int aligned = stream && tail > lead && M % CH == 0;
#pragma unroll
    for (int o = 0; o < NOUT; ++o)
        aligned = aligned && ((ulong)((o ? dst1 + dst1_off : dst0 + dst0_off) + lead) % 64) == 0;
    for (long r0 = (long)atomic_inc(flag + 1) * LANES; r0 < rows; r0 = (long)atomic_inc(flag + 1) * LANES) {
        const int valid = (int)IMIN((long)LANES, rows - r0), nt = aligned && valid == LANES;
        __global const REAL *src[2] = {src0 + src0_off + r0 * M, src1 + src1_off + r0 * M};
        __global REAL *dst[2] = {dst0 + dst0_off + r0 * M, dst1 + dst1_off + r0 * M};
        for (int d = 1; d >= 0; --d) {      /* the initial states: backward, then forward */
            start_states(&p, fr, fi, d, cval0, cval1, 0, 1);
            for (int j = 0; j < L; ++j) {
                gather_step(x, src, valid, M, d ? M - 1 - j : j);
#pragma unroll
                for (int i = 0; i < NIN; ++i)
                    add_initial(fr, fi, omega, L, i, d, j, x[i], 0, 1);
            }
            if (!d)
                break;
            for (int k = M - 1; k >= 0; --k) {
                if (k == tail - 1 && tail > lead) {        /* the chunks, backward */
                    for (int c0 = tail - CH; c0 >= lead; c0 -= CH) {
                        load_chunk(t, src, valid, M, c0);
#pragma unroll
                        for (int j = CH - 1; j >= 0; --j) {
#pragma unroll
                            for (int i = 0; i < NIN; ++i)
                                x[i] = t[i * CH + j];
                            back_step(&p, fr, fi, anti + (long)(c0 + j) * SS, x, &chk);
                        }
                    }
                    k = lead;
                    continue;
                }
                gather_step(x, src, valid, M, k);
                back_step(&p, fr, fi, anti + (long)k * SS, x, &chk);
            }
        }
        for (int k = 0; k < M; ++k) {
            if (k == lead && tail > lead) {     /* the chunks, forward: outputs transposed back in t */
                for (int c0 = lead; c0 < tail; c0 += CH) {
#pragma unroll
                    for (int j = 0; j < CH; ++j) {
#pragma unroll
                        for (int i = 0; i < NIN; ++i)
                            x[i] = anti[(long)(c0 + j) * SS + NOUT + i];
                        fwd_step(&p, fr, fi, anti + (long)(c0 + j) * SS, x, y);
#pragma unroll
                        for (int o = 0; o < NOUT; ++o)
                            t[o * CH + j] = y[o];
                    }
#pragma unroll
                    for (int o = 0; o < NOUT; ++o) {
#pragma unroll
                        for (int h = 0; h < CH; h += LANES)
                            rows_transpose(t + o * CH + h);
                        if (nt)     /* a row's whole cache line at a time: one write-combining buffer */
#pragma unroll
                            for (int l = 0; l < LANES; ++l)
#pragma unroll
                                for (int h = 0; h < CH; h += LANES)
                                    STORE_NT(t[o * CH + h + l], dst[o] + (long)l * M + c0 + h);
                        else
                            for (int l = 0; l < valid; ++l)
#pragma unroll
                                for (int h = 0; h < CH; h += LANES)
                                    VSTORE(t[o * CH + h + l], dst[o] + (long)l * M + c0 + h);
                    }
                }
                k = tail;
                if (k >= M)
                    break;
            }
#pragma unroll
            for (int i = 0; i < NIN; ++i)
                x[i] = anti[(long)k * SS + NOUT + i];
            fwd_step(&p, fr, fi, anti + (long)k * SS, x, y);
#pragma unroll
            for (int o = 0; o < NOUT; ++o)
                for (int l = 0; l < valid; ++l)
                    dst[o][(long)l * M + k] = y[o][l];
        }
    }
    if (aligned)
        STREAM_FENCE();
#if CHECK
    if (lanes_nonzero(chk))
        atomic_or(flag, 1);
#endif
}
#endif
