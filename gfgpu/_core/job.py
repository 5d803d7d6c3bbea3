"""One operator call: input validation, device placement, output handling and the run.

:class:`Job` turns the caller's ``input``/``output`` into device arrays on an already
resolved backend (``numpy in, numpy out``; a device array stays on its device) and
:func:`apply_program` runs a :class:`~gfgpu._core.program.Program` on it, in strips when a
host image exceeds the working set (:mod:`gfgpu._core.strips`).
"""

from __future__ import annotations

import numpy as np

from . import arrays, strips
from .magnitude import host_peak, range_limit, scale_exponent
from .program import is_checkable, is_translation, run_passes, run_passes_checked, run_translation_checked
from .validation import wide_integer, work_dtype

NONFINITE = "input contains NaN or infinite values"

__all__ = ["Job", "apply_program", "copy_of_input"]


def _is_float32(output):
    """``output`` names the float32 dtype (a dtype argument, not an array)."""
    if not isinstance(output, (type, np.dtype, str)):
        return False
    try:
        return np.dtype(output) == np.float32
    except TypeError:
        return False


class Job:
    """Input validation, device placement and output handling shared by every operator.

    ``backend`` is a resolved :class:`gfgpu.backends.Backend` (the caller applies the
    resolution rule with the input array, so that device arrays stay where they are).
    ``finite=True``: the caller has already checked that the input holds no NaN or infinity
    and lies within :func:`~gfgpu._core.magnitude.range_limit` (an application passing on its
    own validated, normalised image), so the check is not repeated.

    Magnitude: the input check also tests that every sample lies below the dtype's range
    limit (:mod:`gfgpu._core.magnitude`); an input beyond it (a float32 image near 1e38) is
    computed as ``ldexp(input, scale_exp)`` and :meth:`finish` scales the result back, both
    exact.  Operators that run kernels on :attr:`data` themselves pass their constant as
    :meth:`scaled` ``(cval)``; :func:`apply_program` does so itself.
    """

    def __init__(self, input, output, backend, min_ndim=1, finite=False):
        be = backend
        self.backend = be
        # a foreign array (torch, CuPy, JAX, any DLPack producer) is computed on as a numpy view
        # or as the backend's own device array, without a copy; results go back as its kind
        self.kind, self.like = arrays.kind_of(input), input
        if self.kind is not None:
            input = arrays.take(input, self.kind, be, "input")
        self.host_input = be.name == "numpy" or not be.owns(input)
        if self.host_input:
            library = type(input).__module__.split(".")[0]
            if library in ("pyopencl", "warp") and be.name == "numpy" or (library == "pyopencl" and not be.owns(input)):
                raise TypeError(f"input is a {library} array, which the {be.name} backend cannot read; use "
                                f"backend={'opencl' if library == 'pyopencl' else 'warp'!r} (or pass a numpy array)")
            arr = np.asarray(input)
            if arr.dtype == object:
                raise TypeError(f"input must be a numeric array, got {type(input).__name__} (no array protocol: numpy, "
                                f"__array__, __dlpack__ or __cuda_array_interface__, or a ragged sequence)")
        else:
            arr = input
        if arr.ndim < min_ndim:
            raise ValueError(f"input must have at least {min_ndim} dimension(s), got shape {arr.shape}")
        if arr.size == 0:
            raise ValueError(f"input is empty (shape {arr.shape})")
        self.shape = tuple(int(s) for s in arr.shape)
        self.ndim = len(self.shape)
        self.dtype = work_dtype(arr.dtype if self.host_input else be.dtype_of(arr))
        if wide_integer(arr.dtype if self.host_input else be.dtype_of(arr)) and _is_float32(output):
            self.dtype = np.dtype(np.float32)      # asked for: float32's rounding above 2**24 accepted
        if self.dtype == np.float64 and not be.supports_float64:
            if self.dtype != (arr.dtype if self.host_input else be.dtype_of(arr)):
                raise TypeError(f"input is {arr.dtype}, computed in float64 (float32 rounds integers above "
                                f"2**24), but {be!r} has no float64 support; pass output=numpy.float32 to "
                                f"accept float32's rounding, or choose another device")
            raise TypeError(f"input is float64 but {be!r} has no float64 support; pass a float32 "
                            f"array or choose another device (no silent downcast)")
        self.output = output
        self.scale_exp = 0          # the input is computed as ldexp(input, scale_exp): see settle()
        if output is not None and isinstance(output, (type, np.dtype, str)):
            try:
                out_dtype = np.dtype(output)
            except TypeError:
                raise TypeError(f"output must be an array or a float dtype, got {output!r}") from None
            out_dtype = np.dtype(out_dtype.type) if out_dtype.kind == "f" else out_dtype   # numpy's own dtype object
            if out_dtype not in (np.float32, np.float64):
                raise TypeError(f"output dtype must be float32 or float64, got {out_dtype}")
            if out_dtype.itemsize < self.dtype.itemsize:
                raise TypeError(f"output dtype {out_dtype} would downcast the {self.dtype} result")
            self.dtype = out_dtype
            self.output = None
        self.caller_output = self.output       # returned as it is: ``output=`` of any kind
        out_kind = arrays.kind_of(self.output)
        if out_kind is not None:
            self.output = arrays.take(self.output, out_kind, be, "output")
        if self.host_input:
            # the finite check runs before the input is first used: on the device that reads it,
            # or fused into the first pass (apply_program), one read of the image instead of two
            self._source = arr          # converted and placed on the device when first used
            self._data = None
            # integers hold no NaN or infinity; ``finite``: the caller checked the image
            self.check_pending = not finite and arr.dtype.kind not in "biu"
        else:
            dev_dtype = np.dtype(be.dtype_of(arr))
            if dev_dtype not in (np.float32, np.float64):
                raise TypeError(f"a device input must be float32 or float64 in native byte order, got {dev_dtype}; "
                                f"convert it on the device first (e.g. astype(numpy.float32))")
            if not be.is_contiguous(arr):   # a view (slice, step, transpose): copied on the device
                arr = be.contiguous(arr)
            if work_dtype(be.dtype_of(arr)) != self.dtype:
                raise TypeError(f"device input must be float32 or float64, got {be.dtype_of(arr)}")
            self._source = self._data = arr
            self.check_pending = False
            if not finite and not be.all_finite(arr):      # (a read-back: waits for the device)
                self.settle()
        if self.output is not None:
            self._check_output(self.output)

    @property
    def source(self):
        """The caller's input (host images: checked to be finite first), unscaled: a consumer
        of the source computes on ``ldexp(source, scale_exp)`` where :attr:`scale_exp` is set."""
        if self.check_pending:
            self.settle()
        return self._source

    @property
    def data(self):
        """The input as a device array of the work dtype (host images: uploaded on first use
        and checked to be finite), scaled by ``2**scale_exp`` where it lies beyond the range
        limit (:meth:`settle`)."""
        data = self.unchecked_data()
        if self.check_pending:
            if not self.backend.input_finite(self._source, data):
                self.settle()
                return self._data
            self.check_pending = False
        return data

    def settle(self, extra=0.0):
        """The input check's verdict made exact, once the fast check (finite and in range) has
        failed or not run: a non-finite sample raises; a peak ``max(max|input|, extra)`` at or
        beyond the range limit sets :attr:`scale_exp` and replaces the device input by the
        scaled copy (host images: on the host; device arrays: through the host, a rare path).
        ``extra``: a constant the passes read beside the image (``cval``)."""
        be = self.backend
        host = self._source if self.host_input else be.to_host(self._source)
        peak = host_peak(host)
        if not np.isfinite(peak):
            raise ValueError(NONFINITE)
        self.check_pending = False
        exp = scale_exponent(max(peak, abs(float(extra))), self.dtype)
        if exp == self.scale_exp:
            return
        self.scale_exp = exp
        scaled = np.ldexp(np.asarray(host), exp, dtype=self.dtype)
        if self.host_input:
            self._data = be.host_view(np.ascontiguousarray(scaled))
        else:
            self._data = be.asarray(np.ascontiguousarray(scaled))

    def scaled(self, value):
        """``value`` (a constant read beside the image: ``cval``) in the units of :attr:`data`;
        the input check runs first if it has not, with ``value`` counted in the peak."""
        value = float(value)
        if value == 0.0:     # nothing to scale: the image is not read here (refusals come first)
            return 0.0
        if self.check_pending or not abs(np.ldexp(value, self.scale_exp)) < range_limit(self.dtype):
            self.settle(value)
        return float(np.ldexp(value, self.scale_exp))

    def unchecked_data(self):
        """:attr:`data` without the finite check: the caller runs it, fused into a pass
        (:func:`apply_program`), before any result reaches the caller."""
        if self._data is None:
            self._data = self.backend.host_view(np.ascontiguousarray(self._source, dtype=self.dtype))
        return self._data

    @property
    def nbytes(self):
        return int(np.prod(self.shape, dtype=np.int64)) * self.dtype.itemsize

    def _check_output(self, output):
        if not (isinstance(output, np.ndarray) or (not self.host_input and self.backend.owns(output))):
            raise TypeError(f"output must be a numpy array, the input's kind of device array or a dtype "
                            f"(float32/float64), got {type(output).__name__}")
        if tuple(output.shape) != self.shape:
            raise ValueError(f"output must have the input's shape {self.shape}, got {tuple(output.shape)}")
        odt = np.dtype(output.dtype) if isinstance(output, np.ndarray) else self.backend.dtype_of(output)
        if isinstance(output, np.ndarray):
            if not output.flags.writeable:
                raise ValueError("output is read-only")
            # a non-native byte order (e.g. '>f4' from FITS) is written through numpy's conversion
            odt = odt.newbyteorder("=") if odt.kind == "f" else odt
        if odt not in (np.float32, np.float64):
            raise TypeError(f"output must be float32 or float64, got {odt}")
        if odt.itemsize < self.dtype.itemsize:
            raise TypeError(f"output dtype {odt} would downcast the {self.dtype} result")
        if (not isinstance(output, np.ndarray) and not self.backend.is_contiguous(output)
                and not self.backend.writes_views):
            raise ValueError(f"output is a non-contiguous view, which the {self.backend.name} backend cannot write; "
                             f"pass a contiguous array (or no output)")
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
                      and not np.may_share_memory(out, self._source))
            return be.host_result(self.shape, self.dtype, into=out) if direct else self.empty()
        if (out is not None and be.dtype_of(out) == self.dtype and be.is_contiguous(out)
                and not be.may_share_memory(out, self._source)):
            return out
        return self.empty()

    def finish(self, result):
        """Return ``result`` (a device array of self.shape) in the caller's array kind: the
        caller's ``output``, or a new array of the input's kind (numpy, the backend's device
        array, or the foreign kind: torch in, torch out, :mod:`gfgpu._core.arrays`)."""
        return self.deliver(self._finish_native(result))

    def deliver(self, result):
        """A finished ``result`` (a numpy array, a device array, or a tuple of them, already
        written into ``output`` if one was given) as the caller gets it: the caller's own
        ``output`` object, else ``result`` in the input's kind."""
        if self.output is not None:
            return self.caller_output
        return arrays.as_kind(result, self.kind, self.like)

    def _unscale_host(self, host):
        """``ldexp(host, -scale_exp)`` in place where it can be written (values beyond the
        dtype's range become inf, as numpy's float64 result cast to it)."""
        with np.errstate(over="ignore"):
            if host.flags.writeable:
                return np.ldexp(host, -self.scale_exp, out=host)
            return np.ldexp(host, -self.scale_exp, dtype=host.dtype)

    def _finish_native(self, result):
        be = self.backend
        if self.scale_exp and not self.host_input:    # the rare path: through the host
            result = be.asarray(np.ascontiguousarray(self._unscale_host(np.array(be.to_host(result)))))
        if self.host_input:
            host = be.to_host(result).reshape(self.shape)   # devices may fold leading axes
            if self.scale_exp:
                host = self._unscale_host(host)
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


def apply_program(job, program, mode, cval):
    """Run a :class:`~gfgpu._core.program.Program` with ping-pong buffers; never touch the input.

    Host images whose working memory exceeds the working set are streamed through the device
    in strips (exact, :mod:`gfgpu._core.strips`).
    """
    if job.host_input and strips.needs_strips(job):
        return job.deliver(strips.run_job(job, program, mode, cval))
    steps = program.steps
    if not steps:
        return job.finish(copy_of_input(job))
    # the last step writes the result buffer; a ping-pong partner only where there are two steps
    # or more (no temporary allocated to be dropped at once)
    last = (len(steps) - 1) % 2
    bufs = [None] * min(2, len(steps))
    bufs[last] = job.result_buffer()
    if len(bufs) == 2:
        bufs[1 - last] = job.empty()
    done = 0
    passes, axis, angle = steps[0]
    if cval and not abs(cval) < range_limit(job.dtype):
        job.scaled(cval)         # a constant beyond the range limit scales the job (rare)
    # the finite check fused into the first pass (a translation, or a recursion along an axis),
    # unless that pass writes the caller's own output array (which a non-finite input must leave
    # untouched): the first pass writes bufs[0], the result buffer whenever the number of steps is odd
    first_writes_result = (len(steps) - 1) % 2 == 0
    if job.check_pending and not (first_writes_result and job.output is not None):
        if is_translation(passes, angle):
            ok = run_translation_checked(job.backend, job.unchecked_data(), bufs[0], passes, mode, cval, axis,
                                         job.shape)
        elif is_checkable(passes, angle):
            ok = run_passes_checked(job.backend, job.unchecked_data(), bufs[0], job.dtype, passes, mode, cval,
                                    axis, job.shape)
        else:
            ok = None
        if ok is not None:
            if ok:
                job.check_pending = False
            else:
                # not finite, or beyond the range limit: the exact verdict; a scaled input runs
                # again from the first pass (the rare case pays it), else the pass stands
                job.settle(cval)
            done = 0 if job.scale_exp else 1
    cur = bufs[0] if done else job.data
    cval = job.scaled(cval)        # (the input is settled by now)
    for i, (passes, axis, angle) in enumerate(steps[done:], start=done):
        nxt = bufs[i % 2]
        run_passes(job.backend, cur, nxt, job.dtype, passes, mode, cval, axis=axis, angle=angle,
                   plane=program.plane, shape=job.shape)
        cur = nxt
    return job.finish(cur)


def copy_of_input(job):
    """A device copy of the job's input (the result of an empty program)."""
    if job.host_input:
        return job.backend.asarray(np.array(job.backend.to_host(job.data), copy=True))
    out = job.empty()
    job.backend.copy(job.data, out)
    return out
