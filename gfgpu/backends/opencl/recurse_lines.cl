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
