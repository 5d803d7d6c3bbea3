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
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define INLINE static inline __attribute__((always_inline))

/* THE section step of this file (the per-line primitive's and the shears'): with F = fr + i fi,
 * output y = Re F + tap v, then F <- lam F + kap v; T the type of the lines' vector (REAL or a
 * vector of lanes, one line each) */
#define SECTION_STEP(T, y, fr, fi, lr, li, kr, ki, tap, v) do {                                     \
        const T v_ = (v), r_ = (fr);                                                                 \
        (y) = r_ + (tap) * v_;                                                                       \
        (fr) = (lr) * r_ - (li) * (fi) + (kr) * v_;                                                  \
        (fi) = (lr) * (fi) + (li) * r_ + (ki) * v_;                                                  \
    } while (0)

/* line i (of batch b) from s to d: the whole recursion of the header */
INLINE void one_line(
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
        REAL y;
        SECTION_STEP(REAL, y, fr, fi, lr, li, kr, ki, t, v);
        d[x] = y;
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
INLINE void lanes_run(
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
            VT y;
            SECTION_STEP(VT, y, fr[q], fi[q], lr[q], li[q], kr[q], ki[q], t[q], v);
            STOREV(y, d + q * vec + x);
        }
    }
}

/* whether lines i0 .. i0 + count - 1 exist and share reverse[i0] */
INLINE int one_direction(__global const int *reverse, const int i0, const int count, const int lines)
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
 *   shear_out: image[m, t] = A_t(layout column t)[m - start[t]]                        (causal)
 *
 * Column t of the layout is a line of the per-line primitive above with two cascaded sections
 * (SECTION_STEP): A_t, one complex pair (lam, kap, tap) and one real pole (p, k, tapb: a section
 * whose imaginary parts are 0), started at the steady state of the first sample its walk reads
 * ("nearest": the layout's margin makes the start irrelevant at the lines read back).  The
 * gather is index arithmetic on a table of O(H + W) numbers: base[j] is the offset of minor
 * coordinate first + min(r) + j (extended by the mode; -1 for cval).  Layout sample (q, t) at
 * q * qs + t * ts; image pixel (minor m, step t) at m * stride + t * tstride.
 *
 * SHEAR_TILE 0 (SHEAR_LANES 1: GPU launch shapes, and layouts the CPU kernels do not take): one
 * step t per work-item, any strides.  CPU kernels: SHEAR_LANES adjacent steps per work-item (one
 * cache line), every access a whole vector:
 *   SHEAR_TILE 1, steep directions in the layout (steps, lines) (stride = qs = 1): each lane's
 *     samples are consecutive in its own row of both arrays; tiles of SHEAR_LANES x SHEAR_LANES
 *     are loaded one row vector per lane, transposed in registers (a vector per line position),
 *     run, transposed back and stored (each lane streams along its rows, as the row passes do).
 *   SHEAR_TILE 2, shallow directions in the layout (lines, steps) (tstride = ts = 1): a row of
 *     either array holds the lanes; the walk goes down both arrays one row at a time, 4 vectors
 *     (4 cache lines of each row) per work-item.  The lanes enter their lines at rows up to
 *     `spread` apart (about SHEAR_LANES x the slope): the last row vectors wait in a ring in
 *     private memory and each lane takes its own (a blend of spread + 1 vectors).  shear_in's
 *     lanes all start at their vector's first image row.
 * Coefficients come grouped per vector, coef[g][j][lane] (g = t / SHEAR_LANES, j < NCOEF): lam
 * re, im, kap re, im, tap, g re, im (= kap / (1 - lam)), p, k, tapb, gb (= k / (1 - p)); lanes past
 * the last step repeat it (computed, never written).  -D SHEAR_INT=int|long: the lane masks'
 * element type (REAL's width).
 */
#ifndef SHEAR_LANES
#define SHEAR_LANES 1
#endif
#ifndef SHEAR_TILE
#define SHEAR_TILE 0
#endif
#ifndef SHEAR_INT
#define SHEAR_INT int
#endif
#define NCOEF 11
#define SMIN(a, b) ((a) < (b) ? (a) : (b))     /* PoCL calls min() out of line */
#define SMAX(a, b) ((a) > (b) ? (a) : (b))

#if SHEAR_LANES == 1
typedef REAL SVT;
#define SLOAD(p) (*(p))
#define SSTORE(v, p) (*(p) = (v))
#define SLANE(v, l) (v)
#else
/* vectors of the element's alignment (rows start anywhere); lanes by subscript (clang) */
typedef CAT(REAL, SHEAR_LANES) SVT;
typedef REAL SVTU __attribute__((ext_vector_type(SHEAR_LANES), aligned(sizeof(REAL))));
#define SLOAD(p) ((SVT)(*(__global const SVTU *)(p)))
#define SSTORE(v, p) (*(__global SVTU *)(p) = (SVTU)(v))
#define SLANE(v, l) ((v)[l])
#endif

typedef struct {
    SVT lr, li, kr, ki, ta, pp, kb, tb, gr, gi, gb;
} shear_coef;

/* the coefficients of vector g (registers for the whole walk) */
INLINE shear_coef shear_coefs(__global const REAL *coef, const int g)
{
    __global const REAL *c = coef + (long)g * (NCOEF * SHEAR_LANES);
    shear_coef k;
    k.lr = SLOAD(c);
    k.li = SLOAD(c + SHEAR_LANES);
    k.kr = SLOAD(c + 2 * SHEAR_LANES);
    k.ki = SLOAD(c + 3 * SHEAR_LANES);
    k.ta = SLOAD(c + 4 * SHEAR_LANES);
    k.gr = SLOAD(c + 5 * SHEAR_LANES);
    k.gi = SLOAD(c + 6 * SHEAR_LANES);
    k.pp = SLOAD(c + 7 * SHEAR_LANES);
    k.kb = SLOAD(c + 8 * SHEAR_LANES);
    k.tb = SLOAD(c + 9 * SHEAR_LANES);
    k.gb = SLOAD(c + 10 * SHEAR_LANES);
    return k;
}

/* the cascade's state, started at the steady state of input v0 */
typedef struct {
    SVT ar, ai, br, bi;
} shear_state;

INLINE shear_state shear_start(const shear_coef *c, const SVT v0)
{
    shear_state f;
    f.ar = c->gr * v0;
    f.ai = c->gi * v0;
    f.br = c->gb * v0;
    f.bi = (SVT)(0);
    return f;
}

/* one step of A_t on every lane: input v, returns the output */
INLINE SVT shear_step(shear_state *f, const shear_coef *c, const SVT v)
{
    const SVT zero = (SVT)(0);
    SVT ya, y;
    SECTION_STEP(SVT, ya, f->ar, f->ai, c->lr, c->li, c->kr, c->ki, c->ta, v);
    SECTION_STEP(SVT, y, f->br, f->bi, c->pp, zero, c->kb, zero, c->tb, ya);
    return y;
}

/* what every shear kernel starts with: work-item (g, b) runs `per_item` steps from t0 of plane b
 * (s, d: the plane in src and dst) */
#define SHEAR_PLANE(per_item)                                                                      \
    const int t0 = (int)get_global_id(0) * (per_item);                                             \
    const long b = get_global_id(1);                                                               \
    if (t0 >= steps)                                                                               \
        return;                                                                                    \
    __global const REAL *s = src + src_off + b * src_plane;                                        \
    __global REAL *d = dst + dst_off + b * dst_plane

/* ... one vector of them: steps t0 .. t0 + valid - 1, with the coefficients c of their vector */
#define SHEAR_PROLOGUE                                                                             \
    SHEAR_PLANE(SHEAR_LANES);                                                                      \
    const int valid = SMIN(SHEAR_LANES, steps - t0);                                               \
    const shear_coef c = shear_coefs(coef, t0 / SHEAR_LANES)

#define SHEAR_IN_ARGS                                                                              \
    __global const REAL *src, const long src_off, __global REAL *dst, const long dst_off,          \
    __global const REAL *coef, __global const int *base, __global const int *shift, const int lines, \
    const int steps, const long qs, const long ts, const long stride, const long tstride,          \
    const long src_plane, const long dst_plane, const REAL cval
#define SHEAR_OUT_ARGS                                                                             \
    __global const REAL *src, const long src_off, __global REAL *dst, const long dst_off,          \
    __global const REAL *coef, __global const int *start, const int lines, const int steps,        \
    const int across, const long qs, const long ts, const long stride, const long tstride,         \
    const long src_plane, const long dst_plane

#if SHEAR_TILE == 0
__kernel void shear_in(SHEAR_IN_ARGS)
{
    SHEAR_PROLOGUE;
    const int sh = shift[t0];
    __global const REAL *p = s + (long)t0 * tstride;
    __global REAL *out = d + (long)t0 * ts;
    int row = base[lines - 1 + sh];
    shear_state f = shear_start(&c, row >= 0 ? p[row] : cval);
    for (int q = lines - 1; q >= 0; --q) {
        row = base[q + sh];
        out[q * qs] = shear_step(&f, &c, row >= 0 ? p[row] : cval);
    }
}

__kernel void shear_out(SHEAR_OUT_ARGS)
{
    SHEAR_PROLOGUE;
    const int st = start[t0];
    __global const REAL *p = s + (long)t0 * ts;
    __global REAL *out = d + (long)t0 * tstride;
    /* image rows from the line's first sample to the last row (the lines beyond are not read) */
    shear_state f = shear_start(&c, p[0]);
    for (int m = st; m < across; ++m) {
        const REAL y = shear_step(&f, &c, p[(m - st) * qs]);
        if (m >= 0)
            out[m * stride] = y;
    }
}

#elif SHEAR_TILE == 2
/* ---- shallow directions: rows of lanes, a ring of the last SHEAR_RING row vectors ------------ */
#define SHEAR_RING 32      /* > spread: at most SHEAR_LANES for a slope of at most 1 */
typedef CAT(SHEAR_INT, SHEAR_LANES) SVI;

/* the vector at p (valid real lanes; the rest repeat the last: in bounds, never stored) */
INLINE SVT load_lanes(__global const REAL *p, const int valid)
{
    if (valid == SHEAR_LANES)
        return SLOAD(p);
    SVT v;
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l)
        SLANE(v, l) = p[SMIN(l, valid - 1)];
    return v;
}

INLINE void store_lanes(__global REAL *p, const SVT v, const int valid)
{
    if (valid == SHEAR_LANES) {
        SSTORE(v, p);
        return;
    }
    for (int l = 0; l < valid; ++l)
        p[l] = SLANE(v, l);
}

/* lane l: ring[(i + ds[l]) % SHEAR_RING] (ds[l] in 0 .. spread) */
INLINE SVT from_ring(const SVT *ring, const int i, const SVI ds, const int spread)
{
    SVT v = ring[i & (SHEAR_RING - 1)];
    for (int j = 1; j <= spread; ++j)
        v = ds == (SVI)(j) ? ring[(i + j) & (SHEAR_RING - 1)] : v;
    return v;
}

/* the lanes' table values less their least (returned in *least), and their spread */
INLINE SVI lanes_of(__global const int *table, const int t0, const int steps, int *least, int *spread)
{
    SVI v;
    int lo = table[t0], hi = lo;
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l) {
        const int x = table[SMIN(t0 + l, steps - 1)];
        SLANE(v, l) = x;
        lo = SMIN(lo, x);
        hi = SMAX(hi, x);
    }
    *least = lo;
    *spread = hi - lo;
    return v - (SVI)(lo);
}

/* SHEAR_VECS (the host's -D, 4) vectors of adjacent steps per work-item, each with variables of
 * its own (named A .. D: no private array is indexed by vector, which PoCL compiled 1.5-3x
 * slower), so that a row step touches 4 cache lines of each row (every row a new page: 2-2.7x
 * faster than one vector per work-item) */
#if SHEAR_VECS != 4
#error "the shallow shears run SHEAR_VECS = 4 vectors per work-item"
#endif
#define VEC_DECL(X, k, table)                                                                     \
    const int t##X = SMIN(t0 + (k) * SHEAR_LANES, steps - 1);                                      \
    const int has##X = t0 + (k) * SHEAR_LANES < steps;                                             \
    const int v##X = has##X ? SMIN(SHEAR_LANES, steps - t##X) : 1;                                 \
    const shear_coef c##X = shear_coefs(coef, t##X / SHEAR_LANES);                                 \
    int lo##X, sp##X;                                                                              \
    const SVI ds##X = lanes_of(table, t##X, steps, &lo##X, &sp##X);                                \
    SVT ring##X[SHEAR_RING];                                                                       \
    shear_state f##X

/* base row j (offset off) into the layout: vector X's lines from its last end (top) to lo */
#define VEC_IN(X)                                                                                  \
    if (has##X && j <= lo##X + sp##X + lines - 1 && j >= lo##X) {                                  \
        const SVT x = off >= 0 ? load_lanes(s + off + t##X, v##X) : (SVT)(cval);               \
        if (j == lo##X + sp##X + lines - 1)                                                        \
            f##X = shear_start(&c##X, x);                                                          \
        ring##X[j & (SHEAR_RING - 1)] = shear_step(&f##X, &c##X, x);                               \
        if (j - lo##X < lines)                                                                     \
            store_lanes(d + (j - lo##X) * qs + t##X, from_ring(ring##X, j, ds##X, sp##X), v##X); \
    }

#define VECS_APPLY(M) M(A) M(B) M(C) M(D)
#define VECS_DECL(table) VEC_DECL(A, 0, table); VEC_DECL(B, 1, table); VEC_DECL(C, 2, table); \
    VEC_DECL(D, 3, table)
#define VEC_RANGE(X) if (has##X) { lo = SMIN(lo, lo##X); hi = SMAX(hi, lo##X + sp##X); }

__kernel void shear_in(SHEAR_IN_ARGS)
{
    SHEAR_PLANE(SHEAR_VECS * SHEAR_LANES);
    VECS_DECL(shift);
    /* base rows j down from the last line end (lane l: line j - shift[t]); vector X's line q is
     * whole at j = q + loX, lane l's value ds[l] rows back in its ring */
    int lo = loA, hi = loA + spA;
    VECS_APPLY(VEC_RANGE)
    for (int j = hi + lines - 1; j >= lo; --j) {
        const int off = base[j];
        VECS_APPLY(VEC_IN)
    }
}

/* image row m from layout lines: vector X reads line m - loX (from row loX on; lane l's line
 * m - start[t] ds[l] rows back in its ring, which starts full of line 0: every lane starts at
 * the steady state of its line's first sample) */
#define VEC_START(X)                                                                               \
    {                                                                                              \
        const SVT x0 = load_lanes(s + t##X, v##X);                                              \
        f##X = shear_start(&c##X, x0);                                                             \
        for (int i = 0; i < SHEAR_RING; ++i)                                                       \
            ring##X[i] = x0;                                                                       \
    }
#define VEC_OUT(X)                                                                                 \
    if (has##X && m >= lo##X) {                                                                    \
        ring##X[(-m) & (SHEAR_RING - 1)] = load_lanes(s + (m - lo##X) * qs + t##X, v##X);       \
        const SVT y = shear_step(&f##X, &c##X, from_ring(ring##X, -m, ds##X, sp##X));              \
        if (m >= 0)                                                                                \
            store_lanes(d + m * stride + t##X, y, v##X);                                        \
    }

__kernel void shear_out(SHEAR_OUT_ARGS)
{
    SHEAR_PLANE(SHEAR_VECS * SHEAR_LANES);
    VECS_DECL(start);
    VECS_APPLY(VEC_START)
    int lo = loA, hi = loA + spA;
    VECS_APPLY(VEC_RANGE)
    for (int m = lo; m < across; ++m) {
        VECS_APPLY(VEC_OUT)
    }
}

#elif SHEAR_TILE == 1
/* ---- steep directions: tiles transposed in registers ----------------------------------------- */
#if SHEAR_LANES != 4 && SHEAR_LANES != 8 && SHEAR_LANES != 16
#error "SHEAR_TILE needs SHEAR_LANES 4, 8 or 16"
#endif
/* the in-place register transpose of a SHEAR_LANES x SHEAR_LANES tile (transpose_tile) */
#define TILE_LANES SHEAR_LANES
#define TILE_VT SVT
#include "tile.cl"

/* SHEAR_LANES samples of minor coordinates base[k .. k + SHEAR_LANES - 1] of the row at p: one
 * vector where they are consecutive pixels (the image's interior), else one by one */
INLINE SVT run_of(__global const REAL *p, __global const int *base, const int k, const REAL cval)
{
    const int a = base[k];
    /* an extension never steps up by more than 1: a + SHEAR_LANES - 1 at the end means consecutive */
    if (a >= 0 && base[k + SHEAR_LANES - 1] == a + SHEAR_LANES - 1)
        return SLOAD(p + a);
    SVT v;
#pragma unroll
    for (int i = 0; i < SHEAR_LANES; ++i) {
        const int o = base[k + i];
        SLANE(v, i) = o >= 0 ? p[o] : cval;
    }
    return v;
}

/* lines a multiple of SHEAR_LANES (the host checks) */
__kernel void shear_in(SHEAR_IN_ARGS)
{
    SHEAR_PROLOGUE;
    int sh[SHEAR_LANES];
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l)
        sh[l] = shift[SMIN(t0 + l, steps - 1)];
    shear_state f;
    for (int q0 = lines - SHEAR_LANES; q0 >= 0; q0 -= SHEAR_LANES) {
        SVT w[SHEAR_LANES];
#pragma unroll
        for (int l = 0; l < SHEAR_LANES; ++l)
            w[l] = run_of(s + (long)SMIN(t0 + l, steps - 1) * tstride, base, q0 + sh[l], cval);
        transpose_tile(w);                     /* w[i]: line q0 + i of every lane */
        if (q0 == lines - SHEAR_LANES)
            f = shear_start(&c, w[SHEAR_LANES - 1]);
#pragma unroll
        for (int i = SHEAR_LANES - 1; i >= 0; --i)
            w[i] = shear_step(&f, &c, w[i]);
        transpose_tile(w);
        for (int l = 0; l < valid; ++l)
            SSTORE(w[l], d + (long)(t0 + l) * ts + q0);
    }
}

__kernel void shear_out(SHEAR_OUT_ARGS)
{
    SHEAR_PROLOGUE;
    int st[SHEAR_LANES];
    int lo = start[t0];
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l) {
        st[l] = start[SMIN(t0 + l, steps - 1)];
        lo = SMIN(lo, st[l]);
    }
    /* tiles of image columns m0 .. m0 + SHEAR_LANES - 1 ending at across, the first at or before
     * the least start (each lane starts at its line's first sample) */
    const int tiles = (across - lo + SHEAR_LANES - 1) / SHEAR_LANES;
    SVT v0;
#pragma unroll
    for (int l = 0; l < SHEAR_LANES; ++l)
        SLANE(v0, l) = s[(long)SMIN(t0 + l, steps - 1) * ts];
    shear_state f = shear_start(&c, v0);
    for (int m0 = across - tiles * SHEAR_LANES; m0 < across; m0 += SHEAR_LANES) {
        SVT w[SHEAR_LANES];
#pragma unroll
        for (int l = 0; l < SHEAR_LANES; ++l) {
            __global const REAL *row = s + (long)SMIN(t0 + l, steps - 1) * ts;
            const int q = m0 - st[l];
            if (q >= 0) {
                w[l] = SLOAD(row + q);
            } else {       /* before the line's first sample: that sample (its steady state) */
#pragma unroll
                for (int i = 0; i < SHEAR_LANES; ++i)
                    SLANE(w[l], i) = row[SMAX(q + i, 0)];
            }
        }
        transpose_tile(w);                     /* w[i]: image column m0 + i of every lane */
#pragma unroll
        for (int i = 0; i < SHEAR_LANES; ++i)
            w[i] = shear_step(&f, &c, w[i]);
        transpose_tile(w);
        for (int l = 0; l < valid; ++l) {
            __global REAL *row = d + (long)(t0 + l) * tstride;
            if (m0 >= 0) {
                SSTORE(w[l], row + m0);
            } else {
                for (int i = -m0; i < SHEAR_LANES; ++i)
                    row[m0 + i] = SLANE(w[l], i);
            }
        }
    }
}

#endif
