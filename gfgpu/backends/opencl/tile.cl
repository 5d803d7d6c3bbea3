/* In-place register transpose of a TILE_LANES x TILE_LANES tile, shared by recurse.cl, recurse_lines.cl
 * and gfgpu/motion/motion.cl (pasted in where they say #include "tile.cl": gfgpu.backends.opencl.launch).
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
