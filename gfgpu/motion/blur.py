"""``motion_blur``: uniform motion, per-pixel velocity fields, zoom and spin, with the chapter's
Green's function or a box exposure as the point-spread function.

The kinds and the point-spread functions are the table of :mod:`gfgpu.motion.kinds`; this is the
reference entry point that the others (frames, Dask, batch, the commands) agree with."""

from __future__ import annotations

from .._core.boundary import filter_mode
from .._core.validation import finite_cval, flag
from ..filters import make_job
from .field import check_quadrature
from .kinds import motion_kind, psf_name
from .params import move_channels

__all__ = ["motion_blur"]


def motion_blur(image, velocity, *, kind="uniform", psf="green", center=None, displace=True, mode="reflect",
                cval=0.0, channel_axis=None, output=None, backend=None, device=None, quadrature="gauss"):
    """Motion blur along the true path of uniform motion, a per-pixel velocity field, a zoom or a spin.

    Parameters
    ----------
    image : array_like, warp.array or pyopencl.array.Array
        Image ``(H, W)``, stack ``(..., H, W)`` (the image plane is the last two axes), or a
        colour image with ``channel_axis`` (numpy input).  float32/float64 kept, integers ->
        float32 (wider than 16 bits: float64; see :func:`gfgpu.io.to_output` to write them back at their depth).
    velocity : pair of float, array (2, H, W), or float for ``kind="zoom"`` and ``kind="rotation"``
        ``kind="uniform"``: the displacement ``(vy, vx)`` in pixels during the exposure, in
        array-axis order (rows, cols) as :func:`gfgpu.shift`: ``vy`` down the rows, ``vx``
        right along the columns; at most 1e9 px.  ``(0, 0)`` returns a copy.
        A **velocity field** of shape ``(2, H, W)`` (rows, cols components, the order of
        scikit-image's optical flow; numpy array of float32/float64 or integers, finite, components within
        ±4096 px; used in the computation's dtype) blurs every pixel along its own velocity:
        pixel ``x`` gathers the image along ``x - t v(x)`` (the standard post-process model).
        ``kind="zoom"``: the affine rate ``u1`` (eq. 10, ``U = u1 (x - x_U)``), one value or a
        pair ``(u1_y, u1_x)`` (rows, cols); ``2 - 2 sqrt(2) < u1 < 2`` (about -0.828 .. 2):
        ``u1 > 0`` zooms in, ``u1 < 0`` zooms out.  A point at ``x`` moves to
        ``c + (x - c)(1 + u1)``.
        ``kind="rotation"``: the angle turned during the exposure, in degrees, within
        [-360, 360]; positive turns counter-clockwise on screen (x = column to the right, y = row
        down): a point at ``p = (x, y)`` moves to ``c + R (p - c)``,
        ``R = [[cos, sin], [-sin, cos]]``.
    kind : {'uniform', 'zoom', 'rotation'}
    psf : {'green', 'box'}
        Point-spread function along the path.  ``'green'``: the chapter's G_u (eq. 9), whose
        mean is exactly the displacement (a comet-like smear whose tail runs to ~5 lengths).
        ``'box'``: a uniform exposure over the shutter interval (content at every time weighted
        equally; fractional lengths exact).
    center : pair of float, optional
        Fixed point ``(row, col)`` of the zoom (inside the image) or of the rotation (within
        twice the diagonal of the image centre), i.e. ``(y_U, x_U)``; default the image centre
        ``((H - 1)/2, (W - 1)/2)``.
    displace : bool, optional
        True: content moves by ``velocity`` and is blurred along its path (trailing: the
        output at ``x`` sees the content that passed over it, ``x - t v`` for ``t`` in the
        shutter).  False: content stays in place and is blurred symmetrically along the path
        (the box over ``t`` in ``[-1/2, 1/2]``; G_u as an anticausal half shift then a causal
        one).  Ignored by the Green zoom, which always displaces.
    mode, cval : optional
        Boundary extension (scipy.ndimage names, see :func:`gfgpu.green_filter`).
    channel_axis : int, optional
        Axis of colour channels of a numpy image (e.g. ``-1`` for ``(H, W, 3)``).  Blur an RGBA
        image premultiplied by its alpha (as ``gfgpu blur`` does), so that transparent pixels
        leave no dark fringe.
    output : ndarray or dtype, optional
        As in :func:`gfgpu.green_filter` (not with ``channel_axis``).
    backend, device : str, optional
        ``"numpy"``, ``"warp"`` or ``"opencl"`` and its device (default: the resolution rule
        of :mod:`gfgpu.backends`).
    quadrature : {'gauss', 'exact'}, optional
        How a velocity field's paths (and the box zoom with two rates, an affine field) are
        integrated: ``'gauss'`` (default) a Gauss rule of a few nodes per path, its cost bounded
        per pixel; ``'exact'`` cells of at most one pixel, 5-20 times the samples, for content
        with detail near the Nyquist rate (see *Velocity fields* below).  Other kinds ignore it.

    Returns
    -------
    ndarray or device array
        Same shape as ``image``; same kind of array.

    Raises
    ------
    ValueError
        Unknown ``kind`` or ``psf``, non-finite or malformed ``velocity`` (a field of another
        shape than ``(2, H, W)``, or with ``kind`` other than ``'uniform'``), ``u1`` outside
        ``(2 - 2 sqrt(2), 2)``, a rotation angle outside [-360, 360] degrees, a ``center``
        outside its range, ``channel_axis`` out of range or combined with ``output``, bad
        ``mode``, empty or non-finite input.
    TypeError
        Unsupported dtype or non-numeric parameters.

    Notes
    -----
    Every kind runs along its true path (``docs/motion.md`` has the method and the measured
    accuracy against supersampled renderings: the average of 512 exactly warped copies).

    **Uniform motion**, along the continuous direction (the sheared layout of
    :mod:`gfgpu._core.oblique`; lines step one pixel of the dominant axis, so the length is
    ``L = max(|vy|, |vx|)`` steps).  G_u: one recursive pass of the discrete G_u shift
    (:func:`gfgpu.greens.shift_pass`: unit DC gain, first moment exactly ``L``);
    ``displace=False`` runs the anticausal shift by ``L/2`` then the causal one.  Box: the mean
    of the line's cubic B-spline interpolant (of the line extended by ``mode``) over the window
    ``[x - L, x]`` (centred ``[x - L/2, x + L/2]``), a difference of running sums
    (:mod:`gfgpu.motion.box`).  Cost: O(1) per pixel whatever ``L`` (the part of a window beyond
    the image is summed in closed form).

    **Velocity fields** (:mod:`gfgpu.motion.field`): each pixel integrates the cubic B-spline
    image along its own path, weighted by the PSF in ``t`` (box: ``t`` in ``[0, 1]``; G_u with
    ``u = |v|``), by a fixed rule per velocity (``quadrature="gauss"``): ``ceil(L / 2) + 1``
    Gauss-Legendre nodes (box, ``L`` the dominant component), or G_u's support cut at 6 velocities
    sampled by a graded trapezoidal rule, ``max(12, ceil(1.736 |v|)) + 1`` nodes 2.25 px apart
    where G_u holds its mass (24 intervals at least centred), each node a sample of 16
    coefficients; against a rendering of 512 exactly warped copies at ``|v| <= 30``: 0.02-0.23 %
    (box) and 0.4-0.6 % (G_u) on Gaussian-filtered noise (sigma 2 px) under smooth, split,
    rotation, zoom, shear and random fields; 0.6-8.7 % on photographs (grass 7-18 %), where sharp
    edges put detail at 0.25-0.5 cycles/px that the node spacing aliases.  A field with a path
    beyond the rule's tables (126 px box by its dominant component, 181 px G_u by its length; every
    path of at most 128 px along each axis fits), and every field with ``quadrature="exact"``,
    runs the exact cells:
    cells of at most one pixel with three Gauss-Legendre nodes each (2e-4 on white noise), at most
    96 (box) or 432 (G_u) samples per pixel (:data:`gfgpu.motion.field.FIELD_CELLS`), a field whose
    paths need more running them while its total stays within that budget on average or within
    4 M samples, refused before any work otherwise (``ValueError``).

    **Spin** (:mod:`gfgpu.motion.polar`): the image is resampled onto a polar grid about the
    centre, blurred along every ring by one periodic pass (box window or G_u recursion; the
    angle is the same number of samples on every ring), and the change is resampled back and
    added to the image: each point is blurred along its arc, and a spin by ~0 returns the image
    in every mode.  O(1) per pixel.

    **Zoom.**  Box: along the rays (same polar grid): the output at ``x`` is the mean over the
    segment from ``x`` to its pre-image ``c + (x - c)/(1 + u1)`` (a camera moving toward the scene
    at constant speed), a running-sum window on every ray; a pair of different rates
    ``(u1_y, u1_x)`` runs as the affine velocity field ``v = (u1/(1 + u1)) (x - c)`` per axis.
    G_u: the exact affine G_U^(1) (eq. 10-12, :mod:`gfgpu.motion.zoom`; cell-integrated taps,
    moment-corrected, zoom-out read through ``mode``) along every ray of the same polar grid
    (one rate; pre-image within 0.006 px beyond 5 px of the fixed point, 0.104 px within), or
    separably along the rows then the columns for two different rates (pre-image exact to
    rounding); see ``docs/motion.md``.  The fixed point must lie inside the image.

    References
    ----------
    .. [1] Torreão et al., "Green's Functions of Matching Equations", 2007, eqs. 7-12.
    .. [2] Ferreira Jr. et al., "Motion synthesis through 1D affine matching", PAA, 2008.
    .. [3] M. Unser, "Splines: a perfect fit for signal and image processing", IEEE SPM, 1999
       (cubic B-spline interpolation by recursive prefiltering).

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.motion import motion_blur
    >>> img = np.zeros((32, 256)); img[16, 10] = 1
    >>> out = motion_blur(img, (0, 12.5), mode="constant", backend="numpy")   # (vy, vx)
    >>> round(float((out[16] * np.arange(256)).sum()), 4)
    22.5
    >>> ramp = np.tile(np.arange(64.0), (4, 1))
    >>> box = motion_blur(ramp, (0, 4.5), psf="box", mode="nearest", backend="numpy")
    >>> box[0, 30:33]   # the mean of x over [x - 4.5, x]: x - 2.25
    array([27.75, 28.75, 29.75])
    >>> field = np.zeros((2, 32, 256)); field[1, :, 128:] = 8.0          # right half moves 8 px right
    >>> f = motion_blur(img, field, psf="box", mode="constant", backend="numpy")
    >>> bool(np.allclose(f[:, :128], img[:, :128]))                     # left half untouched
    True
    >>> z = motion_blur(np.tile(np.arange(64.0), (8, 1)), 0.5, kind="zoom", center=(4, 20),
    ...                 backend="numpy")   # center (row, col)
    >>> round(float(z[4, 50]), 1)  # samples the pre-image 20 + 30 / 1.5
    40.0
    >>> yy, xx = np.mgrid[:101, :101].astype(float)
    >>> r = np.hypot(yy - 50, xx - 50)
    >>> rings = np.cos(r / 5)
    >>> s = motion_blur(rings, 30.0, kind="rotation", psf="box", center=(50, 50), backend="numpy")
    >>> bool(np.abs(s - rings)[(r > 3) & (r < 45)].max() < 2e-3)   # content moves along its circle
    True
    """
    motion = motion_kind(kind, velocity)
    psf = psf_name(psf)
    mode = filter_mode(mode)    # scipy's names; a blur takes the filter meaning (grid-* as their twins)
    cval = finite_cval(cval)
    displace = flag("displace", displace)
    quadrature = check_quadrature(quadrature)
    if channel_axis is not None:
        if output is not None:
            raise ValueError("output cannot be combined with channel_axis; use the return value")
        moved, undo = move_channels(image, channel_axis)
        return undo(motion_blur(moved, velocity, kind=kind, psf=psf, center=center, displace=displace,
                                mode=mode, cval=cval, backend=backend, device=device, quadrature=quadrature))
    params = motion.parse(velocity)               # checked before the image is read or uploaded
    job = make_job(image, output, backend, device, min_ndim=2)
    params = motion.fit(params, job.shape)
    fixed = motion.center(center, job.shape[-2], job.shape[-1])
    return motion.run(job, params, psf, fixed, displace, mode, cval, quadrature)
