"""Frame sequences: motion synthesis, translation estimation and in-between frames."""

from __future__ import annotations

import numpy as np

from ..filters import shift as g_shift
from .blur import motion_blur
from .kinds import motion_kind, psf_name
from .params import move_channels, velocity_pair

__all__ = ["synthesize_motion", "estimate_translation", "interpolate_frames"]


def _frame_fractions(n_frames):
    """``t = k / (n - 1)``, ``k = 0 .. n - 1``: the fraction of the motion each frame shows."""
    try:
        n = int(n_frames)
    except (TypeError, ValueError):
        raise TypeError(f"n_frames must be an integer, got {n_frames!r}") from None
    if n != n_frames or n < 2:
        raise ValueError(f"n_frames must be an integer >= 2, got {n_frames!r}")
    return np.arange(n) / (n - 1)


def synthesize_motion(image, velocity, n_frames, *, kind="uniform", psf="green", center=None, displace=True,
                      mode="reflect", cval=0.0, channel_axis=None, backend=None, device=None,
                      progress=None):
    """A sequence of frames moving ``image`` progressively (motion synthesis, chapter §1).

    Frame ``k`` (``k = 0 .. n_frames - 1``) is :func:`motion_blur` at the fraction
    ``t = k / (n_frames - 1)`` of the motion: displacement ``t * velocity`` for uniform motion
    (and for a velocity field, every pixel's velocity scaled by ``t``), scale ``(1 + u1)^t``
    (``u1_k = (1 + u1)^t - 1``, a constant zoom rate) for a zoom, the angle ``t * velocity`` for
    a rotation (the kinds' table, :mod:`gfgpu.motion.kinds`).  Frame 0 is the input itself (for
    a velocity field, to the rounding of the spline resampling, which the zero field still runs).

    Parameters
    ----------
    image : array_like or device array
        As in :func:`motion_blur`.
    velocity : pair of float, array (2, H, W), or float
        The whole motion, as in :func:`motion_blur`: ``(vy, vx)`` pixels (rows, cols) or a
        velocity field ``(2, H, W)`` for ``kind="uniform"``, the rate ``u1`` or
        ``(u1_y, u1_x)`` for a zoom, degrees for a rotation.
    n_frames : int
        Number of frames, >= 2.
    kind, psf, center, displace, mode, cval, channel_axis, backend, device
        As in :func:`motion_blur` (``center`` is ``(row, col)``; ``psf`` ``'green'`` or
        ``'box'``).
    progress : callable, optional
        Called with no argument after each frame (e.g. a tqdm bar's ``update``).

    Returns
    -------
    ndarray of shape ``(n_frames,) + image.shape`` for numpy input, else a list of device arrays.

    Raises
    ------
    ValueError
        ``n_frames`` < 2 or not an integer, and every error of :func:`motion_blur` (the
        velocity, a field's shape and the centre are checked before the first frame).
    TypeError
        A non-integer ``n_frames``, non-numeric parameters, an unsupported dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.motion import synthesize_motion
    >>> img = np.zeros((16, 512)); img[8, 4] = 1
    >>> frames = synthesize_motion(img, (0, 30), 4, mode="constant", backend="numpy")   # (vy, vx)
    >>> [round(float((f[8] * np.arange(512)).sum()), 3) for f in frames]
    [4.0, 14.0, 24.0, 34.0]
    >>> box = synthesize_motion(img, (0, 30), 4, psf="box", mode="constant", backend="numpy")
    >>> [round(float((f[8] * np.arange(512)).sum()), 3) for f in box]   # the box's mean: half the path
    [4.0, 9.0, 14.0, 19.0]
    """
    fractions = _frame_fractions(n_frames)
    motion = motion_kind(kind, velocity)
    psf = psf_name(psf)
    params = motion.parse(velocity)
    moved, undo = move_channels(image, channel_axis)      # once, not per frame
    shape = np.shape(moved)
    if len(shape) >= 2:                    # else motion_blur refuses the image at the first frame
        params = motion.fit(params, shape)
        motion.center(center, shape[-2], shape[-1])
    frames = []
    for t in fractions:
        frames.append(undo(motion_blur(moved, motion.at(params, t), kind=kind, psf=psf, center=center,
                                       displace=displace, mode=mode, cval=cval, backend=backend,
                                       device=device)))
        if progress is not None:
            progress()
    if all(isinstance(f, np.ndarray) for f in frames):
        return np.stack(frames)
    return frames


def estimate_translation(frame0, frame1, *, upsample_factor=20):
    """Global translation ``(dy, dx)`` that moves ``frame0`` onto ``frame1`` (phase correlation).

    :func:`skimage.registration.phase_cross_correlation` on the mean-removed frames under a
    Hann window (which suppresses the border discontinuity of non-periodic images), to
    ``1/upsample_factor`` px.  Colour frames ``(H, W, C)`` are registered on their channel mean.

    Parameters
    ----------
    frame0, frame1 : array_like
        Two numpy images of the same shape, grey ``(H, W)`` or colour ``(H, W, C)``.
    upsample_factor : int, optional
        Precision ``1/upsample_factor`` px of the estimate.

    Returns
    -------
    (float, float)
        ``(dy, dx)`` in pixels, array-axis order (rows, cols) as :func:`gfgpu.shift`:
        ``gfgpu.shift(frame0, (dy, dx))`` approximates ``frame1``.

    Raises
    ------
    ValueError
        Frames of different shapes, or not 2-D / colour 3-D.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.ndimage import gaussian_filter
    >>> big = gaussian_filter(np.random.default_rng(0).random((140, 160)), 2.0)
    >>> estimate_translation(big[20:120, 20:140], big[17:117, 15:135])   # content 3 rows down, 5 cols right
    (3.0, 5.0)
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
    return dy, dx


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
        Displacement ``(vy, vx)`` from ``frame0`` to ``frame1`` in pixels, array-axis order
        (rows, cols); estimated by phase correlation (:func:`estimate_translation`, 1/20 px)
        when omitted.
    mode, channel_axis, backend, device
        As in :func:`motion_blur`; ``mode`` defaults to ``'nearest'`` (content entering at the
        border is extended from the edge).

    Returns
    -------
    ndarray of shape ``(n,) + frame0.shape``, float32 or float64.

    Raises
    ------
    ValueError
        Frames of different shapes, ``n < 1``, a ``velocity`` that is not a pair of finite
        numbers.
    TypeError
        A non-integer ``n``.

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
    >>> mid = interpolate_frames(f0, f1, 1, velocity=(0, 10), backend="numpy")[0]   # (vy, vx)
    >>> round(float((mid[4] * x).sum() / mid[4].sum()), 3)
    125.0
    """
    a, b = np.asarray(frame0), np.asarray(frame1)
    for name, frame in (("frame0", a), ("frame1", b)):
        if frame.dtype == object or frame.dtype.kind not in "biuf":
            raise TypeError(f"{name} must be a real numeric array, got dtype {frame.dtype}")
        if frame.dtype.kind == "f" and not np.isfinite(frame).all():
            raise ValueError(f"{name} contains NaN or infinite values")
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
        vy, vx = estimate_translation(ca, cb)
    else:
        vy, vx = velocity_pair(velocity)
    a_moved, undo = move_channels(a, channel_axis)
    b_moved, _ = move_channels(b, channel_axis)
    frames = []
    for k in range(1, count + 1):
        t = k / (count + 1)
        fwd = g_shift(a_moved, (t * vy, t * vx), mode=mode, axes=(-2, -1), backend=backend, device=device)
        back = g_shift(b_moved, (-(1 - t) * vy, -(1 - t) * vx), mode=mode, axes=(-2, -1),
                       backend=backend, device=device)
        frames.append(undo((1 - t) * fwd + t * back))
    return np.stack(frames)
