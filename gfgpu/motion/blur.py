"""``motion_blur``: uniform motion, zoom or rotation through the chapter's Green's filters."""

from __future__ import annotations

from .._core.job import apply_program
from .._core.recursion import check_mode
from .._core.validation import finite_cval, flag
from ..filters import make_job
from .params import KINDS, move_channels, velocity_pair, zoom_factors
from .rotation import apply_rotation, rotation_angle
from .uniform import uniform_motion_program
from .zoom import apply_zoom

__all__ = ["motion_blur"]


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
        ``kind="uniform"``: the displacement ``(vy, vx)`` in pixels during the exposure, in
        array-axis order (rows, cols) as :func:`gfgpu.shift`: ``vy`` down the rows, ``vx``
        right along the columns.  ``(0, 0)`` returns a copy.
        ``kind="zoom"``: the affine rate ``u1`` (eq. 10, ``U = u1 (x - x_U)``), one value or a
        pair ``(u1_y, u1_x)`` (rows, cols); ``2 - 2 sqrt(2) < u1 < 2`` (about -0.828 .. 2):
        ``u1 > 0`` zooms in, ``u1 < 0`` zooms out, 0 leaves that axis unchanged.  A point at
        column ``x`` moves to ``x_U + (x - x_U)(1 + u1_x)`` (rows likewise with ``u1_y``).
        ``kind="rotation"``: the angle turned during the exposure, in degrees, within
        [-90, 90]; positive turns counter-clockwise on screen (x = column to the right, y = row
        down): a point at ``p = (x, y)`` moves to ``c + R (p - c)``,
        ``R = [[cos, sin], [-sin, cos]]``.
    kind : {'uniform', 'zoom', 'rotation'}
    center : pair of float, optional
        Fixed point ``(row, col)`` of the zoom (inside the image) or of the rotation, i.e.
        ``(y_U, x_U)``; default the image centre ``((H - 1)/2, (W - 1)/2)``.
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
        ``"numpy"``, ``"warp"`` or ``"opencl"`` and its device (default: the resolution rule
        of :mod:`gfgpu.backends`).

    Returns
    -------
    ndarray or device array
        Same shape as ``image``; same kind of array.

    Raises
    ------
    ValueError
        Unknown ``kind``, non-finite or malformed ``velocity``, ``u1`` outside
        ``(2 - 2 sqrt(2), 2)``, a rotation angle outside [-90, 90] degrees, a zoom
        ``center`` outside the image, ``channel_axis`` out of range or combined with
        ``output``, bad ``mode``, empty or non-finite input.
    TypeError
        Unsupported dtype or non-numeric parameters.

    Notes
    -----
    **Uniform motion** (eq. 7-9).  One recursive pass along the direction of ``velocity`` of
    the discrete G_u shift (:func:`gfgpu.greens.shift_pass`: G_u's poles ``e^{(-1±i)/L}``, unit
    DC gain and first moment exactly ``L``), ``L = max(|vy|, |vx|)`` steps of the dominant axis
    along the digital lines of :mod:`gfgpu._core.lines`.  Along an axis or a diagonal the displacement
    is exact (to 1e-6 px); along other directions the displacement of the dominant axis is
    exact and that of the minor axis is exact on average but quantised per pixel (error up to
    0.5 px, see ``docs/motion.md``).  ``displace=False`` runs the anticausal shift by ``L/2`` then
    the causal one by ``L/2``: the PSF is the autocorrelation of the half-shift kernel (even,
    single-peaked, zero phase) and its mean is exactly 0.  Cost: one (two) pass(es), O(1) per
    pixel whatever ``L``.

    **Zoom** (eq. 10-12).  G_U^(1) is an exact affine warp to second order (zero variance, mean
    at the pre-image ``x_U + (x - x_U)/(1 + u1)``; ``docs/motion.md``).  It is applied separably,
    along the rows about ``x_U`` then along the columns about ``y_U``, each line split at the fixed point and the
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
    ``beta = sqrt(1 + u1 - u1^2/4)/|u1|``, real for ``u1 > 2 - 2 sqrt(2)``; ``docs/motion.md``).  It
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
    >>> out = motion_blur(img, (0, 12.5), mode="constant", backend="numpy")   # (vy, vx)
    >>> round(float((out[16] * np.arange(256)).sum()), 4)
    22.5
    >>> z = motion_blur(np.tile(np.arange(64.0), (8, 1)), 0.5, kind="zoom", center=(4, 20),
    ...                 backend="numpy")   # center (row, col)
    >>> round(float(z[4, 50]), 1)  # samples the pre-image 20 + 30 / 1.5
    40.0
    >>> zo = motion_blur(np.tile(np.arange(512.0), (8, 1)), -0.2, kind="zoom", center=(4, 200),
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
    cval = finite_cval(cval)
    if channel_axis is not None:
        if output is not None:
            raise ValueError("output cannot be combined with channel_axis; use the return value")
        moved, undo = move_channels(image, channel_axis)
        return undo(motion_blur(moved, velocity, kind=kind, center=center, displace=displace, mode=mode,
                                cval=cval, backend=backend, device=device))
    if kind == "uniform":
        velocity_pair(velocity)
        job = make_job(image, output, backend, device, min_ndim=2)
        return apply_program(job, uniform_motion_program(job.ndim, velocity, flag("displace", displace)), mode, cval)
    if kind == "rotation":
        degrees = rotation_angle(velocity)
        job = make_job(image, output, backend, device, min_ndim=2)
        return apply_rotation(job, degrees, center, flag("displace", displace), mode, cval)
    u1y, u1x = zoom_factors(velocity)
    job = make_job(image, output, backend, device, min_ndim=2)
    return apply_zoom(job, u1y, u1x, center, mode, cval)
