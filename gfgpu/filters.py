"""Line operators on N-D arrays: green_filter, shift, derivative, projection, gradient.

All are compositions of the recursion primitive (:mod:`gfgpu._core.recursion`) along array
axes or image-plane directions (:mod:`gfgpu._core.lines`), run on the backend chosen by
:func:`gfgpu.backends.resolve_backend`.

Coordinates (as scipy.ndimage and scikit-image): every per-axis tuple is in array-axis order
``(..., row, col)``; for a 2-D image ``shift(img, (dy, dx))`` moves content ``dy`` rows down
and ``dx`` columns right.  x is the column index (0 at the left), y the row index (0 at the
top); angles are in radians from +x toward +y (down the rows).  ``axes`` names the axes an
operator works on; ``channel_axis`` names a colour axis that it leaves alone (each channel is
filtered on its own).  Arguments after the data and the main parameter are keyword-only.

Dtype policy: float32 and float64 are preserved; boolean images and integers of up to 16 bits
are converted to float32, wider integers (int32, uint32, int64, uint64) to float64 (float32
rounds integers above 2**24; ``output=numpy.float32`` asks for float32 instead); float16 is
computed in float32; complex and other types raise ``TypeError``.
numpy in, numpy out; a ``warp.array`` or ``pyopencl.array.Array`` input gives an array of the
same kind on the same device.
"""

from __future__ import annotations

import numpy as np

from . import greens
from ._core.boundary import filter_mode, interpolation_branch, interpolation_mode
from ._core.job import Job, apply_program
from ._core.lines import normalize_axis
from ._core.program import Program, axes_list, direction_steps, is_axis_angle, per_axis, plane_axes
from ._core.validation import finite_cval, flag, positive, scale
from .backends import resolve_backend

__all__ = ["green_filter", "shift", "derivative", "projection", "gradient", "make_job",
           "green_filter_program", "shift_program", "derivative_program", "projection_program",
           "operated_axes", "line_axis", "image_plane", "run_line_program", "job_gradient"]


def make_job(input, output=None, backend=None, device=None, min_ndim=1):
    """The :class:`~gfgpu._core.job.Job` of one call: the backend resolved with the input array."""
    return Job(input, output, resolve_backend(backend, device, input), min_ndim)


# --------------------------------------------------------------------------------------
# axes: what an operator works on, and the colour axis it leaves alone
# --------------------------------------------------------------------------------------
def _channel(ndim, channel_axis):
    if channel_axis is None:
        return None
    ch = normalize_axis(channel_axis, ndim, "channel_axis")
    if ndim < 2:
        raise ValueError(f"channel_axis={channel_axis} needs an input of at least 2 dimensions, got {ndim}")
    return ch


def operated_axes(ndim, axes=None, channel_axis=None):
    """The normalised axes an operator works on: ``axes``, default every axis but ``channel_axis``.

    Parameters
    ----------
    ndim : int
        Number of dimensions of the input.
    axes : int or sequence of int, optional
        Axes to operate on (distinct).
    channel_axis : int, optional
        A colour axis that is not operated on.

    Returns
    -------
    list of int

    Raises
    ------
    ValueError
        An axis out of range or repeated, or ``axes`` that include ``channel_axis``.

    Examples
    --------
    >>> operated_axes(3, channel_axis=-1)
    [0, 1]
    >>> operated_axes(3, axes=(0, 1))
    [0, 1]
    """
    ch = _channel(ndim, channel_axis)
    if axes is None:
        return [a for a in range(ndim) if a != ch]
    ax = axes_list(axes, ndim)
    if ch is not None and ch in ax:
        raise ValueError(f"axes={axes!r} and channel_axis={channel_axis!r} overlap: the channel axis is "
                         f"never operated on; leave it out of axes")
    return ax


def line_axis(ndim, axis=None, channel_axis=None):
    """The normalised axis of a one-axis operator: ``axis``, default the last axis but ``channel_axis``.

    Raises
    ------
    ValueError
        ``axis`` out of range, or ``axis`` and ``channel_axis`` naming the same axis.

    Examples
    --------
    >>> line_axis(3), line_axis(3, channel_axis=-1), line_axis(3, 0)
    (2, 1, 0)
    """
    ch = _channel(ndim, channel_axis)
    if axis is None:
        free = [a for a in range(ndim) if a != ch]
        if not free:
            raise ValueError(f"a line operator needs an input of at least 1 dimension, got {ndim}")
        return free[-1]
    ax = normalize_axis(axis, ndim)
    if ax == ch:
        raise ValueError(f"axis={axis!r} and channel_axis={channel_axis!r} name the same axis: the channel "
                         f"axis is never filtered")
    return ax


def image_plane(ndim, axes=None, channel_axis=None):
    """The ``(row axis, column axis)`` of the image plane for an image-plane direction.

    ``axes`` (two axes, rows then columns), default the last two axes other than
    ``channel_axis``.

    Raises
    ------
    ValueError
        Fewer than two axes left, axes out of range or equal, or ``axes`` that include
        ``channel_axis``.

    Examples
    --------
    >>> image_plane(3), image_plane(3, channel_axis=-1), image_plane(3, channel_axis=0)
    ((1, 2), (0, 1), (1, 2))
    """
    if axes is None:
        free = operated_axes(ndim, None, channel_axis)
        if len(free) < 2:
            raise ValueError(f"an image-plane direction needs two axes besides channel_axis, got an input "
                             f"of {ndim} dimension(s)")
        return free[-2], free[-1]
    ya, xa = plane_axes(axes, ndim)
    operated_axes(ndim, (ya, xa), channel_axis)   # overlap check
    return ya, xa


# --------------------------------------------------------------------------------------
# public operators
# --------------------------------------------------------------------------------------
def green_filter(input, kernel, *, axis=None, angle=None, axes=None, channel_axis=None, anticausal=False,
                 output=None, mode="reflect", cval=0.0, backend=None, device=None):
    """Apply a Green's function of the chapter along an axis or an image-plane direction.

    .. math:: f[x] = \\sum_{x_0 \\le x} G(x, x_0)\\, I[x_0]   \\qquad (causal)

    computed exactly, in O(N) whatever the kernel's length, by the first-order complex
    recursion ``F[x+1] = λ[x] F[x] + κ[x] I[x]``, ``f = c Im F`` (``Re F`` for H_u), whose
    coefficients factorise the kernel as ``c Im[P(x) Q(x0)]`` (:mod:`gfgpu._core.recursion`).

    Parameters
    ----------
    input : array_like, warp.array or pyopencl.array.Array
        Image, stack ``(N, H, W)`` or colour image (with ``channel_axis``); float32/float64
        kept, integers -> float32 (wider than 16 bits: float64).
    kernel : GreenKernel
        :class:`~gfgpu.greens.UniformGreen` ``(u)`` (G_u, eq. 9),
        :class:`~gfgpu.greens.HomogeneousGreen` ``(u)`` (H_u, eq. 33),
        :class:`~gfgpu.greens.AffineGreen` ``(u1, x_U)`` (G_U^(1), eq. 11) or
        :class:`~gfgpu.greens.AffineGreenApprox` ``(sigma, x_U)`` (G_U^(2), eq. 14).
        Positions (``x_U``) are coordinates of the filtered axis (for ``angle``: of the
        dominant axis), 0 at the array's first sample, whatever the traversal sense: a
        right-to-left pass (``anticausal``, or a direction with ``cos θ < 0``) needs the
        affine kernels' fixed point beyond the last sample, ``x_U > n - 1``.
    axis : int, optional
        Axis to filter along (not with ``angle``); default the last axis other than
        ``channel_axis``.
    angle : float, optional
        Filter along the image-plane direction at this angle instead of along ``axis``:
        radians from +x (the column axis, to the right) toward +y (the row axis, down).  The
        lines follow the continuous direction ``y = ℓ + x tan(angle)`` (x and y swapped when
        steeper than 45°), one step of the dominant axis at a time: kernel lengths and
        positions (``u``, ``x_U``) are in those steps.  The image is sheared so that the lines
        become rows (whole pixels by index arithmetic, the sub-pixel rest by a second-order
        allpass along each column) and sheared back (:mod:`gfgpu._core.oblique`): cost O(1)
        per pixel whatever the kernel's length; no displacement is quantised (every pixel's
        impulse centroid is exact to 1e-5 px in float32).  The two resamplings cost, against
        the same operator applied along the exact direction, about 1e-2 rel. L2 on a natural
        image and 5e-3 on a band-limited one, more for detail near Nyquist across the
        direction (``docs/derivations.md``, "Oblique directions").  Axis-aligned angles run
        as plain, exact axis passes.
    axes : pair of int, optional
        With ``angle``: the axes operated on, i.e. the image plane as ``(row axis, column
        axis)``; default the last two axes other than ``channel_axis``.
    channel_axis : int, optional
        Axis of colour channels, filtered each on its own (never filtered along).
    anticausal : bool, optional
        Apply the mirrored operator ``f[x] = Σ_{x0 >= x} G(x', x0')`` (right to left).
    output : ndarray or dtype, optional
        Array to write the result into, or the result dtype (never lower precision).
    mode : {'reflect', 'grid-mirror', 'constant', 'grid-constant', 'nearest', 'mirror', 'wrap', 'grid-wrap'}, optional
        How the input extends beyond its border, with scipy.ndimage's filter meaning
        (``d c b a | a b c d`` for ``'reflect'``, ``d c b | a b c d`` for ``'mirror'``, the
        edge value for ``'nearest'``, ``cval`` for ``'constant'``, period ``n`` for
        ``'wrap'``); as in scipy's filters, ``'grid-mirror'`` is ``'reflect'``,
        ``'grid-constant'`` is ``'constant'`` and ``'grid-wrap'`` is ``'wrap'``.  Realised
        exactly as the recursion's initial state.
    cval : float, optional
        Value beyond the border when ``mode='constant'`` (or ``'grid-constant'``).
    backend, device : str, optional
        ``"numpy"``, ``"warp"`` or ``"opencl"`` and its device; default: the resolution rule
        of :mod:`gfgpu.backends` (explicit argument, the input array's own kind,
        :func:`gfgpu.use_backend`, ``GFGPU_BACKEND``, then automatic).

    Returns
    -------
    ndarray or device array
        Same shape; same kind of array as ``input``.

    Raises
    ------
    ValueError
        Bad ``mode``/``axis``/``angle``/``axes``, ``axes`` given without ``angle``, ``axis``
        or ``axes`` overlapping ``channel_axis``, an oblique direction on a device array whose
        image plane is not on its last two axes, empty or non-finite input, or a kernel whose
        domain does not contain the line (e.g. ``x_U`` inside it).
    TypeError
        Unsupported dtype, or float64 on a device without fp64.

    Notes
    -----
    The kernel is point-sampled at integer offsets; H_u's jump at 0 takes its mean 1/u.
    An oblique direction on a numpy image whose plane is not on its last two axes (e.g.
    ``(H, W, 3)`` with ``channel_axis=-1``) runs on a copy with the plane moved last.

    References
    ----------
    .. [1] Torreão et al., "Green's Functions of Matching Equations", 2007, eqs. 9-14, 33.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> from gfgpu.greens import UniformGreen
    >>> line = np.zeros(32); line[4] = 1
    >>> out = gfgpu.green_filter(line, UniformGreen(3.0), mode="constant", backend="numpy")
    >>> round(float(out.sum()), 3)  # sampled G_u: DC gain slightly below 1 at u = 3
    0.982
    >>> rgb = np.random.default_rng(0).random((16, 20, 3))
    >>> obl = gfgpu.green_filter(rgb, UniformGreen(2.0), angle=0.3, channel_axis=-1, backend="numpy")
    >>> bool(np.allclose(obl[..., 1], gfgpu.green_filter(rgb[..., 1], UniformGreen(2.0), angle=0.3,
    ...                                                   backend="numpy")))
    True
    """
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    if angle is not None and not is_axis_angle(angle):
        ya, xa = image_plane(job.ndim, axes, channel_axis)
        last = (job.ndim - 2, job.ndim - 1)
        if (ya, xa) != last:
            if not job.host_input:
                raise ValueError(f"an oblique direction on a device array needs the image plane on its last two "
                                 f"axes; got plane axes ({ya}, {xa}) of shape {job.shape} (move the channel "
                                 f"axis first)")
            # job.output: the caller's output= as a numpy view (a tensor's memory included)
            native = job.output
            if isinstance(native, np.ndarray):
                out_view = np.moveaxis(native, (ya, xa), last)
            else:   # no output=, or a dtype (it is the job's dtype)
                out_view = None if output is None else job.dtype
            moved = Job(np.moveaxis(np.asarray(job.source), (ya, xa), last), out_view, job.backend)
            program = green_filter_program(job.ndim, kernel, angle=angle, anticausal=anticausal)
            result = apply_program(moved, program, mode, cval)
            return job.deliver(native if isinstance(native, np.ndarray) else np.moveaxis(result, last, (ya, xa)))
    program = green_filter_program(job.ndim, kernel, axis=axis, angle=angle, axes=axes,
                                   channel_axis=channel_axis, anticausal=anticausal)
    return apply_program(job, program, mode, cval)


def green_filter_program(ndim, kernel, *, axis=None, angle=None, axes=None, channel_axis=None,
                         anticausal=False):
    """The :class:`Program` of :func:`green_filter` on ``ndim``-dimensional arrays.

    An oblique ``angle`` needs the image plane on the last two axes (a Program runs on the
    array as it is laid out).
    """
    if not isinstance(kernel, greens.GreenKernel):
        raise TypeError(f"kernel must be a gfgpu.greens kernel (UniformGreen, HomogeneousGreen, "
                        f"AffineGreen, AffineGreenApprox), got {type(kernel).__name__}")
    passes = [kernel.line_pass(reverse=flag("anticausal", anticausal))]
    if angle is None:
        if axes is not None:
            raise ValueError(f"axes={axes!r} names the image plane of angle=; give angle, or use axis= for "
                             f"one axis")
        return Program([(passes, line_axis(ndim, axis, channel_axis), None)])
    if axis is not None:
        raise ValueError("give either axis or angle, not both")
    return Program(*direction_steps(ndim, passes, angle, image_plane(ndim, axes, channel_axis)))


def shift(input, shift, *, output=None, mode="reflect", cval=0.0, axes=None, channel_axis=None,
          interpolation="green", backend=None, device=None):
    """Translate an array by ``shift`` samples per axis, in array-axis order (rows, cols).

    A translation, not a blur: along each axis the shift ``s = n + f`` is split into an
    integer ``n`` and a fraction ``|f| <= 1/2``.  The integer part is index arithmetic on the
    boundary mode's extension (exact, any magnitude, also beyond the image); the fractional
    part is one recursive pass of the discrete Green's function G_f (causal for ``f > 0``,
    anticausal for ``f < 0``), or a cubic B-spline with ``interpolation="cubic"``.  Cost is
    O(1) per sample whatever ``s``; integer shifts are exact, and the fractional error does not
    depend on ``|s|``.  The chapter's G_u with ``u`` the whole displacement (a shift that also
    blurs in proportion to ``u``, the motion-blur PSF) is ``green_filter(input, UniformGreen(u))``.

    Parameters
    ----------
    input : array_like or device array
        Image, stack or colour image (with ``channel_axis``).
    shift : float or sequence of float
        Displacement along each axis operated on, in array-axis order: for a 2-D image
        ``(dy, dx)``, rows (down) then columns (right), as ``scipy.ndimage.shift``.  A single
        number shifts every such axis by the same amount.
    output : ndarray or dtype, optional
        As in :func:`green_filter`.
    mode : {'reflect', 'grid-mirror', 'constant', 'grid-constant', 'nearest', 'mirror', 'wrap', 'grid-wrap'}, optional
        scipy.ndimage's interpolation meaning, for both interpolations (the Green and the cubic
        interpolant are built on the same extension and read at the same source coordinate
        ``c = i - shift`` of each output sample ``i``): ``'reflect'`` (= ``'grid-mirror'``),
        ``'mirror'`` and ``'nearest'`` extend the input as in :func:`green_filter`;
        ``'grid-constant'`` extends it by ``cval`` and ``'grid-wrap'`` with period ``n``; but
        ``'constant'`` interpolates the ``'mirror'`` extension and gives ``cval`` wherever the
        source ``c`` lies outside ``[0, n - 1]`` (no tolerance), and ``'wrap'`` interpolates
        the ``'mirror'`` extension at ``c`` folded into ``[0, n - 1]`` with period ``n - 1``
        (scipy's ``map_coordinate``; :mod:`gfgpu._core.boundary`).  With
        ``interpolation='cubic'`` every mode gives ``scipy.ndimage.shift(order=3)``'s values
        (``'nearest'`` and ``'grid-constant'`` to about 1e-8 of the image's range at shifts of
        more than ~10 px, where scipy pads by 12 samples only).
    cval : float, optional
        The value beyond the border for ``'constant'`` and ``'grid-constant'``.
    axes : sequence of int, optional
        The axes operated on, which ``shift`` refers to; default every axis other than
        ``channel_axis``.
    channel_axis : int, optional
        Axis of colour channels, not shifted: for ``(H, W, 3)`` with ``channel_axis=-1``,
        ``shift`` is ``(dy, dx)`` and every channel moves the same way.
    interpolation : {'green', 'cubic'}, optional
        The fractional part: ``'green'`` (default), the discrete G_f of the chapter's matching
        equation, two poles ``exp((-1 ± i)/|f|)``, unit DC gain and first moment exactly ``f``;
        ``'cubic'``, cubic B-spline interpolation (``scipy.ndimage.shift(order=3)``'s values,
        one pole per direction).  Measured on a band-limited image (rel. L2 against the exact
        Fourier shift, half-pixel shifts): green 1.4e-2, cubic 7.5e-4, linear interpolation
        3.1e-2 (``docs/derivations.md``, "Translation").
    backend, device : str, optional
        As in :func:`green_filter`.

    Returns
    -------
    ndarray or device array

    Raises
    ------
    ValueError
        ``shift`` not finite or with a length other than the number of axes operated on,
        ``axes`` overlapping ``channel_axis``, bad ``mode``, empty or non-finite input.
    TypeError
        Unsupported dtype, or a non-numeric ``shift``.

    Notes
    -----
    The continuous G_u (eq. 9) shifts by ``u`` with zero variance; its samples do not (DC gain
    0.84 and mean 1.17 at u = 1).  The fractional taps used here are ``w[0] = t`` and
    ``w[m] = Re(K λ^{m-1})``, ``λ = e^{(-1+i)/|f|}`` (two poles, numerator of degree two), with
    ``(t, K)`` fitted in float64 so that ``Σ w = 1`` and ``Σ m w = f`` exactly, the variance
    equals that of the pixel-integrated kernel and the taps stay closest to the cell integrals
    ``∫_{m-1/2}^{m+1/2} G_f`` (see ``greens.shift_coefficients``).  Where the integer part is
    not zero the fractional pass runs on the translated line padded by its decay length, so
    the boundary modes hold exactly as for the untranslated line.  ``'constant'`` and
    ``'wrap'`` run as ``'mirror'`` shifts (``'wrap'``: two per axis, by ``s`` and by
    ``s + n - 1``) whose results are masked or selected on the host; a device array makes a
    round trip through host memory for them.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> img = np.zeros((16, 64)); img[:, 10] = 1
    >>> out = gfgpu.shift(img, (0, 2.5), mode="grid-constant", backend="numpy")   # (dy, dx)
    >>> round(float((out[0] * np.arange(64)).sum()), 6)
    12.5
    >>> rgb = np.zeros((16, 64, 3)); rgb[:, 10] = 1
    >>> col = gfgpu.shift(rgb, (0, 2.5), channel_axis=-1, mode="grid-constant", backend="numpy")
    >>> bool(np.allclose(col[..., 2], out))
    True
    >>> line = np.array([4.0, 1, 3, 2])                   # scipy's interpolation-only modes
    >>> gfgpu.shift(line, 0.5, mode="constant", interpolation="cubic", backend="numpy").round(6).tolist()
    [0.0, 2.625, 1.75, 2.625]
    >>> gfgpu.shift(line, 1, mode="wrap", interpolation="cubic", backend="numpy").tolist()
    [3.0, 4.0, 1.0, 3.0]
    """
    engine_mode, rule = interpolation_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    program = shift_program(job.ndim, shift, axes=axes, channel_axis=channel_axis, interpolation=interpolation)
    if rule is None:
        return apply_program(job, program, engine_mode, cval)
    return _shift_by_rule(job, program, shift, axes, channel_axis, interpolation, rule, cval)


def shift_branches(shape, shift, rule, *, axes=None, channel_axis=None):
    """Per axis operated on, ``(axis, amount, branch)`` of scipy's interpolation-only ``rule``.

    ``branch`` is :func:`gfgpu._core.boundary.interpolation_branch` of the source coordinates
    ``arange(n) - amount`` of that axis: -1 where the output is ``cval`` (``'constant'``),
    1 where it reads the ``mirror`` interpolant shifted by ``amount + n - 1`` (``'wrap'``),
    0 where it reads the ``mirror`` interpolant shifted by ``amount``.
    """
    ax = operated_axes(len(shape), axes, channel_axis)
    amounts = per_axis(shift, ax, "shift")
    return [(a, s, interpolation_branch(np.arange(shape[a]) - s, shape[a], rule)) for a, s in zip(ax, amounts)]


def _along(branch, axis, ndim):
    return branch.reshape([-1 if d == axis else 1 for d in range(ndim)])


def _shift_by_rule(job, program, shift, axes, channel_axis, interpolation, rule, cval):
    """scipy's interpolation-only ``constant``/``wrap``: the ``mirror`` interpolant read where
    :func:`shift_branches` says, on the host (masks and selections of whole index ranges)."""
    be = job.backend
    x = np.ascontiguousarray(job.source if job.host_input else be.to_host(job.data), dtype=job.dtype)
    if job.host_input and job.scale_exp:    # beyond the range limit: scaled (job.data is already)
        x = np.ldexp(x, job.scale_exp, dtype=job.dtype)
    cval = job.scaled(cval)

    def run(data, prog):      # numpy in, numpy out, on the job's backend (the input is checked)
        return apply_program(Job(data, None, be, finite=True), prog, "mirror", cval)

    branches = shift_branches(job.shape, shift, rule, axes=axes, channel_axis=channel_axis)
    if rule == "constant":
        out = run(x, program)
        for a, _, branch in branches:
            out = np.where(_along(branch < 0, a, job.ndim), out.dtype.type(cval), out)
    else:
        # one axis at a time: an odd fold reads the interpolant at c - (n - 1) instead of c
        out = x
        for a, s, branch in branches:
            near = run(out, shift_program(job.ndim, [s], axes=[a], interpolation=interpolation))
            if branch.any():
                far = run(out, shift_program(job.ndim, [s + job.shape[a] - 1], axes=[a],
                                             interpolation=interpolation))
                near = np.where(_along(branch > 0, a, job.ndim), far, near)
            out = near
    out = np.ascontiguousarray(out, dtype=job.dtype)
    if job.host_input:
        if job.scale_exp:
            with np.errstate(over="ignore"):
                out = np.ldexp(out, -job.scale_exp, dtype=job.dtype)
        if job.output is not None:
            job.output[...] = out
        return job.deliver(out)
    return job.finish(be.asarray(out))


def shift_program(ndim, shift, *, axes=None, channel_axis=None, interpolation="green"):
    """The :class:`Program` of :func:`shift` on ``ndim``-dimensional arrays."""
    ax = operated_axes(ndim, axes, channel_axis)
    if np.ndim(shift) == 1 and len(shift) != len(ax):
        hint = "" if channel_axis is not None or axes is not None else "; for a colour image pass channel_axis"
        if channel_axis is not None and axes is None and len(shift) == ndim:
            # the shift fits the whole array: the channel axis is the mistake, not the shift
            hint = (f"; channel_axis={channel_axis!r} takes one of the input's {ndim} axes as colour, "
                    f"which a {ndim}-D grey image does not have: drop channel_axis (or pass a colour image)")
        raise ValueError(f"shift must have one value per axis operated on ({len(ax)}: axes {ax}, in "
                         f"array-axis order), got {len(shift)}{hint}")
    amounts = per_axis(shift, ax, "shift")
    steps = [(greens.translation_passes(s, interpolation), a, None) for a, s in zip(ax, amounts)]
    return Program([step for step in steps if step[0]])


def derivative_program(ndim, u, *, axis=None, axes=None, channel_axis=None, a=greens.EDGE_A,
                       eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0):
    """The :class:`Program` of :func:`derivative`: P along the other axes, then D along ``axis``."""
    ax = operated_axes(ndim, axes, channel_axis)
    d_axis = ax[-1] if axis is None else line_axis(ndim, axis, channel_axis)
    if d_axis not in ax:
        raise ValueError(f"axis {axis} must be one of axes {ax}")
    ratio = positive("projection_scale", projection_scale)
    d_passes = list(greens.derivative_passes(u, a, eta, single_scale))
    p_passes = list(greens.projection_passes(scale("u", u) * ratio, a, eta, single_scale))
    steps = [(p_passes, other, None) for other in ax if other != d_axis]
    steps.append((d_passes, d_axis, None))
    return Program(steps)


def projection_program(ndim, u, *, axis=None, channel_axis=None, a=greens.EDGE_A, eta=greens.EDGE_ETA,
                       single_scale=False):
    """The :class:`Program` of :func:`projection`."""
    passes = list(greens.projection_passes(u, a, eta, single_scale))
    return Program([(passes, line_axis(ndim, axis, channel_axis), None)])


def derivative(input, u, *, axis=None, axes=None, channel_axis=None, output=None, mode="reflect", cval=0.0,
               a=greens.EDGE_A, eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0,
               backend=None, device=None):
    """Green's-function derivative: D(x) across ``axis``, the projection P along the others.

    Parameters
    ----------
    input : array_like or device array
        Image, stack or colour image (with ``channel_axis``).
    u : float
        Scale of the operator (> 0), in pixels.
    axis : int, optional
        Axis of differentiation, one of ``axes``; default the last of ``axes`` (for a 2-D
        image the columns: d/dx).
    axes : sequence of int, optional
        Spatial axes, the axes operated on; P smooths along those other than ``axis``.
        Default every axis other than ``channel_axis``.
    channel_axis : int, optional
        Axis of colour channels: each channel is differentiated on its own.
    output, mode, cval, backend, device
        As in :func:`green_filter`.
    a, eta : float
        Weight and scale ratio of the two-scale D (eq. 25-26):
        ``F(x) = A[e^{-x/ηu} sin(x/ηu) + K e^{-x/u} sin(x/u)]``, ``K = a η²``,
        ``A = 2/(u η² (1 + a))``, so that ``a`` weights the fine scale.
    single_scale : bool
        Use D_u of eq. 19 (and its integral) instead.
    projection_scale : float
        Scale of P relative to D's (> 0); 1 is the chapter's P = ∫D at the same u.  Smaller
        values smooth less along edges, which makes the 2-D operator closer to isotropic
        (better on oblique and curved edges; see ``benchmarks/edges_fom.py``).

    Returns
    -------
    ndarray or device array
        The derivative estimate; unit response to a unit ramp along ``axis``.

    Raises
    ------
    ValueError
        ``u <= 0`` or ``projection_scale <= 0``, ``axis`` not among ``axes``, ``axis`` or
        ``axes`` overlapping ``channel_axis``, bad ``mode``, empty or non-finite input.
    TypeError
        Unsupported dtype.

    Notes
    -----
    D is applied as one causal and one anticausal pass of two 2-pole sections (one per
    scale); taps are the point samples of eq. 25-26 normalised so that ``-Σ m D[m] = 1``.
    P = ∫D, the integral of D from -∞, is even; it is sampled and normalised to unit sum.
    On an OpenCL CPU device a step runs its causal and anticausal passes as one kernel, along
    columns or rows: a backward sweep that keeps the anticausal parts in the cache, then the
    forward one, the result written once (:func:`run_line_program`).

    References
    ----------
    .. [1] Torreão & Amaral, "Signal differentiation through a Green's function approach",
       Pattern Recognition Letters 23 (2002) 1755-1759.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> ramp = np.tile(np.arange(256.0), (8, 1))
    >>> d = gfgpu.derivative(ramp, 1.0, axis=1, mode="nearest", backend="numpy")
    >>> round(float(d[4, 128]), 6)
    1.0
    """
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    program = derivative_program(job.ndim, u, axis=axis, axes=axes, channel_axis=channel_axis, a=a, eta=eta,
                                 single_scale=single_scale, projection_scale=projection_scale)
    return run_line_program(job, program, mode, cval)


def projection(input, u, *, axis=None, channel_axis=None, output=None, mode="reflect", cval=0.0,
               a=greens.EDGE_A, eta=greens.EDGE_ETA, single_scale=False, backend=None, device=None):
    """The projection function P = ∫D along one axis (the smoothing used along edges).

    P is even with unit sum (two recursive passes).

    Parameters
    ----------
    input : array_like or device array
    u : float
        Scale (> 0), in pixels.
    axis : int, optional
        Axis to smooth along; default the last axis other than ``channel_axis``.
    channel_axis : int, optional
        Axis of colour channels, never smoothed along.
    output, mode, cval, a, eta, single_scale, backend, device
        As in :func:`derivative`.

    Returns
    -------
    ndarray or device array

    Raises
    ------
    ValueError
        ``u <= 0``, ``axis`` out of range or equal to ``channel_axis``, bad ``mode``, empty or
        non-finite input.
    TypeError
        Unsupported dtype.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> line = np.zeros(257); line[128] = 1
    >>> p = gfgpu.projection(line, 1.0, mode="constant", backend="numpy")
    >>> round(float(p.sum()), 6), bool(np.allclose(p[:128], p[:128:-1]))
    (1.0, True)
    """
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    program = projection_program(job.ndim, u, axis=axis, channel_axis=channel_axis, a=a, eta=eta,
                                 single_scale=single_scale)
    return run_line_program(job, program, mode, cval)


def gradient(input, u, *, axes=None, channel_axis=None, mode="reflect", cval=0.0, a=greens.EDGE_A,
             eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0, backend=None, device=None):
    """Green's-function gradient: :func:`derivative` along each axis operated on.

    Parameters
    ----------
    input : array_like or device array
        Image, stack or colour image (with ``channel_axis``).
    u : float
        Scale of the operator (> 0), in pixels.
    axes : sequence of int, optional
        The axes differentiated along (the spatial axes); default every axis other than
        ``channel_axis``.
    channel_axis : int, optional
        Axis of colour channels: no derivative along it, each channel differentiated on its own.
    mode, cval, a, eta, single_scale, projection_scale, backend, device
        As in :func:`derivative`.

    Returns
    -------
    tuple of arrays
        One derivative per axis operated on, in array-axis order (for a 2-D image:
        ``(d/dy, d/dx)``, rows then columns, as ``numpy.gradient``), each of the input's shape.

    Raises
    ------
    ValueError
        As :func:`derivative`.
    TypeError
        Unsupported dtype.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> yy, xx = np.mgrid[:256, :256].astype(float)
    >>> gy, gx = gfgpu.gradient(2 * yy + 3 * xx, 1.0, mode="nearest", backend="numpy")
    >>> round(float(gy[128, 128]), 6), round(float(gx[128, 128]), 6)
    (2.0, 3.0)
    >>> rgb = np.stack([yy, xx, yy + xx], axis=-1)
    >>> gy, gx = gfgpu.gradient(rgb, 1.0, channel_axis=-1, mode="nearest", backend="numpy")
    >>> gy.shape, [round(float(v), 6) for v in gx[128, 128]]
    ((256, 256, 3), [0.0, 1.0, 1.0])
    """
    mode = filter_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, None, backend, device)
    ax = operated_axes(job.ndim, axes, channel_axis)
    d_passes = greens.derivative_passes(u, a, eta, single_scale)
    p_passes = greens.projection_passes(scale("u", u) * positive("projection_scale", projection_scale), a, eta,
                                        single_scale)
    return job_gradient(job, d_passes, p_passes, ax, mode, cval)


# --------------------------------------------------------------------------------------
# running the derivative, projection and gradient: two-sided steps where the device has them
# --------------------------------------------------------------------------------------
def _two_sided_runner(be):
    """The two-sided step launcher of ``be`` (OpenCL CPU devices), else None: elsewhere (numpy,
    Warp, OpenCL GPUs, whose generic primitive cuts lines into blocks) the program's passes run
    one by one through :func:`~gfgpu._core.job.apply_program`."""
    if be.name != "opencl":
        return None
    from .backends.opencl import twosided
    return twosided.run_two_sided if twosided.runs_on(be) else None


def _two_sided_steps(job, steps, mode):
    """Per step of ``steps`` (``[(outputs, axis), ...]``, outputs as
    :func:`~gfgpu._core.twosided.plan_two_sided` takes them): ``(plan, view, line_axis)`` for a
    step that a two-sided kernel runs, else None (rows too few or too long for it: the generic
    primitive's fused pair; a step no plan expresses)."""
    from ._core.lines import axis_view_shape
    from ._core.twosided import plan_two_sided
    from .backends.opencl.twosided import takes
    plans = []
    for outputs, axis in steps:
        view, line = axis_view_shape(job.shape, axis)
        nin = len({i for i, _ in outputs})
        fits = takes(job.backend, view, line, job.dtype, nin, len(outputs))
        plan = plan_two_sided(outputs, view[line], mode, job.dtype) if fits else None
        plans.append(None if plan is None else (plan, view, line))
    return plans


def _paired(passes):
    """A step's passes as one causal and one anticausal pass (their sections and taps summed: the
    same sum) where all are shift-invariant without translation, so that the generic primitive of
    an OpenCL CPU device runs the step as one fused pair (``recurse_pair``; the one-signed D of
    :mod:`gfgpu.edges.operator` has one pass per scale and direction).  Only for devices whose
    recursions take any number of sections (Warp's take two)."""
    from ._core.passes import LinePass
    passes = list(passes)
    causal = [lp for lp in passes if not lp.reverse]
    anti = [lp for lp in passes if lp.reverse]
    if len(causal) < 2 and len(anti) < 2 or any(lp.offset or not lp.shift_invariant for lp in passes):
        return passes
    return [LinePass(tuple(sec for lp in group for sec in lp.sections), sum(lp.tap for lp in group), reverse)
            for group, reverse in ((causal, False), (anti, True)) if group]


def _launch(job, runner, step, srcs, dsts, cval, check=False):
    """One two-sided kernel: ``step`` = (plan, view, line_axis) on the job's arrays; ``cval`` is
    the constant of the (first) input's extension."""
    plan, view, line = step
    be = job.backend
    return runner(be, [be.reshape(x, view) for x in srcs], [be.reshape(y, view) for y in dsts],
                  line, plan, (cval, 0.0), check=check)


def _checked_first_step(job, runner, step, dsts, cval, may_write):
    """The first step on the job's input with the finite check in its read, where ``may_write``
    (its outputs are not the caller's own ``output``, which a refused input must leave untouched).
    Returns True when ``dsts`` hold the step's result; False when the step must run (again) on
    :attr:`job.data`: no check ran, or the input was beyond the range limit and is now scaled.
    A non-finite input raises."""
    from ._core.magnitude import range_limit
    if cval and not abs(cval) < range_limit(job.dtype):
        job.scaled(cval)         # a constant beyond the range limit scales the job (rare)
    if not (job.check_pending and may_write):
        return False
    if _launch(job, runner, step, [job.unchecked_data()], dsts, cval, check=True):
        job.check_pending = False
        return True
    job.settle(cval)             # not finite (raises), or beyond the range limit: scaled
    return not job.scale_exp


def run_line_program(job, program, mode, cval):
    """Run a :class:`~gfgpu._core.program.Program` of axis steps on ``job``, as
    :func:`~gfgpu._core.job.apply_program` does (same result to rounding, same checks), with each
    step's passes as one two-sided kernel where the backend has it (OpenCL CPU devices: the
    step's causal and anticausal passes in one two-sided step: the input read twice, the
    result written once).

    Used by :func:`derivative` and :func:`projection`; any other program, backend, or a host image
    streamed in strips runs through :func:`~gfgpu._core.job.apply_program`.
    """
    from ._core import strips
    from ._core.program import run_passes
    runner = _two_sided_runner(job.backend)
    steps = program.steps
    plans = None
    if runner is not None and steps and all(angle is None for _, _, angle in steps) and not (
            job.host_input and strips.needs_strips(job)):
        plans = _two_sided_steps(job, [([(0, tuple(passes))], axis) for passes, axis, _ in steps], mode)
    if plans is None or all(p is None for p in plans):
        return apply_program(job, program, mode, cval)
    bufs = [job.empty() for _ in plans[:-1]] + [job.result_buffer()]
    # the finite check rides on a first two-sided step; otherwise job.data checks the input
    done = plans[0] is not None and _checked_first_step(job, runner, plans[0], bufs[:1], cval,
                                                        may_write=len(plans) > 1 or job.output is None)
    cval = job.scaled(cval)
    cur = bufs[0] if done else job.data
    for k in range(1 if done else 0, len(plans)):
        passes, axis, _ = steps[k]
        if plans[k] is None:
            run_passes(job.backend, cur, bufs[k], job.dtype, _paired(passes), mode, cval, axis=axis,
                       shape=job.shape)
        else:
            _launch(job, runner, plans[k], [cur], [bufs[k]], cval)
        cur = bufs[k]
    return job.finish(cur)


def job_gradient(job, d_passes, p_passes, axes, mode, cval):
    """The derivative of ``job``'s input along each of ``axes``: D (``d_passes``) across the axis,
    P (``p_passes``) along the others; a tuple in the order of ``axes``, each finished as the
    job's result (numpy in, numpy out).

    For two axes on a device with two-sided steps, the passes along one axis ``f`` share their
    states: one two-sided step gives ``C = P_f I`` and ``E = D_f I`` (the image read twice, C and
    E written once); then ``d/df = P_s E`` and ``d/ds = D_s C`` along the other axis ``s``, each
    a two-sided step too where the device runs it, else one fused pair (four reads of an image
    and four writes in all, against eight passes).  ``f`` is the axis along rows (the last axis
    of the array's line view) where it has a two-sided step: the row kernel's streamed outputs
    make its two-output step cheaper than two row steps (4096^2 float32, A/B in one process: the
    gradient in 0.86-0.95x the CPU time of the columns-first order).  P has unit sum and D zero
    sum, so the constant extension of ``C`` is ``cval`` and that of ``E`` is 0: the result equals
    each derivative's own program (P along the other axis first) up to rounding.  Otherwise each
    derivative is its own program (:func:`run_line_program`) on the same input, uploaded and
    checked once.
    """
    from ._core import strips
    from ._core.lines import axis_view_shape
    d_passes, p_passes = tuple(d_passes), tuple(p_passes)
    runner = _two_sided_runner(job.backend)
    if runner is not None and len(axes) == 2 and not (job.host_input and strips.needs_strips(job)):
        # the axis whose lines are rows first (a stable sort: else the first of axes)
        order = sorted(axes, key=lambda a: axis_view_shape(job.shape, a)[1] != 2)
        for f in order:
            plans = _two_sided_steps(job, [([(0, p_passes), (0, d_passes)], f)], mode)
            if plans[0] is not None:
                break
        if plans[0] is not None:
            s = order[1] if f == order[0] else order[0]
            from ._core.program import run_passes
            c, e = job.empty(), job.empty()
            if not _checked_first_step(job, runner, plans[0], [c, e], cval, may_write=True):
                _launch(job, runner, plans[0], [job.data], [c, e], job.scaled(cval))
            cval = job.scaled(cval)
            out = {f: job.result_buffer(), s: job.result_buffer()}
            for src, dst, passes, cv in ((e, out[f], p_passes, 0.0), (c, out[s], d_passes, cval)):
                step = _two_sided_steps(job, [([(0, passes)], s)], mode)[0]
                if step is None:
                    run_passes(job.backend, src, dst, job.dtype, _paired(passes), mode, cv, axis=s, shape=job.shape)
                else:
                    _launch(job, runner, step, [src], [dst], cv)
            return tuple(job.finish(out[a]) for a in axes)
    results = []
    for d in axes:
        steps = [(list(p_passes), other, None) for other in axes if other != d] + [(list(d_passes), d, None)]
        results.append(run_line_program(job, Program(steps), mode, cval))
    return tuple(results)
