// Stereo kernels of gfgpu.stereo (float32 images; integer costs).
// Executable specification: the *_reference functions of gfgpu/stereo.py.
// size_t indices: cost volumes exceed 2^31 entries on large images.

#define NO_MATCH (-2147483647 - 1)

static inline int floor_div(const int a, const int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

// Census transform: bit b of out[plane][y][x] is set where neighbour b of the (2r+1)^2 window
// (row-major, centre skipped, edge pixels repeated) is darker than the centre.
__kernel void census(__global const float *img, __global ulong *out, const long plane_offset,
                     const int h, const int w, const int radius)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const float c = img[(size_t)y * w + x];
    ulong code = 0;
    int bit = 0;
    for (int dy = -radius; dy <= radius; ++dy) {
        const int yy = clamp(y + dy, 0, h - 1);
        for (int dx = -radius; dx <= radius; ++dx) {
            if (dy == 0 && dx == 0)
                continue;
            const int xx = clamp(x + dx, 0, w - 1);
            code |= (ulong)(img[(size_t)yy * w + xx] < c) << bit;
            ++bit;
        }
    }
    out[plane_offset + (size_t)y * w + x] = code;
}

// Matching cost: for each disparity sample k (d = (first_step + k) / steps = n + f / steps), the
// sum over the block around (y, x) (clamped) of popcount(L[y'][x'] ^ R_f[y'][x' - n]), or
// `invalid` per term where x' - n falls outside.
__kernel void census_cost(__global const ulong *cl, __global const ulong *cr, __global short *out,
                          const int h, const int w, const int n_disp, const int first_step,
                          const int steps, const int block, const int invalid)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    const int r = block / 2;
    const size_t plane = (size_t)h * w;
    __global short *dst = out + ((size_t)y * w + x) * n_disp;
    for (int k = 0; k < n_disp; ++k) {
        const int t = first_step + k;
        const int n = floor_div(t, steps);
        __global const ulong *right = cr + (size_t)(t - n * steps) * plane;
        int sum = 0;
        for (int v = -r; v <= r; ++v) {
            const size_t row = (size_t)clamp(y + v, 0, h - 1) * w;
            for (int u = -r; u <= r; ++u) {
                const int xx = clamp(x + u, 0, w - 1);
                const int xr = xx - n;
                sum += (xr < 0 || xr >= w) ? invalid : (int)popcount(cl[row + xx] ^ right[row + xr]);
            }
        }
        dst[k] = (short)sum;
    }
}

// One path direction (dy, dx) of semi-global aggregation: one work-item per line of pixels
// entering the image where (x - dx, y - dy) is outside.  scratch holds 2 * n_disp ints per line.
// total = L_r (accumulate = 0) or total + L_r.
__kernel void sgm_path(__global const short *cost, __global short *total, __global int *scratch,
                       const int h, const int w, const int n_disp, const int dy, const int dx,
                       const int p1, const int p2, const int accumulate)
{
    const int i = get_global_id(0);
    int x, y;
    if (dx == 0) {                      // vertical: one line per column
        if (i >= w) return;
        x = i;
        y = dy > 0 ? 0 : h - 1;
    } else if (dy == 0) {               // horizontal: one line per row
        if (i >= h) return;
        x = dx > 0 ? 0 : w - 1;
        y = i;
    } else if (i < h) {                 // diagonal, entering through the first column
        x = dx > 0 ? 0 : w - 1;
        y = i;
    } else {                            // diagonal, entering through the first row
        if (i >= h + w - 1) return;
        x = dx > 0 ? i - h + 1 : w - 2 - (i - h);
        y = dy > 0 ? 0 : h - 1;
    }
    __global int *prev = scratch + (size_t)i * 2 * n_disp;
    __global int *cur = prev + n_disp;
    int mprev = 0, first = 1;
    while (x >= 0 && x < w && y >= 0 && y < h) {
        const size_t base = ((size_t)y * w + x) * n_disp;
        int m = INT_MAX;
        for (int d = 0; d < n_disp; ++d) {
            int v = cost[base + d];
            if (!first) {
                int best = min(prev[d], mprev + p2);
                if (d > 0) best = min(best, prev[d - 1] + p1);
                if (d < n_disp - 1) best = min(best, prev[d + 1] + p1);
                v += best - mprev;
            }
            cur[d] = v;
            m = min(m, v);
            total[base + d] = (short)(accumulate ? total[base + d] + v : v);
        }
        __global int *tmp = prev; prev = cur; cur = tmp;
        mprev = m;
        first = 0;
        x += dx;
        y += dy;
    }
}

// Winner-take-all for both views: the left disparity (uniqueness test, parabola vertex; NaN when
// not unique) and the right view's winner in steps (NO_MATCH if no left pixel can match).
__kernel void select_disparity(__global const short *agg, __global float *disp, __global int *right,
                               const int h, const int w, const int n_disp, const int d_min,
                               const int steps, const int uniqueness)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    __global const short *s = agg + ((size_t)y * w + x) * n_disp;
    int best = INT_MAX, kb = 0;
    for (int k = 0; k < n_disp; ++k)
        if (s[k] < best) { best = s[k]; kb = k; }
    int second = INT_MAX;
    for (int k = 0; k < n_disp; ++k)
        if (abs(k - kb) > 1 && s[k] < second) second = s[k];
    const int unique = (long)second * 100 > (long)best * (100 + uniqueness);
    const int sm = s[max(kb - 1, 0)], sp = s[min(kb + 1, n_disp - 1)];
    const float den = (float)(sm - 2 * best + sp);
    float delta = 0.0f;
    if (kb > 0 && kb < n_disp - 1 && den > 0.0f)
        delta = (float)(sm - sp) / (2.0f * den);
    disp[(size_t)y * w + x] = unique ? ((float)(d_min * steps) + (float)kb + delta) / (float)steps : NAN;
    int best_r = INT_MAX, kr = NO_MATCH;
    for (int k = 0; k < n_disp; ++k) {
        const int t = d_min * steps + k;
        const int xl = x + floor_div(t, steps);
        if (xl < 0 || xl >= w)
            continue;
        const int v = agg[((size_t)y * w + xl) * n_disp + k];
        if (v < best_r) { best_r = v; kr = t; }
    }
    right[(size_t)y * w + x] = kr;
}

// One step of the running-best sweep: windowed squared difference around (y, x) of the gained,
// shifted left view at x' and right view at x' - offset, then the update of the 5 state planes (best, its d, before, after, prev).
__kernel void sweep_update(__global float *state, __global const float *ls, __global const float *rs,
                           __global const float *gl, __global const float *gr, const int h, const int w,
                           const int offset, const float d, const int radius)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= w || y >= h)
        return;
    float cost = 0.0f;
    for (int v = -radius; v <= radius; ++v) {
        const size_t row = (size_t)clamp(y + v, 0, h - 1) * w;
        for (int u = -radius; u <= radius; ++u) {
            const int xl = clamp(x + u, 0, w - 1);
            const int xr = clamp(xl - offset, 0, w - 1);
            const float a = gl[xl] * ls[row + xl] - gr[xr] * rs[row + xr];
            cost += a * a;
        }
    }
    const size_t n = (size_t)h * w, p = (size_t)y * w + x;
    if (cost < state[p]) {
        state[2 * n + p] = state[4 * n + p];
        state[3 * n + p] = NAN;
        state[p] = cost;
        state[n + p] = d;
    } else if (isnan(state[3 * n + p])) {
        state[3 * n + p] = cost;
    }
    state[4 * n + p] = cost;
}
