// Integer helpers and the path lines of the semi-global aggregation, shared by stereo.cl and
// sgm_groups.cl (pasted in where they say #include "lines.cl": gfgpu.backends.opencl.launch).

#define CLAMPI(v, lo, hi) ((v) < (lo) ? (lo) : (v) > (hi) ? (hi) : (v))   // not clamp(): PoCL calls it
#define IMIN(a, b) ((a) < (b) ? (a) : (b))        // scalar min / max: PoCL calls min() and max()
#define IMAX(a, b) ((a) > (b) ? (a) : (b))

static inline int floor_div(const int a, const int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

// Line i of the paths of direction (dy, dx): the pixel (*y, *x) where it enters the image (its
// predecessor (y - dy, x - dx) is outside), and its length in pixels.  A direction has w lines
// (vertical), h (horizontal) or h + w - 1 (diagonal: the first column's h, then the first row's
// w - 1); 0 for an i past them.
static inline int path_line(const int i, const int h, const int w, const int dy, const int dx, int *y, int *x)
{
    if (dx == 0) {                      // vertical: one line per column
        if (i >= w) return 0;
        *x = i;
        *y = dy > 0 ? 0 : h - 1;
    } else if (dy == 0) {               // horizontal: one line per row
        if (i >= h) return 0;
        *x = dx > 0 ? 0 : w - 1;
        *y = i;
    } else if (i < h) {                 // diagonal, entering through the first column
        *x = dx > 0 ? 0 : w - 1;
        *y = i;
    } else {                            // diagonal, entering through the first row
        if (i >= h + w - 1) return 0;
        *x = dx > 0 ? i - h + 1 : w - 2 - (i - h);
        *y = dy > 0 ? 0 : h - 1;
    }
    const int len_x = dx > 0 ? w - *x : dx < 0 ? *x + 1 : INT_MAX;
    const int len_y = dy > 0 ? h - *y : dy < 0 ? *y + 1 : INT_MAX;
    return IMIN(len_x, len_y);
}
