/* In-place register transpose of a TILE_LANES x TILE_LANES tile, shared by recurse.cl, recurse_lines.cl,
 * twosided.cl and gfgpu/motion/motion.cl (pasted in where they say #include "tile.cl":
 * gfgpu.backends.opencl.launch); rows_transpose, for the row tiles of 256-bit vectors, at the end.
 * Needs TILE_LANES (1, 2, 4, 8 or 16), TILE_VT (the vector type of TILE_LANES lanes) and INLINE.
 * ZIPLO / ZIPHI interleave the low / high halves of two vectors: a0 b0 a1 b1 ...  Each round of
 * transpose_tile moves element (r, c) to the index whose bits [r | c] are rotated left by one, so
 * TILE_LOG2 rounds give [c | r]; fully unrolled, the tile stays in registers. */
#if TILE_LANES == 2
#define TILE_LOG2 1
#define ZIPLO(a, b) ((TILE_VT)((a).s0, (b).s0))
#define ZIPHI(a, b) ((TILE_VT)((a).s1, (b).s1))
#elif TILE_LANES == 4
#define TILE_LOG2 2
#define ZIPLO(a, b) ((TILE_VT)((a).s0, (b).s0, (a).s1, (b).s1))
#define ZIPHI(a, b) ((TILE_VT)((a).s2, (b).s2, (a).s3, (b).s3))
#elif TILE_LANES == 8
#define TILE_LOG2 3
#define ZIPLO(a, b) ((TILE_VT)((a).s0, (b).s0, (a).s1, (b).s1, (a).s2, (b).s2, (a).s3, (b).s3))
#define ZIPHI(a, b) ((TILE_VT)((a).s4, (b).s4, (a).s5, (b).s5, (a).s6, (b).s6, (a).s7, (b).s7))
#elif TILE_LANES == 16
#define TILE_LOG2 4
#define ZIPLO(a, b) ((TILE_VT)((a).s0, (b).s0, (a).s1, (b).s1, (a).s2, (b).s2, (a).s3, (b).s3, \
                               (a).s4, (b).s4, (a).s5, (b).s5, (a).s6, (b).s6, (a).s7, (b).s7))
#define ZIPHI(a, b) ((TILE_VT)((a).s8, (b).s8, (a).s9, (b).s9, (a).sa, (b).sa, (a).sb, (b).sb, \
                               (a).sc, (b).sc, (a).sd, (b).sd, (a).se, (b).se, (a).sf, (b).sf))
#elif TILE_LANES != 1
#error "tile.cl needs TILE_LANES 1, 2, 4, 8 or 16"
#endif

INLINE void transpose_tile(TILE_VT *t)
{
#if TILE_LANES > 1
#pragma unroll
    for (int r = 0; r < TILE_LOG2; ++r) {
        TILE_VT u[TILE_LANES];
#pragma unroll
        for (int i = 0; i < TILE_LANES / 2; ++i) {
            u[2 * i] = ZIPLO(t[i], t[i + TILE_LANES / 2]);
            u[2 * i + 1] = ZIPHI(t[i], t[i + TILE_LANES / 2]);
        }
#pragma unroll
        for (int i = 0; i < TILE_LANES; ++i)
            t[i] = u[i];
    }
#endif
}

/* The tile transpose of the rows in single-instruction shuffles of 256-bit registers (AVX2):
 * interleave within 128-bit halves (unpck), then pairs (shufps / unpckpd), then swap halves
 * (vperm2f128): 24 for 8 x 8, 8 for 4 x 4.  transpose_tile's zips cross the halves (16 x 16
 * float tiles were 512-bit vectors split in two, with spills: the row pass ran 2.4x slower). */
#define SHUF __builtin_shufflevector
INLINE void rows_transpose(TILE_VT *t)
{
#if TILE_LANES == 8 && defined(__clang__)
    TILE_VT u[8], v[8];
#pragma unroll
    for (int i = 0; i < 8; i += 2) {   /* rows i, i + 1: columns 0 1 4 5 and 2 3 6 7 */
        u[i] = SHUF(t[i], t[i + 1], 0, 8, 1, 9, 4, 12, 5, 13);
        u[i + 1] = SHUF(t[i], t[i + 1], 2, 10, 3, 11, 6, 14, 7, 15);
    }
#pragma unroll
    for (int i = 0; i < 8; i += 2) {   /* v[j + 4h]: column j | j + 4 of rows 4h .. 4h + 3 */
        const int a = i / 4 * 4 + i / 2 % 2;
        v[i] = SHUF(u[a], u[a + 2], 0, 1, 8, 9, 4, 5, 12, 13);
        v[i + 1] = SHUF(u[a], u[a + 2], 2, 3, 10, 11, 6, 7, 14, 15);
    }
#pragma unroll
    for (int c = 0; c < 4; ++c) {
        t[c] = SHUF(v[c], v[c + 4], 0, 1, 2, 3, 8, 9, 10, 11);
        t[c + 4] = SHUF(v[c], v[c + 4], 4, 5, 6, 7, 12, 13, 14, 15);
    }
#elif TILE_LANES == 4 && defined(__clang__)
    const TILE_VT u0 = SHUF(t[0], t[1], 0, 4, 2, 6), u1 = SHUF(t[0], t[1], 1, 5, 3, 7);
    const TILE_VT u2 = SHUF(t[2], t[3], 0, 4, 2, 6), u3 = SHUF(t[2], t[3], 1, 5, 3, 7);
    t[0] = SHUF(u0, u2, 0, 1, 4, 5);
    t[1] = SHUF(u1, u3, 0, 1, 4, 5);
    t[2] = SHUF(u0, u2, 2, 3, 6, 7);
    t[3] = SHUF(u1, u3, 2, 3, 6, 7);
#else
    transpose_tile(t);
#endif
}
