"""Dense disparity maps of rectified stereo pairs (chapter §5).

Three methods share one entry point, :func:`disparity`:

``"sgm"`` (default)
    Census matching cost over the disparity range, optionally sampled below the pixel with
    exact Green's-function shifts of the right view (``subpixel_steps``), semi-global
    aggregation (Hirschmüller 2008, 8 paths), winner-take-all with a uniqueness test and a
    parabola fit, and a left-right consistency check.
``"uniform"``
    The chapter's sweep: for each disparity ``d = n + f`` the left view is shifted by ``-f/2``
    and the right view by ``+f/2`` with the exact discrete G_u shift (:func:`gfgpu.shift`),
    the integer part ``n`` is an index offset, windowed squared differences are compared and
    a per-pixel running best is kept (memory O(H·W)).
``"affine"``
    The same sweep with the chapter's G_U^(2) (eq. 14, σ fixed, x_U swept as
    ``x_U = -σ²/s`` for a shift ``s``), each filtered image divided by the filtered constant
    image to undo its gain ramp.  Point-sampled, G_U^(2) shifts by about ``s + 1/(6s)``
    rather than ``s`` (never less than 0.86 px; ``docs/derivations.md``, "G_U^(2)"), so this
    method's sub-pixel values are biased (measured in ``docs/stereo.md``).

Each stage runs on the backend: census, matching cost, path aggregation, selection and the
sweep's running best are fused kernels (:mod:`gfgpu.stereo.kernels`), whose executable numpy
specifications are the ``*_reference`` functions of :mod:`gfgpu.backends.specs`.  The
left-right check and the input handling run on the host (O(H·W)).
"""

from __future__ import annotations

import math

import numpy as np

from .. import greens
from ..backends import resolve_backend
from ..backends.specs import NO_MATCH
from ..filters import green_filter, shift
from . import kernels

__all__ = ["disparity", "disparity_work", "METHODS", "fill_holes", "random_dot_stereogram", "sweep_finish"]

METHODS = ("sgm", "uniform", "affine")

#: largest census radius: (2r+1)^2 - 1 comparison bits must fit one uint64
MAX_CENSUS_RADIUS = 3

#: aggregated costs are int16 on every backend: 8 paths of at most (max cost + P2) each
_INT16_MAX = 32767

#: sweep state planes (float32): best cost, its disparity, cost one step before the best,
#: one step after it, and the previous step's cost (for the parabola of the running best)
SWEEP_PLANES = 5

# --------------------------------------------------------------------------------------
# host helpers
# --------------------------------------------------------------------------------------
def sweep_finish(state, step):
    """Disparity of a finished sweep: the best ``d`` plus the parabola vertex (numpy, O(H·W))."""
    best, best_d, before, after, _ = (np.asarray(p, np.float64) for p in state)
    den = before - 2 * best + after
    ok = np.isfinite(before) & np.isfinite(after) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(ok, (before - after) / (2 * den), 0.0)
    return (best_d + step * delta).astype(np.float32)


def fill_holes(disp):
    """Fill NaN pixels from the nearest valid pixel on the same row, the smaller of the two.

    The smaller disparity is the background's, which is what an occlusion hides (the
    Middlebury evaluation's hole filling, also used by ``benchmarks/stereo.py`` for every
    method).
    Rows without any valid pixel become 0.

    Parameters
    ----------
    disp : (H, W) float ndarray with NaN holes

    Returns
    -------
    (H, W) ndarray, a filled copy
    """
    d = np.array(disp, dtype=np.float32, copy=True)
    holes = ~np.isfinite(d)
    if not holes.any():
        return d
    h, w = d.shape
    idx = np.broadcast_to(np.arange(w), (h, w))
    left = np.maximum.accumulate(np.where(holes, -1, idx), axis=1)
    right = np.minimum.accumulate(np.where(holes, w, idx)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(h)[:, None]
    lv = np.where(left >= 0, d[rows, np.maximum(left, 0)], np.inf)
    rv = np.where(right < w, d[rows, np.minimum(right, w - 1)], np.inf)
    fill = np.minimum(lv, rv)
    fill[~np.isfinite(fill)] = 0
    d[holes] = fill[holes]
    return d


def grey_image(image, name):
    arr = np.asarray(image)
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a real numeric image, got dtype {arr.dtype}")
    if arr.ndim == 3 and arr.shape[-1] in (1, 3, 4):
        if arr.shape[-1] == 4:
            arr = arr[..., :3]     # alpha is not image content
        # the channel mean, summed in channel order as numpy's mean does (an explicit sum:
        # a reduction over a length-3 axis is several times slower)
        chans = arr.astype(np.float32)
        arr = chans[..., 0]
        for c in range(1, chans.shape[-1]):
            arr = arr + chans[..., c]
        arr = arr / np.float32(chans.shape[-1])
    elif arr.ndim != 2:
        raise ValueError(f"{name} must be (H, W) grey or (H, W, C) colour with C in 1, 3, 4; "
                         f"got shape {arr.shape}")
    out = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(out).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return out


def _int_arg(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    return int(value)


def left_right_check(disp, right_steps, steps, tol):
    """NaN where the right view's winner at ``x - d`` disagrees with ``d`` by more than ``tol`` px."""
    h, w = disp.shape
    valid = np.isfinite(disp)
    d = np.where(valid, disp, 0)
    xr = np.rint(np.arange(w)[None] - d).astype(np.int64)
    inside = (xr >= 0) & (xr < w)
    back = np.take_along_axis(right_steps, np.clip(xr, 0, w - 1), axis=1)
    ok = valid & inside & (back != NO_MATCH) & (np.abs(back / steps - d) <= tol)
    out = disp.copy()
    out[~ok] = np.nan
    return out


# --------------------------------------------------------------------------------------
# the methods
# --------------------------------------------------------------------------------------
def _sgm(be, left, right, d_min, d_max, steps, census_radius, block, p1, p2, paths, uniqueness,
         lr_check, progress):
    h, w = left.shape
    n_disp = (d_max - d_min) * steps + 1
    bits = (2 * census_radius + 1) ** 2 - 1     # also the cost of a comparison with no right pixel
    if paths * (bits * block * block + p2) > _INT16_MAX:
        raise ValueError(f"p2 = {p2} is too large: aggregated costs must fit int16 "
                         f"(paths * (census bits * block^2 + p2) <= {_INT16_MAX})")
    cen_l = be.empty((1, h, w), np.uint64)
    kernels.census(be, be.asarray(left), cen_l, 0, census_radius)
    cen_r = be.empty((steps, h, w), np.uint64)
    rgt = be.asarray(right)
    for f in range(steps):
        # the right view moved by +f/steps px with the exact discrete G_u shift: the sub-pixel
        # disparity samples of the cost volume
        moved = rgt if f == 0 else shift(rgt, (0.0, f / steps), mode="nearest", backend=be)
        kernels.census(be, moved, cen_r, f, census_radius)
    cost = be.empty((h, w, n_disp), np.int16)
    kernels.cost(be, cen_l, cen_r, cost, d_min * steps, steps, block, bits)
    progress(1)
    agg = be.empty((h, w, n_disp), np.int16)
    kernels.sgm(be, cost, agg, p1, p2, paths)
    progress(1)
    disp = be.empty((h, w), np.float32)
    right_steps = be.empty((h, w), np.int32)
    kernels.select(be, agg, disp, right_steps, d_min, steps, uniqueness)
    disp = be.to_host(disp)
    if lr_check:
        disp = left_right_check(disp, be.to_host(right_steps), steps, 1.0)
    progress(1)
    return disp


def _green_shift(be, image, amount, method, sigma):
    """``image`` (device) moved by ``amount`` px along x, and the gain to apply to it (host, (W,)).

    ``"uniform"``: the exact discrete G_u shift, unit gain.  ``"affine"``: G_U^(2) (eq. 14)
    with ``x_U = -σ²/amount`` (causal) or its mirror beyond the line's end (anticausal), whose
    gain ramp is undone by dividing by the filtered constant row (``docs/derivations.md``).
    """
    w = image.shape[1]
    ones = np.ones(w, np.float32)
    if amount == 0:
        return image, ones
    if method == "uniform":
        return shift(image, (0.0, float(amount)), mode="nearest", backend=be), ones
    if amount > 0:
        kernel, anti = greens.AffineGreenApprox(sigma, -sigma**2 / amount), False
    else:
        kernel, anti = greens.AffineGreenApprox(sigma, (w - 1) + sigma**2 / -amount), True
    moved = green_filter(image, kernel, axis=1, mode="nearest", anticausal=anti, backend=be)
    den = green_filter(np.ones((1, w)), kernel, axis=1, mode="nearest", anticausal=anti,
                       backend="numpy")[0]
    return moved, (1.0 / den).astype(np.float32)


def _sweep(be, left, right, d_min, d_max, step, method, radius, sigma, progress):
    h, w = left.shape
    lft, rgt = be.asarray(left), be.asarray(right)
    init = np.full((SWEEP_PLANES, h, w), np.nan, np.float32)
    init[0] = np.inf
    state = be.asarray(init)
    for k in range(int(round((d_max - d_min) / step)) + 1):
        d = d_min + k * step
        # integer part by indexing, fractional part by symmetric Green half-shifts: the shifts
        # stay below half a pixel, where the second-order matching equation holds
        offset = math.floor(d)
        ls, gain_l = _green_shift(be, lft, -(d - offset) / 2, method, sigma)
        rs, gain_r = _green_shift(be, rgt, (d - offset) / 2, method, sigma)
        kernels.sweep(be, state, ls, rs, be.asarray(gain_l), be.asarray(gain_r), offset, d, radius)
        progress(1)
    return sweep_finish(be.to_host(state), step)


def disparity(left, right, max_disparity, *, min_disparity=0, method="sgm", window=None,
              subpixel=True, lr_check=True, subpixel_steps=2, census_radius=3, p1=None, p2=None,
              paths=8, uniqueness=10, sweep_step=0.5, sigma=None, progress=None, backend=None,
              device=None):
    """Disparity map of the left view of a rectified stereo pair.

    A left pixel at column ``x`` of row ``y`` matches the right pixel at column ``x - d`` of the
    same row; ``d`` is returned in pixels, NaN where rejected (uniqueness test or left-right
    check).

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) array_like
        The rectified pair, grey or colour (C = 3 or 4; colour is averaged to grey, alpha
        ignored).  Integer images are converted to float32; NaN/inf are rejected.
    max_disparity : int
        Largest disparity searched, ``min_disparity < max_disparity < W``.
    min_disparity : int, optional
        Smallest disparity searched (may be negative), ``> -W``.
    method : {'sgm', 'uniform', 'affine'}, optional
        See the module docstring.  ``"sgm"`` is the accurate one.
    window : int, optional
        Odd window side: the block over which census Hamming distances are summed for
        ``"sgm"`` (default 3), the squared-difference window for the sweeps (default 9).
    subpixel : bool, optional
        Refine the winner with a parabola through its neighbours' costs.
    lr_check : bool, optional
        (``"sgm"``) Reject pixels whose right-view match points back more than 1 px away.
    subpixel_steps : int, optional
        (``"sgm"``) Disparity samples per pixel, 1 to 4: the right view is shifted by
        ``f / subpixel_steps`` px with the exact discrete G_u shift for each ``f``.
    census_radius : int, optional
        (``"sgm"``) Census window ``2r+1`` square, r in 1..3.
    p1, p2 : int, optional
        (``"sgm"``) Penalties of semi-global aggregation for one-step and larger changes, in
        units of the block's summed Hamming distance; default ``6 window²`` and
        ``64 window²`` (measured on the Middlebury scenes of ``benchmarks/stereo.py``).
    paths : {4, 8}, optional
        (``"sgm"``) Aggregation directions.
    uniqueness : int, optional
        (``"sgm"``) Margin in percent by which the best cost must beat every cost more than
        one step away (0 disables).
    sweep_step : float, optional
        (``"uniform"``, ``"affine"``) Disparity step of the sweep, in px (> 0).
    sigma : float, optional
        (``"affine"``) σ of G_U^(2); default ``4 sqrt(W (|d|max + 1))`` so that
        ``|x_U| = σ²/s`` stays well outside the line (``|x_U| >> W``, where eq. 14's
        first-order behaviour holds; ``docs/derivations.md``).
    progress : callable, optional
        Called with a number of completed units of work (for progress bars);
        :func:`disparity_work` gives the total.
    backend, device : optional
        Where the kernels run (default: the resolution rule of :mod:`gfgpu.backends`);
        inputs are numpy images.

    Returns
    -------
    (H, W) float32 ndarray

    Raises
    ------
    ValueError
        Shape mismatch, disparity range outside ``(-W, W)`` or empty, NaN/inf input, or a
        parameter outside its range (named in the message).
    TypeError
        Non-numeric images or non-integer disparity bounds.

    Notes
    -----
    The chapter (§5) matches the left view shifted one way against the right view shifted
    the other while sweeping the shift, with G_U^(2) at σ fixed.  G_U^(2) shifts uniformly
    by σ²/|x_U| with a gain ramp (``docs/derivations.md``), and large Green shifts blur the
    images and shift textures by more than their first moment (third cumulant ``-u³``: a
    G_u shift by 2 px moves a σ = 1 px random-dot texture by 2.09 px, by 3 px 2.76 px), so the
    sweeps apply the Green shifts to the sub-pixel remainder only (half of it to each view,
    at most 0.5 px each) and the integer part as an index offset.  The cost then belongs to
    the left pixel within half a pixel of the window's centre (exact on fronto-parallel
    surfaces).  They stay worse than ``"sgm"`` on real scenes (``docs/stereo.md``).
    ``"sgm"`` uses the Green shift where it is exact and cheap: the fractional disparity
    samples of the cost volume (``subpixel_steps > 1``).  Census cost, 8-path aggregation and
    the left-right check follow Hirschmüller (2008).

    References
    ----------
    .. [1] Torreão et al., "Green's Functions of Matching Equations", 2007, §5, eq. 9, 14.
    .. [2] H. Hirschmüller, "Stereo processing by semiglobal matching and mutual
       information", IEEE PAMI 30(2), 2008.
    .. [3] R. Zabih, J. Woodfill, "Non-parametric local transforms for computing visual
       correspondence", ECCV 1994.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.stereo import disparity
    >>> rng = np.random.default_rng(0)
    >>> right = rng.random((48, 96)).astype(np.float32)
    >>> left = np.roll(right, 5, axis=1)     # left pixel x matches right pixel x - 5
    >>> d = disparity(left, right, 12, backend="numpy")
    >>> round(float(np.nanmedian(d[:, 20:])))
    5
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    lft = grey_image(left, "left")
    rgt = grey_image(right, "right")
    if lft.shape != rgt.shape:
        raise ValueError(f"left and right must have one shape, got {np.shape(left)} and {np.shape(right)}")
    h, w = lft.shape
    if min(h, w) < 2:
        raise ValueError(f"images must be at least 2x2, got {h}x{w}")
    d_max = _int_arg(max_disparity, "max_disparity")
    d_min = _int_arg(min_disparity, "min_disparity")
    if not 0 < d_max < w:
        raise ValueError(f"max_disparity must satisfy 0 < max_disparity < width ({w}); got {d_max}")
    if not -w < d_min < d_max:
        raise ValueError(f"min_disparity must satisfy -width ({-w}) < min_disparity < max_disparity "
                         f"({d_max}); got {d_min}")
    be = resolve_backend(backend, device)
    report = progress if progress is not None else (lambda n: None)
    if method == "sgm":
        window = 3 if window is None else _int_arg(window, "window")
        if window < 1 or window % 2 == 0 or window > 15:
            raise ValueError(f"window must be odd, 1..15, for method 'sgm'; got {window}")
        steps = _int_arg(subpixel_steps, "subpixel_steps")
        if not 1 <= steps <= 4:
            raise ValueError(f"subpixel_steps must be 1..4, got {steps}")
        radius = _int_arg(census_radius, "census_radius")
        if not 1 <= radius <= MAX_CENSUS_RADIUS:
            raise ValueError(f"census_radius must be 1..{MAX_CENSUS_RADIUS}, got {radius}")
        p1 = 6 * window**2 if p1 is None else _int_arg(p1, "p1")
        p2 = 64 * window**2 if p2 is None else _int_arg(p2, "p2")
        if not 0 <= p1 <= p2:
            raise ValueError(f"penalties must satisfy 0 <= p1 <= p2, got p1={p1}, p2={p2}")
        if paths not in (4, 8):
            raise ValueError(f"paths must be 4 or 8, got {paths!r}")
        uniq = _int_arg(uniqueness, "uniqueness")
        if not 0 <= uniq <= 100:
            raise ValueError(f"uniqueness must be 0..100 (percent), got {uniq}")
        disp = _sgm(be, lft, rgt, d_min, d_max, steps, radius, window, p1, p2, paths,
                    uniq, lr_check, report)
        if not subpixel:
            disp = np.rint(disp * steps) / steps
        return disp.astype(np.float32)
    window = 9 if window is None else _int_arg(window, "window")
    if window < 1 or window % 2 == 0 or window > 31:
        raise ValueError(f"window must be odd, 1..31, for the sweeps; got {window}")
    step = float(sweep_step)
    if not (math.isfinite(step) and 0 < step <= 1):
        raise ValueError(f"sweep_step must lie in (0, 1] px, got {sweep_step!r}")
    if sigma is None:
        sigma = 4.0 * math.sqrt(w * (max(abs(d_min), abs(d_max)) + 1))
    elif not (math.isfinite(float(sigma)) and float(sigma) > 0):
        raise ValueError(f"sigma must be a finite number > 0, got {sigma!r}")
    disp = _sweep(be, lft, rgt, d_min, d_max, step, method, window // 2, float(sigma), report)
    if not subpixel:
        disp = (np.rint((disp - d_min) / step) * step + d_min).astype(np.float32)
    return disp


def disparity_work(max_disparity, *, min_disparity=0, method="sgm", sweep_step=0.5, **_):
    """Units of work :func:`disparity` reports through ``progress`` (for a progress bar)."""
    if method == "sgm":
        return 3
    return int(round((max_disparity - min_disparity) / float(sweep_step))) + 1


def random_dot_stereogram(disparity_map, seed=0):
    """Rectified random-dot pair with a known left-view disparity (the chapter's Fig. 8).

    The right view is a smoothed random-dot field (Gaussian, σ = 1 px) scaled to [0, 255];
    row ``y`` of the left view samples row ``y`` of the right view at column ``x - d[y, x]``
    (cubic interpolation, nearest extension), so a left pixel at column ``x`` matches the
    right pixel at column ``x - d`` of the same row.

    Parameters
    ----------
    disparity_map : (H, W) array_like
        True disparity of the left view, in pixels (any real values).
    seed : int
        Seed of the dot field.

    Returns
    -------
    left, right : (H, W) float32 ndarrays

    Examples
    --------
    >>> import numpy as np
    >>> left, right = random_dot_stereogram(np.full((32, 48), 3.0))
    >>> left.shape, left.dtype.name
    ((32, 48), 'float32')
    """
    from scipy import ndimage
    d = np.asarray(disparity_map, np.float64)
    if d.ndim != 2 or d.size == 0 or not np.isfinite(d).all():
        raise ValueError(f"disparity_map must be a finite, non-empty 2-D array, got shape {d.shape}")
    h, w = d.shape
    rng = np.random.default_rng(seed)
    right = ndimage.gaussian_filter(rng.random((h, w)), 1.0)
    right = (right - right.min()) / np.ptp(right) * 255
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    left = ndimage.map_coordinates(right, [yy, xx - d], order=3, mode="nearest")
    return left.astype(np.float32), right.astype(np.float32)
