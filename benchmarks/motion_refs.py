"""References and peer kernels for benchmarks/motion.py; none reuses gfgpu's fast paths.

* textures and fields: Gaussian-filtered white noise (band-limited in practice) and a smooth
  analytic velocity field of any shape;
* supersampled renderings: the weighted sum of exactly warped copies of the image (cubic
  spline, ``scipy.ndimage.map_coordinates``), the weights a composite 3-point Gauss-Legendre
  quadrature of the point-spread function in time (box, the chapter's G_u, the zoom's
  G_U^(1) in ``tau = ln(s/x0)``), with cells of at most one pixel of motion where the PSF holds
  its mass;
* impulse centroids of oblique uniform blurs (one impulse per phase of the line's fractions);
* the 2-D kernels that ``cv2.filter2D`` runs as peers: a box along the segment, MATLAB's
  ``fspecial('motion')`` (antialiased by the distance to the line) and the sampled G_u.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from gfgpu import greens

#: scipy.ndimage's names for the boundary modes of the renderings (its 'wrap' is not periodic)
SCIPY_MODES = {"wrap": "grid-wrap", "reflect": "reflect"}

#: G_u's support is cut at t = GREEN_END velocities: the tail beyond holds e^-t (sin t + cos t) < 2e-6
GREEN_END = 14.0

#: 3-point Gauss-Legendre nodes (fractions of a cell) and weights (their sum is 1)
GL_NODES = np.array([0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6)])
GL_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0


# --------------------------------------------------------------------------------------
# inputs
# --------------------------------------------------------------------------------------
def texture(shape, sigma=2.0, seed=0):
    """Unit-variance white noise filtered by a periodic Gaussian of ``sigma`` px (its spectrum
    is below 1 % of the peak beyond 0.25 cycles/px for sigma = 2)."""
    rng = np.random.default_rng(seed)
    img = ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return img / img.std()


def velocity_field(shape, vmax=30.0):
    """A smooth field ``(2, H, W)`` (rows, cols components) whose speed ``|v|`` spans 3 % to 100 %
    of ``vmax`` in every direction, defined by the shape alone (cheap at any size)."""
    h, w = shape
    y = np.arange(h)[:, None] / h
    x = np.arange(w)[None, :] / w
    speed = vmax * (0.515 + 0.485 * np.sin(2 * np.pi * (1.3 * x + 0.11)) * np.cos(2 * np.pi * (0.9 * y + 0.07)))
    angle = 2 * np.pi * (0.8 * x + 0.6 * y) + 0.3 * np.sin(6 * np.pi * y)
    return np.stack([speed * np.sin(angle), speed * np.cos(angle)]).astype(np.float32)


# --------------------------------------------------------------------------------------
# point-spread functions in time and their quadrature
# --------------------------------------------------------------------------------------
def box_density(t):
    return np.ones_like(t)


def green_density(t):
    """G_u with u = 1 (eq. 9, mean one velocity): ``2 e^-t sin t``, t >= 0."""
    return 2.0 * np.exp(-t) * np.sin(t)


def green_zoom_density(u1):
    """G_U^(1) (eq. 11) of a zoom-in ``u1 > 0`` as a density in ``tau = ln(s/x0)`` (the pre-image
    of radius ``s`` is ``s e^-tau``): ``c e^(alpha tau) sin(beta tau)``, and where it ends
    (``e^(alpha tau) < 1e-13``)."""
    if u1 <= 0:
        raise ValueError("green_zoom_density: zoom-in only (u1 > 0)")
    alpha = 0.5 - 1.0 / u1
    beta = math.sqrt(1.0 + u1 - u1 * u1 / 4.0) / u1
    c = 2.0 / (u1 * u1 * beta)
    return (lambda tau: c * np.exp(alpha * tau) * np.sin(beta * tau)), 30.0 / abs(alpha), 5.0 / abs(alpha)


def quadrature(density, end, px_per_t, core=None, min_copies=512):
    """``(t, w)``: composite 3-point Gauss-Legendre nodes and weights of ``density`` on
    ``[0, end]``, with cells of at most one pixel of motion up to ``core`` (default ``end``) and
    four pixels beyond (the tail's small mass), at least ``min_copies`` nodes; weights
    normalised to a sum of 1 (the part beyond ``end`` is below float32 rounding)."""
    core = end if core is None else min(core, end)
    n_core = max(1, math.ceil(core * px_per_t))
    n_tail = math.ceil((end - core) * px_per_t / 4)
    refine = max(1, math.ceil(min_copies / (3 * (n_core + n_tail))))
    edges = np.concatenate([np.linspace(0.0, core, refine * n_core + 1),
                            np.linspace(core, end, refine * n_tail + 1)[1:]])
    width = np.diff(edges)
    t = (edges[:-1, None] + width[:, None] * GL_NODES[None, :]).ravel()
    w = (width[:, None] * GL_WEIGHTS[None, :]).ravel() * density(t)
    return t, w / w.sum()


def time_cells(psf, px_per_t, min_copies=512):
    """Quadrature of the uniform, field and spin PSFs in ``t`` (fraction of the motion)."""
    if psf == "box":
        return quadrature(box_density, 1.0, px_per_t, min_copies=min_copies)
    return quadrature(green_density, GREEN_END, px_per_t, core=5.0, min_copies=min_copies)


def render(img, preimage, cells, mode):
    """``Σ_k w_k I(preimage(y, x, t_k))`` in float64: the supersampled rendering."""
    h, w = img.shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    smode = SCIPY_MODES[mode]
    coef = ndimage.spline_filter(np.asarray(img, np.float64), 3, mode=smode)
    acc = np.zeros((h, w))
    for t, wt in zip(*cells):
        py, px = preimage(yy, xx, t)
        acc += wt * ndimage.map_coordinates(coef, [py, px], order=3, mode=smode, prefilter=False)
    return acc


def translate(v):
    return lambda yy, xx, t: (yy - t * v[0], xx - t * v[1])


def spin(degrees, cy, cx):
    """Content turned by ``t * degrees`` counter-clockwise on screen: read at R(-t theta)."""
    def pre(yy, xx, t):
        a = math.radians(degrees) * t
        dy, dx = yy - cy, xx - cx
        return cy + math.sin(a) * dx + math.cos(a) * dy, cx + math.cos(a) * dx - math.sin(a) * dy
    return pre


def scale_about(cy, cx, factor):
    """The pre-image ``c + (x - c) factor(t)``."""
    def pre(yy, xx, t):
        f = factor(t)
        return cy + (yy - cy) * f, cx + (xx - cx) * f
    return pre


def rel_l2(out, ref, margin):
    o = np.asarray(out, np.float64)[margin:-margin, margin:-margin]
    r = np.asarray(ref, np.float64)[margin:-margin, margin:-margin]
    return float(np.linalg.norm(o - r) / np.linalg.norm(r))


# --------------------------------------------------------------------------------------
# impulse centroids of an oblique uniform blur
# --------------------------------------------------------------------------------------
def green_taps(length, count):
    """The discrete G_u shift by ``length`` (the operator run along each line): taps 0..count-1."""
    lam, kap, tap = greens.shift_coefficients(float(length))
    m = np.arange(1, count)
    return np.concatenate([[tap], np.real(kap * lam ** (m - 1))])


def centroid_planes(velocity, psf, phases=None):
    """A stack with one impulse per plane, one plane per column (row, when steep) of one period
    of the line's fractions (``phases`` of them, evenly spread, if given), and each response's
    exact centroid offset: ``v/2`` for the box, for G_u the taps' mean over the steps that stay
    inside the plane."""
    vy, vx = velocity
    steep = abs(vy) > abs(vx)
    length = int(max(abs(vy), abs(vx)))
    dom_v, min_v = (vy, vx) if steep else (vx, vy)
    dom = 7 * length + 24
    minor = -(-dom * abs(min_v) // length) + 60
    w = green_taps(length, dom)
    m = np.arange(dom)
    planes, src, expect = [], [], []
    ks = range(length) if phases is None else np.unique(np.linspace(0, length - 1, phases).round().astype(int))
    for k in ks:
        t = 12 + k if dom_v > 0 else dom - 13 - k
        kept = dom - t if dom_v > 0 else t + 1
        mean = length / 2 if psf == "box" else (m[:kept] * w[:kept]).sum() / w[:kept].sum()
        pos = (t, 30 if min_v > 0 else minor - 31)
        pos = pos if steep else pos[::-1]
        plane = np.zeros((dom, minor) if steep else (minor, dom), np.float32)
        plane[pos] = 1.0
        planes.append(plane)
        src.append(pos)
        expect.append((mean * vy / length, mean * vx / length))
    return np.stack(planes), np.array(src, np.float64), np.array(expect)


def centroid_error(out, src, expect):
    """Worst distance (px, per axis) between a response's centroid and its expected offset."""
    out = np.asarray(out, np.float64)
    yy = np.arange(out.shape[1])[None, :, None]
    xx = np.arange(out.shape[2])[None, None, :]
    mass = out.sum(axis=(1, 2))
    cy = (out * yy).sum(axis=(1, 2)) / mass - src[:, 0]
    cx = (out * xx).sum(axis=(1, 2)) / mass - src[:, 1]
    return float(max(np.abs(cy - expect[:, 0]).max(), np.abs(cx - expect[:, 1]).max()))


# --------------------------------------------------------------------------------------
# 2-D kernels for cv2.filter2D (correlation: dst(x) = Σ k(d) src(x + d - anchor))
# --------------------------------------------------------------------------------------
def splat(offsets, weights):
    """Weights at fractional offsets ``(dy, dx)`` split bilinearly on the grid: ``(kernel,
    anchor)``, ``anchor = (x, y)`` as cv2 names it, the kernel only as large as its support."""
    dy, dx = offsets
    y0, x0 = np.floor(dy).astype(int), np.floor(dx).astype(int)
    fy, fx = dy - y0, dx - x0
    oy, ox = -y0.min(), -x0.min()
    ker = np.zeros((y0.max() + oy + 2, x0.max() + ox + 2))
    for sy, sx, a in ((0, 0, (1 - fy) * (1 - fx)), (1, 0, fy * (1 - fx)), (0, 1, (1 - fy) * fx), (1, 1, fy * fx)):
        np.add.at(ker, (oy + y0 + sy, ox + x0 + sx), weights * a)
    rows, cols = np.nonzero(ker)
    ker = ker[: rows.max() + 1, : cols.max() + 1]      # no empty last row or column
    return (ker / ker.sum()).astype(np.float32), (int(ox), int(oy))


def box_line_kernel(v):
    """The trailing box exposure ``mean_t I(x - t v)``, t in [0, 1]: 8 samples per pixel of the segment."""
    n = max(16, 8 * math.ceil(math.hypot(*v)))
    t = (np.arange(n) + 0.5) / n
    return splat((-t * v[0], -t * v[1]), np.ones(n))


def green_line_kernel(v, tail=1e-3):
    """G_u sampled along the direction: one tap per pixel of the dominant axis, each the PSF's
    mass over its cell (closed-form cumulative ``1 - e^-t (sin t + cos t)``), cut where the
    remaining tail is below ``tail``."""
    length = max(abs(v[0]), abs(v[1]))
    cdf = lambda t: 1.0 - np.exp(-t) * (np.sin(t) + np.cos(t))
    end = 1.0
    while np.exp(-end) * math.sqrt(2.0) > tail:
        end += 0.25
    k = np.arange(int(math.ceil(end * length)) + 1, dtype=np.float64)
    mass = cdf(np.maximum(k + 0.5, 0) / length) - cdf(np.maximum(k - 0.5, 0) / length)
    return splat((-k * v[0] / length, -k * v[1] / length), mass)


def fspecial_motion(length, theta):
    """MATLAB's ``fspecial('motion', length, theta)`` (theta in degrees, counter-clockwise with
    y up): a centred line whose pixels weigh by their distance to it (width 1), normalised."""
    eps = np.finfo(float).eps
    length = max(1.0, float(length))
    half = (length - 1) / 2
    phi = math.radians(theta % 180)
    cosphi, sinphi = math.cos(phi), math.sin(phi)
    xsign = 1 if cosphi >= 0 else -1
    sx = math.trunc(half * cosphi + xsign - length * eps)
    sy = math.trunc(half * sinphi + 1 - length * eps)
    x, y = np.meshgrid(np.arange(0, sx + xsign, xsign), np.arange(0, sy + 1))
    dist = y * cosphi - x * sinphi
    last = (np.hypot(x, y) >= half) & (np.abs(dist) <= 1)
    along = half - np.abs((x[last] + dist[last] * sinphi) / cosphi)
    dist[last] = np.sqrt(dist[last] ** 2 + along ** 2)
    dist = np.maximum(1 + eps - np.abs(dist), 0)
    m, n = dist.shape
    h = np.zeros((2 * m - 1, 2 * n - 1))
    h[:m, :n] = dist[::-1, ::-1]
    h[m - 1:, n - 1:] = dist
    h /= h.sum() + eps * length * length
    if cosphi > 0:
        h = h[::-1]
    return np.ascontiguousarray(h, np.float32)
