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

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from . import greens
from .backends import resolve_backend
from .lines import axis_view_shape, direction, normalize_axis, oblique_maps
from .recursion import check_mode, plan_pass

__all__ = ["green_filter", "shift", "derivative", "projection", "gradient"]


# --------------------------------------------------------------------------------------
# argument handling
# --------------------------------------------------------------------------------------
def _work_dtype(dtype, name="input"):
    dtype = np.dtype(dtype)
    if dtype in (np.float32, np.float64):
        return dtype
    if dtype.kind in "biu" or dtype == np.float16:
        return np.dtype(np.float32)
    raise TypeError(f"{name} must have a real numeric dtype (float32/float64, or integer/bool "
                    f"converted to float32); got {dtype}")


def _host_all_finite(arr, block=1 << 22):
    """``np.isfinite(arr).all()`` without a full-size temporary (large and memory-mapped images)."""
    if arr.dtype.kind in "biu":
        return True
    flat = arr.reshape(-1) if arr.flags.c_contiguous else None
    if flat is None:
        return bool(np.isfinite(arr).all())
    return all(np.isfinite(flat[i:i + block]).all() for i in range(0, flat.size, block))


def _finite_cval(cval):
    return greens._finite_scalar("cval", cval)


class Program(NamedTuple):
    """What an operator computes, independent of arrays and devices.

    ``steps`` is a list of ``(passes, axis, angle)`` applied in turn; the passes of one step
    run along the same lines and are summed.  ``axis`` is an array axis (``angle`` None) or
    None for the image-plane direction ``angle`` (the plane is ``plane``, the last two axes).
    The in-memory operators (:func:`_apply_sequence`), the strip executor
    (:mod:`gfgpu.strips`) and the Dask wrappers (:mod:`gfgpu.dask`) all run programs.
    """

    steps: list
    plane: tuple | None = None


class _Job:
    """Input validation, device placement and output handling shared by every operator."""

    def __init__(self, input, output, backend, device, min_ndim=1):
        be = resolve_backend(backend, device, input)
        self.backend = be
        self.host_input = be.name == "numpy" or not be.owns(input)
        if self.host_input:
            arr = np.asarray(input)
            if arr.dtype == object:
                raise TypeError("input must be a numeric array, got dtype object")
        else:
            arr = input
        if arr.ndim < min_ndim:
            raise ValueError(f"input must have at least {min_ndim} dimension(s), got shape {arr.shape}")
        if arr.size == 0:
            raise ValueError(f"input is empty (shape {arr.shape})")
        self.shape = tuple(int(s) for s in arr.shape)
        self.ndim = len(self.shape)
        self.dtype = _work_dtype(arr.dtype if self.host_input else be.dtype_of(arr))
        if self.dtype == np.float64 and not be.supports_float64:
            raise TypeError(f"input is float64 but {be!r} has no float64 support; pass a float32 "
                            f"array or choose another device (no silent downcast)")
        self.output = output
        out_dtype = self.dtype
        if output is not None and isinstance(output, (type, np.dtype, str)):
            out_dtype = np.dtype(output)
            if out_dtype not in (np.float32, np.float64):
                raise TypeError(f"output dtype must be float32 or float64, got {out_dtype}")
            if out_dtype.itemsize < self.dtype.itemsize:
                raise TypeError(f"output dtype {out_dtype} would downcast the {self.dtype} result")
            self.dtype = out_dtype
            self.output = None
        if self.host_input:
            if not _host_all_finite(arr):
                raise ValueError("input contains NaN or infinite values")
            self.source = arr           # converted and placed on the device when first used
            self._data = None
        else:
            if _work_dtype(be.dtype_of(arr)) != self.dtype:
                raise TypeError(f"device input must be float32 or float64, got {be.dtype_of(arr)}")
            if not be.all_finite(arr):
                raise ValueError("input contains NaN or infinite values")
            self.source = self._data = arr
        if self.output is not None:
            self._check_output(self.output)

    @property
    def data(self):
        """The input as a device array of the work dtype (host images: uploaded on first use)."""
        if self._data is None:
            self._data = self.backend.host_view(np.ascontiguousarray(self.source, dtype=self.dtype))
        return self._data

    @property
    def nbytes(self):
        return int(np.prod(self.shape, dtype=np.int64)) * self.dtype.itemsize

    def _check_output(self, output):
        if tuple(output.shape) != self.shape:
            raise ValueError(f"output must have the input's shape {self.shape}, got {tuple(output.shape)}")
        odt = np.dtype(output.dtype) if isinstance(output, np.ndarray) else self.backend.dtype_of(output)
        if odt not in (np.float32, np.float64):
            raise TypeError(f"output must be float32 or float64, got {odt}")
        if odt.itemsize < self.dtype.itemsize:
            raise TypeError(f"output dtype {odt} would downcast the {self.dtype} result")
        if isinstance(output, np.ndarray) != self.host_input:
            raise TypeError("output must be the same kind of array as input (numpy or device array)")

    def empty(self):
        return self.backend.empty(self.shape, self.dtype)

    def result_buffer(self):
        """The buffer of the final result: the caller's ``output`` itself where it can be
        written in place, host-shared when a numpy result is returned, else a new array."""
        be, out = self.backend, self.output
        if self.host_input:
            if out is None:
                return be.host_result(self.shape, self.dtype)
            direct = (out.dtype == self.dtype and out.flags.c_contiguous and out.flags.writeable
                      and not np.may_share_memory(out, self.source))
            return be.host_result(self.shape, self.dtype, into=out) if direct else self.empty()
        if (out is not None and be.dtype_of(out) == self.dtype and be.is_contiguous(out)
                and not be.may_share_memory(out, self.source)):
            return out
        return self.empty()

    def finish(self, result):
        """Return ``result`` (a device array of self.shape) in the caller's array kind."""
        be = self.backend
        if self.host_input:
            host = be.to_host(result)
            if self.output is not None:
                if host is not self.output:
                    self.output[...] = host
                return self.output
            return host
        if self.output is not None:
            if self.backend.dtype_of(self.output) != self.dtype:
                raise TypeError("device output must have the computation's dtype")
            if result is not self.output:
                be.copy(result, self.output)
            return self.output
        return result


def _run_passes(be, src, dst, dtype, passes, mode, cval, axis=None, angle=None, plane=None):
    """Apply ``passes`` (summed: the first writes, the rest accumulate) along an axis or direction.

    ``src`` and ``dst`` are distinct device arrays of the same shape; ``src`` is not modified.
    """
    shape = tuple(src.shape)
    if angle is None:
        view, line_axis = axis_view_shape(shape, axis)
        n = view[line_axis]
        s3, d3 = be.reshape(src, view), be.reshape(dst, view)
        for i, lp in enumerate(passes):
            be.recurse(s3, d3, line_axis, plan_pass(lp, n, mode, dtype), cval, accumulate=i > 0)
        return dst
    ya, xa = plane
    if (ya, xa) != (len(shape) - 2, len(shape) - 1):
        raise ValueError("oblique filtering needs the image plane on the last two axes of the "
                         "working array")
    height, width = shape[-2], shape[-1]
    batch = int(np.prod(shape[:-2], dtype=np.int64))
    _, reverse, _ = direction(angle)
    shear, unshear, lines, steps = oblique_maps(height, width, batch, float(angle), mode)
    rows_in = be.empty((batch, lines, steps), dtype)
    rows_out = be.empty((batch, lines, steps), dtype)
    be.gather(be.reshape(src, (-1,)), shear, cval, be.reshape(rows_in, (-1,)))
    for i, lp in enumerate(passes):
        lp = greens.LinePass(lp.sections, lp.tap, lp.reverse != reverse)
        be.recurse(rows_in, rows_out, 2, plan_pass(lp, steps, mode, dtype), cval, accumulate=i > 0)
    be.gather(be.reshape(rows_out, (-1,)), unshear, 0.0, be.reshape(dst, (-1,)))
    return dst


def _run_steps(be, data, dtype, steps, mode, cval, plane=None):
    """Apply ``steps`` in turn to the device array ``data`` (kept); the last result is returned.

    The strip executor and the Dask tasks run their in-block steps with this.
    """
    cur = data
    for passes, axis, angle in steps:
        nxt = be.empty(tuple(data.shape), dtype)
        _run_passes(be, cur, nxt, dtype, passes, mode, cval, axis=axis, angle=angle, plane=plane)
        cur = nxt
    return cur


def _is_axis_angle(angle):
    steep, _, gamma = direction(angle)
    return abs(gamma) < 1e-12


def _apply_sequence(job, program, mode, cval):
    """Run a :class:`Program` with ping-pong buffers; never touch the input.

    Host images whose working memory exceeds :func:`gfgpu.strips.get_working_set` are
    streamed through the device in strips (exact, :mod:`gfgpu.strips`).
    """
    from . import strips
    if job.host_input and strips.needs_strips(job):
        return strips.run_job(job, program, mode, cval)
    steps = program.steps
    if not steps:
        return job.finish(_copy_of_input(job))
    bufs = [job.empty() for _ in range(min(2, len(steps)))]
    bufs[(len(steps) - 1) % 2] = job.result_buffer()
    cur = job.data
    for i, (passes, axis, angle) in enumerate(steps):
        nxt = bufs[i % 2]
        _run_passes(job.backend, cur, nxt, job.dtype, passes, mode, cval, axis=axis, angle=angle,
                    plane=program.plane)
        cur = nxt
    return job.finish(cur)


def _copy_of_input(job):
    if job.host_input:
        return job.backend.asarray(np.array(job.backend.to_host(job.data), copy=True))
    out = job.empty()
    job.backend.copy(job.data, out)
    return out


def _plane_axes(axes, ndim):
    if axes is None:
        axes = (-2, -1)
    if len(axes) != 2:
        raise ValueError(f"axes must name two axes (rows, columns) of the image plane, got {axes!r}")
    ya, xa = (normalize_axis(a, ndim, "axes") for a in axes)
    if ya == xa:
        raise ValueError(f"axes must name two different axes, got {axes!r}")
    return ya, xa


def _direction_steps(ndim, passes, angle, axes):
    """(steps, plane) for filtering along ``angle`` in the plane ``axes``: an axis pass when aligned."""
    ya, xa = _plane_axes(axes, ndim)
    steep, reverse, gamma = direction(angle)
    if abs(gamma) < 1e-12:
        axis = ya if steep else xa
        flipped = [greens.LinePass(p.sections, p.tap, p.reverse != reverse) for p in passes]
        return [(flipped, axis, None)], None
    if (ya, xa) != (ndim - 2, ndim - 1):
        raise ValueError("oblique directions need the image plane on the last two axes; move the "
                         "channel axis first (e.g. numpy.moveaxis(image, -1, 0)) and pass axes=(-2, -1)")
    return [(passes, None, angle)], (ya, xa)


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
    cval = _finite_cval(cval)
    job = _Job(input, output, backend, device)
    program = green_filter_program(job.ndim, kernel, axis, angle=angle, axes=axes, anticausal=anticausal)
    return _apply_sequence(job, program, mode, cval)


def green_filter_program(ndim, kernel, axis=-1, *, angle=None, axes=(-2, -1), anticausal=False):
    """The :class:`Program` of :func:`green_filter` on ``ndim``-dimensional arrays."""
    if not isinstance(kernel, greens.GreenKernel):
        raise TypeError(f"kernel must be a gfgpu.greens kernel (UniformGreen, HomogeneousGreen, "
                        f"AffineGreen, AffineGreenApprox), got {type(kernel).__name__}")
    passes = [kernel.line_pass(reverse=bool(anticausal))]
    if angle is None:
        return Program([(passes, normalize_axis(axis, ndim), None)])
    return Program(*_direction_steps(ndim, passes, angle, axes))


def _per_axis(value, axes, name):
    if isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, str):
        vals = [float(v) for v in value]
        if len(vals) != len(axes):
            raise ValueError(f"{name} must have one value per axis ({len(axes)}), got {len(vals)}")
        return vals
    return [float(value)] * len(axes)


def _axes_list(axes, ndim):
    if axes is None:
        return list(range(ndim))
    axes = [normalize_axis(a, ndim, "axes") for a in np.atleast_1d(axes)]
    if len(set(axes)) != len(axes):
        raise ValueError(f"axes must not repeat, got {axes!r}")
    return axes


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
    closest to the cell integrals ``∫_{m-1/2}^{m+1/2} G_u`` (see ``greens._shift_coefficients``).

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> img = np.zeros((16, 64)); img[:, 10] = 1
    >>> out = gfgpu.shift(img, (0, 2.5), mode="constant", backend="numpy")
    >>> round(float((out[0] * np.arange(64)).sum()), 6)
    12.5
    """
    check_mode(mode)
    cval = _finite_cval(cval)
    job = _Job(input, output, backend, device)
    return _apply_sequence(job, shift_program(job.ndim, shift, axes), mode, cval)


def shift_program(ndim, shift, axes=None):
    """The :class:`Program` of :func:`shift` on ``ndim``-dimensional arrays."""
    ax = _axes_list(axes, ndim)
    amounts = _per_axis(shift, ax, "shift")
    return Program([([greens.shift_pass(s)], a, None) for a, s in zip(ax, amounts) if s != 0.0])


def derivative_program(ndim, u, axis=-1, axes=None, a=greens.EDGE_A, eta=greens.EDGE_ETA,
                       single_scale=False, projection_scale=1.0):
    """The :class:`Program` of :func:`derivative`: P along the other axes, then D along ``axis``."""
    ax = _axes_list(axes, ndim)
    d_axis = normalize_axis(axis, ndim)
    if d_axis not in ax:
        raise ValueError(f"axis {axis} must be one of axes {ax}")
    ratio = greens._positive("projection_scale", projection_scale)
    d_passes = list(greens.derivative_passes(u, a, eta, single_scale))
    p_passes = list(greens.projection_passes(greens._positive("u", u) * ratio, a, eta, single_scale))
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
    cval = _finite_cval(cval)
    job = _Job(input, output, backend, device)
    program = derivative_program(job.ndim, u, axis, axes, a, eta, single_scale, projection_scale)
    return _apply_sequence(job, program, mode, cval)


def projection(input, u, axis=-1, output=None, mode="reflect", cval=0.0, *, a=greens.EDGE_A,
               eta=greens.EDGE_ETA, single_scale=False, backend=None, device=None):
    """The projection function P = ∫D along one axis (the smoothing used along edges).

    Parameters as in :func:`derivative`; P is even with unit sum (two recursive passes).
    """
    check_mode(mode)
    cval = _finite_cval(cval)
    job = _Job(input, output, backend, device)
    return _apply_sequence(job, projection_program(job.ndim, u, axis, a, eta, single_scale), mode, cval)


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
    cval = _finite_cval(cval)
    job = _Job(input, None, backend, device)
    ax = _axes_list(axes, job.ndim)
    return tuple(_apply_sequence(job, derivative_program(job.ndim, u, d, ax, a, eta, single_scale, projection_scale),
                                 mode, cval) for d in ax)
