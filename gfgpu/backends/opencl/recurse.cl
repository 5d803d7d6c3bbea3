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
 *   BAND           columns: most vectors of adjacent columns per work-item (CPU 64, GPU 1)
 *   STREAM         1: columns may use non-temporal stores (CPU devices; chosen per call by `stream`)
 *   PHASE          0: whole lines; 1 and 2: the two passes of block-parallel lines (below)
 *   CHECK          1: OR `flag` with 1 if a sample read is NaN or infinite (the finite check)
 *   WINDOW         1: the line is read through a window index (an integer translation with the
 *                  boundary mode's extension, fused into the pass): the recursion runs over the
 *                  n window positions, position w reads sample window[w] (cval if negative) and
 *                  is output sample w - first, written when it lies on the line
 *
 * Columns: a work-item runs LANES adjacent columns; one step is one vector load/store of
 * LANES contiguous samples (a full cache line for LANES = 64 bytes / sizeof(REAL)).
 * Rows: a work-item runs LANES rows; LANES steps at a time it loads a LANES x LANES tile
 * (one vector per row), transposes it in registers so that each vector holds one sample of
 * every row, steps with vector arithmetic, transposes the outputs back and stores them (the host
 * gives rows one 256-bit register of lanes: 8 float, 4 double).
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

/* ---- lane vectors ------------------------------------------------------------------
 * PoCL 3.0 (pocl-binary-distribution) calls its builtins out of line: vloadn, vstoren, min, max
 * and any are function calls in the compiled kernel, which in a per-sample loop cost more than
 * the arithmetic.  The hot paths therefore use plain vector accesses through a type of the
 * element's alignment (VTU: unaligned loads and stores, one instruction each), vector subscripts
 * for lanes, and IMIN / IMAX below. */
#define INLINE static inline __attribute__((always_inline))
#define IMIN(a, b) ((a) < (b) ? (a) : (b))
#define IMAX(a, b) ((a) > (b) ? (a) : (b))
#if LANES == 1
typedef REAL VT;
#define VLOAD(p) (*(p))
#define VSTORE(v, p) (*(p) = (v))
#elif LANES == 2 || LANES == 4 || LANES == 8 || LANES == 16
typedef CAT(REAL, LANES) VT;
typedef REAL VTU __attribute__((ext_vector_type(LANES), aligned(sizeof(REAL))));
#define VLOAD(p) ((VT)(*(__global const VTU *)(p)))
#define VSTORE(v, p) (*(__global VTU *)(p) = (VTU)(v))
#else
#error "LANES must be 1, 2, 4, 8 or 16"
#endif

/* lane l of vector v (a subscript: no memory round trip) */
#if LANES == 1
#define LANE(v, l) (v)
#else
#define LANE(v, l) ((v)[l])
#endif

/* the in-place register transpose of a LANES x LANES tile (transpose_tile) */
#define TILE_LANES LANES
#define TILE_VT VT
#include "tile.cl"

/* ---- the recursion ------------------------------------------------------------------ */
typedef struct {
    REAL lr[SECTIONS], li[SECTIONS], kr[SECTIONS], ki[SECTIONS];
} coef_t;

INLINE void load_coef(coef_t *c, __global const REAL *lam, __global const REAL *kap,
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

/* One section's step F <- lam F + kap v (F = fr + i fi); returns nothing, updates in place. */
#define ADVANCE(fr, fi, c, s, v) do { \
        const VT r_ = (c).lr[s] * (fr) - (c).li[s] * (fi) + (c).kr[s] * (v); \
        (fi) = (c).lr[s] * (fi) + (c).li[s] * (fr) + (c).ki[s] * (v); \
        (fr) = r_; } while (0)

/* The input check: a sample is refused if it is NaN, infinite or at least the range limit
 * sqrt(REAL_MAX) (2^64 float, 2^512 double; gfgpu._core.magnitude: the host then settles the
 * verdict, and scales an image beyond the limit).  z = x * 2^(emax/2) is exact (a power of two)
 * and infinite exactly then, so z - z is +0 for a sample in range and NaN otherwise (IEEE
 * arithmetic: the programs are built without fast-math; a contracted fma(x, R, -z) is 0 too);
 * unlike isfinite() it vectorises on CPU devices */
#define RANGE_SCALE (sizeof(REAL) == 8 ? (REAL)0x1p512 : (REAL)0x1p64f)
#define RESIDUE(x) (((x) * RANGE_SCALE) - ((x) * RANGE_SCALE))
#define NONFINITE(x) (RESIDUE(x) != (REAL)0)
/* The fused check: a work-item sums the residues of its samples (a NaN or an infinity never
 * cancels: inf - inf is NaN) and tests the lanes once at its end; a 16-lane reduction per step
 * made a checked pass ~40 % slower than an unchecked one */
#if LANES == 1
#define RESIDUE_BAD(acc) ((acc) != (REAL)0)
#else
#define RESIDUE_BAD(acc) lanes_nonfinite(acc)
INLINE int lanes_nonfinite(const VT z)   /* summed, no any(): a call in PoCL */
{
    REAL t = 0;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        t += LANE(z, l);
    return t != (REAL)0;
}
#endif

/* A store of one vector of LANES samples: non-temporal (past the caches, no read for ownership)
 * where the host asked for it (CPU devices, arrays larger than the caches) and `p` is aligned to
 * the vector, else a plain store.  Every output sample is written once, so nothing is lost by
 * bypassing the caches on images that do not fit them. */
#if STREAM && LANES > 1
#define STORE_V(v, p, nt) do { if (nt) __builtin_nontemporal_store((v), (__global VT *)(p)); \
                               else VSTORE((v), (p)); } while (0)
#if defined(__x86_64__)
#define STREAM_FENCE(nt) do { if (nt) __builtin_ia32_sfence(); } while (0)
#else
#define STREAM_FENCE(nt) do { } while (0)
#endif
#else
#define STORE_V(v, p, nt) VSTORE((v), (p))
#define STREAM_FENCE(nt) do { } while (0)
#endif

/* Block-parallel lines (PHASE 1 and 2; PHASE 0 runs whole lines).  A line of n steps is cut into
 * blocks of `block` steps.  PHASE 1 runs each block from a zero state and writes its end state to
 * `carry`, and its part of the initial state (the omega terms of its own samples) to `partial`;
 * the kernel `compose` turns them into each block's true start state, in place in `carry`;
 * PHASE 2 runs each block again from that state and writes the outputs.  The carries of a (B, nb)
 * grid of blocks are stored [outer][block][section][re, im][inner]: inner = the line's position
 * across lines (column m, or row r for rows), so LANES adjacent lines are one vector. */
#ifndef PHASE
#define PHASE 0
#endif
#ifndef TERMS_ONLY
#define TERMS_ONLY 0    /* PHASE 1 (rows): write the blocks' omega terms to `partial`, nothing else */
#endif

INLINE size_t carry_index(const int outer, const int blk, const int nblocks, const int s,
                                 const int part, const long inner, const long count)
{
    return ((((size_t)outer * nblocks + blk) * SECTIONS + s) * 2 + part) * count + inner;
}

/* LANES values of carry at p (valid of them real lanes; the rest repeat the last) */
INLINE VT load_lanes(__global const REAL *p, const int valid)
{
    if (valid == LANES)
        return VLOAD(p);
    VT v;
#pragma unroll
    for (int l = 0; l < LANES; ++l)
        LANE(v, l) = p[IMIN(l, valid - 1)];
    return v;
}

INLINE void store_lanes(__global REAL *p, const VT v, const int valid)
{
    if (valid == LANES) {
        VSTORE(v, p);
        return;
    }
    for (int l = 0; l < valid; ++l)
        p[l] = LANE(v, l);
}

#if !ROWS
/* ---- columns: a band of nv vectors of LANES adjacent lines, stride M ------------------------
 * A CPU work-item runs a band of up to BAND vectors (BAND * LANES adjacent columns) down the image:
 * each step reads and writes nv whole cache lines of one row, contiguous, with the band's state in
 * private memory (the L1 cache).  A band of 1,024 float32 columns is 4 KiB of a row, and
 * the hardware prefetchers stop at a page's end: the next row's loads missed in every cache (80 %
 * of a 4096^2 pass's samples sat on them), so the band's lines are prefetched PREFETCH_ROWS steps
 * ahead.  A GPU work-item runs one column (LANES = BAND = 1): adjacent work-items touch adjacent
 * addresses (coalesced). */
#ifndef BAND
#define BAND 1
#endif
#if BAND > 1 && defined(__x86_64__)
#ifndef PREFETCH_ROWS
#define PREFETCH_ROWS 4
#endif
#define PREFETCH(p) __builtin_prefetch((p), 0, 3)
#else
#undef PREFETCH_ROWS
#define PREFETCH_ROWS 0
#endif

/* The LANES samples at p; a partial vector (valid < LANES, the last columns of a row) loads
 * lane l from column IMIN(l, valid - 1) so the extra lanes stay finite and in bounds. */
INLINE VT load_cols(__global const REAL *p, const int valid)
{
    return load_lanes(p, valid);
}

INLINE void store_cols(__global REAL *p, const VT y, const int valid, const int accumulate,
                              const int nt)
{
    if (valid == LANES) {
        if (accumulate)
            VSTORE(VLOAD(p) + y, p);
        else
            STORE_V(y, p, nt);
        return;
    }
    for (int l = 0; l < valid; ++l)
        p[l] = accumulate ? p[l] + LANE(y, l) : LANE(y, l);
}

/* STAGED (CPU bands, STREAM): a row's cols outputs at y (private) stored to q: the cache lines
 * wholly inside [q, q + cols) non-temporally, the partial lines at the two ends (shared with the
 * neighbouring bands) sample by sample.  q is aligned to a sample, not to a vector. */
#if STREAM && LANES > 1 && BAND > 1
#define STAGED 1
typedef REAL VTP __attribute__((ext_vector_type(LANES), aligned(sizeof(REAL))));
INLINE void store_row_nt(__global REAL *q, const REAL *y, const int cols)
{
    const int head = IMIN(cols, (int)((LANES - ((ulong)q / sizeof(REAL)) % LANES) % LANES));
    int i = 0;
    for (; i < head; ++i)
        q[i] = y[i];
    for (; i + LANES <= cols; i += LANES)
        __builtin_nontemporal_store((VT)(*(const VTP *)(y + i)), (__global VT *)(q + i));
    for (; i < cols; ++i)
        q[i] = y[i];
}
#else
#define STAGED 0
#endif

/* Work-item (g, b, blk): columns m0 = g * nv * LANES .. of image b, steps of block blk (PHASE 1/2)
 * or of the whole line (PHASE 0). */
__kernel void recurse(__global const REAL *src, __global REAL *dst, const long src_off,
                      const long dst_off, __global const REAL *lam, __global const REAL *kap,
                      __global const REAL *omega, __global const REAL *omega_c, const int L,
                      const int n, const REAL cval, const REAL tap, const int reverse,
                      const int accumulate, const int B, const int N, const int M, const int nv,
                      const int stream, __global int *flag, const int block, const int nblocks,
                      __global REAL *carry, __global REAL *partial, __global const int *window,
                      const int first)
{
    /* bands start where dst's rows are vector-aligned: a numpy output= starts 16 bytes into a
     * cache line, and its misaligned vectors took the staged stores (4096^2 float32 column pass
     * into output= ~20 % more CPU); band 0 is `mis` columns narrower, the last band takes the
     * `mis` columns left (one vector more: only where nv < BAND) */
    const int width = nv * LANES;
    const int g = (int)get_global_id(0);
#if LANES > 1
    const int mis = (M % LANES || nv >= BAND) ? 0 : (int)(((ulong)(dst + dst_off) / sizeof(REAL)) % LANES);
#else
    const int mis = 0;
#endif
    const int m0 = IMAX(0, g * width - mis);
    int m_end = IMIN(M, (g + 1) * width - mis);
    if (mis && M - m_end < LANES)
        m_end = M;
    const int b = (int)get_global_id(1);
    const int blk = (int)get_global_id(2);
    if (m0 >= m_end || b >= B)
        return;
    const int k_lo = PHASE ? blk * block : 0;
    const int k_hi = PHASE ? IMIN(n, k_lo + block) : n;
    if (k_lo >= k_hi)
        return;
    const int cols = m_end - m0;
    const int vecs = (cols + LANES - 1) / LANES;
    const int last = cols - (vecs - 1) * LANES;      /* real lanes of the last vector */
    const long stride = M;
    __global const REAL *s0 = src + src_off + (long)b * N * M + m0;
    __global REAL *d0 = dst + dst_off + (long)b * N * M + m0;
    /* non-temporal stores need aligned vectors: where the band's start and every row are aligned
     * they store the band's vectors directly (nt); else (rows not of whole cache lines: 3000,
     * 741 columns) each row's outputs are staged in `yb` and its aligned interior is streamed
     * (staged, store_row_nt) */
    const int streams = stream && !accumulate && PHASE != 1;
    const int nt = streams && M % LANES == 0 && ((ulong)d0 % sizeof(VT)) == 0;
    const int staged = STAGED && streams && !nt;
    VT fr[SECTIONS][BAND], fi[SECTIONS][BAND];
#if STAGED
    VT yb[BAND];
#endif
    for (int v = 0; v < vecs; ++v) {
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            fr[s][v] = (VT)(0);
            fi[s][v] = (VT)(0);
        }
    }
    /* traversal position k is row (reverse ? n - 1 - k : k); WINDOW: window position w reads
     * source row window[w] (cval where negative) and writes output row w - first (if in range) */
#define POS_AT(k) (reverse ? n - 1 - (k) : (k))
#define ROW_AT(k) ((long)POS_AT(k) * stride)
#if PHASE == 0
    for (int j = 0; j < L; ++j) {
#if WINDOW
        const int q = window[POS_AT(j)];
        __global const REAL *p = s0 + (long)IMAX(q, 0) * stride;
#else
        const int q = 0;
        __global const REAL *p = s0 + ROW_AT(j);
#endif
        for (int v = 0; v < vecs; ++v) {
            const VT x = q >= 0 ? load_cols(p + v * LANES, v == vecs - 1 ? last : LANES) : (VT)(cval);
#pragma unroll
            for (int s = 0; s < SECTIONS; ++s) {
                const size_t o = 2 * ((size_t)s * L + j);
                fr[s][v] += omega[o] * x;
                fi[s][v] += omega[o + 1] * x;
            }
        }
    }
    for (int v = 0; v < vecs; ++v) {
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            fr[s][v] += omega_c[2 * s] * cval;
            fi[s][v] += omega_c[2 * s + 1] * cval;
        }
    }
#elif PHASE == 1
    /* this block's part of the initial state: omega terms of its own samples (j < L) */
    for (int j = k_lo; j < IMIN(k_hi, L); ++j) {
#if WINDOW
        const int q = window[POS_AT(j)];
        __global const REAL *p = s0 + (long)IMAX(q, 0) * stride;
#else
        const int q = 0;
        __global const REAL *p = s0 + ROW_AT(j);
#endif
        for (int v = 0; v < vecs; ++v) {
            const VT x = q >= 0 ? load_cols(p + v * LANES, v == vecs - 1 ? last : LANES) : (VT)(cval);
#pragma unroll
            for (int s = 0; s < SECTIONS; ++s) {
                const size_t o = 2 * ((size_t)s * L + j);
                fr[s][v] += omega[o] * x;
                fi[s][v] += omega[o + 1] * x;
            }
        }
    }
    for (int v = 0; v < vecs; ++v) {
        const int valid = v == vecs - 1 ? last : LANES;
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            store_lanes(partial + carry_index(b, blk, nblocks, s, 0, m0 + v * LANES, M), fr[s][v], valid);
            store_lanes(partial + carry_index(b, blk, nblocks, s, 1, m0 + v * LANES, M), fi[s][v], valid);
            fr[s][v] = (VT)(0);
            fi[s][v] = (VT)(0);
        }
    }
#else
    for (int v = 0; v < vecs; ++v) {
        const int valid = v == vecs - 1 ? last : LANES;
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            fr[s][v] = load_lanes(carry + carry_index(b, blk, nblocks, s, 0, m0 + v * LANES, M), valid);
            fi[s][v] = load_lanes(carry + carry_index(b, blk, nblocks, s, 1, m0 + v * LANES, M), valid);
        }
    }
#endif
    VT chk = (VT)(0);
    coef_t c;
    load_coef(&c, lam, kap, n, k_lo);
    for (int k = k_lo; k < k_hi; ++k) {
#if !CONSTANT_COEF
        load_coef(&c, lam, kap, n, k);
#endif
#if WINDOW
        const int from = window[POS_AT(k)];
        const int to = POS_AT(k) - first;
        __global const REAL *p = s0 + (long)IMAX(from, 0) * stride;
        __global REAL *q = d0 + (long)to * stride;
        const int keep = to >= 0 && to < N;
#else
        const int from = 0, keep = 1;
        const long row = ROW_AT(k);
        __global const REAL *p = s0 + row;
        __global REAL *q = d0 + row;
#endif
#if PREFETCH_ROWS
        /* the band's cache lines PREFETCH_ROWS steps ahead */
        if (k + PREFETCH_ROWS < k_hi) {
#if WINDOW
            const long ahead = (long)IMAX(window[POS_AT(k + PREFETCH_ROWS)], 0) * stride;
#else
            const long ahead = ROW_AT(k + PREFETCH_ROWS);
#endif
            for (int v = 0; v < vecs; ++v)
                PREFETCH(s0 + ahead + v * LANES);
        }
#endif
        for (int v = 0; v < vecs; ++v) {
            const int valid = v == vecs - 1 ? last : LANES;
            /* read before dst (may alias) is written */
            const VT x = from >= 0 ? load_cols(p + v * LANES, valid) : (VT)(cval);
#if CHECK
            chk += RESIDUE(x);
#endif
            VT y = fr[0][v];
#pragma unroll
            for (int s = 1; s < SECTIONS; ++s)
                y += fr[s][v];
            y += tap * x;
#pragma unroll
            for (int s = 0; s < SECTIONS; ++s)
                ADVANCE(fr[s][v], fi[s][v], c, s, x);
#if PHASE != 1
#if STAGED
            if (staged)
                yb[v] = y;
            else
#endif
            if (keep)
                store_cols(q + v * LANES, y, valid, accumulate, nt);
#endif
        }
#if STAGED && PHASE != 1
        if (staged && keep)
            store_row_nt(q, (const REAL *)yb, cols);
#endif
    }
#undef ROW_AT
#undef POS_AT
#if PHASE == 1
    /* not unrolled: PoCL 3.1 (LLVM 15, Debian's) unrolling this store beside the unrolled step
     * above stored a wrong end state for section 0 of two, in one-work-item groups (a GPU-shaped
     * launch of one or two columns); the loop runs once per work-item, so it costs nothing */
    for (int v = 0; v < vecs; ++v) {
        const int valid = v == vecs - 1 ? last : LANES;
        for (int s = 0; s < SECTIONS; ++s) {
            store_lanes(carry + carry_index(b, blk, nblocks, s, 0, m0 + v * LANES, M), fr[s][v], valid);
            store_lanes(carry + carry_index(b, blk, nblocks, s, 1, m0 + v * LANES, M), fi[s][v], valid);
        }
    }
#endif
    STREAM_FENCE(nt || staged);
#if CHECK
    if (RESIDUE_BAD(chk))
        atomic_or(flag, 1);
#else
    (void)chk;
#endif
}

#else
/* ---- rows: LANES contiguous lines of n samples, transposed tile by tile --------------- */

/* w[i] = samples of every lane at traversal position k0 + i, i < cnt.  A full chunk is a
 * tile load + transpose; a partial one (cnt < LANES, the end of the line) is gathered.
 * Lanes past the last row (valid < LANES) repeat the last row: loads stay in bounds.
 * Rows are M samples apart.  WINDOW: traversal runs over n window positions whose samples are
 * src[window[w]] (cval where window[w] < 0); a chunk whose 16 sources are consecutive (the
 * interior) is one tile, the ends are gathered. */
INLINE void load_chunk(VT *w, __global const REAL *src, const int n, const int valid,
                              const int k0, const int cnt, const int reverse, const int M,
                              __global const int *window, const REAL cval)
{
    if (cnt == LANES) {
        VT t[LANES];
        const int p0 = reverse ? n - k0 - LANES : k0;   /* natural start of the tile */
#if WINDOW
        const int q0 = window[p0];
        const int whole = q0 >= 0 && window[p0 + LANES - 1] == q0 + LANES - 1;
#else
        const int q0 = p0;
        const int whole = 1;
#endif
        if (whole) {
#pragma unroll
            for (int l = 0; l < LANES; ++l)
                t[l] = VLOAD(src + (long)IMIN(l, valid - 1) * M + q0);
            rows_transpose(t);
            /* t[j] is natural position p0 + j; traversal runs backwards when reversed */
#pragma unroll
            for (int i = 0; i < LANES; ++i)
                w[i] = reverse ? t[LANES - 1 - i] : t[i];
            return;
        }
    }
    /* unrolled with guards, not `i < cnt`: constant indices keep w[] in registers */
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        if (i < cnt) {
            const int p = reverse ? n - 1 - (k0 + i) : k0 + i;
#if WINDOW
            const int q = window[p];
            if (q < 0) {
                w[i] = (VT)(cval);
                continue;
            }
#else
            const int q = p;
#endif
            VT v;
#pragma unroll
            for (int l = 0; l < LANES; ++l)
                LANE(v, l) = src[(long)IMIN(l, valid - 1) * M + q];
            w[i] = v;
        }
    }
}

/* Write y[i] (traversal position k0 + i, i < cnt) of the `valid` real lanes.  WINDOW: window
 * position p is output sample p - first, written only for 0 <= p - first < M. */
INLINE void store_chunk(VT *y, __global REAL *dst, const int n, const int valid,
                               const int k0, const int cnt, const int reverse,
                               const int accumulate, const int M, const int first)
{
    if (cnt == LANES) {
        const int p0 = reverse ? n - k0 - LANES : k0;
        const int x0 = p0 - first;
        if (x0 >= 0 && x0 + LANES <= M) {
            VT t[LANES];
#pragma unroll
            for (int i = 0; i < LANES; ++i)
                t[i] = reverse ? y[LANES - 1 - i] : y[i];
            rows_transpose(t);   /* back to one vector per row */
#pragma unroll
            for (int l = 0; l < LANES; ++l) {
                if (l < valid) {
                    __global REAL *p = dst + (long)l * M + x0;
                    VSTORE(accumulate ? VLOAD(p) + t[l] : t[l], p);
                }
            }
            return;
        }
    }
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        if (i < cnt) {
            const int x = (reverse ? n - 1 - (k0 + i) : k0 + i) - first;
            if (x >= 0 && x < M) {
#pragma unroll
                for (int l = 0; l < LANES; ++l) {
                    if (l < valid) {
                        __global REAL *q = dst + (long)l * M + x;
                        *q = accumulate ? *q + LANE(y[i], l) : LANE(y[i], l);
                    }
                }
            }
        }
    }
}

/* One step of every section on LANES rows: returns y = sum_s Re F_s + tap v. */
INLINE VT advance(VT *fr, VT *fi, const VT v, const REAL tap, const coef_t *c)
{
    VT y = fr[0];
#pragma unroll
    for (int s = 1; s < SECTIONS; ++s)
        y += fr[s];
    y += tap * v;
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s)
        ADVANCE(fr[s], fi[s], *c, s, v);
    return y;
}

/* Steps k0 .. k0 + cnt - 1 (cnt <= LANES) of the chunk w, in place: w[i] becomes the output of
 * step k0 + i; chk sums the samples' residues (CHECK). */
INLINE void step_chunk(VT *w, const int k0, const int cnt, VT *fr, VT *fi, VT *chk, coef_t *c,
                       __global const REAL *lam, __global const REAL *kap, const int n, const REAL tap)
{
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        if (i < cnt) {
#if CHECK
            *chk += RESIDUE(w[i]);
#endif
#if !CONSTANT_COEF
            load_coef(c, lam, kap, n, k0 + i);
#endif
            w[i] = advance(fr, fi, w[i], tap, c);
        }
    }
}

/* F_s += omega[s, j] v  (initial state, traversal position j < L) */
INLINE void add_initial(VT *fr, VT *fi, const VT v, __global const REAL *omega,
                               const int L, const int j)
{
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        const size_t o = 2 * ((size_t)s * L + j);
        fr[s] += omega[o] * v;
        fi[s] += omega[o + 1] * v;
    }
}

/* Steps before the first whole tile so that the tiles' stores are vector-aligned in dst (a numpy
 * output= starts 16 bytes into a cache line); rows of M % LANES == 0 share the alignment.  Natural
 * position p is output sample p - first (WINDOW; else first = 0): a windowed pass into a numpy
 * output= stored unaligned tiles (4096^2 float32 shift by 2.5 columns: ~7 % more CPU). */
INLINE int tile_lead(__global const REAL *d0, const int n, const int M, const int reverse, const int first)
{
#if LANES == 1
    return 0;
#else
    if (M % LANES)
        return 0;
    const int mis = (int)(((ulong)d0 / sizeof(REAL)) % LANES);    /* samples past an aligned vector */
    /* forward: the tile at traversal k0 = lead stores output p - first = lead - first; reversed,
     * the tile at k0 stores from n - k0 - LANES - first */
    const int lead = reverse ? (n - first + mis) % LANES : (first - mis) % LANES;
    return lead < 0 ? lead + LANES : lead;
#endif
}

/* `reverse` is a literal at each call site, so the tile's traversal order is static.  Runs
 * traversal steps k_lo .. k_hi - 1 (k_lo a multiple of LANES) from the state in fr/fi; the first
 * `lead` steps (< LANES) run as a partial chunk, so that the whole tiles after them start where
 * dst's rows are vector-aligned (tile_lead). */
INLINE int run_rows(__global const REAL *src, __global REAL *dst,
                           __global const REAL *lam, __global const REAL *kap,
                           const int n, const REAL tap, const int accumulate, const int valid,
                           const int reverse, const int k_lo, const int k_hi,
                           VT *fr, VT *fi, const int M, __global const int *window,
                           const int first, const REAL cval, const int lead)
{
    VT w[LANES];
    VT chk = (VT)(0);
    coef_t c;
    load_coef(&c, lam, kap, n, k_lo);
    int k0 = k_lo;
    if (lead > 0 && k0 + lead < k_hi) {   /* the partial chunk before the aligned tiles */
        load_chunk(w, src, n, valid, k0, lead, reverse, M, window, cval);
        step_chunk(w, k0, lead, fr, fi, &chk, &c, lam, kap, n, tap);
#if PHASE != 1
        store_chunk(w, dst, n, valid, k0, lead, reverse, accumulate, M, first);
#endif
        k0 += lead;
    }
#if LANES > 1
    /* two tiles at a time: the second's loads and transposes overlap the first's steps (one chain
     * of dependent multiply-adds); every sample is read before its output is written */
    for (; k0 + 2 * LANES <= k_hi; k0 += 2 * LANES) {
        VT w1[LANES];
        load_chunk(w, src, n, valid, k0, LANES, reverse, M, window, cval);
        load_chunk(w1, src, n, valid, k0 + LANES, LANES, reverse, M, window, cval);
        step_chunk(w, k0, LANES, fr, fi, &chk, &c, lam, kap, n, tap);
        step_chunk(w1, k0 + LANES, LANES, fr, fi, &chk, &c, lam, kap, n, tap);
#if PHASE != 1
        store_chunk(w, dst, n, valid, k0, LANES, reverse, accumulate, M, first);
        store_chunk(w1, dst, n, valid, k0 + LANES, LANES, reverse, accumulate, M, first);
#endif
    }
#endif
    for (; k0 < k_hi; k0 += LANES) {   /* the last tile and the line's end (LANES = 1: every step) */
        const int cnt = IMIN(LANES, k_hi - k0);
        load_chunk(w, src, n, valid, k0, cnt, reverse, M, window, cval);   /* read before written */
        step_chunk(w, k0, cnt, fr, fi, &chk, &c, lam, kap, n, tap);
#if PHASE != 1
        store_chunk(w, dst, n, valid, k0, cnt, reverse, accumulate, M, first);
#endif
    }
#if CHECK
    return RESIDUE_BAD(chk);
#else
    (void)chk;
    return 0;
#endif
}

/* fr/fi = the omega terms of traversal positions j_lo .. j_hi - 1, summed from zero, then
 * + omega_c cval where omega_c is given (a whole line's initial state; 0: a block's share). */
INLINE void initial_terms(__global const REAL *src, __global const REAL *omega,
                          __global const REAL *omega_c, const int L, const int n, const int valid,
                          const int reverse, const int j_lo, const int j_hi, VT *fr, VT *fi,
                          const int M, __global const int *window, const REAL cval)
{
    VT w[LANES];
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s)
        fr[s] = fi[s] = (VT)(0);
    for (int k0 = j_lo - j_lo % LANES; k0 < j_hi; k0 += LANES) {
        load_chunk(w, src, n, valid, k0, IMIN(LANES, n - k0), reverse, M, window, cval);
#pragma unroll
        for (int i = 0; i < LANES; ++i)
            if (k0 + i >= j_lo && k0 + i < j_hi)
                add_initial(fr, fi, w[i], omega, L, k0 + i);
    }
    if (omega_c) {
#pragma unroll
        for (int s = 0; s < SECTIONS; ++s) {
            fr[s] += omega_c[2 * s] * cval;
            fi[s] += omega_c[2 * s + 1] * cval;
        }
    }
}

/* Work-item (g, blk): rows g*LANES.. (lines of M samples), steps of block blk (PHASE 1/2) or the
 * whole line (PHASE 0). */
__kernel void recurse(__global const REAL *src, __global REAL *dst, const long src_off,
                      const long dst_off, __global const REAL *lam, __global const REAL *kap,
                      __global const REAL *omega, __global const REAL *omega_c, const int L,
                      const int n, const REAL cval, const REAL tap, const int reverse,
                      const int accumulate, const int B, const int N, const int M, const int nv,
                      const int stream, __global int *flag, const int block, const int nblocks,
                      __global REAL *carry, __global REAL *partial, __global const int *window,
                      const int first)
{
    const long rows = (long)B * N;
    const long r0 = (long)get_global_id(0) * LANES;
    const int blk = (int)get_global_id(1);
    if (r0 >= rows)
        return;
    const int k_lo = PHASE ? blk * block : 0;
    const int k_hi = PHASE ? IMIN(n, k_lo + block) : n;
    if (k_lo >= k_hi)
        return;
    const int valid = (int)IMIN((long)LANES, rows - r0);
    const long base = r0 * M;
    __global const REAL *s0 = src + src_off + base;
    __global REAL *d0 = dst + dst_off + base;
    /* plain stores: non-temporal ones ran the 4096^2 row pass 35-55 % slower (PoCL, AVX2, 2 cores,
     * 8 lanes, A/B in one process) */
    (void)stream;
    VT fr[SECTIONS], fi[SECTIONS];
#if PHASE == 0
    initial_terms(s0, omega, omega_c, L, n, valid, reverse, 0, L, fr, fi, M, window, cval);
#elif PHASE == 1
    /* the block's share of the initial state (its samples' omega terms), then a zero start */
    initial_terms(s0, omega, 0, L, n, valid, reverse, k_lo, IMIN(k_hi, L), fr, fi, M, window, cval);
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        store_lanes(partial + carry_index(0, blk, nblocks, s, 0, r0, rows), fr[s], valid);
        store_lanes(partial + carry_index(0, blk, nblocks, s, 1, r0, rows), fi[s], valid);
        fr[s] = fi[s] = (VT)(0);
    }
#if TERMS_ONLY
    /* only the omega terms asked for (the first blocks of long rows, _recurse_row_blocks): the
     * block's recursion ran 2.2 ms of a (4, 4194304) pass's 22 for end states nobody reads */
    return;
#endif
#else
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        fr[s] = load_lanes(carry + carry_index(0, blk, nblocks, s, 0, r0, rows), valid);
        fi[s] = load_lanes(carry + carry_index(0, blk, nblocks, s, 1, r0, rows), valid);
    }
#endif
    const int bad = reverse
        ? run_rows(s0, d0, lam, kap, n, tap, accumulate, valid, 1, k_lo, k_hi, fr, fi, M, window, first, cval,
                   tile_lead(d0, n, M, 1, first))
        : run_rows(s0, d0, lam, kap, n, tap, accumulate, valid, 0, k_lo, k_hi, fr, fi, M, window, first, cval,
                   tile_lead(d0, n, M, 0, first));
#if PHASE == 1
#pragma unroll
    for (int s = 0; s < SECTIONS; ++s) {
        store_lanes(carry + carry_index(0, blk, nblocks, s, 0, r0, rows), fr[s], valid);
        store_lanes(carry + carry_index(0, blk, nblocks, s, 1, r0, rows), fi[s], valid);
    }
#endif
#if CHECK
    if (bad)
        atomic_or(flag, 1);
#else
    (void)bad;
#endif
}

/* Two passes of one step on the same LANES rows, the second accumulating, in one work-item: the
 * second sweep reads the rows the first has just written from the cache (LANES rows of M samples:
 * 256 KiB at M = 4096, float32), so the step reads src and writes dst once from memory instead of
 * twice and three times.  Whole lines; the two plans share SECTIONS and CONSTANT_COEF. */
__kernel void recurse_pair(__global const REAL *src, __global REAL *dst, const long src_off,
                           const long dst_off, __global const REAL *lam, __global const REAL *kap,
                           __global const REAL *omega, __global const REAL *omega_c, const int L,
                           const REAL tap, const int reverse, __global const REAL *lam2,
                           __global const REAL *kap2, __global const REAL *omega2,
                           __global const REAL *omega_c2, const int L2, const REAL tap2,
                           const int reverse2, const int n, const REAL cval, const int B,
                           const int N, const int M, __global int *flag)
{
    const long rows = (long)B * N;
    const long r0 = (long)get_global_id(0) * LANES;
    if (r0 >= rows)
        return;
    const int valid = (int)IMIN((long)LANES, rows - r0);
    __global const REAL *s0 = src + src_off + r0 * M;
    __global REAL *d0 = dst + dst_off + r0 * M;
    __global const int *none = 0;
    VT fr[SECTIONS], fi[SECTIONS];
    initial_terms(s0, omega, omega_c, L, n, valid, reverse, 0, L, fr, fi, M, none, cval);
    const int bad = reverse
        ? run_rows(s0, d0, lam, kap, n, tap, 0, valid, 1, 0, n, fr, fi, M, none, 0, cval, tile_lead(d0, n, M, 1, 0))
        : run_rows(s0, d0, lam, kap, n, tap, 0, valid, 0, 0, n, fr, fi, M, none, 0, cval, tile_lead(d0, n, M, 0, 0));
    initial_terms(s0, omega2, omega_c2, L2, n, valid, reverse2, 0, L2, fr, fi, M, none, cval);
    if (reverse2)
        run_rows(s0, d0, lam2, kap2, n, tap2, 1, valid, 1, 0, n, fr, fi, M, none, 0, cval, tile_lead(d0, n, M, 1, 0));
    else
        run_rows(s0, d0, lam2, kap2, n, tap2, 1, valid, 0, 0, n, fr, fi, M, none, 0, cval, tile_lead(d0, n, M, 0, 0));
#if CHECK
    if (bad)
        atomic_or(flag, 1);
#else
    (void)bad;
#endif
}
#endif

/* ---- compose: the blocks' start states from their zero-start end states --------------------
 * Line (outer o, inner i): F = omega_c cval + sum_blk partial[blk]; then for each block in
 * traversal order, carry[blk] <- F (its start state) and F <- Lambda[blk] F + end[blk], where
 * Lambda[s, blk] is the product of the block's lam (host, float64).  One work-item per line. */
__kernel void compose(__global REAL *carry, __global const REAL *partial,
                      __global const REAL *omega_c, __global const REAL *blockpow, const REAL cval,
                      const int nblocks, const long count, const int outer)
{
    const long i = (long)get_global_id(0);
    const int o = (int)get_global_id(1);
    if (i >= count || o >= outer)
        return;
    for (int s = 0; s < SECTIONS; ++s) {
        REAL fr = omega_c[2 * s] * cval, fi = omega_c[2 * s + 1] * cval;
        for (int blk = 0; blk < nblocks; ++blk) {
            fr += partial[carry_index(o, blk, nblocks, s, 0, i, count)];
            fi += partial[carry_index(o, blk, nblocks, s, 1, i, count)];
        }
        for (int blk = 0; blk < nblocks; ++blk) {
            const size_t re = carry_index(o, blk, nblocks, s, 0, i, count);
            const size_t im = carry_index(o, blk, nblocks, s, 1, i, count);
            const REAL er = carry[re], ei = carry[im];
            carry[re] = fr;
            carry[im] = fi;
            const REAL pr = blockpow[2 * ((size_t)s * nblocks + blk)];
            const REAL pi = blockpow[2 * ((size_t)s * nblocks + blk) + 1];
            const REAL nr = pr * fr - pi * fi + er;
            fi = pr * fi + pi * fr + ei;
            fr = nr;
        }
    }
}

/* ---- compose_rows: few long lines whose nb blocks are rows (line i's block t: row i*nb + t) ----
 * carry: each row's end state from a zero start, [s][part][row]; partial: the omega terms of the
 * line's first lblocks blocks (carry_index layout); overwrites each end state by the row's start
 * state, walking the blocks in traversal order.  blockpow: lam^blen (constant coefficients). */
__kernel void compose_rows(__global REAL *carry, __global const REAL *partial,
                           __global const REAL *omega_c, __global const REAL *blockpow, const REAL cval,
                           const int nb, const int lblocks, const int pblocks, const long count,
                           const int reverse)
{
    const long i = (long)get_global_id(0);
    if (i >= count)
        return;
    const long rows = count * nb;
    for (int s = 0; s < SECTIONS; ++s) {
        REAL fr = omega_c[2 * s] * cval, fi = omega_c[2 * s + 1] * cval;
        for (int blk = 0; blk < lblocks; ++blk) {
            fr += partial[carry_index(0, blk, pblocks, s, 0, i, count)];
            fi += partial[carry_index(0, blk, pblocks, s, 1, i, count)];
        }
        const REAL pr = blockpow[2 * ((size_t)s * nb)], pi = blockpow[2 * ((size_t)s * nb) + 1];
        for (int t = 0; t < nb; ++t) {
            const long r = i * nb + (reverse ? nb - 1 - t : t);
            const size_t re = (size_t)(2 * s) * rows + r, im = (size_t)(2 * s + 1) * rows + r;
            const REAL er = carry[re], ei = carry[im];
            carry[re] = fr;
            carry[im] = fi;
            const REAL nr = pr * fr - pi * fi + er;
            fi = pr * fi + pi * fr + ei;
            fr = nr;
        }
    }
}

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
