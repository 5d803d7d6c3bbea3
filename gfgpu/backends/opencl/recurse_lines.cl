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
 * step M).  One work-item per line: lines differ in their coefficients, so the vectorised
 * tiles of recurse.cl (shared coefficients) do not apply.  Packed arrays: lam, kap (m, 2),
 * tap (m), reverse (m), omega (m, L, 2), omega_c (m, 2).  -D REAL=float|double.
 */

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#ifndef REAL
#define REAL float
#endif

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
