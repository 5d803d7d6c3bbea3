"""Motion blur, zoom and frame synthesis with the Green's filters (chapter §1, §6).

The chapter's Green's functions are point-spread functions that *move* image content and
add the blur of that motion: G_u (eq. 9) along a direction for uniform motion, and the exact
affine G_U^(1) (eq. 11-12) for a zoom about a fixed point.  This module turns them into
graphics operators:

* :func:`motion_blur` -- uniform linear motion of any direction (``kind="uniform"``) or a
  zoom about a centre (``kind="zoom"``);
* :func:`synthesize_motion` -- a sequence of frames at growing displacement;
* :func:`interpolate_frames` -- in-between frames of a pair related by a uniform translation.

Every operator is a fixed number of O(N) recursive passes (DESIGN §1): the cost per pixel does
not depend on the blur length or the zoom factor.

Discretisations (and their errors) are stated in each docstring; the derivations are in
``docs/motion.md``.

References
----------
.. [1] J. R. A. Torreão, S. M. C. Victer, J. L. Fernandes, "Green's Functions of Matching
   Equations: A Unifying Approach for Low-level Vision Problems", 2007, eqs. 9-12 and §1, §6.
.. [2] J. Ferreira Jr., J. R. A. Torreão et al., "Motion synthesis through 1D affine
   matching", Pattern Analysis and Applications, doi:10.1007/s10044-007-0078-6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import greens, strips
from .filters import Program, _apply_sequence, _copy_of_input, _direction_steps, _finite_cval, _Job
from .recursion import check_mode, plan_lines, plan_pass

__all__ = ["motion_blur", "synthesize_motion", "interpolate_frames", "estimate_translation",
           "zoom_cell_weights"]

KINDS = ("uniform", "zoom", "rotation")


# --------------------------------------------------------------------------------------
# argument handling
# --------------------------------------------------------------------------------------
def _pair(value, name):
    """A pair of finite floats from a scalar (used twice) or a length-2 sequence."""
    arr = np.asarray(value, dtype=object)
    if arr.ndim == 0:
        arr = np.array([value, value], dtype=object)
    if arr.shape != (2,):
        raise ValueError(f"{name} must be a number or a pair of numbers, got {value!r}")
    return tuple(greens._finite_scalar(name, v) for v in arr)


def _velocity(velocity):
    if np.ndim(velocity) == 0:
        raise ValueError(f"velocity must be a pair (dx, dy) in pixels for kind='uniform', got {velocity!r}")
    return _pair(velocity, "velocity")


U1_MIN = 2.0 - 2.0 * math.sqrt(2.0)   # below: beta of eq. 12 is imaginary (no oscillating G_U^(1))


def _zoom_u1(name, u1):
    """One zoom rate, checked against the range of a bounded real G_U^(1)."""
    if not U1_MIN < u1 < 2.0:
        raise ValueError(f"{name} must lie in (2 - 2*sqrt(2), 2) ~ (-0.8284, 2) for a bounded G_U^(1) "
                         f"(eq. 12: alpha < 0 for zoom-in u1 > 0, real beta for zoom-out u1 < 0), "
                         f"got {u1!r}")
    return u1


def _zoom_factors(velocity):
    u1x, u1y = _pair(velocity, "velocity (zoom u1)")
    return _zoom_u1("velocity (zoom u1)", u1x), _zoom_u1("velocity (zoom u1)", u1y)


def _move_channels(image, channel_axis):
    """Put a colour axis first (numpy input only); returns (array, undo)."""
    if channel_axis is None:
        return image, lambda out: out
    arr = np.asarray(image)
    ax = int(channel_axis)
    if not -arr.ndim <= ax < arr.ndim or arr.ndim < 3:
        raise ValueError(f"channel_axis={channel_axis} is out of range for an input of shape {arr.shape} "
                         f"(a colour image needs 3 dimensions)")
    ax %= arr.ndim
    moved = np.ascontiguousarray(np.moveaxis(arr, ax, 0))
    return moved, lambda out: np.moveaxis(out, 0, ax)


# --------------------------------------------------------------------------------------
# uniform motion: the discrete G_u shift along a direction
# --------------------------------------------------------------------------------------
def uniform_motion_program(ndim, velocity, displace=True):
    """The :class:`~gfgpu.filters.Program` of a uniform motion by ``velocity = (dx, dy)``."""
    if ndim < 2:
        raise ValueError(f"motion blur needs an image (at least 2 dimensions), got {ndim}")
    dx, dy = _velocity(velocity)
    length = max(abs(dx), abs(dy))   # steps of the dominant axis (gfgpu.lines convention)
    if length == 0.0:
        return Program([])
    angle = math.atan2(dy, dx)
    if displace:
        parts = [greens.shift_pass(length)]
    else:
        # anticausal half then causal half: the PSF is the autocorrelation of one half-shift
        # kernel (symmetric, single-peaked); both halves have mean exactly -L/2 and +L/2.
        parts = [greens.shift_pass(-length / 2), greens.shift_pass(length / 2)]
    steps, plane = [], None
    for lp in parts:
        s, plane = _direction_steps(ndim, [lp], angle, (-2, -1))
        steps += s
    return Program(steps, plane)


# --------------------------------------------------------------------------------------
# zoom: G_U^(1) with cell-integrated source taps, run outward (zoom-in) or inward (zoom-out)
# --------------------------------------------------------------------------------------
def _affine_z(u1):
    """``(z, C)`` of G_U^(1) = C/s0 Im[(s/s0)^z], z = alpha + i beta (beta > 0 on both sides).

    Zoom-in (u1 > 0): causal from the fixed point, C = 2/(u1^2 beta).  Zoom-out (u1 < 0):
    anticausal (sources further from the fixed point than the output), C = -2/(u1^2 beta)
    from the jump condition (science.md §4); both have unit integral since
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
    anticausal bounded solution of eq. 10, science.md §4):

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
    u1 = _zoom_u1("u1", greens._finite_scalar("u1", u1))
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
    m0, m1, m_first = np.empty(n), np.empty(n), np.empty(n)
    f0 = f1 = f_first = 0j
    for k in range(n):
        own = kap_own[k].real
        m0[k], m1[k], m_first[k] = f0.real + own, f1.real + own * s[k], f_first.real + (own if k == 0 else 0.0)
        f0 = lam_full[k] * f0 + kap_full[k]
        f1 = lam_full[k] * f1 + kap_full[k] * s[k]
        f_first = lam_full[k] * f_first + (kap_full[k] if k == 0 else 0.0)
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
    """(lam, kap) of the two sections over one segment laid out as duplicated pixels.

    Zoom-in: segment pixels at distances ``s_k = s0 + k`` (k < n) from the fixed point, run
    outward.  Zoom-out: ``s_k = s0 + (n - 1 - k)``, run inward from the far end, whose cell
    extends to infinity (the extension beyond it is constant).  Each pixel occupies positions
    2k and 2k+1.  Section A carries the full cells of the pixels before the output, section B
    the output pixel's own half cell (``(s - 1/2, s)`` zoom-in, ``(s, s + 1/2)`` zoom-out);
    outputs are read at the odd positions (see ``docs/motion.md``).
    """
    if u1 < 0:
        return _segment_coefficients_inward(u1, s0, n)
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
    return _layout(lam_full, kap_full, kap_own, *_mean_correction(lam_full, kap_full, kap_own, s, u1))


def _segment_coefficients_inward(u1, s0, n):
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
    return _layout(lam_full, kap_full, kap_own, *_mean_correction(lam_full, kap_full, kap_own, s, u1))


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


def _extension_index(p, n, mode):
    """Image index of the (possibly outside) pixel ``p`` under a scipy.ndimage mode; -1 = cval."""
    if mode == "constant":
        return np.where((p >= 0) & (p < n), p, -1)
    if mode == "nearest":
        return np.clip(p, 0, n - 1)
    if mode == "wrap":
        return np.mod(p, n)
    if mode == "reflect":                    # d c b a | a b c d | d c b a
        q = np.mod(p, 2 * n)
        return np.where(q < n, q, 2 * n - 1 - q)
    if n == 1:                               # mirror: d c b | a b c d | c b a
        return np.zeros_like(p)
    q = np.mod(p, 2 * n - 2)
    return np.where(q < n, q, 2 * n - 2 - q)


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
    along = np.repeat(_extension_index(np.concatenate([left, right]), n, mode), 2)  # (L,)
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


def _zoom(job, u1x, u1y, center, mode, cval):
    height, width = job.shape[-2], job.shape[-1]
    batch = int(np.prod(job.shape[:-2], dtype=np.int64))
    if center is None:
        cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    else:
        cx, cy = _pair(center, "center")
    if not (0.0 <= cx <= width - 1 and 0.0 <= cy <= height - 1):
        raise ValueError(f"center (x, y) = ({cx}, {cy}) must lie inside the image, 0 <= x <= {width - 1} "
                         f"and 0 <= y <= {height - 1}: the zoom's line layout splits each line at "
                         f"the fixed point")
    strips.require_whole_image(job, "a zoom (its lines run through the fixed point)")
    be, dtype = job.backend, job.dtype
    cur = job.data
    for u1, centre, along_x in ((u1x, cx, True), (u1y, cy, False)):
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
        return job.finish(_copy_of_input(job))
    return job.finish(cur)


# --------------------------------------------------------------------------------------
# rotation: three Green's shears (Paeth), each line shifted by its own amount
# --------------------------------------------------------------------------------------
ROTATION_MAX_DEGREES = 90.0   # tan(θ/2) <= 1: the shears stay at most one pixel per pixel


def _rotation_angle(velocity):
    theta = greens._finite_scalar("velocity (rotation angle in degrees)", velocity)
    if abs(theta) > ROTATION_MAX_DEGREES:
        raise ValueError(f"velocity (rotation angle) must lie in [-{ROTATION_MAX_DEGREES:g}, "
                         f"{ROTATION_MAX_DEGREES:g}] degrees for the three-shear rotation, got {theta!r}")
    return theta


def rotation_shears(degrees):
    """``[(axis, rate), ...]``: the three shears whose product is the rotation by ``degrees``.

    A point p (x right, y down) moves to ``c + R (p - c)``, R = [[cos θ, sin θ], [-sin θ, cos θ]]
    (counter-clockwise on screen for θ > 0), and ``R = X(a) Y(b) X(a)`` with ``a = tan(θ/2)``,
    ``b = -sin θ`` (Paeth 1986): ``X(a)`` moves row y by ``a (y - y_c)`` along x (axis -1),
    ``Y(b)`` column x by ``b (x - x_c)`` along y (axis -2).
    """
    theta = math.radians(degrees)
    a, b = math.tan(theta / 2.0), -math.sin(theta)
    return [(-1, a), (-2, b), (-1, a)]


def _shear_plans(rate, n_lines, centre, n, mode, dtype):
    """Per-line plans of a shear: line i displaced by ``rate (i - centre)`` (the G_u shift)."""
    passes = []
    for i in range(n_lines):
        d = rate * (i - centre)
        passes.append(greens.shift_pass(d) if abs(d) > 1e-9 else None)
    return plan_lines(passes, n, mode, dtype)


def _rotation(job, degrees, center, displace, mode, cval):
    height, width = job.shape[-2], job.shape[-1]
    if center is None:
        cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    else:
        cx, cy = _pair(center, "center")
    strips.require_whole_image(job, "a rotation (its shears move whole rows and columns)")
    if degrees == 0.0:
        return job.finish(_copy_of_input(job))
    shears = rotation_shears(degrees) if displace else \
        rotation_shears(-degrees / 2.0) + rotation_shears(degrees / 2.0)
    be, dtype = job.backend, job.dtype
    batch = int(np.prod(job.shape[:-2], dtype=np.int64))
    cur = be.reshape(job.data, (batch, height, width))
    bufs = [be.empty((batch, height, width), dtype) for _ in range(2)]
    for i, (axis, rate) in enumerate(shears):
        # rows (axis -1): line = row y, about y_c; columns (axis -2): line = column x, about x_c
        lines, n, centre = (height, width, cy) if axis == -1 else (width, height, cx)
        plans = _shear_plans(rate, lines, centre, n, mode, dtype)
        nxt = bufs[i % 2]
        be.recurse_lines(cur, nxt, 2 if axis == -1 else 1, plans, cval)
        cur = nxt
    result = job.result_buffer()
    be.copy(cur, be.reshape(result, (batch, height, width)))
    return job.finish(result)


# --------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------
def motion_blur(image, velocity, *, kind="uniform", center=None, displace=True, mode="reflect",
                cval=0.0, channel_axis=None, output=None, backend=None, device=None):
    """Motion blur through the chapter's Green's filters: uniform motion, a zoom or a rotation.

    Parameters
    ----------
    image : array_like, warp.array or pyopencl.array.Array
        Image ``(H, W)``, stack ``(..., H, W)`` (the image plane is the last two axes), or a
        colour image with ``channel_axis`` (numpy input).  float32/float64 kept, integers ->
        float32.
    velocity : pair of float, or float for ``kind="zoom"`` and ``kind="rotation"``
        ``kind="uniform"``: the displacement ``(dx, dy)`` in pixels during the exposure, x to
        the right (columns), y down (rows).  ``(0, 0)`` returns a copy.
        ``kind="zoom"``: the affine rate ``u1`` (eq. 10, ``U = u1 (x - x_U)``), one value or
        ``(u1_x, u1_y)``; ``2 - 2 sqrt(2) < u1 < 2`` (about -0.828 .. 2): ``u1 > 0`` zooms in,
        ``u1 < 0`` zooms out, 0 leaves that axis unchanged.  A point at ``x`` moves to
        ``x_U + (x - x_U)(1 + u1)``.
        ``kind="rotation"``: the angle turned during the exposure, in degrees, within
        [-90, 90]; positive turns counter-clockwise on screen (x right, y down): a point at p
        moves to ``c + R (p - c)``, ``R = [[cos, sin], [-sin, cos]]``.
    kind : {'uniform', 'zoom', 'rotation'}
    center : pair of float, optional
        Fixed point ``(x_U, y_U)`` of the zoom (inside the image) or of the rotation; default
        the image centre.
    displace : bool, optional
        Uniform motion and rotation.  True: content moves by ``velocity`` and is blurred along
        its path (the G_u point-spread function).  False: content stays in place (centroid kept
        exactly; a rotation by ``-velocity/2`` then ``+velocity/2``) and is blurred
        symmetrically along the path.
    mode, cval : optional
        Boundary extension along the motion (scipy.ndimage names, see :func:`gfgpu.green_filter`).
        A zoom-in reads no sample beyond the image (its sources lie between the fixed point and
        the output), so ``mode`` does not affect it.  A zoom-out reads outward to infinity:
        ``mode`` extends the image beyond the border (see Notes).
    channel_axis : int, optional
        Axis of colour channels of a numpy image (e.g. ``-1`` for ``(H, W, 3)``).
    output : ndarray or dtype, optional
        As in :func:`gfgpu.green_filter` (not with ``channel_axis``).
    backend, device : str, optional
        ``"numpy"``, ``"warp"`` or ``"opencl"`` and its device (DESIGN §4 rule by default).

    Returns
    -------
    ndarray or device array
        Same shape as ``image``; same kind of array.

    Raises
    ------
    ValueError
        Unknown ``kind``, non-finite or malformed ``velocity``, ``u1`` outside
        ``(2 - 2 sqrt(2), 2)``, a rotation angle outside [-90, 90] degrees, a zoom
        ``center`` outside the image, bad ``mode``, empty or non-finite input.
    TypeError
        Unsupported dtype or non-numeric parameters.

    Notes
    -----
    **Uniform motion** (eq. 7-9).  One recursive pass along the direction of ``velocity`` of
    the discrete G_u shift (:func:`gfgpu.greens.shift_pass`: G_u's poles ``e^{(-1±i)/L}``, unit
    DC gain and first moment exactly ``L``), ``L = max(|dx|, |dy|)`` steps of the dominant axis
    along the digital lines of :mod:`gfgpu.lines`.  Along an axis or a diagonal the displacement
    is exact (to 1e-6 px); along other directions the displacement of the dominant axis is
    exact and that of the minor axis is exact on average but quantised per pixel (error up to
    0.5 px, see ``docs/motion.md``).  ``displace=False`` runs the anticausal shift by ``L/2`` then
    the causal one by ``L/2``: the PSF is the autocorrelation of the half-shift kernel (even,
    single-peaked, zero phase) and its mean is exactly 0.  Cost: one (two) pass(es), O(1) per
    pixel whatever ``L``.

    **Zoom** (eq. 10-12).  G_U^(1) is an exact affine warp to second order (zero variance, mean
    at the pre-image ``x_U + (x - x_U)/(1 + u1)``; science.md §4).  It is applied separably, rows
    about ``x_U`` then columns about ``y_U``, each line split at the fixed point and the
    recursion run outward on each side.  Point samples of eq. 11 fail near the fixed point
    (the kernel has an integrable singularity there), so the source taps are the exact cell
    integrals of eq. 11 (:func:`zoom_cell_weights`): unit DC gain at every pixel, mean within
    0.3 px of the pre-image (0.13 px beyond 5 px from the fixed point for 0.25 <= u1 <= 1.5;
    measured in ``docs/motion.md``).
    The output pixel's own half cell needs a per-position direct
    term, realised by laying each pixel out twice (two sections, see ``docs/motion.md``).

    **Zoom-out** (``u1 < 0``).  The bounded solution of eq. 10 is then anticausal: the sources
    of the output at distance ``s`` from the fixed point lie further out, ``x0 > s``, with
    ``G = 2/(u1^2 beta x0) (x0/s)^(-alpha) sin(beta ln(x0/s))`` (``alpha = 1/2 - 1/u1 > 0``,
    ``beta = sqrt(1 + u1 - u1^2/4)/|u1|``, real for ``u1 > 2 - 2 sqrt(2)``; science.md §4).  It
    has unit integral and its mean is at the pre-image ``x_U + (x - x_U)/(1 + u1)`` (zero
    variance for ``u1 > -2/3``; infinite below).  Same cell-integrated taps and factorisation,
    but the recursion runs inward, from beyond the border toward the fixed point.  The kernel's
    tail decays only like ``(s/x0)^alpha``, so it reaches past the border: one line length of
    the ``mode`` extension is laid out beyond each border, and the last extended pixel's cell
    takes the rest of the tail (exact for ``'nearest'`` and ``'constant'``; for
    ``'reflect'/'mirror'/'wrap'`` the extension is constant beyond one image length).  Unit DC
    gain everywhere except with ``mode='constant'``, where the mass beyond the border is
    ``cval``'s.  The mapping is accurate (0.04 px at ``u1 = -0.1``, 0.06 px at ``-0.3``) where
    ``s`` is small beside the distance ``S`` to the border (``s <= S/3`` and ``S/10``); closer
    to the border the extension shows (``docs/motion.md``).

    *Rotation* is the product of three shears, ``R = X(tan(θ/2)) Y(-sin θ) X(tan(θ/2))``
    (Paeth 1986, :func:`rotation_shears`): each shear moves every row (column) by its own
    amount ``a (y - y_c)`` with the discrete G_u shift of that amount (unit DC gain, mean
    exactly the amount), run by the per-line primitive (:meth:`Backend.recurse_lines`).  The
    mapping is therefore exact for linear content (every pixel shows its rotation pre-image,
    away from the border's reach) and the blur of each shear runs along its own direction:
    the composite smear approximates the arc of length ``r θ`` (radians) at radius r by three
    straight strokes, which is close for small angles and coarser towards 90 degrees.

    References
    ----------
    .. [1] Torreão et al., "Green's Functions of Matching Equations", 2007, eqs. 7-12.
    .. [2] Ferreira Jr. et al., "Motion synthesis through 1D affine matching", PAA, 2008.
    .. [3] A. W. Paeth, "A fast algorithm for general raster rotation", Graphics Interface, 1986.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.motion import motion_blur
    >>> img = np.zeros((32, 256)); img[16, 10] = 1
    >>> out = motion_blur(img, (12.5, 0), mode="constant", backend="numpy")
    >>> round(float((out[16] * np.arange(256)).sum()), 4)
    22.5
    >>> z = motion_blur(np.tile(np.arange(64.0), (8, 1)), 0.5, kind="zoom", center=(20, 4),
    ...                       backend="numpy")
    >>> round(float(z[4, 50]), 1)  # samples the pre-image 20 + 30 / 1.5
    40.0
    >>> zo = motion_blur(np.tile(np.arange(512.0), (8, 1)), -0.2, kind="zoom", center=(200, 4),
    ...                  mode="nearest", backend="numpy")
    >>> round(float(zo[4, 216]), 2)  # zoom-out: samples the pre-image 200 + 16 / 0.8
    220.0
    >>> yy, xx = np.mgrid[:101, :101].astype(float)
    >>> r = motion_blur(xx, 5.0, kind="rotation", center=(50, 50), mode="nearest", backend="numpy")
    >>> round(float(r[40, 50]), 4)  # 10 px above the centre: pre-image x = 50 + 10 sin(5 deg)
    50.8716
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    check_mode(mode)
    cval = _finite_cval(cval)
    if channel_axis is not None:
        if output is not None:
            raise ValueError("output cannot be combined with channel_axis; use the return value")
        moved, undo = _move_channels(image, channel_axis)
        return undo(motion_blur(moved, velocity, kind=kind, center=center, displace=displace, mode=mode,
                                cval=cval, backend=backend, device=device))
    if kind == "uniform":
        _velocity(velocity)
        job = _Job(image, output, backend, device, min_ndim=2)
        return _apply_sequence(job, uniform_motion_program(job.ndim, velocity, bool(displace)), mode, cval)
    if kind == "rotation":
        degrees = _rotation_angle(velocity)
        job = _Job(image, output, backend, device, min_ndim=2)
        return _rotation(job, degrees, center, bool(displace), mode, cval)
    u1x, u1y = _zoom_factors(velocity)
    job = _Job(image, output, backend, device, min_ndim=2)
    return _zoom(job, u1x, u1y, center, mode, cval)


def _frame_parameters(velocity, kind, n_frames):
    try:
        n = int(n_frames)
    except (TypeError, ValueError):
        raise TypeError(f"n_frames must be an integer, got {n_frames!r}") from None
    if n != n_frames or n < 2:
        raise ValueError(f"n_frames must be an integer >= 2, got {n_frames!r}")
    t = np.arange(n) / (n - 1)
    if kind == "uniform":
        dx, dy = _velocity(velocity)
        return [(float(dx * f), float(dy * f)) for f in t]
    if kind == "zoom":
        u1x, u1y = _zoom_factors(velocity)
        # constant zoom rate: the scale grows geometrically, (1 + u1)^t
        return [((1 + u1x) ** f - 1, (1 + u1y) ** f - 1) for f in t]
    if kind == "rotation":
        return [float(_rotation_angle(velocity) * f) for f in t]
    raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")


def synthesize_motion(image, velocity, n_frames, *, kind="uniform", center=None, displace=True,
                      mode="reflect", cval=0.0, channel_axis=None, backend=None, device=None,
                      progress=None):
    """A sequence of frames moving ``image`` progressively (motion synthesis, chapter §1).

    Frame ``k`` (``k = 0 .. n_frames - 1``) is :func:`motion_blur` at the fraction
    ``t = k / (n_frames - 1)`` of the motion: displacement ``t * velocity`` for uniform motion,
    scale ``(1 + u1)^t`` (``u1_k = (1 + u1)^t - 1``, a constant zoom rate) for a zoom.  Frame 0
    is the input itself.

    Parameters
    ----------
    image, velocity, kind, center, displace, mode, cval, channel_axis, backend, device
        As in :func:`motion_blur`.
    n_frames : int
        Number of frames, >= 2.
    progress : callable, optional
        Called with no argument after each frame (e.g. a tqdm bar's ``update``).

    Returns
    -------
    ndarray of shape ``(n_frames,) + image.shape`` for numpy input, else a list of device arrays.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.motion import synthesize_motion
    >>> img = np.zeros((16, 512)); img[8, 4] = 1
    >>> frames = synthesize_motion(img, (30, 0), 4, mode="constant", backend="numpy")
    >>> [round(float((f[8] * np.arange(512)).sum()), 3) for f in frames]
    [4.0, 14.0, 24.0, 34.0]
    """
    params = _frame_parameters(velocity, kind, n_frames)
    frames = []
    for p in params:
        frames.append(motion_blur(image, p, kind=kind, center=center, displace=displace, mode=mode,
                                  cval=cval, channel_axis=channel_axis, backend=backend, device=device))
        if progress is not None:
            progress()
    if all(isinstance(f, np.ndarray) for f in frames):
        return np.stack(frames)
    return frames


def estimate_translation(frame0, frame1, upsample_factor=20):
    """Global translation ``(dx, dy)`` that moves ``frame0`` onto ``frame1`` (phase correlation).

    :func:`skimage.registration.phase_cross_correlation` on the mean-removed frames under a
    Hann window (which suppresses the border discontinuity of non-periodic images), to
    ``1/upsample_factor`` px.  Colour frames ``(H, W, C)`` are registered on their channel mean.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.ndimage import gaussian_filter
    >>> big = gaussian_filter(np.random.default_rng(0).random((140, 160)), 2.0)
    >>> estimate_translation(big[20:120, 20:140], big[17:117, 15:135])
    (5.0, 3.0)
    """
    from skimage.filters import window
    from skimage.registration import phase_cross_correlation
    a, b = np.asarray(frame0, np.float64), np.asarray(frame1, np.float64)
    if a.shape != b.shape:
        raise ValueError(f"frame0 and frame1 must have the same shape, got {a.shape} and {b.shape}")
    if a.ndim == 3:   # colour: register the channel mean
        a, b = a.mean(axis=-1), b.mean(axis=-1)
    if a.ndim != 2:
        raise ValueError(f"frames must be 2-D (or colour (H, W, C)), got shape {a.shape}")
    hann = window("hann", a.shape)
    shift, _, _ = phase_cross_correlation((b - b.mean()) * hann, (a - a.mean()) * hann,
                                          upsample_factor=upsample_factor)
    dy, dx = (float(s) for s in shift)
    return dx, dy


def interpolate_frames(frame0, frame1, n, *, velocity=None, mode="nearest", channel_axis=None,
                       backend=None, device=None):
    """``n`` in-between frames of a pair related by a global uniform translation.

    Frame ``k`` (``k = 1 .. n``) at ``t = k / (n + 1)`` is the blend

    .. math:: (1 - t)\\, S_{t v}[I_0] + t\\, S_{-(1 - t) v}[I_1]

    of ``frame0`` moved forward by ``t v`` and ``frame1`` moved back by ``(1 - t) v``, both with
    the exact-mean G_u shift (:func:`gfgpu.shift`).  Where the pair really is a translation, both
    terms agree and the blend only averages their (small, symmetric) filter blur; the weights
    fade each frame in as it gets closer in time.

    Parameters
    ----------
    frame0, frame1 : array_like
        Two numpy images of the same shape (grey ``(H, W)`` or colour with ``channel_axis``).
    n : int
        Number of in-between frames (>= 1).
    velocity : pair of float, optional
        Displacement ``(dx, dy)`` from ``frame0`` to ``frame1`` in pixels; estimated by phase
        correlation (:func:`estimate_translation`, 1/20 px) when omitted.
    mode, channel_axis, backend, device
        As in :func:`motion_blur`; ``mode`` defaults to ``'nearest'`` (content entering at the
        border is extended from the edge).

    Returns
    -------
    ndarray of shape ``(n,) + frame0.shape``, float32 or float64.

    Raises
    ------
    ValueError
        Frames of different shapes, ``n < 1``.

    Notes
    -----
    Limits: one global translation only (no per-pixel flow, no occlusion handling, no affine or
    rotational motion); content that enters through the border is an extension by ``mode``;
    phase correlation needs enough texture and finds the dominant translation of the pair.  The
    blend is computed on the host (numpy); device arrays are not accepted here.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.motion import interpolate_frames
    >>> x = np.arange(256.0)
    >>> f0 = np.tile(np.exp(-(x - 120) ** 2 / 18), (8, 1)); f1 = np.tile(np.exp(-(x - 130) ** 2 / 18), (8, 1))
    >>> mid = interpolate_frames(f0, f1, 1, velocity=(10, 0), backend="numpy")[0]
    >>> round(float((mid[4] * x).sum() / mid[4].sum()), 3)
    125.0
    """
    a, b = np.asarray(frame0), np.asarray(frame1)
    if a.shape != b.shape:
        raise ValueError(f"frame0 and frame1 must have the same shape, got {a.shape} and {b.shape}")
    try:
        count = int(n)
    except (TypeError, ValueError):
        raise TypeError(f"n must be an integer, got {n!r}") from None
    if count != n or count < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    if velocity is None:
        ca, cb = a, b
        if channel_axis is not None:
            ca, cb = np.moveaxis(a, channel_axis, -1), np.moveaxis(b, channel_axis, -1)
        dx, dy = estimate_translation(ca, cb)
    else:
        dx, dy = _velocity(velocity)
    from .filters import shift as g_shift
    a_moved, undo = _move_channels(a, channel_axis)
    b_moved, _ = _move_channels(b, channel_axis)
    frames = []
    for k in range(1, count + 1):
        t = k / (count + 1)
        fwd = g_shift(a_moved, (t * dy, t * dx), mode=mode, axes=(-2, -1), backend=backend, device=device)
        back = g_shift(b_moved, (-(1 - t) * dy, -(1 - t) * dx), mode=mode, axes=(-2, -1),
                       backend=backend, device=device)
        frames.append(undo((1 - t) * fwd + t * back))
    return np.stack(frames)
