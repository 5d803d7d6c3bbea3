"""Zoom blur: the exact affine G_U^(1) (chapter eqs. 11-12) along lines through the fixed point.

Cell-integrated source taps, run outward for a zoom-in and inward for a zoom-out, with a
per-pixel two-tap moment correction so that each output's taps average exactly to its affine
pre-image (``docs/motion.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .. import greens
from .._core import strips
from .._core.boundary import extend_index
from .._core.job import copy_of_input
from .._core.recursion import plan_pass
from .._core.validation import finite_scalar
from .params import center_point, zoom_u1

__all__ = ["zoom_cell_weights", "ray_zoom_pass", "apply_zoom"]


def _affine_z(u1):
    """``(z, C)`` of G_U^(1) = C/s0 Im[(s/s0)^z], z = alpha + i beta (beta > 0 on both sides).

    Zoom-in (u1 > 0): causal from the fixed point, C = 2/(u1^2 beta).  Zoom-out (u1 < 0):
    anticausal (sources further from the fixed point than the output), C = -2/(u1^2 beta)
    from the jump condition at x0 = s (docs/motion.md); both have unit integral since
    alpha^2 + beta^2 = 2/u1^2.
    """
    alpha = 0.5 - 1.0 / u1
    beta = math.sqrt(1.0 + u1 - u1 * u1 / 4.0) / abs(u1)
    c = 2.0 / (u1 * u1 * beta)
    return complex(alpha, beta), (c if u1 > 0 else -c)


def _power(ratio, z):
    """``ratio**z`` for real ratio >= 0 (inf -> 0 when alpha < 0, 0 -> 0 when alpha > 0)."""
    ratio = np.asarray(ratio, np.float64)
    with np.errstate(divide="ignore"):
        logr = np.log(ratio)
    out = np.exp(z * np.where(np.isfinite(logr), logr, 0.0))
    return np.where(np.isinf(ratio) | (ratio == 0), 0.0, out)


def zoom_cell_weights(s_out, s_src, u1):
    """Cell-integrated G_U^(1) weights (float64 closed form, O(N*K)): the zoom's exact taps.

    The weight of the source pixel at distance ``s_src`` from the fixed point for the output
    at distance ``s_out`` (same side) is ``∫ G_U^(1)(s_out, ξ) dξ`` over the pixel's cell
    ``[s_src - 1/2, s_src + 1/2]`` clipped to the kernel's support: ``(0, s_out)`` for a
    zoom-in (``u1 > 0``, eq. 11-12), ``(s_out, inf)`` for a zoom-out (``u1 < 0``, the
    anticausal bounded solution of eq. 10, see ``docs/motion.md``):

    .. math:: w = \\operatorname{Im}\\Big[\\frac{C}{z}\\big((s/a)^{z} - (s/b)^{z}\\big)\\Big],
       \\quad z = \\alpha + i\\beta,\\ C = \\pm\\frac{2}{u_1^2\\beta}

    with ``alpha = 1/2 - 1/u1``, ``beta = sqrt(1 + u1 - u1^2/4)/|u1|`` and the sign of ``u1``
    (``(s/0)^z = 0`` for ``alpha < 0``, ``(0/a)^z = 0`` for ``alpha > 0``).  At ``s_out = 0`` (the
    fixed point itself) the weight is the limit, the identity.

    Parameters
    ----------
    s_out, s_src : array_like
        Distances from the fixed point (broadcast together), in pixels.
    u1 : float
        Zoom parameter, ``2 - 2 sqrt(2) < u1 < 2``, non-zero.

    Returns
    -------
    ndarray of float64

    Raises
    ------
    ValueError
        ``u1`` outside that range or zero.

    Examples
    --------
    >>> import numpy as np
    >>> w = zoom_cell_weights(40.0, np.arange(41.0), 0.5)
    >>> round(float(w.sum()), 12), round(float((w * np.arange(41)).sum() / w.sum()), 2)
    (1.0, 26.67)
    >>> w = zoom_cell_weights(20.0, np.arange(20.0, 20000.0), -0.3)
    >>> round(float(w.sum()), 9), round(float((w * np.arange(20.0, 20000.0)).sum()), 2)
    (1.0, 28.57)
    """
    u1 = zoom_u1("u1", finite_scalar("u1", u1))
    if u1 == 0.0:
        raise ValueError("u1 must be non-zero for zoom_cell_weights (u1 = 0 is the identity)")
    z, c = _affine_z(u1)
    s, k = np.broadcast_arrays(np.asarray(s_out, np.float64), np.asarray(s_src, np.float64))
    if u1 > 0:
        a = np.clip(k - 0.5, 0.0, None)
        b = np.minimum(k + 0.5, s)
    else:
        a = np.maximum(k - 0.5, s)
        b = k + 0.5
    valid = (s > 0) & (b > a)
    with np.errstate(divide="ignore", invalid="ignore"):
        ra = np.where(valid, s / np.where(a > 0, a, 0.0), 1.0)
        rb = np.where(valid, s / np.where(b > 0, b, 1.0), 1.0)
    w = np.imag((c / z) * (_power(ra, z) - _power(rb, z)))
    w = np.where(valid, w, 0.0)
    return np.where((s == 0) & (k == 0), 1.0, w)


def _mean_correction(lam_full, kap_full, kap_own, s, u1):
    """Weights ``(d_prev, d_own)`` that make an output's taps sum to 1 and average to the
    exact pre-image ``s/(1 + u1)``.

    The cell integrals sample eq. 11 on the pixel grid: where the kernel is narrower than a
    pixel (small displacements ``u1 s/(1 + u1)``, near the fixed point or for small ``u1``)
    their mean is the pixel, not the sub-pixel pre-image (errors up to 0.3 px).  Moving weight
    ``d_prev`` to the previous pixel of the traversal and ``d_own`` to the output's own pixel
    restores both moments exactly (``d_prev = pre - mean`` for a unit step, i.e. linear
    interpolation where the kernel is below a pixel).  The moments of the discrete taps come
    from running the recursion on ``1`` and on ``s`` (float64, O(n)).
    """
    n = len(s)
    # a sequential recursion (no vectorised form with the same rounding), run on Python floats and
    # complexes: the same IEEE operations as on numpy scalars, ~8x faster (4 ms -> 0.5 ms for the
    # 1456 rings of a 2048^2 zoom, a plan each new shape computes)
    lam, kap, owns, ss = lam_full.tolist(), kap_full.tolist(), kap_own.real.tolist(), s.tolist()
    m0, m1, m_first = [0.0] * n, [0.0] * n, [0.0] * n
    f0 = f1 = f_first = 0j
    for k in range(n):
        own, lk, kk, sk = owns[k], lam[k], kap[k], ss[k]
        m0[k], m1[k], m_first[k] = f0.real + own, f1.real + own * sk, f_first.real + (own if k == 0 else 0.0)
        f0 = lk * f0 + kk
        f1 = lk * f1 + kk * sk
        f_first = lk * f_first + (kk if k == 0 else 0.0)
    m0, m1, m_first = np.array(m0), np.array(m1), np.array(m_first)
    excess = 1.0 - m0
    prev = np.empty(n)
    prev[1:] = s[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        d_prev = (s / (1.0 + u1) - m1 - excess * s) / (prev - s)
    d_prev[0] = 0.0      # the segment's first pixel has no previous pixel on its side
    d_prev[s <= 0] = 0.0  # the fixed point maps to itself
    # a zoom-out's far-end cell holds the kernel's whole outer tail: where it carries weight, the
    # mean is off by the image's finite extent (not by sampling) and is left alone
    if u1 < 0:
        d_prev[np.abs(m_first) > 1e-9] = 0.0
    excess = np.where(d_prev == 0.0, 0.0, excess)
    return d_prev, excess - d_prev


def _layout(lam_full, kap_full, kap_own, d_prev, d_own):
    """Two sections on duplicated pixels: A (full source cells) and B (own half cell + the
    previous pixel's correction ``d_prev``, see :func:`_mean_correction`).

    B's state is cleared on each pixel's second copy and picks up ``d_prev I[k-1]`` there,
    then ``(own + d_own) I[k]`` on the first copy of pixel ``k``: per-position taps on the
    output's pixel and its predecessor, which the primitive's constant ``tap`` cannot express.
    """
    n = len(lam_full)
    lam_a = np.empty(2 * n, np.complex128)
    kap_a = np.zeros(2 * n, np.complex128)
    lam_b = np.zeros(2 * n, np.complex128)
    kap_b = np.zeros(2 * n, np.complex128)
    lam_a[0::2] = 1.0
    lam_a[1::2] = lam_full
    kap_a[1::2] = kap_full
    lam_b[0::2] = 1.0
    kap_b[0::2] = kap_own + d_own
    kap_b[1:-1:2] = d_prev[1:]
    return lam_a, kap_a, lam_b, kap_b


@lru_cache(maxsize=64)
def _segment_coefficients(u1, s0, n):
    """(lam, kap) of the two sections over one segment laid out as duplicated pixels
    (:func:`_layout` of :func:`_segment_terms`)."""
    return _layout(*_segment_terms(u1, s0, n))


@lru_cache(maxsize=64)
def _segment_terms(u1, s0, n):
    """``(lam_full, kap_full, kap_own, d_prev, d_own)`` of one segment, in traversal order.

    Zoom-in: segment pixels at distances ``s_k = s0 + k`` (k < n) from the fixed point, run
    outward.  Zoom-out: ``s_k = s0 + (n - 1 - k)``, run inward from the far end, whose cell
    extends to infinity (the extension beyond it is constant).  Each pixel occupies positions
    2k and 2k+1.  Section A carries the full cells of the pixels before the output, section B
    the output pixel's own half cell (``(s - 1/2, s)`` zoom-in, ``(s, s + 1/2)`` zoom-out);
    outputs are read at the odd positions (see ``docs/motion.md``).
    """
    if u1 < 0:
        return _segment_terms_inward(u1, s0, n)
    z, c = _affine_z(u1)
    s = s0 + np.arange(n, dtype=np.float64)
    nxt = s + 1.0
    a = np.clip(s - 0.5, 0.0, None)
    b = s + 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio_a = np.where(a > 0, nxt / np.where(a > 0, a, 1.0), np.inf)
        ratio_b = np.where(b > 0, nxt / np.where(b > 0, b, 1.0), 1.0)
        step = np.where(s > 0, nxt / np.where(s > 0, s, 1.0), 1.0)
    kap_full = np.where(b > 0, -1j * (c / z) * (_power(ratio_a, z) - _power(ratio_b, z)), 0.0)
    lam_full = np.where(s > 0, _power(step, z), 0.0)
    lam_full[-1] = 0.0   # the segment ends: no state leaks into the next one
    kap_full[-1] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        own_ratio = np.where(s > 0.5, s / np.where(s > 0.5, s - 0.5, 1.0), np.inf)
    kap_own = np.where(s > 0, -1j * (c / z) * (_power(own_ratio, z) - 1.0), 0.0)
    kap_own = np.where(s == 0, 1.0 + 0j, kap_own)   # the fixed point maps to itself
    return _terms(lam_full, kap_full, kap_own, s, u1)


def _segment_terms_inward(u1, s0, n):
    """Zoom-out coefficients: F_{k+1} = (s_{k+1}/s_k)^z F_k + [(s_{k+1}/a_k)^z - (s_{k+1}/b_k)^z] I_k."""
    z, c = _affine_z(u1)
    s = s0 + np.arange(n - 1, -1, -1, dtype=np.float64)     # decreasing: far end first
    nxt = np.append(s[1:], -1.0)                             # distance of the next (inner) pixel
    inner = nxt > 0            # outputs at s <= 0 are read from the other segment (or are s = 0)
    a = s - 0.5                # > 0 wherever inner
    b = s + 0.5
    b[0] = np.inf              # the far end's cell takes the whole tail of the kernel
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.where(inner, nxt / s, 0.0)
        ratio_a = np.where(inner, nxt / a, 0.0)
        ratio_b = np.where(inner, nxt / b, 0.0)
        own = np.where(s > 0, s / (s + 0.5), 0.0)
    lam_full = np.where(inner, _power(step, z), 0.0)
    kap_full = np.where(inner, -1j * (c / z) * (_power(ratio_a, z) - _power(ratio_b, z)), 0.0)
    # own half cell (s, s + 1/2); at s = 0 this is -iC/z, i.e. weight 1: the fixed point stays
    kap_own = np.where(s >= 0, -1j * (c / z) * (1.0 - _power(own, z)), 0.0)
    return _terms(lam_full, kap_full, kap_own, s, u1)


def _terms(lam_full, kap_full, kap_own, s, u1):
    terms = (lam_full, kap_full, kap_own, *_mean_correction(lam_full, kap_full, kap_own, s, u1))
    for arr in terms:
        arr.setflags(write=False)     # cached: shared by every caller
    return terms


@dataclass(frozen=True)
class _ZoomLine(greens.GreenKernel):
    """One section of the zoom pass on lines ``[left segment | right segment]``.

    Not a kernel of the chapter in its own right: it packs the coefficients of G_U^(1) run
    outward (zoom-in) or inward (zoom-out) on both sides of the fixed point (``part`` =
    ``"full"`` or ``"own"``).
    """

    u1: float
    left_s0: float
    left_n: int
    right_s0: float
    right_n: int
    part: str

    x_min = -0.5   # no source before the line: a zoom-out's extension is laid out in the line

    @property
    def length(self):
        return 2 * (self.left_n + self.right_n)

    def __call__(self, x, x0):  # pragma: no cover - see zoom_cell_weights for the closed form
        raise NotImplementedError("use zoom_cell_weights for the closed form")

    def coefficients(self, positions):
        left = _segment_coefficients(self.u1, self.left_s0, self.left_n)
        right = _segment_coefficients(self.u1, self.right_s0, self.right_n)
        i = 0 if self.part == "full" else 2
        lam = np.concatenate([left[i], right[i]])
        kap = np.concatenate([left[i + 1], right[i + 1]])
        idx = np.asarray(positions, np.int64)
        return lam[idx], kap[idx]

    def validate_line(self, n, reverse):
        if n != self.length or reverse:
            raise ValueError(f"zoom line layout needs {self.length} causal samples, got {n}")


@dataclass(frozen=True)
class _RayLine(greens.GreenKernel):
    """One section of the zoom pass along a ray from the fixed point, one sample per radius
    ``s = 0, 1, ..., n - 1``, in traversal order (outward for a zoom-in, inward from the far end
    for a zoom-out, whose pass runs reversed): ``part`` ``"full"`` carries the full source cells
    of the samples before the output, ``"prev"`` (no memory: ``lam = 0``) the moment correction
    ``d_prev`` on the previous sample (:func:`_mean_correction`)."""

    u1: float
    n: int
    part: str

    x_min = -0.5   # no source before the ray's first sample

    def __call__(self, x, x0):  # pragma: no cover - see zoom_cell_weights for the closed form
        raise NotImplementedError("use zoom_cell_weights for the closed form")

    def coefficients(self, positions):
        lam_full, kap_full, _, d_prev, _ = _segment_terms(self.u1, 0.0, self.n)
        idx = np.asarray(positions, np.int64)
        if self.part == "full":
            return lam_full[idx], kap_full[idx]
        # the state after sample k is d_prev[k + 1] I[k], read (and replaced) at sample k + 1
        kap = np.zeros(self.n, np.complex128)
        kap[:-1] = d_prev[1:]
        return np.zeros(len(idx), np.complex128), kap[idx]

    def validate_line(self, n, reverse):
        if n != self.n or reverse != (self.u1 < 0):
            raise ValueError(f"a ray pass needs {self.n} samples, run {'in' if self.u1 < 0 else 'out'}ward, got {n}")


def ray_zoom_pass(u1, n):
    """G_U^(1) along rays of ``n`` samples at radii ``0, 1, ..., n - 1`` from the fixed point:
    ``(line_pass, own)``.

    ``line_pass`` (a :class:`~gfgpu._core.passes.LinePass`, causal for a zoom-in, anticausal for
    a zoom-out) gives each sample the full cells of the samples before it in the traversal and
    the moment correction on the previous one; ``own`` (float64, ``(n,)``, by radius) is the
    weight of the sample's own half cell plus its correction, a per-position tap that the
    primitive's constant ``tap`` cannot express: the output is ``line_pass(I) + own * I``.  The
    same cell-integrated taps and moment correction as the separable zoom (:func:`apply_zoom`).
    """
    u1, n = float(u1), int(n)
    _, _, kap_own, _, d_own = _segment_terms(u1, 0.0, n)
    own = kap_own.real + d_own
    kernels = [_RayLine(u1, n, p) for p in ("full", "prev")]
    return (greens.LinePass(tuple(greens.Section(kernel=k) for k in kernels), 0.0, u1 < 0),
            own[::-1].copy() if u1 < 0 else own.copy())


def _zoom_pass(u1, centre, n, pad):
    """The LinePass and segment geometry for a zoom about ``centre`` on lines of ``n`` pixels.

    ``pad`` extension pixels lie beyond each border (zoom-out only, whose sources lie between
    the output and the border and beyond it).
    """
    first_right = math.floor(centre)         # right segment: pixels floor(c) .. n-1 (+ pad)
    first_left = math.ceil(centre)           # left segment (mirrored): pixels ceil(c) .. 0 (- pad)
    geom = dict(left_s0=centre - first_left, left_n=first_left + 1 + pad,
                right_s0=first_right - centre, right_n=n - first_right + pad)
    kernels = [_ZoomLine(u1, part=p, **geom) for p in ("full", "own")]
    lp = greens.LinePass(tuple(greens.Section(kernel=k) for k in kernels), 0.0, False)
    return lp, first_left, first_right, kernels[0].length


@lru_cache(maxsize=16)
def _zoom_maps(batch, height, width, centre, along_x, pad=0, mode="constant"):
    """Gather maps image -> (lines, L) layout and back, for the zoom pass along x or y.

    Zoom-in (``pad = 0``): segments run outward from the fixed point.  Zoom-out (``pad > 0``):
    they run inward from ``pad`` pixels beyond each border, read through ``mode``.
    """
    n, across = (width, height) if along_x else (height, width)
    _, first_left, first_right, length = _zoom_pass(0.5, centre, n, pad)   # geometry only
    if pad == 0:
        left = first_left - np.arange(first_left + 1)
        right = first_right + np.arange(n - first_right)
        pos_right = 2 * (first_left + 1) + 2 * (np.arange(n) - first_right) + 1
        pos_left = 2 * (first_left - np.arange(n)) + 1
    else:
        left = np.arange(-pad, first_left + 1)
        right = np.arange(n - 1 + pad, first_right - 1, -1)
        pos_right = 2 * len(left) + 2 * (n - 1 + pad - np.arange(n)) + 1
        pos_left = 2 * (np.arange(n) + pad) + 1
    along = np.repeat(extend_index(np.concatenate([left, right]), n, mode), 2)  # (L,)
    plane = height * width
    b = np.arange(batch)[:, None, None]
    line = np.arange(across)[None, :, None]
    if along_x:
        flat = b * plane + line * width + along[None, None, :]
    else:
        flat = b * plane + along[None, None, :] * width + line
    flat = np.where(along[None, None, :] < 0, -1, flat)       # constant mode: cval
    pos = np.where(np.arange(n) >= centre, pos_right, pos_left)
    yy, xx = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    line_of, along_of = (yy, xx) if along_x else (xx, yy)
    unshear = ((np.arange(batch)[:, None, None] * across + line_of[None]) * length + pos[along_of][None])
    itype = np.int32 if batch * across * length < 2**31 else np.int64
    shear, unshear = flat.astype(itype).reshape(-1), unshear.astype(itype).reshape(-1)
    for arr in (shear, unshear):
        arr.setflags(write=False)
    return shear, unshear, batch * across, length


def apply_zoom(job, u1y, u1x, center, mode, cval):
    """Zoom ``job``'s image planes by the rates ``(u1y, u1x)`` about ``center = (row, col)``."""
    height, width = job.shape[-2], job.shape[-1]
    batch = int(np.prod(job.shape[:-2], dtype=np.int64))
    cy, cx = center_point(center, height, width)
    if not (0.0 <= cy <= height - 1 and 0.0 <= cx <= width - 1):
        raise ValueError(f"center (row, col) = ({cy:g}, {cx:g}) must lie inside the image, "
                         f"0 <= row <= {height - 1} and 0 <= col <= {width - 1}: the zoom's line layout "
                         f"splits each line at the fixed point")
    strips.require_whole_image(job, "a zoom (its lines run through the fixed point)")
    be, dtype = job.backend, job.dtype
    cur = job.data
    for u1, centre, along_x in ((u1x, cx, True), (u1y, cy, False)):   # along the rows, then the columns
        if u1 == 0.0:
            continue
        n = width if along_x else height
        # zoom-out: materialise one line length of the mode's extension beyond each border
        # (constant beyond that); see docs/motion.md for the error this leaves
        pad = n if u1 < 0 else 0
        lp, _, _, length = _zoom_pass(u1, float(centre), n, pad)
        shear, unshear, lines, length = _zoom_maps(batch, height, width, float(centre), along_x, pad,
                                                   mode if pad else "constant")
        rows_in = be.empty((1, lines, length), dtype)
        rows_out = be.empty((1, lines, length), dtype)
        be.gather(be.reshape(cur, (-1,)), shear, cval, be.reshape(rows_in, (-1,)))
        be.recurse(rows_in, rows_out, 2, plan_pass(lp, length, "constant", dtype), 0.0)
        nxt = job.empty()
        be.gather(be.reshape(rows_out, (-1,)), unshear, 0.0, be.reshape(nxt, (-1,)))
        cur = nxt
    if cur is job.data:
        return job.finish(copy_of_input(job))
    return job.finish(cur)
