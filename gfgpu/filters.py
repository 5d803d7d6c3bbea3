"""Line operators on N-D arrays: green_filter, shift, derivative, projection, gradient.

All are compositions of the recursion primitive (:mod:`gfgpu.recursion`) along array axes
or image-plane directions (:mod:`gfgpu.lines`), run on the backend chosen by
:func:`gfgpu.backends.resolve_backend`.

Dtype policy: float32 and float64 are preserved; integer and boolean images are converted
to float32; float16 is computed in float32; complex and other types raise ``TypeError``.
numpy in, numpy out; a ``warp.array`` or ``pyopencl.array.Array`` input gives an array of the
same kind on the same device.
"""

from __future__ import annotations

from . import greens
from ._core.job import Job, apply_program
from ._core.lines import normalize_axis
from ._core.program import Program, axes_list, direction_steps, per_axis
from ._core.recursion import check_mode
from ._core.validation import finite_cval, positive
from .backends import resolve_backend

__all__ = ["green_filter", "shift", "derivative", "projection", "gradient", "make_job",
           "green_filter_program", "shift_program", "derivative_program", "projection_program"]


def make_job(input, output=None, backend=None, device=None, min_ndim=1):
    """The :class:`~gfgpu._core.job.Job` of one call: the backend resolved with the input array."""
    return Job(input, output, resolve_backend(backend, device, input), min_ndim)


# --------------------------------------------------------------------------------------
# public operators
# --------------------------------------------------------------------------------------
def green_filter(input, kernel, axis=-1, output=None, mode="reflect", cval=0.0, *, angle=None,
                 axes=(-2, -1), anticausal=False, backend=None, device=None):
    """Apply a Green's function of the chapter along an axis or an image-plane direction.

    .. math:: f[x] = \\sum_{x_0 \\le x} G(x, x_0)\\, I[x_0]   \\qquad (causal)

    computed exactly by the first-order complex recursion of DESIGN §1, in O(N) whatever
    the kernel's length.

    Parameters
    ----------
    input : array_like, warp.array or pyopencl.array.Array
        Image, stack ``(N, H, W)`` or colour image; float32/float64 kept, integers -> float32.
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
        Axis to filter along (ignored when ``angle`` is given).
    output : ndarray or dtype, optional
        Array to write the result into, or the result dtype (never lower precision).
    mode : {'reflect', 'constant', 'nearest', 'mirror', 'wrap'}, optional
        How the input extends beyond its border (scipy.ndimage semantics); realised exactly
        as the recursion's initial state.
    cval : float, optional
        Value beyond the border when ``mode='constant'``.
    angle : float, optional
        Filter along the image-plane direction at this angle (radians from +x toward +y, y
        being the row index) instead of ``axis``; see :mod:`gfgpu.lines` for the digital lines
        used and the units of kernel lengths along them.
    axes : pair of int, optional
        (row axis, column axis) of the image plane for ``angle``; default the last two.
    anticausal : bool, optional
        Apply the mirrored operator ``f[x] = Σ_{x0 >= x} G(x', x0')`` (right to left).
    backend, device : str, optional
        ``"numpy"``, ``"warp"`` or ``"opencl"`` and its device; default: DESIGN §4 rule.

    Returns
    -------
    ndarray or device array
        Same shape; same kind of array as ``input``.

    Raises
    ------
    ValueError
        Bad ``mode``/``axis``/``angle``, empty or non-finite input, or a kernel whose domain
        does not contain the line (e.g. ``x_U`` inside it).
    TypeError
        Unsupported dtype, or float64 on a device without fp64.

    Notes
    -----
    The kernel is point-sampled at integer offsets; H_u's jump at 0 takes its mean 1/u.

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
    """
    check_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    program = green_filter_program(job.ndim, kernel, axis, angle=angle, axes=axes, anticausal=anticausal)
    return apply_program(job, program, mode, cval)


def green_filter_program(ndim, kernel, axis=-1, *, angle=None, axes=(-2, -1), anticausal=False):
    """The :class:`Program` of :func:`green_filter` on ``ndim``-dimensional arrays."""
    if not isinstance(kernel, greens.GreenKernel):
        raise TypeError(f"kernel must be a gfgpu.greens kernel (UniformGreen, HomogeneousGreen, "
                        f"AffineGreen, AffineGreenApprox), got {type(kernel).__name__}")
    passes = [kernel.line_pass(reverse=bool(anticausal))]
    if angle is None:
        return Program([(passes, normalize_axis(axis, ndim), None)])
    return Program(*direction_steps(ndim, passes, angle, axes))


def shift(input, shift, output=None, mode="reflect", cval=0.0, *, axes=None, backend=None,
          device=None):
    """Sub-pixel shift through G_u: content moves by ``shift`` (scipy.ndimage.shift order).

    Each axis with a non-zero shift ``s`` gets one recursive pass: causal (toward higher
    indices) for ``s > 0``, anticausal for ``s < 0``.  The discrete operator has unit DC gain
    and first moment exactly ``s`` for every ``|s|`` (checked to 1e-6 for
    0.25 <= |s| <= 40), and G_u's poles ``exp((-1 ± i)/|s|)``; cost is independent of ``s``.

    Parameters
    ----------
    input : array_like or device array
    shift : float or sequence of float
        Displacement per axis in ``axes`` (for a 2-D image: ``(dy, dx)``, rows then columns).
    output, mode, cval, backend, device
        As in :func:`green_filter`.
    axes : sequence of int, optional
        Axes that ``shift`` refers to (default: all), e.g. ``(0, 1)`` for a colour image.

    Returns
    -------
    ndarray or device array

    Notes
    -----
    The continuous G_u (eq. 9) shifts by ``u`` with zero variance; its samples do not (DC gain
    0.84 and mean 1.17 at u = 1, DESIGN §2).  The taps used here are
    ``w[0] = t`` and ``w[m] = Re(K λ^{m-1})``, ``λ = e^{(-1+i)/u}`` (two poles, numerator of
    degree two), with ``(t, K)`` fitted in float64 so that ``Σ w = 1`` and ``Σ m w = u``
    exactly, the variance equals that of the pixel-integrated kernel (1/12) and the taps stay
    closest to the cell integrals ``∫_{m-1/2}^{m+1/2} G_u`` (see ``greens.shift_coefficients``).

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> img = np.zeros((16, 64)); img[:, 10] = 1
    >>> out = gfgpu.shift(img, (0, 2.5), mode="constant", backend="numpy")
    >>> round(float((out[0] * np.arange(64)).sum()), 6)
    12.5
    """
    check_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    return apply_program(job, shift_program(job.ndim, shift, axes), mode, cval)


def shift_program(ndim, shift, axes=None):
    """The :class:`Program` of :func:`shift` on ``ndim``-dimensional arrays."""
    ax = axes_list(axes, ndim)
    amounts = per_axis(shift, ax, "shift")
    return Program([([greens.shift_pass(s)], a, None) for a, s in zip(ax, amounts) if s != 0.0])


def derivative_program(ndim, u, axis=-1, axes=None, a=greens.EDGE_A, eta=greens.EDGE_ETA,
                       single_scale=False, projection_scale=1.0):
    """The :class:`Program` of :func:`derivative`: P along the other axes, then D along ``axis``."""
    ax = axes_list(axes, ndim)
    d_axis = normalize_axis(axis, ndim)
    if d_axis not in ax:
        raise ValueError(f"axis {axis} must be one of axes {ax}")
    ratio = positive("projection_scale", projection_scale)
    d_passes = list(greens.derivative_passes(u, a, eta, single_scale))
    p_passes = list(greens.projection_passes(positive("u", u) * ratio, a, eta, single_scale))
    steps = [(p_passes, other, None) for other in ax if other != d_axis]
    steps.append((d_passes, d_axis, None))
    return Program(steps)


def projection_program(ndim, u, axis=-1, a=greens.EDGE_A, eta=greens.EDGE_ETA, single_scale=False):
    """The :class:`Program` of :func:`projection`."""
    return Program([(list(greens.projection_passes(u, a, eta, single_scale)), normalize_axis(axis, ndim), None)])


def derivative(input, u, axis=-1, output=None, mode="reflect", cval=0.0, *, axes=None,
               a=greens.EDGE_A, eta=greens.EDGE_ETA, single_scale=False, projection_scale=1.0,
               backend=None, device=None):
    """Green's-function derivative: D(x) across ``axis``, the projection P along the others.

    Parameters
    ----------
    input : array_like or device array
    u : float
        Scale of the operator (> 0), in pixels.
    axis : int
        Axis of differentiation.
    axes : sequence of int, optional
        Spatial axes (default all); P smooths along ``axes`` other than ``axis``.
    a, eta : float
        Weight and scale ratio of the two-scale D (eq. 25-26, ``K = a eta^2``, DESIGN §2).
    single_scale : bool
        Use D_u of eq. 19 (and its integral) instead.
    projection_scale : float
        Scale of P relative to D's (> 0); 1 is the chapter's P = ∫D at the same u.  Smaller
        values smooth less along edges, which makes the 2-D operator closer to isotropic
        (better on oblique and curved edges; see ``benchmarks/edges_fom.py``).
    output, mode, cval, backend, device
        As in :func:`green_filter`.

    Returns
    -------
    ndarray or device array
        The derivative estimate; unit response to a unit ramp along ``axis``.

    Notes
    -----
    D is applied as one causal and one anticausal pass of two 2-pole sections (one per
    scale); taps are the point samples of eq. 25-26 normalised so that ``-Σ m D[m] = 1``.
    P = ∫D (science notes §1.5) is sampled and normalised to unit sum.

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
    check_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    program = derivative_program(job.ndim, u, axis, axes, a, eta, single_scale, projection_scale)
    return apply_program(job, program, mode, cval)


def projection(input, u, axis=-1, output=None, mode="reflect", cval=0.0, *, a=greens.EDGE_A,
               eta=greens.EDGE_ETA, single_scale=False, backend=None, device=None):
    """The projection function P = ∫D along one axis (the smoothing used along edges).

    Parameters as in :func:`derivative`; P is even with unit sum (two recursive passes).
    """
    check_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, output, backend, device)
    return apply_program(job, projection_program(job.ndim, u, axis, a, eta, single_scale), mode, cval)


def gradient(input, u, mode="reflect", cval=0.0, *, axes=None, a=greens.EDGE_A, eta=greens.EDGE_ETA,
             single_scale=False, projection_scale=1.0, backend=None, device=None):
    """Green's-function gradient: :func:`derivative` along each axis in ``axes``.

    Parameters are those of :func:`derivative`.

    Returns
    -------
    tuple of arrays
        One derivative per axis, in axis order (for a 2-D image: ``(d/dy, d/dx)``, as
        ``numpy.gradient``).

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> yy, xx = np.mgrid[:256, :256].astype(float)
    >>> gy, gx = gfgpu.gradient(2 * yy + 3 * xx, 1.0, mode="nearest", backend="numpy")
    >>> round(float(gy[128, 128]), 6), round(float(gx[128, 128]), 6)
    (2.0, 3.0)
    """
    check_mode(mode)
    cval = finite_cval(cval)
    job = make_job(input, None, backend, device)
    ax = axes_list(axes, job.ndim)
    return tuple(apply_program(job, derivative_program(job.ndim, u, d, ax, a, eta, single_scale, projection_scale),
                                 mode, cval) for d in ax)
