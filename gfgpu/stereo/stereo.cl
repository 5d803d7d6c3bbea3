// Stereo kernels of gfgpu.stereo (float32 images; integer costs).
// Executable specification: the *_reference functions of gfgpu/stereo/spec.py.
// size_t indices: cost volumes exceed 2^31 entries on large images.
// The launcher (gfgpu/stereo/_opencl.py) defines the constants shared with the specification,
// none retyped here: NO_MATCH, OUT_OF_VIEW, COST_MAX (spec.NO_MATCH, OUT_OF_VIEW, COST_MAX), and
// PAD_COST, the int16 path value of samples out of view (the int32 spec.PATH_UNDEFINED does not fit).

#if !defined(NO_MATCH) || !defined(OUT_OF_VIEW) || !defined(COST_MAX) || !defined(PAD_COST)
#error "stereo.cl is built by gfgpu.stereo._opencl, which defines the constants of the specification"
#endif

#include "lines.cl"     // CLAMPI, IMIN, IMAX, floor_div, path_line

// Census transform: bit b of out[plane][y][x] is set where neighbour b of the (2r+1)^2 window
// (row-major, centre skipped, edge pixels repeated) is darker than the centre.  One work-item per
// row; built with -D CENSUS_RADIUS=r the loops unroll (the bit positions become constants) and
// the interior runs 8 pixels at a time as float8 compares (3-4x the per-pixel loop on PoCL).
#ifdef CENSUS_RADIUS
#define R_ CENSUS_RADIUS
#ifdef __clang__
typedef float8 float8_u __attribute__((aligned(4)));
typedef ulong8 ulong8_u __attribute__((aligned(8)));
#define CENSUS_LOAD8(p) (*(const __global float8_u *)(p))
#define CENSUS_STORE8(v, p) (*(__global ulong8_u *)(p) = (v))
#define CENSUS_WIDEN(v) __builtin_convertvector((v), ulong8)
#else
#define CENSUS_LOAD8(p) vload8(0, p)
#define CENSUS_STORE8(v, p) vstore8((v), 0, p)
#define CENSUS_WIDEN(v) convert_ulong8(v)
#endif

// The neighbourhood in bit order, written once for the per-pixel and the 8-pixel transforms (a
// census variant changes it here): BODY runs for window row v (0..2r), column offset u (-r..r)
// and bit position bit, row-major with the centre skipped (census_transform_reference).
#define CENSUS_NEIGHBOURS(BODY)                                 \
    {                                                           \
        int bit = 0;                                            \
        _Pragma("unroll")                                       \
        for (int v = 0; v < 2 * R_ + 1; ++v) {                  \
            _Pragma("unroll")                                   \
            for (int u = -R_; u <= R_; ++u) {                   \
                if (v == R_ && u == 0)                          \
                    continue;                                   \
                BODY                                            \
                ++bit;                                          \
            }                                                   \
        }                                                       \
    }

static inline ulong census_pixel(__global const float *const *rows, const int x, const int w)
{
    const float c = rows[R_][x];
    ulong code = 0;
    CENSUS_NEIGHBOURS(code |= (ulong)(rows[v][CLAMPI(x + u, 0, w - 1)] < c) << bit;)
    return code;
}

__kernel void census(__global const float *img, __global ulong *out, const long plane_offset,
                     const int h, const int w)
{
    const int y = get_global_id(0);
    if (y >= h)
        return;
    __global const float *rows[2 * R_ + 1];
    for (int v = -R_; v <= R_; ++v)
        rows[v + R_] = img + (size_t)CLAMPI(y + v, 0, h - 1) * w;
    __global ulong *o = out + plane_offset + (size_t)y * w;
    const int x0 = IMIN(R_, w), x1 = IMAX(x0, w - R_ - 7);    // [x0, x1): 8-pixel blocks inside
    int x = 0;
    for (; x < x0; ++x)
        o[x] = census_pixel(rows, x, w);
    for (; x < x1; x += 8) {
        // bits 0..31 and 32..63 as 32-bit lanes (the compare's own width: no widening per bit)
        const float8 c = CENSUS_LOAD8(rows[R_] + x);
        uint8 lo = (uint8)(0), hi = (uint8)(0);
        CENSUS_NEIGHBOURS(
            const uint8 m = as_uint8(CENSUS_LOAD8(rows[v] + x + u) < c);
            if (bit < 32)
                lo |= m & (uint8)(1U << bit);
            else
                hi |= m & (uint8)(1U << (bit - 32));
        )
        CENSUS_STORE8(CENSUS_WIDEN(lo) | (CENSUS_WIDEN(hi) << 32), o + x);
    }
    for (; x < w; ++x)
        o[x] = census_pixel(rows, x, w);
}
#undef CENSUS_NEIGHBOURS
#undef R_
#endif  // CENSUS_RADIUS

// ---- matching cost and aggregation, vectorised over the disparity axis -------------------
// Built with -D N_DISP=n (the disparity samples per pixel, the innermost axis of the int16 cost
// volumes): a pixel's n values are NV short16 vectors, the last one holding TAIL lanes; the
// loops over the vectors unroll and PoCL (or any OpenCL C compiler) emits SIMD for them.
// Pixel x of one row of the left-right check (the left_right kernel; the band matcher's
// selection with -D SELECT_LR, at the end of each row it selects: a row's right winners are all
// of that row); float64 as the specification, left_right_reference.
#if defined(LEFT_RIGHT) || defined(SELECT_LR)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#ifdef __clang__        // the instructions, not calls (PoCL does not inline its builtins)
#define RINT_D(v) __builtin_rint(v)
#define FABS_D(v) __builtin_fabs(v)
#else
#define RINT_D(v) rint(v)
#define FABS_D(v) fabs(v)
#endif
static inline void left_right_pixel(__global float *drow, __global const int *rrow, __global float *mrow,
                                    const int x, const int w, const int steps, const double tol)
{
    const float d = drow[x];
    int ok = 0;
    double diff = 0.0;
    if (d == d) {                           // not NaN
        const double xr = RINT_D((double)x - (double)d);
        if (xr >= 0.0 && xr <= (double)(w - 1)) {
            const int back = rrow[(int)xr];
            if (back != NO_MATCH) {
                diff = FABS_D((double)back / (double)steps - (double)d);
                ok = diff <= tol;
            }
        }
    }
    if (ok) {
        mrow[x] = (float)((double)mrow[x] * (1.0 - diff / (2.0 * tol)));
    } else {
        drow[x] = as_float(0x7fc00000u);       // numpy's NaN (OpenCL's NAN is 0x7fffffff)
        mrow[x] = 0.0f;
    }
}
#endif

#ifdef N_DISP
#define NV ((N_DISP + 15) / 16)
#define TAIL (N_DISP - 16 * (NV - 1))      // lanes of the last vector that are disparities, 1..16
// PAD_COST (a define): path cost of the padding lanes and of samples out of view, never a minimum
#define NP (16 * NV)                       // padded disparities of a state vector
// Sample-count buckets (the CPU band matcher, gfgpu/stereo/band_plan.py): built once with N_DISP =
// the bucket's padded size, the true count n a kernel argument (n_valid): the samples n .. N_DISP - 1
// are padding, as the lanes past TAIL are.  Vectors 0 .. NV_FULL - 1 hold samples below every n of
// the bucket (no lane test); the default, NV - 1, is an exact build (n = N_DISP).
#ifndef NV_FULL
#define NV_FULL (NV - 1)
#endif
// The pixel stride of the volumes: N_DISP (whole volumes, the public kernels), or NP with
// -D PADDED_PIXELS (the CPU band matcher's own buffers): every pixel then starts on a 32-byte
// boundary (short) and owns its padding lanes.  With an odd N_DISP (every default sub-pixel
// range: (max - min) * 2 + 1 samples) the unpadded vectors straddled cache lines and the band
// sweeps and the selection ran twice as long per sample (1000 x 1500, 383 samples)
#ifdef PADDED_PIXELS
#define PIX NP
#else
#define PIX N_DISP
#endif
// Loops over a pixel's vectors unroll (SIMD over all its disparities, arrays in registers) up to
// 1024 samples (UNROLL_NV; with padded pixels the band sweeps of 1000 x 1500 x 383 samples took
// 605 -> 407 ms unrolled, their checkpointing sweep 220 -> 89 ms; 511 samples alike; 5 s to
// build at 1023), the selection's up to 512 (UNROLL_SEL: at 767 samples 526 ms as a loop, 742
// unrolled); wider ranges stay loops: unrolled, 4096 samples took PoCL minutes to build
#if NV <= 32
#define UNROLL_SEL _Pragma("unroll")
#else
#define UNROLL_SEL _Pragma("nounroll")
#endif
#if NV <= 64
#define UNROLL_NV _Pragma("unroll")
#else
#define UNROLL_NV _Pragma("nounroll")
#endif

// Vector loads and stores at element alignment, and the elementwise minimum, as operators: PoCL
// calls (does not inline) vloadn/vstoren/min, which would dominate the loops.
#ifdef __clang__
typedef short16 short16_u __attribute__((aligned(2)));
typedef ushort16 ushort16_u __attribute__((aligned(2)));
typedef short8 short8_u __attribute__((aligned(2)));
typedef short4 short4_u __attribute__((aligned(2)));
typedef short2 short2_u __attribute__((aligned(2)));
typedef uchar16 uchar16_u __attribute__((aligned(1)));
typedef uchar8 uchar8_u __attribute__((aligned(1)));
typedef uchar4 uchar4_u __attribute__((aligned(1)));
typedef uchar2 uchar2_u __attribute__((aligned(1)));
#define VLOAD(T, N, p) (*(const __global T##N##_u *)(p))
#define VSTORE(T, N, v, p) (*(__global T##N##_u *)(p) = (v))
#define TO_USHORT16(v) __builtin_convertvector((v), ushort16)
#define TO_SHORT16(v) __builtin_convertvector((v), short16)
#define TO_UCHAR16(v) __builtin_convertvector((v), uchar16)
#define POPCOUNT(v) __builtin_popcountl(v)         // long is 64-bit in OpenCL C
#define ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define VLOAD(T, N, p) vload##N(0, p)
#define VSTORE(T, N, v, p) vstore##N((v), 0, p)
#define TO_USHORT16(v) convert_ushort16(v)
#define TO_SHORT16(v) convert_short16(v)
#define TO_UCHAR16(v) convert_uchar16(v)
#define POPCOUNT(v) popcount(v)
#define ALWAYS_INLINE inline
#endif
#define VMIN(a, b) ((a) < (b) ? (a) : (b))

// The last vector of a pixel: TAIL values, the other lanes PAD; loads and stores of the tail are
// split into 8/4/2/1-lane parts so that no neighbouring pixel is read or written (the
// neighbour may belong to another work-item).  Built with -D PADDED_PIXELS (a pixel owns its
// padding lanes): the tail is one full load, its lanes past TAIL replaced (a split load
// assembles the vector in private memory: a store-forwarding stall per pixel on CPUs), and one
// full store.
#ifdef PADDED_PIXELS
#define TAIL_LOAD(NAME, T, PAD, LANE_T)                                                        \
static inline T##16 NAME(__global const T *p)                                                 \
{                                                                                             \
    const T##16 v = VLOAD(T, 16, p);                                                          \
    if (TAIL == 16) return v;                                                                 \
    const LANE_T##16 lane = (LANE_T##16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15); \
    return lane < (LANE_T##16)(TAIL) ? v : (T##16)(PAD);                                      \
}
#else
#define TAIL_LOAD(NAME, T, PAD, LANE_T)                                                        \
static inline T##16 NAME(__global const T *p)                                                 \
{                                                                                             \
    if (TAIL == 16) return VLOAD(T, 16, p);                                                   \
    T##16 v = (T##16)(PAD);                                                                   \
    __private T *b = (__private T *)&v;                                                       \
    if (TAIL & 8) *(__private T##8 *)b = VLOAD(T, 8, p);                                      \
    if (TAIL & 4) *(__private T##4 *)(b + (TAIL & 8)) = VLOAD(T, 4, p + (TAIL & 8));          \
    if (TAIL & 2) *(__private T##2 *)(b + (TAIL & 12)) = VLOAD(T, 2, p + (TAIL & 12));        \
    if (TAIL & 1) b[TAIL - 1] = p[TAIL - 1];                                                  \
    return v;                                                                                 \
}
#endif
TAIL_LOAD(load_last_short, short, PAD_COST, short)
TAIL_LOAD(load_last_short_max, short, SHRT_MAX, short)
TAIL_LOAD(load_last_uchar, uchar, 0, char)

// ... and its store, also in 8/4/2/1-lane parts
#ifdef PADDED_PIXELS
#define PADDED 1
#else
#define PADDED 0
#endif
#define TAIL_STORE(NAME, T)                                                                    \
static inline void NAME(T##16 v, __global T *p)                                               \
{                                                                                             \
    if (TAIL == 16 || PADDED) {                                                               \
        VSTORE(T, 16, v, p);                                                                  \
        return;                                                                               \
    }                                                                                         \
    __private T *b = (__private T *)&v;                                                       \
    if (TAIL & 8) VSTORE(T, 8, *(__private T##8 *)b, p);                                      \
    if (TAIL & 4) VSTORE(T, 4, *(__private T##4 *)(b + (TAIL & 8)), p + (TAIL & 8));          \
    if (TAIL & 2) VSTORE(T, 2, *(__private T##2 *)(b + (TAIL & 12)), p + (TAIL & 12));        \
    if (TAIL & 1) p[TAIL - 1] = b[TAIL - 1];                                                  \
}
TAIL_STORE(store_last_short, short)
TAIL_STORE(store_last_uchar, uchar)

#define LOAD_S(p, j) ((j) < NV - 1 ? VLOAD(short, 16, (p) + 16 * (j)) : load_last_short((p) + 16 * (j)))
#define LOAD_SMAX(p, j) ((j) < NV - 1 ? VLOAD(short, 16, (p) + 16 * (j)) : load_last_short_max((p) + 16 * (j)))
#define LOAD_UC(p, j) ((j) < NV - 1 ? VLOAD(uchar, 16, (p) + 16 * (j)) : load_last_uchar((p) + 16 * (j)))
#define STORE_UC(v, p, j) do { if ((j) < NV - 1) VSTORE(uchar, 16, (v), (p) + 16 * (j));             \
                               else store_last_uchar((v), (p) + 16 * (j)); } while (0)
// Costs: int16 with OUT_OF_VIEW (-1) out of view (whole volumes, GPUs), or with -D COST_BYTES bytes
// with COST_OUT, OUT_OF_VIEW's byte (255), out of view (the CPU matcher's volume); both saturated at
// COST_MAX, which leaves COST_OUT to the mark.
#define COST_OUT ((OUT_OF_VIEW) & 0xff)
#if COST_OUT <= COST_MAX
#error "the out-of-view byte must lie above COST_MAX"
#endif
#ifdef COST_BYTES
typedef uchar cost_t;
#define STORE_COST(v, p, j) STORE_UC(TO_UCHAR16((v) < (short16)(0) ? (short16)(COST_OUT) : (v)), p, j)
#define LOAD_COST(p, j) load_cost_bytes(p, j)
#else
typedef short cost_t;
#define STORE_COST(v, p, j) STORE_S(v, p, j)
#define LOAD_COST(p, j) LOAD_S(p, j)
#endif
#define STORE_S(v, p, j) do { if ((j) < NV - 1) VSTORE(short, 16, (v), (p) + 16 * (j));             \
                              else store_last_short((v), (p) + 16 * (j)); } while (0)

// Right census codes interleaved along the row with the sub-pixel planes in reverse order,
// out[y - row0][x*steps + steps-1-f] = cr[f][y][x]: the right pixel of disparity sample t = n*steps + f
// at left column x is then index x*steps + steps-1 - t, consecutive (decreasing) in t.  Rows
// row0 .. row0 + global size(1) - 1 (the CPU matcher's coarse bands: a band's rows, not the image's).
// Columns x = global id 0 in steps of global size 0: a work-item per row on CPUs (global size 0
// of 1; a work-item per pixel took 3-5x as long on PoCL: 4.6 against 0.8 ms at 741 x 500), a
// work-item per pixel on GPUs.
__kernel void census_interleave(__global const ulong *cr, __global ulong *out, const int h, const int w,
                                const int steps, const int row0)
{
    const int y = row0 + (int)get_global_id(1);
    if (y >= h)
        return;
    const size_t plane = (size_t)h * w;
    for (int x = get_global_id(0); x < w; x += get_global_size(0)) {
        __global ulong *dst = out + ((size_t)(y - row0) * w + x) * steps + steps - 1;
        for (int f = 0; f < steps; ++f)
            dst[-f] = cr[f * plane + (size_t)y * w + x];
    }
}

#ifdef NIBBLES
// The right census codes as nibble planes (the CPU band matcher's block_cost with -D NIBBLES): row
// y - row0 of `out` is NIB_LEAD bytes of zeros, then NIB_PLANES planes of nib_plane(w, steps)
// bytes, plane p holding nibble p (bits 4p .. 4p + 3) of the code with the right pixel of sample t
// = n*steps + f at left column x at index q = (w - 1 - x + n)*steps + f: the reverse of
// census_interleave's order, so that a left pixel's samples are consecutive *increasing* bytes of
// every plane (one vector load per plane and 32 samples), and a nibble is a vpshufb index (the
// distance of a nibble pair is a 16-entry table lookup).  Each plane's tail past w*steps is zeros,
// so that a vector starting up to 31 bytes before a plane or inside it stays in the row.
#define NIB_PLANES 12                      // nibbles of the widest code: (2*3 + 1)^2 - 1 = 48 bits
#define NIB_LEAD 32
static inline size_t nib_plane(const int w, const int steps)
{
    return (size_t)(((w * steps + 31) / 32) * 32 + 32);
}
static inline size_t nib_row(const int w, const int steps)
{
    return NIB_LEAD + NIB_PLANES * nib_plane(w, steps);
}

__kernel void census_nibbles(__global const ulong *cr, __global uchar *out, const int h, const int w,
                             const int steps, const int row0)
{
    const int y = row0 + (int)get_global_id(1);
    if (y >= h)
        return;
    const size_t plane = (size_t)h * w, ps = nib_plane(w, steps);
    const int ws = w * steps;
    __global uchar *row = out + (size_t)(y - row0) * nib_row(w, steps);
    for (int i = 0; i < NIB_LEAD; ++i)
        row[i] = 0;
    row += NIB_LEAD;
    __global const ulong *src = cr + (size_t)y * w + w - 1;
    int xr = 0;
#if defined(STEPS)
    // 16 right pixels at a time (their STEPS * 16 codes gathered, each plane's bytes stored as
    // vectors: the byte-wise loop below took 20 cycles per code)
    for (; xr + 16 <= w; xr += 16, src -= 16) {
        ulong code[16 * STEPS];
        #pragma unroll
        for (int i = 0; i < 16; ++i)
            #pragma unroll
            for (int f = 0; f < STEPS; ++f)
                code[i * STEPS + f] = src[f * plane - i];
        __global uchar *dst = row + xr * STEPS;
        #pragma unroll
        for (int p = 0; p < NIB_PLANES; ++p) {
            #pragma unroll
            for (int v = 0; v < STEPS; ++v) {
                uchar16 b;
                __private uchar *bp = (__private uchar *)&b;
                #pragma unroll
                for (int m = 0; m < 16; ++m)
                    bp[m] = (uchar)((code[16 * v + m] >> (4 * p)) & 15);
                VSTORE(uchar, 16, b, dst + p * ps + 16 * v);
            }
        }
    }
#endif
    for (; xr < w; ++xr, --src) {        // right pixel w - 1 - xr
        for (int f = 0; f < steps; ++f) {
            const ulong code = src[f * plane];
            __global uchar *dst = row + xr * steps + f;
            #pragma unroll
            for (int p = 0; p < NIB_PLANES; ++p)
                dst[p * ps] = (uchar)((code >> (4 * p)) & 15);
        }
    }
    for (int p = 0; p < NIB_PLANES; ++p)
        for (int q = ws; q < (int)ps; ++q)
            row[p * ps + q] = 0;
}
#endif

// Hamming distances of the census codes, ham[i][x][k] = popcount(L[y][x] ^ R_f[y][x - n]) for the
// image row y = row0 + i and the disparity sample t = first_step + k = n*steps + f, or 0 where
// x - n is outside (never summed into a sample in view; uchar: the distances of 48-bit codes are
// at most 48).  row0 > 0: the rows of one band (launched over its rows only).
__kernel void census_hamming(__global const ulong *cl, __global const ulong *ri, __global uchar *ham,
                             const int h, const int w, const int first_step, const int steps,
                             const int row0)
{
    const int x = get_global_id(0), i = get_global_id(1), y = row0 + i;
    if (x >= w || y >= h)
        return;
    const int ws = w * steps;
    const ulong c = cl[(size_t)y * w + x];
    __global const ulong *row = ri + (size_t)y * ws;
    __global uchar *dst = ham + ((size_t)i * w + x) * N_DISP;
    const int j0 = x * steps + steps - 1 - first_step;          // right index of sample k is j0 - k
    const int k_hi = CLAMPI(j0 + 1, 0, N_DISP), k_lo = CLAMPI(j0 - ws + 1, 0, k_hi);
    int k = 0;
    for (; k < k_lo; ++k)
        dst[k] = 0;
    for (; k < k_hi; ++k)
        dst[k] = (uchar)POPCOUNT(c ^ row[j0 - k]);
    for (; k < N_DISP; ++k)
        dst[k] = 0;
}

// The block sum of the Hamming distances over the block x block window (clamped at the border):
// one work-item per row, a running sum along the row of the window's column sums (streaming
// through memory).  Exact integer sums (ushort: at most 15^2 * 48), saturated at COST_MAX.  Samples out of view (the right pixel's block not inside the image:
// k outside [k_lo, k_hi] at this x) are OUT_OF_VIEW.  Output row i is image row y0 + i; `ham`
// holds image rows ham_row0, ... (those of the band and its block margin).
static inline ushort16 window_column(__global const uchar *ham, const int y, const int x, const int h,
                                     const int w, const int r, const int j, const int ham_row0)
{
    ushort16 s = (ushort16)(0);
    for (int v = -r; v <= r; ++v) {
        __global const uchar *p = ham + ((size_t)(CLAMPI(y + v, 0, h - 1) - ham_row0) * w + x) * N_DISP;
        s += TO_USHORT16(LOAD_UC(p, j));
    }
    return s;
}

// The samples k of column x whose right pixel is in view: lo <= k <= hi (r <= x - n <= w - 1 - r,
// n = floor((first_step + k) / steps))
static inline void view_range(const int x, const int r, const int w, const int first_step, const int steps,
                              long *lo, long *hi)
{
    *hi = (long)(x - r + 1) * steps - 1 - first_step;
    *lo = (long)(x + r - (w - 1)) * steps - first_step;
}

// Whether every sample of column x is in view
static inline int all_in_view(const int x, const int r, const int w, const int first_step, const int steps,
                              const int n)
{
    long lo, hi;
    view_range(x, r, w, first_step, steps, &lo, &hi);
    return x >= 0 && x < w && lo <= 0 && hi >= n - 1;
}

// Output pixel x's block sums, shifted right by COST_SHIFT bits (spec.cost_shift of the block, defined by
// the launcher of every kernel that stores block costs) and saturated at COST_MAX, OUT_OF_VIEW where the
// sample is out of view: r <= x - n <= w - 1 - r with n = floor((first_step + k) / steps)
#if defined(BLOCK) && !defined(COST_SHIFT)
#error "kernels that store block costs are built with -D COST_SHIFT (gfgpu.stereo.spec.cost_shift)"
#endif
#ifdef COST_SHIFT
static ALWAYS_INLINE void store_block_costs(const ushort16 *sum, __global cost_t *dst, const int x, const int r,
                                            const int w, const int first_step, const int steps, const int n)
{
    const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    long lo, hi;
    view_range(x, r, w, first_step, steps, &lo, &hi);
    // samples n .. N_DISP - 1 (a bucket's padding) are out of view
    const short16 k_hi = (short16)((short)CLAMPI(IMIN(hi, (long)n - 1), -1L, (long)N_DISP));
    const short16 k_lo = (short16)((short)CLAMPI(lo, -1L, (long)N_DISP));
    // every sample in view (most pixels): no mask (a bucket's padding samples n .. then hold sums that
    // every reader masks as padding: sgm_band's path_vec and the selection)
    if (lo <= 0 && hi >= n - 1) {
        UNROLL_NV
        for (int j = 0; j < NV; ++j)
            STORE_COST(VMIN(as_short16(sum[j] >> (ushort16)(COST_SHIFT)), (short16)(COST_MAX)), dst, j);
        return;
    }
    UNROLL_NV
    for (int j = 0; j < NV; ++j) {
        const short16 k = lane + (short16)(16 * j);
        const short16 c = VMIN(as_short16(sum[j] >> (ushort16)(COST_SHIFT)), (short16)(COST_MAX));
        STORE_COST((k < k_lo) | (k > k_hi) ? (short16)(OUT_OF_VIEW) : c, dst, j);
    }
}

__kernel void block_sum(__global const uchar *ham, __global cost_t *out, const int h, const int w,
                        const int block, const int first_step, const int steps, const int y0,
                        const int rows, const int ham_row0, const int out_row0)
{
    const int i = get_global_id(0), y = y0 + i;
    if (i >= rows || y >= h)
        return;
    const int r = block / 2;
    ushort16 sum[NV];
    UNROLL_NV
    for (int j = 0; j < NV; ++j) {
        sum[j] = (ushort16)(0);
        for (int u = -r; u <= r; ++u)
            sum[j] += window_column(ham, y, CLAMPI(u, 0, w - 1), h, w, r, j, ham_row0);
    }
    __global cost_t *dst = out + (size_t)(out_row0 + i) * w * N_DISP;
    for (int x = 0; x < w; ++x, dst += N_DISP) {
        const int add = IMIN(x + r, w - 1), sub = IMAX(x - 1 - r, 0);
        const int moved = x > 0 && add != sub;     // the window moved to columns [x-r, x+r] (clamped)
        UNROLL_NV
        for (int j = 0; j < NV; ++j)
            if (moved)
                sum[j] += window_column(ham, y, add, h, w, r, j, ham_row0) -
                          window_column(ham, y, sub, h, w, r, j, ham_row0);
        store_block_costs(sum, dst, x, r, w, first_step, steps, N_DISP);
    }
}
#endif  // COST_SHIFT

// The block cost straight from the census codes, without a Hamming volume (built with -D BLOCK=b):
// work-item g of `splits` takes the columns [g w / splits, (g + 1) w / splits) of every output row
// y0 .. y0 + rows - 1, going down.  The Hamming distances of the block's b rows (columns widened
// by the block's margin) live in a ring of b row slots in `scratch`: slot t mod b holds virtual
// row t = y + v (image row clamp(t), so border rows repeat as the clamped window repeats them);
// each row's distances are computed once (one popcount per sample, b at a band's first row) and
// summed b times as byte vectors.  The window sum runs along the row: + the column entering,
// - the column leaving (the same column at a clamped border: no change).  Same values as
// census_hamming + block_sum.
#ifdef BLOCK
#if defined(__clang__) && defined(__AVX2__)
// x86 with AVX2 (PoCL on the host CPU): 16 Hamming distances at once with a nibble lookup
// table (vpshufb) and byte sums (vpsadbw), 2.8 instructions per distance instead of 7 (the
// CPU has no vector popcount below AVX-512)
typedef char v32c __attribute__((__vector_size__(32)));
typedef char v16c __attribute__((__vector_size__(16)));
typedef char v8c __attribute__((__vector_size__(8)));
typedef ulong v4ul __attribute__((__vector_size__(32)));
typedef ulong v4ul_u __attribute__((__vector_size__(32), __aligned__(8)));
typedef char v16c_u __attribute__((__vector_size__(16), __aligned__(1)));

static ALWAYS_INLINE v4ul popcount4(const v4ul x)
{
    const v32c lut = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4,
                      0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    const ulong m = 0x0f0f0f0f0f0f0f0fUL;
    const v4ul low = {m, m, m, m}, zero = {0, 0, 0, 0};
    const v32c c = __builtin_ia32_pshufb256(lut, (v32c)(x & low)) +
                   __builtin_ia32_pshufb256(lut, (v32c)((x >> 4) & low));
    return (v4ul)__builtin_ia32_psadbw256(c, (v32c)zero);
}

// dst[i] = popcount(lc ^ p[15 - i]), i = 0 .. 15
static ALWAYS_INLINE void hamming16_reversed(__global uchar *dst, const ulong lc, __global const ulong *p)
{
    const v4ul key = {lc, lc, lc, lc};
    const v4ul s0 = popcount4(*(__global const v4ul_u *)p ^ key);
    const v4ul s1 = popcount4(*(__global const v4ul_u *)(p + 4) ^ key);
    const v4ul s2 = popcount4(*(__global const v4ul_u *)(p + 8) ^ key);
    const v4ul s3 = popcount4(*(__global const v4ul_u *)(p + 12) ^ key);
    // byte 8 q of s_t: the distance of p[4 t + q]
    const v8c hi = __builtin_shufflevector((v32c)s3, (v32c)s2, 24, 16, 8, 0, 56, 48, 40, 32);
    const v8c lo = __builtin_shufflevector((v32c)s1, (v32c)s0, 24, 16, 8, 0, 56, 48, 40, 32);
    *(__global v16c_u *)dst = __builtin_shufflevector(hi, lo, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13,
                                                      14, 15);
}
#define HAMMING16 1
#endif
#if defined(HAMMING16) && defined(VPOPCNTQ)
// with AVX512-VPOPCNTDQ (-D VPOPCNTQ: the launcher found it on the host CPU that PoCL runs on):
// 8 distances per instruction, then packed to bytes
#undef HAMMING16_FN
typedef ulong v8ul __attribute__((__vector_size__(64)));
typedef ulong v8ul_u __attribute__((__vector_size__(64), __aligned__(8)));
typedef long v8l __attribute__((__vector_size__(64)));
typedef uchar v8uc __attribute__((__vector_size__(8)));
typedef uchar v16uc_u __attribute__((__vector_size__(16), __aligned__(1)));
#define VPOP_TARGET __attribute__((target("avx512f,avx512vpopcntdq,avx512bw,avx512vl")))
static ALWAYS_INLINE VPOP_TARGET void hamming16_vpop(__global uchar *dst, const ulong lc, __global const ulong *p)
{
    const v8ul key = {lc, lc, lc, lc, lc, lc, lc, lc};
    const v8uc a = __builtin_convertvector((v8ul)__builtin_ia32_vpopcntq_512(
        (v8l)(*(__global const v8ul_u *)p ^ key)), v8uc);
    const v8uc b = __builtin_convertvector((v8ul)__builtin_ia32_vpopcntq_512(
        (v8l)(*(__global const v8ul_u *)(p + 8) ^ key)), v8uc);
    *(__global v16uc_u *)dst = __builtin_shufflevector(b, a, 7, 6, 5, 4, 3, 2, 1, 0, 15, 14, 13, 12, 11, 10, 9, 8);
}
#define hamming16_reversed hamming16_vpop
#else
#define VPOP_TARGET
#endif

static VPOP_TARGET void hamming_row(__global uchar *dst, __global const ulong *cl, __global const ulong *ri, const int y,
                        const int ca, const int cb, const int w, const int first_step, const int steps,
                        const int n, const int ri_row0)
{
    const int ws = w * steps;
    for (int c = ca; c < cb; ++c, dst += NP) {
        const int j0 = c * steps + steps - 1 - first_step;      // right code of sample k: j0 - k
        const int k_hi = CLAMPI(j0 + 1, 0, n), k_lo = CLAMPI(j0 - ws + 1, 0, k_hi);
        const ulong lc = cl[(size_t)y * w + c];
        __global const ulong *row = ri + (size_t)(y - ri_row0) * ws;     // ri holds rows ri_row0, ...
        int k = 0;
        for (; k < k_lo; ++k)
            dst[k] = 0;
#ifdef HAMMING16
        for (; k + 16 <= k_hi; k += 16)
            hamming16_reversed(dst + k, lc, row + j0 - k - 15);
        // the last, partial vector whole where all its 16 codes exist (the ring's lanes past
        // N_DISP are padding, never read as costs): no scalar tail of up to 15 samples
        if (k < k_hi && k + 15 <= j0 && k + 16 <= NP) {
            hamming16_reversed(dst + k, lc, row + j0 - k - 15);
            k = k_hi;
        }
#endif
        for (; k < k_hi; ++k)
            dst[k] = (uchar)POPCOUNT(lc ^ row[j0 - k]);
        for (; k < NP; ++k)
            dst[k] = 0;
    }
}

// the block's column c (index c - ca of the ring's rows), vector j: the sum of its BLOCK rows
static ALWAYS_INLINE ushort16 ring_column(__global const uchar *ring, const size_t slot, const int c, const int j)
{
    ushort16 s = (ushort16)(0);
    #pragma unroll
    for (int v = 0; v < BLOCK; ++v)
        s += TO_USHORT16(*(__global const uchar16 *)(ring + v * slot + (size_t)c * NP + 16 * j));
    return s;
}

// the column sums' slots: the last BLOCK + 1 columns entered, column c in slot c mod (BLOCK + 1)
#define COLSUM_SLOTS (BLOCK + 1)

#ifdef NIBBLES
// block_cost of a 3 x 3 block (COST_SHIFT 0) from the nibble planes of census_nibbles (in `ri`), for
// x86 CPUs with AVX2 (the launcher builds it only there): 32 samples per vector.  The Hamming
// distances of a row's column: 12 vpshufb lookups (one per nibble plane, the table of the left
// code's nibble: popcount(l ^ r) = T_l[r]) and byte adds per 32 samples, ~1.4 instructions per
// distance with the addressing (popcount4's ~2.8).  The block sum: each column's three rows added
// as bytes (at most 3 * 48 = 144, exact) into a slot as the column enters the window, then the three
// columns with saturating byte adds and the minimum with COST_MAX: min(sum, 255) then
// min(., COST_MAX) is min(sum, COST_MAX), the cost without a shift.  No 16-bit sums, no running
// sum carried in (spilled) registers.
#if !defined(__clang__) || !defined(__AVX2__) || BLOCK != 3 || COST_SHIFT != 0 || !defined(COST_BYTES) || \
    !defined(PADDED_PIXELS)
#error "NIBBLES: block_cost of 3 x 3 byte costs, padded pixels, on an x86 CPU with AVX2 (clang)"
#endif
typedef uchar v32u __attribute__((__vector_size__(32)));
typedef uchar v32u_u __attribute__((__vector_size__(32), __aligned__(1)));
typedef uchar v16u_u __attribute__((__vector_size__(16), __aligned__(1)));
#define V32(x) {x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x}
#define LOAD32(p) (*(__global const v32u_u *)(p))
// 32 bytes at p, or the first 16 where only 16 lanes of the pixel remain (NP % 32 = 16)
#define STORE32(v, p, k) do { if ((k) + 32 <= NP) *(__global v32u_u *)(p) = (v);                          \
                              else *(__global v16u_u *)(p) = __builtin_shufflevector((v), (v), 0, 1, 2, 3, \
                                  4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15); } while (0)

// dst[k] = popcount(code of left pixel c ^ code of sample k's right pixel), k = 0 .. NP - 1, for the
// columns c = ca .. cb - 1 of image row y; samples whose right pixel is outside the image get any
// value (never summed into a sample in view; the cost stores mark those out of view), vectors
// wholly outside 0 (the loads stay inside the row: census_nibbles' margins)
static ALWAYS_INLINE void nibble_row(__global uchar *dst, __global const ulong *cl, __global const uchar *nib,
                                     const int y, const int ca, const int cb, const int w, const int first_step,
                                     const int steps, const int n, const int ri_row0, const __private v32c *tables)
{
    const int ws = w * steps;
    const size_t ps = nib_plane(w, steps);
    __global const uchar *row = nib + (size_t)(y - ri_row0) * nib_row(w, steps) + NIB_LEAD;
    for (int c = ca; c < cb; ++c, dst += NP) {
        const ulong lc = cl[(size_t)y * w + c];
        const int base = (w - 1 - c) * steps + first_step;         // the index of sample 0
        v32c tab[NIB_PLANES];
        #pragma unroll
        for (int p = 0; p < NIB_PLANES; ++p)
            tab[p] = tables[(lc >> (4 * p)) & 15];
        UNROLL_NV
        for (int k = 0; k < NP; k += 32) {
            const int s = base + k;
            v32c acc = V32(0);
            if (k < n && s > -32 && s < ws) {
                __global const uchar *q = row + s;
                #pragma unroll
                for (int p = 0; p < NIB_PLANES; ++p)
                    acc += __builtin_ia32_pshufb256(tab[p], (v32c)LOAD32(q + p * ps));
            }
            STORE32((v32u)acc, dst + k, k);
        }
    }
}

__kernel void block_cost(__global const ulong *cl, __global const uchar *ri, __global cost_t *out,
                         __global uchar *scratch, const int h, const int w, const int first_step,
                         const int steps, const int y0, const int rows, const int out_row0, const int splits,
                         const int slot_cols, const int n_valid, const int ri_row0)
{
    const int g = get_global_id(0);
    if (g >= splits)
        return;
    const int xa = (int)((long)g * w / splits), xb = (int)((long)(g + 1) * w / splits);
    const int ca = IMAX(xa - 1, 0), cb = IMIN(xb + 1, w);
    const size_t slot = (size_t)slot_cols * NP;
    __global uchar *ring = scratch + (size_t)g * (3 * slot + 2 * COLSUM_SLOTS * NP);
    // the three-row sums of the last columns entered, column c in slot c & 3 (the colsum region)
    __global uchar *vs = ring + 3 * slot;
    const v32u cmax = V32(COST_MAX), out_mark = V32(COST_OUT);
    const v32c lanes = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23,
                        24, 25, 26, 27, 28, 29, 30, 31};
    // the 16 tables T_l[r] = popcount(l ^ r) of a left nibble l, in both 128-bit lanes (vpshufb
    // looks up within each): a column's 12 are loads, not 12 broadcasts, xors and shuffles
    v32c tables[16];
    const v32c lut = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    const v32c iota = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
                       0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    for (int l = 0; l < 16; ++l) {
        const v32c lv = V32((char)l);
        tables[l] = __builtin_ia32_pshufb256(lut, iota ^ lv);
    }
    for (int i = 0; i < rows; ++i) {
        const int y = y0 + i;
        for (int t = i == 0 ? y - 1 : y + 1; t <= y + 1; ++t)
            nibble_row(ring + (((t % 3) + 3) % 3) * slot, cl, ri, CLAMPI(t, 0, h - 1), ca, cb, w, first_step,
                       steps, n_valid, ri_row0, tables);
        // the window's columns clamp(x - 1), x, clamp(x + 1): the first two entered before x = xa
        for (int c = IMAX(xa - 1, 0); c <= xa; ++c) {
            __global const uchar *r0 = ring + (size_t)(c - ca) * NP;
            UNROLL_NV
            for (int k = 0; k < NP; k += 32)
                STORE32(LOAD32(r0 + k) + LOAD32(r0 + slot + k) + LOAD32(r0 + 2 * slot + k),
                        vs + (size_t)(c & 3) * NP + k, k);
        }
        __global cost_t *dst = out + ((size_t)(out_row0 + i) * w + xa) * PIX;
        for (int x = xa; x < xb; ++x, dst += PIX) {
            const int cp = IMIN(x + 1, w - 1);
            __global const uchar *va = vs + (size_t)(IMAX(x - 1, 0) & 3) * NP, *vb = vs + (size_t)(x & 3) * NP;
            __global uchar *vc = vs + (size_t)(cp & 3) * NP;
            __global const uchar *r0 = ring + (size_t)(cp - ca) * NP;
            long lo, hi;
            view_range(x, 1, w, first_step, steps, &lo, &hi);
            const int masked = !(lo <= 0 && hi >= n_valid - 1);
            const long k_lo = lo, k_hi = hi < (long)n_valid - 1 ? hi : (long)n_valid - 1;
            UNROLL_NV
            for (int k = 0; k < NP; k += 32) {
                // column cp's three rows (x = w - 1: its own, already in its slot)
                v32u c3 = LOAD32(vc + k);
                if (cp != x) {
                    c3 = LOAD32(r0 + k) + LOAD32(r0 + slot + k) + LOAD32(r0 + 2 * slot + k);
                    STORE32(c3, vc + k, k);
                }
                v32u sum = __builtin_elementwise_min(
                    __builtin_elementwise_add_sat(__builtin_elementwise_add_sat(LOAD32(va + k), LOAD32(vb + k)), c3),
                    cmax);
                if (masked) {
                    // lanes k + i in view: k_lo <= k + i <= k_hi (COST_OUT elsewhere)
                    const char a = (char)CLAMPI(k_lo - k, 0L, 32L), b = (char)CLAMPI(k_hi - k + 1, 0L, 32L);
                    const v32c va_ = V32(a), vb_ = V32(b);
                    const v32c in_view = (v32c)((lanes >= va_) & (lanes < vb_));
                    sum = (sum & (v32u)in_view) | (out_mark & ~(v32u)in_view);
                }
                STORE32(sum, dst + k, k);
            }
        }
    }
}
#else
__kernel VPOP_TARGET void block_cost(__global const ulong *cl, __global const ulong *ri, __global cost_t *out,
                         __global uchar *scratch, const int h, const int w, const int first_step,
                         const int steps, const int y0, const int rows, const int out_row0, const int splits,
                         const int slot_cols, const int n_valid, const int ri_row0)
{
    const int g = get_global_id(0), r = BLOCK / 2;
    if (g >= splits)
        return;
    const int xa = (int)((long)g * w / splits), xb = (int)((long)(g + 1) * w / splits);
    const int ca = IMAX(xa - r, 0), cb = IMIN(xb + r, w);
    const size_t slot = (size_t)slot_cols * NP;
    // per column range: BLOCK row slots, then the column sums' COLSUM_SLOTS (ushort)
    __global uchar *ring = scratch + (size_t)g * (BLOCK * slot + 2 * COLSUM_SLOTS * NP);
    // the column sums of the ring (ushort) in COLSUM_SLOTS slots, computed as a column enters the
    // window and read again as it leaves it (BLOCK + 1 columns later at most; the column entering
    // at a clamped right border is the one already there): cache-resident, no row of them
    __global ushort *colsum = (__global ushort *)(ring + BLOCK * slot);
    for (int i = 0; i < rows; ++i) {
        const int y = y0 + i;
        // the rows entering the window: all b at the first row, then y + r
        for (int t = i == 0 ? y - r : y + r; t <= y + r; ++t) {
            const int sl = ((t % BLOCK) + BLOCK) % BLOCK;
            hamming_row(ring + sl * slot, cl, ri, CLAMPI(t, 0, h - 1), ca, cb, w, first_step, steps, n_valid,
                        ri_row0);
        }
        ushort16 sum[NV];
        UNROLL_NV
        for (int j = 0; j < NV; ++j)
            sum[j] = (ushort16)(0);
        // the window of x = xa: columns clamp(xa - r .. xa + r), each distinct one into its slot
        for (int c = IMAX(xa - r, 0); c <= IMIN(xa + r, w - 1); ++c) {
            __global ushort *cs = colsum + (size_t)(c % COLSUM_SLOTS) * NP;
            UNROLL_NV
            for (int j = 0; j < NV; ++j)
                VSTORE(ushort, 16, ring_column(ring, slot, c - ca, j), cs + 16 * j);
        }
        for (int u = -r; u <= r; ++u) {
            __global const ushort *cs = colsum + (size_t)(CLAMPI(xa + u, 0, w - 1) % COLSUM_SLOTS) * NP;
            UNROLL_NV
            for (int j = 0; j < NV; ++j)
                sum[j] += VLOAD(ushort, 16, cs + 16 * j);
        }
        __global cost_t *dst = out + ((size_t)(out_row0 + i) * w + xa) * PIX;
        for (int x = xa; x < xb; ++x, dst += PIX) {
            const int add = IMIN(x + r, w - 1), sub = IMAX(x - 1 - r, 0);
            if (x > xa && add != sub) {
                __global ushort *pa = colsum + (size_t)(add % COLSUM_SLOTS) * NP;
                __global const ushort *ps = colsum + (size_t)(sub % COLSUM_SLOTS) * NP;
                UNROLL_NV
                for (int j = 0; j < NV; ++j) {
                    const ushort16 in = ring_column(ring, slot, add - ca, j);
                    sum[j] += in - VLOAD(ushort, 16, ps + 16 * j);
                    VSTORE(ushort, 16, in, pa + 16 * j);
                }
            }
            store_block_costs(sum, dst, x, r, w, first_step, steps, n_valid);
        }
    }
}
#endif  // NIBBLES
#endif  // BLOCK

static inline short hmin16(const short16 v)
{
    const short8 a = VMIN(v.lo, v.hi);
    const short4 b = VMIN(a.lo, a.hi);
    const short2 c = VMIN(b.lo, b.hi);
    return VMIN(c.x, c.y);
}

// hmin16 of lanes that are all 0 .. SHRT_MAX (their unsigned minimum is the minimum): on x86 with
// SSE4.1 one vpminuw and one phminposuw, about 9 instructions less than hmin16's shuffles (the
// selection's three minima per pixel, the band sweeps' one per path and pixel)
#if defined(__clang__) && defined(__SSE4_1__)
typedef short v8s_ __attribute__((__vector_size__(16)));
static inline short hmin16_nonneg(const short16 v)
{
    const ushort8 a = VMIN(as_ushort8(v.lo), as_ushort8(v.hi));
    const v8s_ r = __builtin_ia32_phminposuw128(__builtin_astype(a, v8s_));
    return r[0];
}
#else
#define hmin16_nonneg hmin16
#endif

// One sweep of the path recursion along a line of `len` pixels starting at element `base`,
// `stride` elements per pixel; total = L_r (accumulate = 0) or total + L_r.  Samples out of view
// (cost < 0) have path value PAD_COST (never a minimum, no neighbour) and total OUT_OF_VIEW; a sample
// entering the view takes the predecessor's minimum as its own predecessor (L = C).  Path values
// of samples in view stay below PAD_COST (at most COST_MAX + P2: the launcher keeps P1 and P2 within
// _PENALTY_MAX, gfgpu/stereo/_opencl.py).
static ALWAYS_INLINE void sgm_sweep(__global const short *cost, __global short *total, long base,
                                     const long stride, const int len, const short p1, const short p2,
                                     const int accumulate)
{
    const short16 pad = (short16)(PAD_COST), vp1 = (short16)(p1);
    const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const short16 is_pad = lane >= (short16)(TAIL);
    short16 prev[NV];
    short m = PAD_COST;
    for (int t = 0; t < len; ++t, base += stride) {
        __global const short *c = cost + base;
        __global short *tot = total + base;
        const short16 vm = (short16)(m), jump = (short16)(m + p2);
        short16 before = pad, mv = pad;
        UNROLL_NV
        for (int j = 0; j < NV; ++j) {
            const short16 cv = LOAD_S(c, j);
            short16 cur = cv;
            if (t > 0) {
                // L(d) = C(d) + min(L'(d), L'(d-1) + P1, L'(d+1) + P1, m' + P2) - m'
                const short16 old = prev[j];
                const short16 next = j + 1 < NV ? prev[j + 1] : pad;
                const short16 lower = (short16)(before.sf, old.s0123, old.s4567, old.s89ab, old.scde);
                const short16 upper = (short16)(old.s1234, old.s5678, old.s9abc, old.sdef, next.s0);
                const short16 step = VMIN(lower, upper) + vp1;
                const short16 stay = VMIN(old >= pad ? vm : old, step);
                cur += VMIN(stay, jump) - vm;
                before = old;
            }
            const short16 out_of_view = cv < (short16)(0);
            cur = out_of_view ? pad : cur;
            if (j == NV - 1)
                cur = is_pad ? pad : cur;
            prev[j] = cur;
            mv = VMIN(mv, cur);
            STORE_S(out_of_view ? (short16)(OUT_OF_VIEW) : accumulate ? LOAD_S(tot, j) + cur : cur, tot, j);
        }
        m = hmin16(mv);
    }
}

// Semi-global aggregation along direction (dy, dx) and its opposite: one work-item per line of
// pixels entering the image where (x - dx, y - dy) is outside; the line is swept forward, then
// backward while it is still in cache.  total = L_r + L_-r (accumulate = 0) or total + both.
__kernel void sgm_line_pair(__global const short *cost, __global short *total, const int h, const int w,
                            const int dy, const int dx, const short p1, const short p2,
                            const int accumulate)
{
    int x, y;
    const int len = path_line(get_global_id(0), h, w, dy, dx, &y, &x);
    if (len == 0) return;
    const long stride = ((long)dy * w + dx) * N_DISP;
    const long first = ((long)y * w + x) * N_DISP;
    sgm_sweep(cost, total, first, stride, len, p1, p2, accumulate);
    sgm_sweep(cost, total, first + (len - 1) * stride, -stride, len, p1, p2, 1);
}

#define CELL (NP + 16)                     // a state cell: NP values, then a gap of PAD_COST

// Vector j of one pixel of one path: the predecessor's vectors at `in` (a state cell, PAD_COST
// before and after it, so d - 1 and d + 1 are unaligned loads, no shuffles), its minimum `vm`:
// L = C + min(L', L'(d-1) + P1, L'(d+1) + P1, m' + P2) - m' = C + min(min(L', ...) - m', P2);
// a predecessor of zeros (m' = 0) gives L = C, a path's first pixel.  Samples out of view (C < 0)
// get PAD_COST (never a minimum, no neighbour) and add nothing to `sum`; one entering the view
// takes m' as its own predecessor (L = C).  Returns the new vector (min'd into `run`, added to
// `sum`); the caller stores it only after reading vector j + 1 (`in` and the output may be one
// cell, and vector j + 1 reads lane 16 j + 15 of the predecessor): one vector per path is live,
// not a pixel's NV (which spilled from registers and made the sweep super-linear in N_DISP).
static ALWAYS_INLINE short16
path_vec(__global const short *in, const int j, const short16 vm, const short16 cv, short16 *run,
         short16 *sum, const short16 vp1, const short16 vp2, const int enter, const int masked, const int n)
{
    const short16 pad = (short16)(PAD_COST);
    const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const short16 old = VLOAD(short, 16, in + 16 * j);
    const short16 lower = VLOAD(short, 16, in + 16 * j - 1);
    const short16 upper = VLOAD(short, 16, in + 16 * j + 1);
    const short16 stay = VMIN(enter ? (old >= pad ? vm : old) : old, VMIN(lower, upper) + vp1);
    const short16 out_of_view = cv < (short16)(0);
    short16 v = cv + VMIN(stay - vm, vp2);
    if (masked)
        v = out_of_view ? pad : v;
    if (j >= NV_FULL)      // the lanes past the last sample: padding
        v = lane >= (short16)(n - 16 * j) ? pad : v;
    *run = VMIN(*run, v);
    *sum += masked ? (out_of_view ? (short16)(0) : v) : v;
    return v;
}

// path_vec for path P (in, vm, out, pending vector, running minimum) and the store of its
// previous vector after the reads
#define PATH_STEP(P, j, ENTER, MASKED)                                                         \
    do {                                                                                      \
        const short16 v_ = path_vec(in_##P, (j), vm_##P, cv, &run_##P, &sum, vp1, vp2, (ENTER),  \
                                    (MASKED), n_valid);                                       \
        if ((j) > 0)                                                                          \
            VSTORE(short, 16, pend_##P, out_##P + 16 * ((j) - 1));                            \
        pend_##P = v_;                                                                        \
    } while (0)

// One pixel of sgm_band: the paths' vectors j = 0 .. NV - 1 (MASKED: samples out of view or
// entering it may occur; COST(c, j): the cost vector; WRITE: the horizontal path and the sum;
// DIAG: the diagonals).  The interior's 4-path sweeps get WRITE and DIAG as constants: no test
// per vector (band sweeps of 1000 x 1500 x 383 -6 %, of teddy -16 %)
#define BAND_PIXEL(MASKED, COST, WRITE, DIAG)                                                  \
    do {                                                                                      \
        UNROLL_NV                                                                             \
        for (int j = 0; j < NV; ++j) {                                                        \
            const short16 cv = COST;                                                          \
            short16 sum = (short16)(0);                                                       \
            if (WRITE)                                                                        \
                PATH_STEP(h, j, MASKED, MASKED);                                              \
            PATH_STEP(v, j, 0, MASKED);                                                       \
            if (DIAG) {                                                                       \
                PATH_STEP(e, j, MASKED, MASKED);                                              \
                PATH_STEP(d, j, MASKED, MASKED);                                              \
            }                                                                                 \
            if (WRITE)                                                                        \
                STORE_S((MASKED) ? (cv < (short16)(0) ? (short16)(OUT_OF_VIEW) : sum) : sum, o, j); \
        }                                                                                     \
    } while (0)


// Semi-global aggregation of a band of rows in two sweeps (for CPUs, as OpenCV's SGBM); the band's
// byte costs are in `cost` (image row y0 + i at row cost_row0 + i).  Work-item 0 goes down the band's rows, each left
// to right, with the paths (0,1), (1,0) [, (1,1), (1,-1)] and writes their sum to sum_down;
// work-item 1 goes up, right to left, with the opposite paths, to sum_up (each row stored right to
// left: column x at w - 1 - x, so that the up sweep writes, and the selection reads, upwards in
// memory).  The path costs of the
// previous pixels live in `state` (per work-item 5 rows of w + 2 cells: horizontal, vertical,
// diagonal from x + s, and the diagonal from x - s double-buffered by the row's parity; guard
// cells of zeros at both ends) and their minima in `state_min` (4 rows); reading a guard or the
// initial zeros is a path's first pixel.  The states persist between launches, so a band goes on
// with the sweep of the band before it; bit p of `init` zeroes work-item p's state first (its
// sweep enters the image here), bit p of `active` runs work-item p.  write_up = 0: work-item 1
// only advances its vertical and diagonal paths (a checkpointing sweep: no horizontal path, no
// output; `split` runs it on both work-items).  Memory O(band rows x w x N_DISP) whatever the
// image's height.
// Work-item 1's vertical and diagonal states (its state rows 1 .. 4 and minima rows 0 .. 3; 1 and
// 0 only with 4 paths) are a *region*: its own rows in `state` / `state_min` (index -1) or a slot
// of the checkpoints `ckpt` / `ckpt_min` (index s >= 0: `ck_rows` state rows and minima rows each,
// laid out as those rows).  The sweep reads its first row's predecessors from region `src` and
// writes every row's states to region `dst` (the rows after the first read `dst`): a checkpointing
// sweep writes the next checkpoint while it sweeps, and a band's up sweep runs in the slot it
// starts from, which is then spent -- no copies of states between launches.  A slot's guard lanes
// and guard cells are written once by sgm_guards, never by a sweep; init zeroes region `src`.
#ifdef COST_BYTES
static inline short16 load_cost_bytes(__global const uchar *p, const int j)
{
    const short16 v = TO_SHORT16(LOAD_UC(p, j));
    return v == (short16)(COST_OUT) ? (short16)(OUT_OF_VIEW) : v;
}

__kernel void sgm_band(__global const cost_t *cost, __global short *sum_down, __global short *sum_up,
                       __global short *state, __global short *state_min, const int h, const int w,
                       const int y0, const int rows, const short p1, const short p2,
                       const int diagonals, const int init, const int active, const int write_up,
                       const int cost_row0, const int split, const int r, const int first_step,
                       const int steps, const int tile, __global short *bound, const int n_valid,
                       __global short *ckpt, __global short *ckpt_min, const int ck_rows, const int src,
                       const int dst, const int chain)
{
    // split = 1 (a checkpointing sweep of 4 paths: the vertical path alone, column-local): both
    // work-items sweep up, work-item g on the columns [g w / 2, (g + 1) w / 2); the state is
    // then initialised by an earlier launch (init is ignored)
    const int gid = get_global_id(0), pass = split ? 1 : gid;
    if (gid > 1 || (!split && !((active >> gid) & 1)))
        return;
    const int xa = split ? gid * (w / 2) : 0, xb = split && gid == 0 ? w / 2 : w;
    const int write = pass == 0 || write_up;
    __global short *out = pass == 0 ? sum_down : sum_up;
    const size_t cells = (size_t)(w + 2), row = 16 + cells * CELL;
    __global short *st = state + (size_t)pass * 5 * row;
    __global short *mins = state_min + (size_t)pass * 4 * cells;
    // the regions of the vertical and diagonal states (row 1 of st and row 0 of mins, or a slot)
    __global short *reg_src = pass == 1 && src >= 0 ? ckpt + (size_t)src * ck_rows * row : st + row;
    __global short *reg_dst = pass == 1 && dst >= 0 ? ckpt + (size_t)dst * ck_rows * row : st + row;
    __global short *min_src = pass == 1 && src >= 0 ? ckpt_min + (size_t)src * ck_rows * cells : mins;
    __global short *min_dst = pass == 1 && dst >= 0 ? ckpt_min + (size_t)dst * ck_rows * cells : mins;
    // a chained checkpointing sweep (pass 1 writing slots, chain > 0): the rows in groups of
    // `chain` from the band's top, group g written to slot dst + g, its first row (its bottom)
    // reading the predecessors of slot dst + g + 1 (the last group: region src) -- the states at
    // the tops of several bands in one launch, as launches of one group each would leave them
    const int links = pass == 1 && dst >= 0 && chain > 0 ? chain : rows;
    const int last_link = (rows - 1) / links;
    const size_t slot_step = (size_t)ck_rows * row, min_step = (size_t)ck_rows * cells;
    if (!split && ((init >> pass) & 1)) {
        // (never with split: the vertical path reads the last guard lane of the cell before
        // its first, which the other work-item would be writing)
        // (4 paths: the horizontal and vertical rows only; the diagonals' rows are never read,
        // and untouched they take no memory)
        for (size_t q = 0; q < (diagonals ? 5 : 2); ++q) {
            __global short *p = q == 0 ? st : reg_src + (q - 1) * row;
            for (int i = 0; i < 16; ++i)
                p[i] = PAD_COST;
            for (size_t c = 0; c < cells; ++c) {
                for (int i = 0; i < NP; ++i)
                    p[16 + c * CELL + i] = 0;
                for (int i = NP; i < CELL; ++i)
                    p[16 + c * CELL + i] = PAD_COST;
            }
        }
        for (size_t i = 0; i < (diagonals ? 4 : 1) * cells; ++i)
            min_src[i] = 0;
    }
    __global short *sh = st + 16;
    // A state row's cells in the sweep's order: column x in cell x + 1 going right (work-item
    // 0), in cell w - x going left, so that both sweeps walk their states (and the path
    // predecessors) upwards in memory: descending, the up sweep took 35 % longer than the down
    // sweep (1000 x 1500 x 383)
    // 4 paths: the columns in tiles of `tile`, all the band's rows of a tile before the next, so
    // that the tile's vertical states stay in cache (a row of them exceeds L2 on wide images);
    // each row's horizontal path goes on across a tile's edge from `bound` (the row's last
    // vector cell and minimum).  The diagonals need the whole previous row: one tile.
    const int ncol = xb - xa, tw = diagonals ? ncol : IMAX(1, IMIN(tile, ncol));
    __global short *bnd = bound + (size_t)gid * rows * (NP + 1);
    for (int t0 = 0; t0 < ncol; t0 += tw) {
      const int tn = IMIN(tw, ncol - t0);
      for (int i = 0; i < rows; ++i) {
        const int bi = pass == 0 ? i : rows - 1 - i, y = y0 + bi;
        // the predecessors: the first row's in region src, the others' in region dst (chained:
        // group g's first row's in group g + 1's slot, the last group's first row's in src)
        const int link = bi / links, head = i == 0 || (pass == 1 && bi % links == links - 1);
        __global short *g_dst = reg_dst + link * slot_step, *gm_dst = min_dst + link * min_step;
        __global short *g_src = link == last_link ? reg_src : g_dst + slot_step;
        __global short *gm_src = link == last_link ? min_src : gm_dst + min_step;
        __global short *sv_in = (head ? g_src : g_dst) + 16, *sv_out = g_dst + 16;
        __global short *se_in = sv_in + row, *se_out = sv_out + row;
        __global short *mv_in = head ? gm_src : gm_dst, *mv_out = gm_dst;
        __global short *me_in = mv_in + cells, *me_out = mv_out + cells;
        // the diagonal from x - s: read the buffer of the previous row's parity, write this row's
        const int in_buf = 1 + ((y & 1) ^ 1), out_buf = 1 + (y & 1);
        __global short *sd_in = se_in + in_buf * row, *sd_out = se_out + out_buf * row;
        __global short *md_in = me_in + in_buf * cells, *md_out = me_out + out_buf * cells;
        short mh = 0;
        if (write && t0 > 0) {      // the predecessor's cell of the tile's first pixel
            __global short *c = sh + (size_t)(pass == 0 ? xa + t0 : w - xb + t0) * CELL;
            for (int q = 0; q < NP; ++q)
                c[q] = bnd[(size_t)i * (NP + 1) + q];
            mh = bnd[(size_t)i * (NP + 1) + NP];
        }
        for (int xi = t0; xi < t0 + tn; ++xi) {
            const int x = pass == 0 ? xa + xi : xb - 1 - xi, cell = pass == 0 ? x + 1 : w - x;
            __global const cost_t *c = cost + ((size_t)(cost_row0 + bi) * w + x) * PIX;
            const short16 pad = (short16)(PAD_COST), vp1 = (short16)(p1), vp2 = (short16)(p2);
            // (sum_up in the up sweep's order too: column x at w - 1 - x)
            __global short *o = out + ((size_t)bi * w + (pass == 0 ? x : w - 1 - x)) * PIX;
            // the paths: horizontal from x - s, vertical, diagonals from x + s and x - s (cells
            // cell - 1, cell, cell + 1 and cell - 1: the cells' order above)
            __global const short *in_h = sh + (cell - 1) * CELL, *in_v = sv_in + cell * CELL;
            __global const short *in_e = se_in + (cell + 1) * CELL, *in_d = sd_in + (cell - 1) * CELL;
            __global short *out_h = sh + cell * CELL, *out_v = sv_out + cell * CELL;
            __global short *out_e = se_out + cell * CELL, *out_d = sd_out + cell * CELL;
            const short16 vm_h = (short16)(mh), vm_v = (short16)(mv_in[cell]);
            const short16 vm_e = (short16)(diagonals ? me_in[cell + 1] : 0);
            const short16 vm_d = (short16)(diagonals ? md_in[cell - 1] : 0);
            short16 pend_h = pad, pend_v = pad, pend_e = pad, pend_d = pad;
            short16 run_h = pad, run_v = pad, run_e = pad, run_d = pad;
            // columns x - 1 .. x + 1 with every sample in view (most of the image): no sample is
            // out of view or entering it, the masks drop out.  The vertical path never needs
            // the entering rule: its predecessor is the same column, whose samples in view are
            // the same.
            const int interior = all_in_view(x - 1, r, w, first_step, steps, n_valid) &&
                                 all_in_view(x + 1, r, w, first_step, steps, n_valid);
            if (interior)
                if (!diagonals && write)
                    BAND_PIXEL(0, TO_SHORT16(LOAD_UC(c, j)), 1, 0);
                else if (!diagonals)
                    BAND_PIXEL(0, TO_SHORT16(LOAD_UC(c, j)), 0, 0);
                else
                    BAND_PIXEL(0, TO_SHORT16(LOAD_UC(c, j)), write, diagonals);
            else
                BAND_PIXEL(1, LOAD_COST(c, j), write, diagonals);
            // (path values are 0 .. COST_MAX + P2 and padding PAD_COST: the unsigned minimum)
            if (write) {
                VSTORE(short, 16, pend_h, out_h + 16 * (NV - 1));
                mh = hmin16_nonneg(run_h);
            }
            VSTORE(short, 16, pend_v, out_v + 16 * (NV - 1));
            mv_out[cell] = hmin16_nonneg(run_v);
            if (diagonals) {
                VSTORE(short, 16, pend_e, out_e + 16 * (NV - 1));
                VSTORE(short, 16, pend_d, out_d + 16 * (NV - 1));
                me_out[cell] = hmin16_nonneg(run_e);
                md_out[cell] = hmin16_nonneg(run_d);
            }
        }
        if (write && t0 + tn < ncol) {   // the row's last cell of this tile, for the next
            __global const short *c = sh + (size_t)(pass == 0 ? xa + t0 + tn : w - xb + t0 + tn) * CELL;
            for (int q = 0; q < NP; ++q)
                bnd[(size_t)i * (NP + 1) + q] = c[q];
            bnd[(size_t)i * (NP + 1) + NP] = mh;
        }
      }
    }
}


// The guard lanes and guard cells of `slots` checkpoint slots of sgm_band (`ck_rows` state rows and
// minima rows each): each row's 16 leading lanes and each cell's gap PAD_COST, the guard cells 0
// and w + 1 zeros (a path's first pixel), their minima zeros; one work-item per row.  The cells
// 1 .. w are left as they are: a sweep writes them before it reads them.
__kernel void sgm_guards(__global short *ckpt, __global short *ckpt_min, const int w, const int rows_total)
{
    const int q = get_global_id(0);
    if (q >= rows_total)
        return;
    const size_t cells = (size_t)(w + 2), row = 16 + cells * CELL;
    __global short *p = ckpt + (size_t)q * row;
    for (int i = 0; i < 16; ++i)
        p[i] = PAD_COST;
    for (size_t c = 0; c < cells; ++c) {
        __global short *cell = p + 16 + c * CELL;
        if (c == 0 || c == cells - 1)
            for (int i = 0; i < NP; ++i)
                cell[i] = 0;
        for (int i = NP; i < CELL; ++i)
            cell[i] = PAD_COST;
    }
    ckpt_min[(size_t)q * cells] = 0;
    ckpt_min[(size_t)q * cells + cells - 1] = 0;
}

#ifdef NIBBLES
// A pixel's vertical path alone (sgm_band's BAND_PIXEL without the horizontal path, the sum or the
// diagonals: a checkpointing sweep of 4 paths)
#define VERTICAL_PIXEL(MASKED, COST)                                                           \
    do {                                                                                      \
        UNROLL_NV                                                                             \
        for (int j = 0; j < NV; ++j) {                                                        \
            const short16 cv = COST;                                                          \
            short16 sum = (short16)(0);                                                       \
            PATH_STEP(v, j, 0, MASKED);                                                       \
        }                                                                                     \
    } while (0)

// The checkpointing up sweep of 4 paths fused with the 3 x 3 block costs of its rows (block_cost's
// nibble-plane kernel, going up): image rows y0 .. y0 + rows - 1 from the bottom, each work-item a
// range of columns (block_cost's), each pixel's block costs computed and its vertical path advanced
// at once.  store = 0 (pass 1): the costs in a cell of the work-item's scratch (in L1), no cost band
// written and read again; store = 1 (pass 2): into out[out_row0 + i] as block_cost, and the vertical
// path reads them there.  The vertical path runs on the bottom `v_rows` rows, as sgm_band's up sweep
// with write_up = 0 (split) and `chain` (rows in groups of `chain` from the top of those rows, group
// g into slot dst + g, its first row's predecessors from slot dst + g + 1, the last group's from slot
// `src`; never from zeros: sgm_band's init, which also sets the up sweep's own state rows, runs the
// image's last rows); 4 paths: one state row and one minima row per slot, guard lanes and cells from
// sgm_guards.  Bit for bit block_cost then sgm_band.
__kernel void ckpt_cost(__global const ulong *cl, __global const uchar *ri, __global uchar *scratch,
                        __global short *ckpt, __global short *ckpt_min, const int h, const int w,
                        const int first_step, const int steps, const int y0, const int rows, const int splits,
                        const int slot_cols, const int n_valid, const int ri_row0, const short p1, const short p2,
                        const int src, const int dst, __global cost_t *out, const int store, const int out_row0,
                        const int v_rows, const int chain)
{
    const int g = get_global_id(0);
    if (g >= splits)
        return;
    const int xa = (int)((long)g * w / splits), xb = (int)((long)(g + 1) * w / splits);
    const int ca = IMAX(xa - 1, 0), cb = IMIN(xb + 1, w);
    const size_t slot = (size_t)slot_cols * NP;
    __global uchar *ring = scratch + (size_t)g * (3 * slot + 2 * COLSUM_SLOTS * NP);
    __global uchar *vs = ring + 3 * slot;
    // the pixel's block costs (after the column sums' slots, in the ring's spare cells)
    __global uchar *pc = vs + (size_t)COLSUM_SLOTS * NP;
    const size_t cells = (size_t)(w + 2), row = 16 + cells * CELL;
    const int links = IMAX(chain, 1), last_link = (v_rows - 1) / links;
    const v32u cmax = V32(COST_MAX), out_mark = V32(COST_OUT);
    const v32c lanes = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23,
                        24, 25, 26, 27, 28, 29, 30, 31};
    v32c tables[16];
    const v32c lut = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4, 0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    const v32c iota = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
                       0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    for (int l = 0; l < 16; ++l) {
        const v32c lv = V32((char)l);
        tables[l] = __builtin_ia32_pshufb256(lut, iota ^ lv);
    }
    const short16 pad = (short16)(PAD_COST), vp1 = (short16)(p1), vp2 = (short16)(p2);
    for (int i = rows - 1; i >= 0; --i) {
        const int y = y0 + i;
        // the Hamming rows y + 1, y, y - 1 (the first row) or y - 1 (the rows after): ring slot t mod 3
        for (int t = i == rows - 1 ? y + 1 : y - 1; t >= y - 1; --t)
            nibble_row(ring + (((t % 3) + 3) % 3) * slot, cl, ri, CLAMPI(t, 0, h - 1), ca, cb, w, first_step,
                       steps, n_valid, ri_row0, tables);
        for (int c = IMAX(xa - 1, 0); c <= xa; ++c) {
            __global const uchar *r0 = ring + (size_t)(c - ca) * NP;
            UNROLL_NV
            for (int k = 0; k < NP; k += 32)
                STORE32(LOAD32(r0 + k) + LOAD32(r0 + slot + k) + LOAD32(r0 + 2 * slot + k),
                        vs + (size_t)(c & 3) * NP + k, k);
        }
        // the predecessors: a group's first row's in the slot below (the last group's in src), the
        // others' in the group's slot
        const int vi = i - (rows - v_rows), link = vi / links;
        const int head = vi == v_rows - 1 || vi % links == links - 1;
        const int from = head ? (link == last_link ? src : dst + link + 1) : dst + link;
        __global short *sv_in = ckpt + (size_t)from * row + 16;
        __global short *mv_in = ckpt_min + (size_t)from * cells;
        __global short *sv_dst = ckpt + (size_t)(dst + link) * row + 16;
        __global short *mv_dst = ckpt_min + (size_t)(dst + link) * cells;
        __global cost_t *orow = out + ((size_t)(out_row0 + i) * w) * PIX;
        for (int x = xa; x < xb; ++x) {
            const int cp = IMIN(x + 1, w - 1);
            __global const uchar *va = vs + (size_t)(IMAX(x - 1, 0) & 3) * NP, *vb = vs + (size_t)(x & 3) * NP;
            __global uchar *vc = vs + (size_t)(cp & 3) * NP;
            __global const uchar *r0 = ring + (size_t)(cp - ca) * NP;
            long lo, hi;
            view_range(x, 1, w, first_step, steps, &lo, &hi);
            const int masked = !(lo <= 0 && hi >= n_valid - 1);
            const long k_lo = lo, k_hi = hi < (long)n_valid - 1 ? hi : (long)n_valid - 1;
            UNROLL_NV
            for (int k = 0; k < NP; k += 32) {
                v32u c3 = LOAD32(vc + k);
                if (cp != x) {
                    c3 = LOAD32(r0 + k) + LOAD32(r0 + slot + k) + LOAD32(r0 + 2 * slot + k);
                    STORE32(c3, vc + k, k);
                }
                v32u sum = __builtin_elementwise_min(
                    __builtin_elementwise_add_sat(__builtin_elementwise_add_sat(LOAD32(va + k), LOAD32(vb + k)), c3),
                    cmax);
                if (masked) {
                    const char a = (char)CLAMPI(k_lo - k, 0L, 32L), b = (char)CLAMPI(k_hi - k + 1, 0L, 32L);
                    const v32c va_ = V32(a), vb_ = V32(b);
                    const v32c in_view = (v32c)((lanes >= va_) & (lanes < vb_));
                    sum = (sum & (v32u)in_view) | (out_mark & ~(v32u)in_view);
                }
                STORE32(sum, (store ? orow + (size_t)x * PIX : pc) + k, k);
            }
            if (vi < 0)          // (the rows above the vertical path's: costs only)
                continue;
            // the vertical path of pixel x (sgm_band's up sweep: column x in cell w - x)
            const int cell = w - x;
            __global const short *in_v = sv_in + cell * CELL;
            __global short *out_v = sv_dst + cell * CELL;
            const short16 vm_v = (short16)(mv_in[cell]);
            short16 pend_v = pad, run_v = pad;
            __global const uchar *c = store ? orow + (size_t)x * PIX : pc;
            const int interior = all_in_view(x - 1, 1, w, first_step, steps, n_valid) &&
                                 all_in_view(x + 1, 1, w, first_step, steps, n_valid);
            if (interior)
                VERTICAL_PIXEL(0, TO_SHORT16(LOAD_UC(c, j)));
            else
                VERTICAL_PIXEL(1, LOAD_COST(c, j));
            VSTORE(short, 16, pend_v, out_v + 16 * (NV - 1));
            mv_dst[cell] = hmin16_nonneg(run_v);
        }
    }
}
#endif  // NIBBLES

#endif  // COST_BYTES

// Winner-take-all for both views, one work-item per row: the left disparity (NaN when nothing is
// in view, when the minimum is cut by the image or not unique; parabola vertex), its margin
// (S2 - S1) / S2 (0 where rejected) and the right view's winner in steps (NO_MATCH if no left
// pixel can match).  Samples out of view (S < 0) are no candidates: they read as SHRT_MAX (the
// host keeps aggregated costs below it).  The right view's costs of pixel xr are the samples k
// of the left pixels xr + n0 + floor(k / STEPS) (first_step = n0 STEPS, a multiple of STEPS):
// for each sub-pixel phase k mod STEPS a diagonal through the pixels' entries.  Walking the row
// right to left, F_x[k] = min(S_x[k], F_(x+1)[k + STEPS]) (ties to S_x[k], the smaller k) is the
// best (cost, k) of the diagonal from entry k of pixel x on: one vector shift per pixel; the
// winner of right pixel xr is the best of F_(xr + n0)[0 .. STEPS - 1], ties to the smaller k
// (the specification's first minimum).
#if defined(STEPS)
// The right winner (in steps, NO_MATCH if none) from F's first STEPS lanes: the least cost,
// ties to the smaller k.  As one minimum of the keys cost * 65536 + k (k: 0 .. 32767): the same
// order, without branches (which lane wins is data-dependent; the compare-and-branch code held
// ~7 % of the selection's perf samples at tsukuba)
static inline int right_winner(const short16 ev, const short16 ei, const int t0)
{
    int key = (int)ev.s0 * 65536 + (int)ei.s0;
#if STEPS > 1
    key = IMIN(key, (int)ev.s1 * 65536 + (int)ei.s1);
#endif
#if STEPS > 2
    key = IMIN(key, (int)ev.s2 * 65536 + (int)ei.s2);
#endif
#if STEPS > 3
    key = IMIN(key, (int)ev.s3 * 65536 + (int)ei.s3);
#endif
    // (key >> 16 = floor(key / 65536): the cost, a negative one too)
    const int best = key >> 16, k = key & 0xffff;
    return best < SHRT_MAX ? t0 + k : NO_MATCH;
}

// Private vectors at element alignment (the F cells of select_pass: loads at lane offset STEPS)
#ifdef __clang__
#define PLOAD16(p) (*(const __private short16_u *)(p))
#define PSTORE16(v, p) (*(__private short16_u *)(p) = (v))
#else
#define PLOAD16(p) vload16(0, (const __private short *)(p))
#define PSTORE16(v, p) vstore16((v), 0, (__private short *)(p))
#endif

// One pass over pixel x's vectors (two = 1: S = agg + agg2, the band sweeps' sums, agg2's rows
// stored right to left as sgm_band's sum_up, both -1 where
// out of view): per lane the least cost m1 (its first k, i1) and the second least m2, and the
// right view's F_x (fv_out, fi_out: costs and their k) from F_(x+1) (fv_in, fi_in) read STEPS
// lanes on: F_x[k] = min(S_x[k], F_(x+1)[k + STEPS]).  The cells are private memory of NP + 16
// lanes (lanes NP .. of fv_in hold SHRT_MAX: no pixel); a vector load at lane offset STEPS
// replaces the two lane shuffles per vector of F kept in registers, which spilled (48 vectors
// at 383 samples: each a reload, two shuffles and a spill per pixel, 51 instructions a vector in
// all, now 18).
static ALWAYS_INLINE void select_pass(__global const short *agg, __global const short *agg2, const int y,
                                      const int w, const int x, const int two,
                                      const __private short *fv_in, const __private short *fi_in,
                                      __private short *fv_out, __private short *fi_out,
                                      short16 *m1_, short16 *m2_, short16 *i1_, const int n)
{
    const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const short16 none = (short16)(SHRT_MAX);
    __global const short *s = agg + ((size_t)y * w + x) * PIX;
    __global const short *s2 = agg2 + ((size_t)y * w + w - 1 - x) * PIX;     // rows right to left
    short16 m1 = none, m2 = none, i1 = (short16)(0);
    UNROLL_SEL
    for (int j = 0; j < NV; ++j) {
        const short16 k = lane + (short16)(16 * j);
        const short16 v = LOAD_SMAX(s, j);
        // (padding lanes read SHRT_MAX in both: kept at none, not summed past it)
        short16 sv = v < (short16)(0) || v == none ? none : two ? v + LOAD_SMAX(s2, j) : v;
        if (j >= NV_FULL)      // a bucket's padding samples (n .. N_DISP - 1): no candidates
            sv = k >= (short16)(n) ? none : sv;
        i1 = sv < m1 ? k : i1;
        m2 = VMIN(m2, sv < m1 ? m1 : sv);
        m1 = VMIN(m1, sv);
        const short16 cv = PLOAD16(fv_in + 16 * j + STEPS), ci = PLOAD16(fi_in + 16 * j + STEPS);
        const short16 take = sv <= cv;
        PSTORE16(take ? sv : cv, fv_out + 16 * j);
        PSTORE16(take ? k : ci, fi_out + 16 * j);
    }
    *m1_ = m1;
    *m2_ = m2;
    *i1_ = i1;
}

// Pixel x's left view from its lanes' m1, i1, m2: the first minimum kb; the best cost more than
// one step from it is a lane's m1, or its m2 where m1 is within one step of kb (a lane's samples
// are 16 apart); uniqueness, cut and parabola as the specification.
static ALWAYS_INLINE void select_left(__global const short *agg, __global const short *agg2, const int y,
                                      const int w, const int x, const int two, const short16 m1,
                                      const short16 m2, const short16 i1, const int t0, const int steps,
                                      const int uniqueness, __global float *drow, __global float *mrow,
                                      const int n)
{
    __global const short *s = agg + ((size_t)y * w + x) * PIX;
    __global const short *s2 = agg2 + ((size_t)y * w + w - 1 - x) * PIX;     // rows right to left
    // (m1, m2: sums in view 0 .. SHRT_MAX - 1 or SHRT_MAX; i1: sample indices)
    const int best = hmin16_nonneg(m1);
    const int kb = hmin16_nonneg(m1 == (short16)(best) ? i1 : (short16)(SHRT_MAX));
    const short16 near = (i1 >= (short16)(kb - 1)) & (i1 <= (short16)(kb + 1));
    // SHRT_MAX: nothing in view, or no sample in view more than one step from kb
    const int second = hmin16_nonneg(near ? m2 : m1);
    const int unique = best < SHRT_MAX && second < SHRT_MAX &&
                       (long)second * 100 > (long)best * (100 + uniqueness);
    const int km = kb > 0 ? kb - 1 : 0, kp = kb < n - 1 ? kb + 1 : n - 1;
    const int sm = s[km] < 0 || !two ? s[km] : s[km] + s2[km];
    const int sp = s[kp] < 0 || !two ? s[kp] : s[kp] + s2[kp];
    const int cut = (kb > 0 && sm < 0) || (kb < n - 1 && sp < 0);
    const float den = (float)(sm - 2 * best + sp);
    float delta = 0.0f;
    if (kb > 0 && kb < n - 1 && den > 0.0f)
        delta = (float)(sm - sp) / (2.0f * den);
    if (STEPS == 2 && kb >= 2 && kb <= n - 3) {
        // half-pixel samples: one baseline per phase (spec._half_pixel_fit)
        const int sm2 = s[kb - 2] < 0 || !two ? s[kb - 2] : s[kb - 2] + s2[kb - 2];
        const int sp2 = s[kb + 2] < 0 || !two ? s[kb + 2] : s[kb + 2] + s2[kb + 2];
        const int den2 = sm2 + sp2 - 2 * best;
        if (sm >= 0 && sp >= 0 && sm2 >= 0 && sp2 >= 0 && den2 > 0) {
            const float fit = (float)(2 * (sm - sp) + sm2 - sp2) / (2.0f * (float)den2);
            delta = fit < -1.0f ? -1.0f : fit > 1.0f ? 1.0f : fit;
        }
    }
    const int keep = unique && !cut;
    // (the build's STEPS, the launch's steps: a constant divisor, a multiplication for 1, 2 and 4)
    drow[x] = keep ? ((float)t0 + (float)kb + delta) / (float)STEPS : as_float(0x7fc00000u);   // numpy's NaN
    mrow[x] = keep ? (float)(second - best) / (float)second : 0.0f;
}

__kernel void select_disparity(__global const short *agg, __global const short *agg2, __global float *disp,
                               __global int *right, __global float *margin, const int h, const int w,
                               const int d_min, const int steps, const int uniqueness, const int two,
                               const int y_out0, const int n_valid, const float lr_tol)
{
    const int y = get_global_id(0);
    if (y >= h)
        return;
    const int t0 = d_min * STEPS, n0 = d_min;
    // F_x (costs, their k) of the pixel before and of this one, alternating: cell x & 1
    short fv[2][NP + 16], fi[2][NP + 16];
    for (int i = 0; i < NP + 16; ++i) {
        fv[0][i] = fv[1][i] = SHRT_MAX;         // F beyond the right edge: no pixel
        fi[0][i] = fi[1][i] = 0;
    }
    __global int *rrow = right + (size_t)(y_out0 + y) * w;
    __global float *drow = disp + (size_t)(y_out0 + y) * w;
    __global float *mrow = margin + (size_t)(y_out0 + y) * w;
    for (int x = 0; x < w; ++x)
        rrow[x] = NO_MATCH;
    // four pixels per iteration: their left-view reductions (three dependent horizontal minima
    // and a division each) are independent, so the CPU overlaps them (two: 22 % less time than
    // one; four: 18 % less than two)
    for (int x = w - 1; x >= 0; x -= 4) {
        short16 m1[4], m2[4], i1[4];
        const int cnt = IMIN(4, x + 1);
        for (int q = 0; q < 4; ++q) {
            if (q < cnt) {
                const int xq = x - q, cur = xq & 1;
                // `two` as a constant: no test per vector (1000 x 1500 x 383: -38 %)
                if (two)
                    select_pass(agg, agg2, y, w, xq, 1, fv[cur ^ 1], fi[cur ^ 1], fv[cur], fi[cur], &m1[q], &m2[q],
                                &i1[q], n_valid);
                else
                    select_pass(agg, agg2, y, w, xq, 0, fv[cur ^ 1], fi[cur ^ 1], fv[cur], fi[cur], &m1[q], &m2[q],
                                &i1[q], n_valid);
                if (xq - n0 >= 0 && xq - n0 < w)
                    rrow[xq - n0] = right_winner(PLOAD16(fv[cur]), PLOAD16(fi[cur]), t0);
            }
        }
        for (int q = 0; q < 4; ++q)
            if (q < cnt)
                select_left(agg, agg2, y, w, x - q, two, m1[q], m2[q], i1[q], t0, steps, uniqueness, drow, mrow,
                            n_valid);
    }
    // right pixels whose diagonals start left of the image enter it at pixel 0 (F_0: cell 0),
    // entries g STEPS .. g STEPS + STEPS - 1 with g = -xr - n0
    const int xr_end = IMIN(w, -n0);
    for (int xr = 0; xr < xr_end; ++xr) {
        const int k0 = (-xr - n0) * STEPS;
        int best = SHRT_MAX, kb = 0;
        for (int k = k0; k < IMIN(k0 + STEPS, n_valid); ++k)
            if (fv[0][k] < best || (fv[0][k] == best && fi[0][k] < kb)) {
                best = fv[0][k];
                kb = fi[0][k];
            }
        rrow[xr] = best < SHRT_MAX ? t0 + kb : NO_MATCH;
    }
#ifdef SELECT_LR
    // lr_tol > 0: the left-right check of this row, its maps still in cache (a launch and a pass
    // over three maps fewer than the left_right kernel after the matcher)
    if (lr_tol > 0.0f)
        for (int x = 0; x < w; ++x)
            left_right_pixel(drow, rrow, mrow, x, w, steps, (double)lr_tol);
#endif
}
#endif  // STEPS
#endif  // N_DISP

// One step of the running-best sweep: windowed squared difference around (y, x) of the gained,
// shifted left view at x' and right view at x' - offset (+inf where the right window around
// x - offset is not inside the image: not in view), then the update of the 9 state planes (best, its d, before, after,
// prev, second, older; the right view's best and its d at xr = x - offset, one writer per right
// pixel; sweep_update_reference).
__kernel void sweep_update(__global float *state, __global const float *ls, __global const float *rs,
                           __global const float *gl, __global const float *gr, const int h, const int w,
                           const int offset, const float d, const int radius)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const int in_view = x - offset >= radius && x - offset <= w - 1 - radius;
    float cost = in_view ? 0.0f : INFINITY;
    for (int v = -radius; v <= radius && in_view; ++v) {
        const size_t row = (size_t)CLAMPI(y + v, 0, h - 1) * w;
        for (int u = -radius; u <= radius; ++u) {
            const int xl = CLAMPI(x + u, 0, w - 1);
            const int xr = CLAMPI(xl - offset, 0, w - 1);
            const float a = gl[xl] * ls[row + xl] - gr[xr] * rs[row + xr];
            cost += a * a;
        }
    }
    const size_t n = (size_t)h * w, p = (size_t)y * w + x;
    const float prev = state[4 * n + p], older = state[6 * n + p];
    if (cost < state[p]) {
        state[5 * n + p] = older;
        state[2 * n + p] = prev;
        state[3 * n + p] = NAN;
        state[p] = cost;
        state[n + p] = d;
    } else if (state[3 * n + p] != state[3 * n + p]) {      // isnan(): a call in PoCL
        state[3 * n + p] = cost;
    } else if (cost < state[5 * n + p]) {
        state[5 * n + p] = cost;
    }
    if (prev < older)                   // false while prev is NaN (before the first step)
        state[6 * n + p] = prev;
    state[4 * n + p] = cost;
    if (in_view) {
        const size_t q = (size_t)y * w + (x - offset);
        if (cost < state[7 * n + q]) {
            state[7 * n + q] = cost;
            state[8 * n + q] = d;
        }
    }
}

// The right view's sub-pixel planes (gfgpu.stereo.spec.subpixel_planes_reference; built with
// -D SHIFT_PLANES, float64 as the specification): one work-item per 4 rows of plane `plane`, the mean
// of `jobs` (1 or 2) Green shifts of the row, each a second-order recursion (spec.shift_recursion:
// `coef` holds per job b0, b1, b2, a1, a2, zi0, zi1, n >= 0, reverse), in lfilter's operations and order
// with no contraction into fused multiply-adds, so the values are the host's bit for bit; rounded to
// float32, subnormals and -0 set to +0.  The first job's values wait in `scratch` (a float64 row per
// image row) for the second's.
#ifdef SHIFT_PLANES
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

// Rows y0 .. y0 + 3 (those below h) of the shifted rows of job `c`, one row per lane of double4
// recursions (each lane the scalar recursion's operations, so its values; 4 independent chains:
// one row per work-item left the float64 latency chain z0 -> y -> z0 idle most of the time);
// mode 0: scratch[x] = value, 1: plane[x] = value, 2: plane[x] = (scratch[x] + value) * 0.5
// (then rounded and flushed)
#define SHIFT_ROWS 4
static void shift_rows(__global const float *right, const int y0, const int h, const int w,
                       __global const double *c, const int mode, __global double *scratch, __global float *plane)
{
    #pragma OPENCL FP_CONTRACT OFF
    const double b0 = c[0], b1 = c[1], b2 = c[2], a1 = c[3], a2 = c[4];
    const int n = (int)c[7], reverse = c[8] != 0.0;
    const int len = w + n;                        // a row extended by n >= 0 copies of its first value
    const int rows = IMIN(SHIFT_ROWS, h - y0);    // lanes past the image repeat its last row, unwritten
    __global const float *r0 = right + (size_t)y0 * w;
    __global const float *r1 = right + (size_t)IMIN(y0 + 1, h - 1) * w;
    __global const float *r2 = right + (size_t)IMIN(y0 + 2, h - 1) * w;
    __global const float *r3 = right + (size_t)IMIN(y0 + 3, h - 1) * w;
    // src[i] = row[max(i - n, 0)]; the recursion runs over src, reversed if `reverse`; its value
    // at step i is moved[s], s = i or len - 1 - i, the output at column s (s < w)
    const int f = reverse ? w - 1 : 0;
    const double4 first = (double4)((double)r0[f], (double)r1[f], (double)r2[f], (double)r3[f]);
    double4 z0 = c[5] * first, z1 = c[6] * first;
    for (int i = 0; i < len; ++i) {
        const int s = reverse ? len - 1 - i : i;
        const int k = s - n > 0 ? s - n : 0;
        const double4 x = (double4)((double)r0[k], (double)r1[k], (double)r2[k], (double)r3[k]);
        const double4 bx0 = x * b0, bx1 = x * b1, bx2 = x * b2;
        const double4 y = bx0 + z0;
        const double4 t = z1 + bx1;
        z0 = t - y * a1;
        z1 = bx2 - y * a2;
        if (s >= w)
            continue;
        const double yq[SHIFT_ROWS] = {y.s0, y.s1, y.s2, y.s3};
        for (int q = 0; q < rows; ++q) {
            const size_t p = (size_t)(y0 + q) * w + s;
            if (mode == 0) {
                scratch[p] = yq[q];
            } else {
                const float v = (float)(mode == 2 ? (scratch[p] + yq[q]) * 0.5 : yq[q]);
                plane[p] = (as_uint(v) & 0x7F800000u) == 0 ? 0.0f : v;
            }
        }
    }
}

// one work-item per SHIFT_ROWS rows of plane `plane`
__kernel void shift_planes(__global const float *right, __global float *planes, __global double *scratch,
                           __global const double *coef, const int h, const int w, const int plane,
                           const int jobs)
{
    const int y0 = SHIFT_ROWS * (int)get_global_id(0);
    if (y0 >= h)
        return;
    __global float *out = planes + (size_t)plane * h * w;
    if (jobs == 1) {
        shift_rows(right, y0, h, w, coef, 1, scratch, out);
    } else {
        shift_rows(right, y0, h, w, coef, 0, scratch, out);
        shift_rows(right, y0, h, w, coef + 9, 2, scratch, out);
    }
}
#endif  // SHIFT_PLANES

// Left-right check of the matcher's maps in place (built with -D LEFT_RIGHT; float64 as the
// specification, left_right_reference, so that a tie of rint(x - d) or of |d - d_R| = tol
// falls the same way): NaN where the right view's winner at rint(x - d) is missing or more than
// tol px from d; the confidence margin times 1 - |d - d_R| / (2 tol), 0 where rejected.
#ifdef LEFT_RIGHT
// Columns x = global id 0 in steps of global size 0: a work-item per row on CPUs, per pixel on
// GPUs (as census_interleave)
__kernel void left_right(__global float *disp, __global const int *right, __global float *margin,
                         const int h, const int w, const int steps, const double tol)
{
    const int y = get_global_id(1);
    if (y >= h)
        return;
    for (int x = get_global_id(0); x < w; x += get_global_size(0))
        left_right_pixel(disp + (size_t)y * w, right + (size_t)y * w, margin + (size_t)y * w, x, w, steps, tol);
}
#endif  // LEFT_RIGHT

// Speckle filter of a finished map (built with -D SPECKLES; specification: filter_speckles of
// postfilter.py, which it gives bit for bit): 4-connected regions of valid pixels whose
// neighbours differ by at most max_diff px (the difference in float64, as numpy takes it) of at
// most max_size pixels become NaN.  A union-find over the pixels (parent >= 0: a pixel of the
// same region nearer its root; a root holds -its region's size): speckle_label joins each half of
// the rows in a work-item of its own, speckle_seam the two halves, speckle_mark then reads the
// trees (no writes: any number of work-items) and sets the small regions' pixels to NaN and the
// confidence to 0 wherever the map is not finite.
#ifdef SPECKLES
static inline int speckle_joined(const float a, const float b, const double max_diff)
{
    return fabs((double)a - (double)b) <= max_diff;       // NaN joins nothing
}

// the root of i's tree, halving the path on the way (only the trees of one work-item's pixels)
static inline int speckle_root(__global int *parent, int i)
{
    while (parent[i] >= 0) {
        const int q = parent[i], g = parent[q];
        if (g < 0)
            return q;
        parent[i] = g;
        i = g;
    }
    return i;
}

// the regions of roots a and b made one (the larger one's root keeps its place)
static inline void speckle_union(__global int *parent, int a, int b)
{
    if (a == b)
        return;
    if (parent[a] > parent[b]) {       // sizes are negative: a is the smaller region
        const int t = a;
        a = b;
        b = t;
    }
    parent[a] += parent[b];
    parent[b] = a;
}

__kernel void speckle_label(__global const float *disp, __global int *parent, const int h, const int w,
                            const double max_diff)
{
    const int k = get_global_id(0);
    if (k > 1)
        return;
    const int ya = k == 0 ? 0 : h / 2, yb = k == 0 ? h / 2 : h;
    for (int y = ya; y < yb; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t i = (size_t)y * w + x;
            const float d = disp[i];
            parent[i] = -1;
            if (x > 0 && speckle_joined(d, disp[i - 1], max_diff)) {
                const int r = speckle_root(parent, (int)i - 1);
                parent[r] -= 1;
                parent[i] = r;
            }
            if (y > ya && speckle_joined(d, disp[i - w], max_diff))
                speckle_union(parent, speckle_root(parent, (int)i), speckle_root(parent, (int)(i - w)));
        }
}

__kernel void speckle_seam(__global const float *disp, __global int *parent, const int h, const int w,
                           const double max_diff)
{
    const int y = h / 2;
    if (get_global_id(0) != 0 || y == 0)
        return;
    for (int x = 0; x < w; ++x) {
        const size_t i = (size_t)y * w + x;
        if (speckle_joined(disp[i], disp[i - w], max_diff))
            speckle_union(parent, speckle_root(parent, (int)i), speckle_root(parent, (int)(i - w)));
    }
}

__kernel void speckle_mark(__global float *disp, __global float *margin, __global const int *parent, const int h,
                           const int w, const int max_size)
{
    const int y = get_global_id(0);
    if (y >= h)
        return;
    for (int x = 0; x < w; ++x) {
        const size_t i = (size_t)y * w + x;
        // finite pixels only, as the host's filter (an infinite one joins nothing and stays; its
        // confidence 0, as every non-finite pixel's): the exponent field not all ones
        int finite = (as_uint(disp[i]) & 0x7f800000u) != 0x7f800000u;
        if (finite) {
            int r = (int)i;
            while (parent[r] >= 0)
                r = parent[r];
            if (-parent[r] <= max_size) {
                disp[i] = as_float(0x7fc00000u);         // numpy's NaN
                finite = 0;
            }
        }
        if (!finite)
            margin[i] = 0.0f;
    }
}
#endif  // SPECKLES
