// The 2-D cubic B-spline at a point, shared by field.cl and polar.cl (pasted in where they say
// #include "spline2d.cl"; after spline.cl).  Needs GRID, the type of the positions.

// coefficient i of a line of n as w0 c[j0] + w1 c[j1] + (1 - w0 - w1) cval
// (gfgpu._core.bspline.coef_taps; cval only in constant mode): returns j0
static inline int coef_taps(const int i, const int n, const int mode, POS *w0, int *j1, POS *w1)
{
    *w0 = (POS)1;
    *w1 = (POS)0;
    if ((unsigned)i < (unsigned)n || IS_PERIODIC(mode)) {
        *j1 = (unsigned)i < (unsigned)n ? i : extend(i, n, mode);
        return *j1;
    }
    const int left = i < 0, j = left ? 0 : n - 1;
    const POS f = pole_power(left ? -i : i - n + 1);
    *j1 = j;
    if (mode == MODE_CONSTANT) {
        *w0 = f;
        return j;
    }
    *j1 = left ? IMIN(1, n - 1) : IMAX(n - 2, 0);
    *w0 = f + ((POS)1 - f) * (POS)NEAR_A;
    *w1 = ((POS)1 - f) * (POS)NEAR_B;
    return j;
}

// the 2-D cubic B-spline of one plane (h x w, at `plane`) at (py, px)
static inline REAL spline2(__global const REAL *src, const long plane, const int h, const int w, const GRID py,
                           const GRID px, const int mode_y, const int mode_x, const REAL cval)
{
    const int iy = ifloor(py), ix = ifloor(px);
    const REAL ty = (REAL)(py - (GRID)iy), tx = (REAL)(px - (GRID)ix);
    REAL wx[4], wy[4];
    for (int q = 0; q < 4; ++q) {
        wx[q] = bweight(tx, q);
        wy[q] = bweight(ty, q);
    }
    if (iy >= 1 && iy + 2 < h && ix >= 1 && ix + 2 < w) {    // all 16 coefficients inside: no extension
        __global const REAL *line = src + plane + (long)(iy - 1) * w + (ix - 1);
        REAL acc = 0;
        for (int p = 0; p < 4; ++p, line += w)
            acc += wy[p] * (wx[0] * line[0] + wx[1] * line[1] + wx[2] * line[2] + wx[3] * line[3]);
        return acc;
    }
    // beyond the border a coefficient may weigh two ('nearest'): two columns and two rows per tap
    const REAL base = mode_x == MODE_CONSTANT ? cval : (REAL)0;
    int rx0[4], rx1[4];
    REAL vx0[4], vx1[4];
    for (int q = 0; q < 4; ++q) {
        POS g0, g1;
        rx0[q] = coef_taps(ix + q - 1, w, mode_x, &g0, &rx1[q], &g1);
        vx0[q] = wx[q] * (REAL)g0;
        vx1[q] = wx[q] * (REAL)g1;
    }
    REAL acc = 0;
    for (int p = 0; p < 4; ++p) {
        POS h0, h1;
        int ry1;
        const int ry0 = coef_taps(iy + p - 1, h, mode_y, &h0, &ry1, &h1);
        for (int r = 0; r < 2; ++r) {
            const POS g = r ? h1 : h0;
            if (g == (POS)0)
                continue;
            __global const REAL *line = src + plane + (long)(r ? ry1 : ry0) * w;
            REAL row = 0;
            for (int q = 0; q < 4; ++q)
                row += vx0[q] * (line[rx0[q]] - base) + vx1[q] * (line[rx1[q]] - base);
            acc += wy[p] * (REAL)g * row;
        }
    }
    return acc + base;
}
