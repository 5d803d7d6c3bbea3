"""Images larger than the device (or a working-set limit): exact processing in strips.

A host image whose working memory would exceed the *working set* is cut into strips along
its first axis and streamed through the device a strip at a time:

* steps along other axes (rows of a 2-D image, image planes of a stack) act within a
  strip: the strip holds whole lines;
* steps along the first axis cross the strips: their recursion state is carried from strip
  to strip exactly (:mod:`gfgpu._core.carry`), so the result equals the one-piece call within the
  dtype's rounding — no seams, no overlap, no truncation.

Steps along different axes commute, so a strip runs its in-strip steps first, then the
crossing ones.  Oblique directions of a 2-D image cross strips diagonally; they need the
whole image plane on the device (a clear error says so when it does not fit).

The working set (bytes) is, in order: :func:`set_working_set` / :func:`working_set`, the
environment variable ``GFGPU_WORKING_SET`` (e.g. ``"2G"``, ``"512M"``), else the backend's
default (half the memory of a GPU; unlimited on CPU devices, whose memory is the host's).

:func:`gfgpu.filter_npy` runs an operator from one ``.npy`` file to another with strips read
and written by offset (:class:`NpyStore`), so the process holds only the working set.
"""

from __future__ import annotations

import contextlib
import os
import re

import numpy as np

from . import carry
from .program import Program, run_steps
from .recursion import plan_pass
from .translation import decay_length, step_offset, window_index, without_offset

__all__ = ["set_working_set", "get_working_set", "working_set", "parse_bytes", "needs_strips",
           "require_whole_image", "run_job", "Strips", "ArrayStore", "NpyStore", "FiniteStore",
           "strip_rows"]

#: device buffers per strip sample: input, two ping-pong buffers, output, host copy
_BUFFERS_PER_SAMPLE = 5

_explicit = None


def parse_bytes(value, name="working_set"):
    """Bytes from an int or a string such as ``"512M"``, ``"2G"``, ``"1.5GB"`` (powers of 1024)."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        nbytes = int(value)
    elif isinstance(value, str):
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)(i?[bB])?\s*", value)
        if not m:
            raise ValueError(f"{name} must be a byte count such as 536870912, '512M' or '2G'; got {value!r}")
        nbytes = int(float(m.group(1)) * 1024 ** " KMGT".index((m.group(2) or " ").upper()))
    else:
        raise TypeError(f"{name} must be an int or a string such as '512M', got {type(value).__name__}")
    if nbytes <= 0:
        raise ValueError(f"{name} must be positive, got {value!r}")
    return nbytes


def set_working_set(nbytes):
    """Set the working-set limit (bytes, or a string like ``"2G"``); None restores the default."""
    global _explicit
    _explicit = None if nbytes is None else parse_bytes(nbytes)


def get_working_set(backend=None):
    """The working-set limit in bytes for ``backend`` (None: unlimited)."""
    if _explicit is not None:
        return _explicit
    env = os.environ.get("GFGPU_WORKING_SET")
    if env:
        return parse_bytes(env, "GFGPU_WORKING_SET")
    return None if backend is None else backend.memory_budget


@contextlib.contextmanager
def working_set(nbytes):
    """Context manager: operators inside use ``nbytes`` as the working-set limit.

    Examples
    --------
    >>> import numpy as np, gfgpu
    >>> img = np.random.default_rng(0).random((512, 256)).astype(np.float32)
    >>> with gfgpu.working_set("64K"):    # 512 kB image: processed in strips
    ...     a = gfgpu.shift(img, (3.5, -2), backend="numpy")
    >>> b = gfgpu.shift(img, (3.5, -2), backend="numpy")
    >>> bool(np.abs(a - b).max() < 1e-5)
    True
    """
    global _explicit
    saved = _explicit
    set_working_set(nbytes)
    try:
        yield
    finally:
        _explicit = saved


# --------------------------------------------------------------------------------------
# where strips are read from and written to
# --------------------------------------------------------------------------------------
class ArrayStore:
    """Strips of an in-memory (or memory-mapped) numpy array."""

    def __init__(self, array):
        self.array = array
        self.shape = tuple(array.shape)

    def read(self, r0, r1, dtype):
        return np.ascontiguousarray(self.array[r0:r1], dtype=dtype)

    def write(self, r0, r1, values):
        self.array[r0:r1] = values

    def sub(self, index):
        return ArrayStore(self.array[index])


class NpyStore:
    """Strips of a C-ordered ``.npy`` file, read and written by offset (nothing mapped)."""

    def __init__(self, fileobj, offset, shape, dtype):
        self.file, self.offset, self.shape, self.dtype = fileobj, offset, tuple(shape), np.dtype(dtype)
        self.row_bytes = int(np.prod(self.shape[1:], dtype=np.int64)) * self.dtype.itemsize

    @classmethod
    def open(cls, path):
        path = os.fspath(path)
        f = open(path, "rb")
        try:
            # the header only (nothing mapped: a memory cap applies to maps as well)
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                raise ValueError(f"format version {version} (re-save it with numpy.save)")
            offset = f.tell()
            if dtype.hasobject:
                raise ValueError("it holds Python objects, not numbers")
            if fortran and len(shape) > 1:
                raise ValueError("it is stored in Fortran order; strips need C order (re-save it "
                                 "with numpy.save(path, numpy.ascontiguousarray(a)))")
            need = offset + int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
            if os.fstat(f.fileno()).st_size < need:
                raise ValueError("it is truncated (shorter than its header says)")
        except (ValueError, OSError, EOFError) as exc:
            f.close()
            raise ValueError(f"{path!r} is not a usable .npy file: {exc}") from None
        return cls(f, offset, shape, dtype)

    @classmethod
    def create(cls, path, shape, dtype):
        f = open(path, "w+b")
        header = {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": False,
                  "shape": tuple(shape)}
        np.lib.format.write_array_header_2_0(f, header)
        store = cls(f, f.tell(), shape, dtype)
        f.truncate(store.offset + store.row_bytes * store.shape[0])
        return store

    def read(self, r0, r1, dtype):
        buf = np.empty((r1 - r0,) + self.shape[1:], self.dtype)
        self.file.seek(self.offset + r0 * self.row_bytes)
        view = memoryview(buf).cast("B")
        got = self.file.readinto(view)
        if got != view.nbytes:
            raise ValueError(f"{self.file.name!r} is truncated (rows {r0}..{r1} missing)")
        return np.ascontiguousarray(buf, dtype=dtype)

    def write(self, r0, r1, values):
        self.file.seek(self.offset + r0 * self.row_bytes)
        self.file.write(memoryview(np.ascontiguousarray(values, dtype=self.dtype)).cast("B"))

    def sub(self, index):
        return NpyStore(self.file, self.offset + index * self.row_bytes, self.shape[1:], self.dtype)

    def close(self):
        self.file.close()


# --------------------------------------------------------------------------------------
# the executor
# --------------------------------------------------------------------------------------
def _split(program, ndim):
    """(steps within a strip, steps across strips) of a program on ``ndim``-D arrays."""
    within, across = [], []
    for step in program.steps:
        passes, axis, angle = step
        if angle is not None and ndim <= 2:
            return None
        (across if angle is None and axis == 0 else within).append(step)
    return within, across


def _drop_first_axis(program):
    steps = [(p, None if a is None else a - 1, ang) for p, a, ang in program.steps]
    plane = None if program.plane is None else tuple(x - 1 for x in program.plane)
    return Program(steps, plane)


def needs_strips(job):
    """True when a host job's working memory exceeds the working set."""
    limit = get_working_set(job.backend)
    return limit is not None and _BUFFERS_PER_SAMPLE * job.nbytes > limit


def require_whole_image(job, what):
    """Raise a clear error when an operator that needs the whole image exceeds the working set."""
    if job.host_input and needs_strips(job):
        raise ValueError(f"{what} needs the whole image on the device: its working memory "
                         f"({_size_bytes(_BUFFERS_PER_SAMPLE * job.nbytes)}) exceeds the working set "
                         f"({_size_bytes(get_working_set(job.backend))}); raise it with "
                         f"gfgpu.set_working_set or GFGPU_WORKING_SET")


def strip_rows(shape, dtype, limit):
    row = int(np.prod(shape[1:], dtype=np.int64)) * np.dtype(dtype).itemsize
    return max(1, min(shape[0], limit // (_BUFFERS_PER_SAMPLE * row)))


class Strips:
    """Run a program over strips of ``src`` into ``dst`` on one backend."""

    def __init__(self, backend, dtype, mode, cval, progress=None):
        self.be, self.dtype, self.mode, self.cval = backend, np.dtype(dtype), mode, cval
        self.progress = progress

    def _within(self, host, steps, plane):
        """Apply in-strip steps to a host strip; return a device array."""
        return run_steps(self.be, self.be.host_view(host), self.dtype, steps, self.mode, self.cval, plane,
                         shape=host.shape)

    def _rows(self, store, r0, r1, steps, plane):
        if r1 <= r0:
            return np.zeros((0,) + store.shape[1:], self.dtype)
        host = store.read(r0, r1, self.dtype)
        return self.be.to_host(self._within(host, steps, plane)).reshape(host.shape) if steps else host

    def run(self, program, src, dst, limit):
        shape = src.shape
        split = _split(program, len(shape))
        if split is None and _BUFFERS_PER_SAMPLE * _nbytes(shape, self.dtype) <= limit:
            # oblique lines need the whole plane, and it fits: one piece
            dst.write(0, shape[0], self._rows(src, 0, shape[0], program.steps, program.plane))
            return
        if split is None:
            raise ValueError(f"oblique directions need the whole image plane on the device: the image "
                             f"({_size(shape, self.dtype)}) exceeds the working set ({_size_bytes(limit)}); "
                             f"raise it (gfgpu.set_working_set / GFGPU_WORKING_SET) or use an axis direction")
        within, across = split
        rows = strip_rows(shape, self.dtype, limit)
        if not across and rows == 1 and len(shape) > 2 and \
                _BUFFERS_PER_SAMPLE * _nbytes(shape[1:], self.dtype) > limit:
            # one plane of a stack is too big: recurse into the planes, strips within each
            inner = _drop_first_axis(program)
            for i in range(shape[0]):
                self.run(inner, src.sub(i), dst.sub(i), limit)
            return
        bounds = list(range(0, shape[0], rows)) + [shape[0]]
        if not across:
            for r0, r1 in self._bar(zip(bounds[:-1], bounds[1:]), len(bounds) - 1):
                dst.write(r0, r1, self._rows(src, r0, r1, within, program.plane))
            return
        for k, (passes, _, _) in enumerate(across):
            # the first crossing step reads the input (with the in-strip steps); later ones
            # read the previous result and rewrite it strip by strip (each strip is read
            # before it is written)
            store, steps = (src, within) if k == 0 else (dst, [])
            offset = step_offset(passes)
            if offset == 0:
                self._across(passes, store, dst, steps, program.plane, bounds, self.mode)
                continue
            if k > 0:   # it would read rows of dst that earlier strips have rewritten
                raise ValueError("a translated step along the first axis must be the first step across strips")
            self._translated(passes, offset, store, dst, steps, program.plane, rows)

    def _translated(self, passes, offset, src, dst, within, plane, rows):
        """A translated step along the first axis: the passes run on the translated, padded
        row window (:mod:`gfgpu._core.translation`), written back cropped."""
        n = src.shape[0]
        identity = len(passes) == 1 and passes[0].is_identity
        pad = 0 if identity else decay_length(passes, self.dtype)
        window = TranslatedStore(src, window_index(n, offset, pad, self.mode), self.cval)
        out = CroppedStore(dst, pad, n)
        bounds = list(range(0, n + 2 * pad, rows)) + [n + 2 * pad]
        if identity:
            for r0, r1 in self._bar(zip(bounds[:-1], bounds[1:]), len(bounds) - 1):
                out.write(r0, r1, self._rows(window, r0, r1, within, plane))
            return
        self._across([without_offset(lp) for lp in passes], window, out, within, plane, bounds, "nearest")

    def _across(self, passes, src, dst, within, plane, bounds, mode):
        n = src.shape[0]
        segs = [carry.segments(plan_pass(lp, n, mode, self.dtype), bounds, self.dtype) for lp in passes]
        ends = [[None] * len(s) for s in segs]
        initial = [0j] * len(segs)
        for p, seg_list in enumerate(segs):            # 1. end and boundary contributions
            for i, seg in enumerate(seg_list):
                ends[p][i] = carry.end_state(seg, carry.line_matrix(self._rows(src, *seg.tail_rows, within, plane), 0))
                if seg.boundary.shape[1] or seg.boundary_c.any():
                    head = carry.line_matrix(self._rows(src, *seg.head_rows, within, plane), 0)
                    initial[p] = initial[p] + carry.boundary_state(seg, head, self.cval)
        states = [carry.carry_scan(s, e, init) for s, e, init in zip(segs, ends, initial)]   # 2. scan
        be = self.be
        for i in self._bar(range(len(bounds) - 1), len(bounds) - 1):   # 3. strips
            r0, r1 = bounds[i], bounds[i + 1]
            # ``host`` must outlive the device work reading it: CPU devices read it in place
            host = src.read(r0, r1, self.dtype)
            x = self._within(host, within, plane)
            block = (r1 - r0,) + tuple(src.shape[1:])
            y = be.empty(block, self.dtype)
            carry.zero_state_pass(be, x, y, 0, [s[i] for s in segs], shape=block)
            out = be.to_host(y).reshape(block)
            for p in range(len(segs)):
                carry.add_correction(segs[p][i], out, states[p][i], 0)
            dst.write(r0, r1, out)

    def _bar(self, iterable, total):
        if not self.progress:
            return iterable
        from tqdm import tqdm
        return tqdm(iterable, total=total, desc=self.progress, unit="strip", disable=None, leave=False)


def _nbytes(shape, dtype):
    return int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize


def _size_bytes(n):
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024


def _size(shape, dtype):
    return _size_bytes(_nbytes(shape, dtype))


def run_job(job, program, mode, cval):
    """Run ``program`` on a host job in strips (called by the operators of :mod:`gfgpu.filters`)."""
    limit = get_working_set(job.backend)
    src = job.source                    # checked: job.scale_exp set beyond the range limit
    # strips are read after earlier strips are written: an output over the input (in place, a
    # shifted or reversed view, a memmap filtered into itself) would read results as input
    out = job.output
    own = out is None or np.may_share_memory(out, src)
    buf = np.empty(job.shape, job.dtype) if own else out
    source = ArrayStore(src)
    cval = job.scaled(cval)
    if job.scale_exp:
        source = ScaledStore(source, job.scale_exp)
    Strips(job.backend, job.dtype, mode, cval).run(program, source, ArrayStore(buf), limit)
    if job.scale_exp:
        with np.errstate(over="ignore"):
            np.ldexp(buf, -job.scale_exp, out=buf)
    if out is not None and own:
        out[...] = buf
        return out
    return buf


class ScaledStore:
    """Strips of ``store`` read as ``ldexp(strip, exp)`` (an input beyond the range limit,
    :mod:`gfgpu._core.magnitude`)."""

    def __init__(self, store, exp):
        self.store, self.exp, self.shape = store, exp, store.shape

    def read(self, r0, r1, dtype):
        return np.ldexp(self.store.read(r0, r1, dtype), self.exp, dtype=dtype)

    def sub(self, index):
        return ScaledStore(self.store.sub(index), self.exp)


class TranslatedStore:
    """Rows ``index[q]`` of ``store`` (``-1``: a row of ``cval``), read in runs of consecutive rows."""

    def __init__(self, store, index, cval):
        self.store, self.index, self.cval = store, np.asarray(index, np.int64), cval
        self.shape = (len(self.index),) + tuple(store.shape[1:])

    def read(self, r0, r1, dtype):
        idx = self.index[r0:r1]
        out = np.empty((len(idx),) + self.shape[1:], dtype)
        i = 0
        while i < len(idx):
            j = i + 1
            if idx[i] < 0:
                while j < len(idx) and idx[j] < 0:
                    j += 1
                out[i:j] = self.cval
            else:
                step = int(idx[j] - idx[i]) if j < len(idx) and idx[j] >= 0 else 1
                step = step if abs(step) == 1 else 1
                while j < len(idx) and idx[j] >= 0 and idx[j] - idx[j - 1] == step:
                    j += 1
                lo, hi = sorted((int(idx[i]), int(idx[j - 1])))
                rows = self.store.read(lo, hi + 1, dtype)
                out[i:j] = rows if step == 1 else rows[::-1]
            i = j
        return out

    def sub(self, index):
        return TranslatedStore(self.store.sub(index), self.index, self.cval)


class CroppedStore:
    """Writes rows ``[pad, pad + n)`` of a padded result into rows ``[0, n)`` of ``store``."""

    def __init__(self, store, pad, n):
        self.store, self.pad, self.n = store, pad, n
        self.shape = (n + 2 * pad,) + tuple(store.shape[1:])

    def write(self, r0, r1, values):
        lo, hi = max(r0, self.pad), min(r1, self.pad + self.n)
        if hi > lo:
            self.store.write(lo - self.pad, hi - self.pad, values[lo - r0:hi - r0])


class FiniteStore:
    """A store whose strips are checked for NaN/inf as they are read."""

    def __init__(self, store):
        self.store, self.shape = store, store.shape

    def read(self, r0, r1, dtype):
        out = self.store.read(r0, r1, dtype)
        if not np.isfinite(out).all():
            raise ValueError(f"input contains NaN or infinite values (rows {r0}..{r1})")
        return out

    def sub(self, index):
        return FiniteStore(self.store.sub(index))
