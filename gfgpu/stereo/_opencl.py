"""OpenCL launchers of the stereo matcher's fused kernels (``stereo.cl``), registered by
:mod:`gfgpu.stereo.kernels`; specifications: the ``*_reference`` functions of
:mod:`gfgpu.stereo.spec` (``SGM_PATHS`` gives the path order the SGM launch follows).
"""

from __future__ import annotations

import os

import numpy as np

from ..backends.opencl import launch as ocl
from . import band_plan
from . import spec as specs
from .band_plan import padded_samples
from .workspace import empty as _empty

#: largest penalty P1, P2 of the int16 path costs of stereo.cl (with :data:`_PATH_PAD`)
_PENALTY_MAX = 8191

#: path value of the samples out of view and of the padding lanes in stereo.cl's int16 sweeps
#: (``PAD_COST``), which cannot hold the specification's int32 ``PATH_UNDEFINED``: above every path
#: value in view (at most ``COST_MAX + _PENALTY_MAX``), and still an int16 plus a penalty
_PATH_PAD = 1 << 14


def _build(be, name, **defines):
    """The kernel ``name`` of stereo.cl, built with ``defines`` and the constants it shares with
    the specification (:mod:`gfgpu.stereo.spec`: ``NO_MATCH``, ``OUT_OF_VIEW``, ``COST_MAX``) and
    the int16 path value ``PAD_COST`` (:data:`_PATH_PAD`), read at each build: never retyped in
    the kernels (the same values every call: no build of their own)."""
    # INT_MIN (NO_MATCH) is no C literal: written as a difference, as limits.h does
    return ocl.kernel(be, __package__, "stereo.cl", name, np.float32, NO_MATCH=f"({specs.NO_MATCH + 1}-1)",
                      OUT_OF_VIEW=int(specs.OUT_OF_VIEW), COST_MAX=int(specs.COST_MAX), PAD_COST=_PATH_PAD,
                      **defines)


def _stereo_kernel(be, name, n_disp=None, cost_bytes=False, padded=False, steps=None, cost_shift=None):
    """A kernel of stereo.cl; those of the cost volumes are built for their ``n_disp`` (and
    with ``cost_bytes`` for byte costs, with ``padded`` for volumes of :func:`_padded`, the
    selection for its sub-pixel ``steps``, the block sums for their ``cost_shift``)."""
    defines = {} if n_disp is None else {"N_DISP": int(n_disp)}
    if steps is not None:
        defines["STEPS"] = int(steps)
    if cost_shift is not None:
        defines["COST_SHIFT"] = int(cost_shift)
    if cost_bytes:
        defines["COST_BYTES"] = 1
    if padded:
        defines["PADDED_PIXELS"] = 1
    return _build(be, name, **defines)


def _bucket_kernel(be, name, bucket):
    """A kernel of the CPU band matcher, built for ``bucket = (samples, nv_full, block, steps)``
    (:func:`gfgpu.stereo.band_plan.sample_bucket`): one program for the interleave, block_cost,
    sgm_band and select_disparity kernels of a bucket, window and sub-pixel step (one build
    instead of four)."""
    # looked up once per (backend, kernel, bucket): a call of the band matcher asks 4-5 times per
    # image and twice per band, and each lookup rebuilt its defines and queried the device (the
    # key also holds what the defines follow: the nibble switch, the host's flags and the
    # function that reads them, which tests replace)
    key = (be, name, tuple(bucket), USE_NIBBLES, _CPU_FLAGS, _host_cpu_defines)
    knl = _BUCKET_KERNELS.get(key)
    if knl is None:
        nb, nv_full, block, steps = bucket
        extra = {"NIBBLES": 1} if _nibbles(be, block) else {}
        knl = _BUCKET_KERNELS[key] = _build(be, name, N_DISP=int(nb), NV_FULL=int(nv_full), BLOCK=int(block),
                                            COST_SHIFT=specs.cost_shift(int(block)), STEPS=int(steps), COST_BYTES=1,
                                            PADDED_PIXELS=1, **_host_cpu_defines(be), **extra,
                                            **({"SELECT_LR": 1} if be.supports_float64 else {}))
    return knl


#: (backend, kernel name, bucket, what its defines follow) -> the kernel of :func:`_bucket_kernel`
_BUCKET_KERNELS = {}
os.register_at_fork(after_in_child=_BUCKET_KERNELS.clear)      # a forked child has contexts of its own


#: whether the CPU band matcher's 3 x 3 block costs run from nibble planes of the right census
#: codes (stereo.cl's census_nibbles and block_cost with -D NIBBLES) where the device allows
#: (:func:`_nibbles`); False: from the interleaved codes, as every other block (tests set it to
#: compare the two)
USE_NIBBLES = True


#: whether the band matcher's checkpointing sweeps over coarse bands (the costs recomputed) run in
#: stereo.cl's ckpt_cost, the block costs and the vertical path fused in one kernel going up (where
#: the costs come from nibble planes and 4 paths run; not the image's last coarse band, whose sweep
#: starts from zeros); False: block_cost, then sgm_band (tests and benchmarks compare the two)
FUSED_CHECKPOINTS = True


def _nibbles(be, block):
    """Whether the band matcher's cost runs from nibble planes: PoCL on an x86-64 host with AVX2
    (the kernel's vpshufb lookups) and a 3 x 3 block (byte sums without a shift).  Also with
    AVX512-VPOPCNTDQ: the interleaved-code kernel's vpopcntq counts 8 distances per instruction,
    but its 16-bit running sums took longer than the nibble kernel's whole work (1000 x 1500 x 383,
    alternated in one process: block_cost 238 -> 141 ms)."""
    if not USE_NIBBLES or int(block) != 3 or be.kind != "cpu":
        return False
    return _pocl_x86(be) and "avx2" in _host_cpu_flags()


def _nibble_row_bytes(w, steps):
    """Bytes per image row of census_nibbles' planes (stereo.cl's nib_row)."""
    plane = -(-w * steps // 32) * 32 + 32
    return 32 + 12 * plane


def _host_cpu_flags():
    """The host CPU's feature flags (``/proc/cpuinfo``; empty where it cannot be read)."""
    global _CPU_FLAGS
    if _CPU_FLAGS is None:
        try:
            with open("/proc/cpuinfo") as f:
                line = next((ln for ln in f if ln.startswith("flags")), "")
            _CPU_FLAGS = frozenset(line.split(":", 1)[1].split()) if ":" in line else frozenset()
        except OSError:
            _CPU_FLAGS = frozenset()
    return _CPU_FLAGS


_CPU_FLAGS = None


def _host_cpu_defines(be):
    """Build options of the CPU band matcher's kernels for instructions of the host CPU that an
    OpenCL CPU device (which runs on it) may not target by default: ``VPOPCNTQ`` where the CPU
    has AVX512-VPOPCNTDQ (PoCL 3.1 targets such a Zen 5 as skylake-avx512, without it)."""
    # the kernel names x86 clang builtins: only PoCL (clang) on an x86-64 host compiles them
    if be.kind == "cpu" and _pocl_x86(be) and "avx512_vpopcntdq" in _host_cpu_flags():
        return {"VPOPCNTQ": 1}
    return {}


def _pocl_x86(be):
    """Whether ``be``'s device is PoCL on an x86-64 host (whose clang compiles x86 builtins); asked
    once per device (its platform query and the host's machine name)."""
    import platform
    key = be.cl_device.int_ptr
    if key not in _POCL_X86:
        pocl = "portable computing language" in be.cl_device.platform.name.lower()
        _POCL_X86[key] = pocl and platform.machine() in ("x86_64", "AMD64")
    return _POCL_X86[key]


#: device (its ``int_ptr``) -> :func:`_pocl_x86`
_POCL_X86 = {}


def _padded(be, rows, w, n, dtype, workspace=None, name="padded"):
    """A (rows, w, n) volume of the band matcher with each pixel's samples padded to whole
    vectors, (rows, w, :func:`_padded_samples` (n)): every pixel starts on a vector boundary
    (``PADDED_PIXELS`` kernels; an odd n, the default sub-pixel ranges, otherwise misaligns
    half of the loads and stores)."""
    return _empty(be, workspace, name, (rows, w, padded_samples(n)), dtype)

def launch_census(be, image, out, plane, radius):
    image = ocl.plain(be, image, "image", np.float32)
    ocl.plain(be, out, "out", np.uint64, output=True)
    h, w = image.shape
    knl = _build(be, "census", CENSUS_RADIUS=int(radius))
    group = ocl.group_size(be)
    ocl.launch(be, knl, (-(-h // group) * group,), (group,), [image], [out],
               (image.data, out.data, np.int64(plane * h * w), np.int32(h), np.int32(w)))
    return out

def launch_planes(be, right, out, steps):
    right = ocl.plain(be, right, "right", np.float32)
    ocl.plain(be, out, "out", np.float32, output=True)
    h, w = right.shape
    if out.shape != (steps, h, w):
        raise ValueError(f"out must have shape {(steps, h, w)}, got {out.shape}")
    if not be.supports_float64:
        raise TypeError("the sub-pixel planes are float64 recursions: this OpenCL device has no cl_khr_fp64")
    if steps > 1 and right.size:
        ocl.copy_bytes(be, out, right, right.nbytes)          # plane 0: the view itself
        knl = _build(be, "shift_planes", SHIFT_PLANES=1)
        scratch = be.empty((h, w), np.float64)
        group = ocl.group_size(be)
        for f, (jobs, coef_d) in enumerate(_plane_coefficients(be, steps), start=1):
            items = -(-h // _SHIFT_ROWS)      # stereo.cl's SHIFT_ROWS rows per work-item
            ocl.launch(be, knl, (-(-items // group) * group,), (group,), [right, coef_d], [out, scratch],
                       (right.data, out.data, scratch.data, coef_d.data, np.int32(h), np.int32(w), np.int32(f),
                        np.int32(len(jobs))))
    elif right.size:
        ocl.copy_bytes(be, out, right, right.nbytes)
    return out


#: rows per work-item of stereo.cl's shift_planes (its SHIFT_ROWS)
_SHIFT_ROWS = 4


def _plane_coefficients(be, steps):
    """Per sub-pixel plane 1 .. steps - 1: its jobs and their recursions' coefficients on the
    device, (2, 9) float64, per job b0, b1, b2, a1, a2, zi0, zi1, n, reverse (stereo.cl's
    shift_row).  Constants of ``steps``: uploaded once per backend (each upload was a blocking
    write that waited for the queue)."""
    key = (be.context, int(steps))
    if key not in _PLANE_COEFFICIENTS:
        planes = []
        for jobs in specs.subpixel_jobs(steps):
            coef = np.zeros((2, 9))
            for q, job in enumerate(jobs):
                b, a, zi, n, reverse = specs.shift_recursion(*job)
                if n < 0:       # (no sub-pixel job has one: shifts by 0 .. 1 px, offsets 0 and 1)
                    raise ValueError(f"shift_planes extends rows at their start only, got n = {n}")
                coef[q] = (*b, a[1], a[2], *zi, n, reverse)
            planes.append((jobs, be.asarray(coef)))
        _PLANE_COEFFICIENTS[key] = planes
    return _PLANE_COEFFICIENTS[key]


#: (context, steps) -> [(jobs, device coefficients)] of :func:`_plane_coefficients`, uploaded once
_PLANE_COEFFICIENTS = {}
os.register_at_fork(after_in_child=_PLANE_COEFFICIENTS.clear)      # a forked child has contexts of its own


def launch_cost(be, census_left, census_right, out, first_step, steps, block):
    cl_ = ocl.plain(be, census_left, "census_left", np.uint64)
    cr = ocl.plain(be, census_right, "census_right", np.uint64)
    ocl.plain(be, out, "out", np.int16, output=True)
    h, w, n = out.shape
    if out.size == 0:
        return out
    # interleaved right codes -> uchar Hamming volume -> running block sums (stereo.cl)
    ri = _interleave(be, cr, h, w, steps, n)
    ham = None if be.kind == "cpu" else be.empty((h, w, n), np.uint8)
    _band_cost(be, cl_, ri, out, ham, 0, h, 0, h, w, n, first_step, steps, block)
    return out


def _interleave(be, cr, h, w, steps, n, workspace=None, bucket=None, row0=0, rows=None, ri=None):
    """The right census codes of image rows row0 .. row0 + rows - 1 (default: all) interleaved
    with their sub-pixel planes (stereo.cl's census_interleave) into ``ri`` (a new buffer of
    ``rows`` rows where None)."""
    rows = h if rows is None else int(rows)
    if bucket is not None and _nibbles(be, bucket[2]):
        # the bucket's block_cost reads nibble planes (census_nibbles) instead
        if ri is None:
            ri = _empty(be, workspace, "nibbles", (rows, _nibble_row_bytes(w, steps)), np.uint8)
        gsize, lsize = _row_grid(be, 1, rows)
        ocl.launch(be, _bucket_kernel(be, "census_nibbles", bucket), gsize, lsize, [cr], [ri],
                   (cr.data, ri.data, np.int32(h), np.int32(w), np.int32(steps), np.int32(row0)))
        return ri
    if ri is None:
        ri = _empty(be, workspace, "interleaved", (rows, w * steps), np.uint64)
    knl = _stereo_kernel(be, "census_interleave", n) if bucket is None else _bucket_kernel(be, "census_interleave",
                                                                                          bucket)
    gsize, lsize = _row_grid(be, w, rows)
    ocl.launch(be, knl, gsize, lsize, [cr], [ri],
               (cr.data, ri.data, np.int32(h), np.int32(w), np.int32(steps), np.int32(row0)))
    return ri


def _row_grid(be, w, rows):
    """Global and local size of the kernels that loop over a row's columns in steps of the
    global size 0 (census_interleave, left_right): a work-item per row on CPUs, per pixel on
    GPUs."""
    if be.kind == "cpu":
        return (1, rows), (1, 1)
    return (w, rows), None


def _cost_splits(be, w):
    """Column ranges of the CPU block_cost kernel: two per core (load balance), at least one
    column each."""
    return max(1, min(2 * be.cl_device.max_compute_units, w))


def _block_scratch(be, w, n, block, workspace=None):
    """The Hamming ring of the CPU block_cost kernel: per column range, ``block`` rows of its
    columns plus the block's margins, 16 * ceil(n / 16) bytes per column, then the column sums of
    the last ``block + 1`` columns entered (ushort; stereo.cl's COLSUM_SLOTS); and the slot width."""
    splits = _cost_splits(be, w)
    cols = -(-w // splits) + 2 * (block // 2)
    per_split = (block * cols + 2 * (block + 1)) * padded_samples(n)
    return _empty(be, workspace, "ring", (splits * per_split,), np.uint8), cols


def _band_cost(be, cl_, ri, out, ham, y0, rows, out_row0, h, w, n, first_step, steps, block, workspace=None,
               bucket=None, ri_row0=0):
    """The cost of image rows y0 .. y0 + rows - 1 into out[out_row0:out_row0 + rows], int16 or
    byte costs as ``out``'s dtype, n samples per pixel (``out`` of :func:`_padded` where its
    last axis is longer; CPUs: with ``bucket`` (:func:`_bucket_kernel`) the bucket's kernel, n an
    argument; ``ri`` holding image rows ri_row0, ...).  CPUs: straight from the census codes,
    each column range's rows in sequence (block_cost); GPUs: Hamming distances of the rows and their block margin into
    ``ham`` (one work-item per pixel), then block sums."""
    padded = out.shape[2] != n
    group = ocl.group_size(be)
    gsize = (-(-rows // group) * group,)
    if ham is None:
        if bucket is None:
            nb = n
            knl = _build(be, "block_cost", N_DISP=n, BLOCK=int(block), COST_SHIFT=specs.cost_shift(int(block)),
                         **({"COST_BYTES": 1} if out.dtype == np.uint8 else {}),
                         **({"PADDED_PIXELS": 1} if padded else {}))
        else:
            nb = bucket[0]
            knl = _bucket_kernel(be, "block_cost", bucket)
        splits = _cost_splits(be, w)
        scratch, cols = _block_scratch(be, w, nb, block, workspace)
        ocl.launch(be, knl, (splits,), (1,), [cl_, ri], [out, scratch],
                   (cl_.data, ri.data, out.data, scratch.data, np.int32(h), np.int32(w), np.int32(first_step),
                    np.int32(steps), np.int32(y0), np.int32(rows), np.int32(out_row0), np.int32(splits),
                    np.int32(cols), np.int32(n), np.int32(ri_row0)))
        return
    if padded:
        raise ValueError("padded volumes are the CPU band matcher's")
    r = block // 2
    ya, yb = max(0, y0 - r), min(h, y0 + rows + r)
    ocl.launch(be, _stereo_kernel(be, "census_hamming", n), (w, yb - ya), None, [cl_, ri], [ham],
               (cl_.data, ri.data, ham.data, np.int32(h), np.int32(w), np.int32(first_step),
                np.int32(steps), np.int32(ya)))
    knl = _stereo_kernel(be, "block_sum", n, cost_bytes=out.dtype == np.uint8, cost_shift=specs.cost_shift(block))
    ocl.launch(be, knl, gsize, (group,), [ham], [out],
               (ham.data, out.data, np.int32(h), np.int32(w), np.int32(block), np.int32(first_step),
                np.int32(steps), np.int32(y0), np.int32(rows), np.int32(ya), np.int32(out_row0)))


def launch_sgm(be, cost, out, p1, p2, paths):
    cost = ocl.plain(be, cost, "cost", np.int16)
    ocl.plain(be, out, "out", np.int16, output=True)
    h, w, n = cost.shape
    if cost.size == 0:
        return out
    if not (0 <= p1 <= _PENALTY_MAX and 0 <= p2 <= _PENALTY_MAX):
        raise ValueError(f"p1 and p2 must be 0..{_PENALTY_MAX} (int16 path costs), got p1={p1}, p2={p2}")
    knl = _stereo_kernel(be, "sgm_line_pair", n)
    group = ocl.group_size(be)   # GPU: a warp's multiple
    # each launch sweeps a direction of gfgpu.stereo.spec.SGM_PATHS and its opposite
    for i, (dy, dx) in enumerate(((0, 1), (1, 0), (1, 1), (1, -1))[:paths // 2]):
        count = w if dx == 0 else h if dy == 0 else h + w - 1
        ocl.launch(be, knl, (-(-count // group) * group,), (group,), [cost], [out],
                     (cost.data, out.data, np.int32(h), np.int32(w), np.int32(dy), np.int32(dx),
                      np.int16(p1), np.int16(p2), np.int32(i > 0)))
    return out

def launch_select(be, aggregated, disp, disp_right, margin, d_min, steps, uniqueness):
    agg = ocl.plain(be, aggregated, "aggregated", np.int16)
    for a, name, dt in ((disp, "disp", np.float32), (disp_right, "disp_right", np.int32),
                        (margin, "margin", np.float32)):
        ocl.plain(be, a, name, dt, output=True)
    h, w, n = agg.shape
    if agg.size == 0:
        return disp, disp_right, margin
    if n > 32767:
        raise ValueError(f"aggregated must have at most 32767 disparity samples (int16 lane "
                         f"indices in select_disparity), got {n}")
    _select(be, agg, None, disp, disp_right, margin, 0, h, w, n, d_min, steps, uniqueness)
    return disp, disp_right, margin


def _select(be, agg, agg2, disp, disp_right, margin, y0, rows, w, n, d_min, steps, uniqueness, bucket=None,
            lr_tol=0.0):
    """Winners of image rows y0 .. y0 + rows - 1 from agg[:rows] (+ agg2[:rows], whose rows are
    stored right to left as sgm_band's up sums), n samples per pixel (volumes of
    :func:`_padded` where their last axis is longer; ``bucket`` as for :func:`_band_cost`, whose
    kernel checks each row left against right where ``lr_tol`` > 0: :func:`_fused_tolerance`)."""
    padded = agg.shape[2] != n
    if not 1 <= steps <= 4:
        raise ValueError(f"steps must be 1..4 (select_disparity's build options), got {steps}")
    group = ocl.group_size(be)
    second = agg if agg2 is None else agg2
    if bucket is None:
        knl = _stereo_kernel(be, "select_disparity", n, padded=padded, steps=steps)
    else:
        knl = _bucket_kernel(be, "select_disparity", bucket)
    ocl.launch(be, knl, (-(-rows // group) * group,), (group,), [agg, second], [disp, disp_right, margin],
               _select_args(agg, second, disp, disp_right, margin, y0, rows, w, n, d_min, steps, uniqueness,
                            agg2 is not None, lr_tol))


def _select_args(agg, second, disp, disp_right, margin, y0, rows, w, n, d_min, steps, uniqueness, two, lr_tol=0.0):
    """The arguments of select_disparity (:func:`_select`); the band's (``rows``, ``y0``) at
    indices 5 and 11."""
    return (agg.data, second.data, disp.data, disp_right.data, margin.data, np.int32(rows), np.int32(w),
            np.int32(d_min), np.int32(steps), np.int32(uniqueness), np.int32(two), np.int32(y0), np.int32(n),
            np.float32(lr_tol))


def _fused_tolerance(be, tol):
    """The tolerance the band matcher's selection checks its rows left against right with
    (stereo.cl's select_disparity with -D SELECT_LR, built where the device has fp64), or None
    where it cannot: no ``tol``, no fp64, or a ``tol`` that a float32 argument does not hold
    exactly (the check then runs as the left_right kernel after the matcher)."""
    # (the range test first: a float32 cast of a larger tolerance overflows with a RuntimeWarning)
    if tol is None or not be.supports_float64 or not 0 < tol <= float(np.finfo(np.float32).max):
        return None
    if float(np.float32(tol)) != float(tol):
        return None
    return float(tol)


def _sgm_state(be, w, n, workspace=None):
    """The band sweeps' path states (2 work-items x 5 rows of w + 2 cells) and their minima."""
    return (_empty(be, workspace, "state", (2, 5, 16 + (w + 2) * (padded_samples(n) + 16)), np.int16),
            _empty(be, workspace, "state_min", (2, 4, w + 2), np.int16))


def _checkpoints(be, w, n, paths, slots, workspace=None):
    """``slots`` checkpoints of the up sweep's vertical (and diagonal) states, laid out as its
    state rows (``ck_rows`` of them: 1 for 4 paths, 4 for 8) and minima rows, with their guard
    lanes and guard cells written (stereo.cl's sgm_guards; sweeps never write them)."""
    ck_rows = 4 if paths == 8 else 1
    slots = max(int(slots), 1)
    ckpt = _empty(be, workspace, "checkpoints", (slots * ck_rows, 16 + (w + 2) * (padded_samples(n) + 16)), np.int16)
    ckpt_min = _empty(be, workspace, "checkpoint_minima", (slots * ck_rows, w + 2), np.int16)
    return ckpt, ckpt_min, ck_rows


def _band_sweep_args(be, cost, down, up, state, state_min, bound, ckpt, y0, rows, cost_row0, h, w, n, p1, p2, paths,
                     init, active, view, write_up=True, bucket=None, src=-1, dst=-1, chain=0):
    """The kernel and arguments of one launch of sgm_band (:func:`_band_sweeps`); the band's
    arguments (``y0``, ``rows``, ``init``, ``active``, ``write_up``, ``cost_row0``, ``split``,
    ``src``, ``dst``, ``chain``) at :data:`_SWEEP_BAND_ARGS`; ``ckpt`` from :func:`_checkpoints`."""
    nb = n if bucket is None else bucket[0]
    # a checkpointing sweep of 4 paths advances the vertical path only: column-local, so
    # both work-items take half of the columns each; not the sweep's first band, whose state
    # one work-item initialises (a cell's guard lanes are read from the neighbouring column)
    split = not write_up and paths == 4 and w >= 2 and not init
    knl = (_stereo_kernel(be, "sgm_band", n, cost_bytes=True, padded=True) if bucket is None
           else _bucket_kernel(be, "sgm_band", bucket))
    return knl, (cost.data, down.data, up.data, state.data, state_min.data, np.int32(h), np.int32(w),
                 np.int32(y0), np.int32(rows), np.int16(p1), np.int16(p2), np.int32(paths == 8),
                 np.int32(init), np.int32(active), np.int32(write_up), np.int32(cost_row0), np.int32(split),
                 np.int32(view[0] // 2), np.int32(view[1]), np.int32(view[2]),
                 np.int32(max(1, band_plan.TILE_BYTES // (2 * (padded_samples(nb) + 16)))), bound.data, np.int32(n),
                 ckpt[0].data, ckpt[1].data, np.int32(ckpt[2]), np.int32(src), np.int32(dst), np.int32(chain))


#: positions of sgm_band's per-band arguments in :func:`_band_sweep_args`
_SWEEP_BAND_ARGS = (7, 8, 12, 13, 14, 15, 16, 26, 27, 28)


def _band_sweeps(be, cost, down, up, state, state_min, bound, ckpt, y0, rows, cost_row0, h, w, n, p1, p2, paths,
                 init, active, view, write_up=True, bucket=None, src=-1, dst=-1, chain=0):
    """One launch of sgm_band on volumes of :func:`_padded` with n samples per pixel; ``view`` =
    (block, first_step, steps): which samples are in view; ``bound``: the horizontal paths'
    states at the column tiles' edges; the up sweep's vertical states read from region ``src``
    and written to region ``dst`` (-1: its own rows of ``state``; else a slot of ``ckpt``,
    :func:`_checkpoints`); ``chain`` > 0 (a checkpointing sweep into slots): the rows in groups
    of ``chain`` from the top, group g written to slot ``dst + g`` and starting from slot
    ``dst + g + 1`` (the last group from ``src``); ``bucket`` as for :func:`_band_cost`."""
    knl, args = _band_sweep_args(be, cost, down, up, state, state_min, bound, ckpt, y0, rows, cost_row0, h, w, n,
                                 p1, p2, paths, init, active, view, write_up, bucket, src, dst, chain)
    ocl.launch(be, knl, (2,), (1,), [cost], [down, up, state, state_min, bound, ckpt[0], ckpt[1]], args)


def launch_match(be, census_left, census_right, disp, disp_right, margin, first_step, n_disp, steps, block,
                 p1, p2, paths, uniqueness, budget=None, workspace=None, left_right=None, speckles=None):
    cl_ = ocl.plain(be, census_left, "census_left", np.uint64)
    cr = ocl.plain(be, census_right, "census_right", np.uint64)
    for a, name, dt in ((disp, "disp", np.float32), (disp_right, "disp_right", np.int32),
                        (margin, "margin", np.float32)):
        ocl.plain(be, a, name, dt, output=True)
    h, w = disp.shape
    n = int(n_disp)
    if not (0 <= p1 <= _PENALTY_MAX and 0 <= p2 <= _PENALTY_MAX):
        raise ValueError(f"p1 and p2 must be 0..{_PENALTY_MAX} (int16 path costs), got p1={p1}, p2={p2}")
    if not 1 <= steps <= 4:
        raise ValueError(f"steps must be 1..4 (select_disparity's build options), got {steps}")
    if speckles is not None and be.kind != "cpu":
        # (a union-find on two work-items: a GPU would run it on two of its threads)
        raise ValueError(f"speckles runs on CPU devices only, got a {be.kind} device")
    if be.kind != "cpu":
        # GPUs: a work-group per line with the samples across its work-items, a uint8 cost and
        # one int16 sum volume (_opencl_groups.py; disparity() checks the device's memory before
        # allocating)
        from . import _opencl_groups
        _opencl_groups.launch_match(be, cl_, cr, disp, disp_right, margin, first_step, n, steps, block,
                                    p1, p2, paths, uniqueness, workspace)
        if left_right is not None:
            launch_left_right(be, disp, disp_right, margin, steps, left_right)
        return disp, disp_right, margin
    # CPUs: bands of k rows through the two sweeps (one per core).  The up sweep's state at
    # each band's top is kept from a first, checkpointing up sweep, and each band's up sums are
    # recomputed from its checkpoint: O(k W D + (H / k) W D) for the sums instead of (H, W, D)
    # volumes.  The byte costs of the whole image are kept between the two sweeps where they fit
    # band_plan.KEEP_BYTES and ``budget``; else the image runs in coarse bands of K rows
    # (band_plan.match_plan): the first sweep keeps the up state at each coarse band's top only,
    # and each coarse band computes its costs again, sweeps up through them once more to keep the
    # state at its fine bands' tops, then runs its fine bands (O(K W D + (H / K + K / k) W D)).
    # left_right (a tolerance): the maps come back checked, by the selection of each row where it can
    lr_fused = _fused_tolerance(be, left_right)
    plan = band_plan.match_plan(h, w, n, paths, block, budget)
    k, keep = plan.rows, plan.keep
    # one call's buffers are made once even without the caller's workspace (the cost kernel's
    # ring was allocated at each of its launches: 55 x 1.7 MB of fresh pages at 1000 x 1500)
    workspace = {} if workspace is None else workspace
    # the kernels are built for the bucket of n (nb samples, the rest padding), n an argument: a
    # new range within a built bucket builds nothing
    nb, nv_full = band_plan.sample_bucket(n)
    bucket = (nb, nv_full, block, steps)
    coarse = h if keep else plan.coarse          # rows of a coarse band (the whole image: one)
    # the interleaved right codes: of the whole image where the costs are kept, else of a coarse
    # band and its block margin, interleaved before each computation of its costs
    r = block // 2
    if keep:
        ri = _interleave(be, cr, h, w, steps, nb, workspace, bucket)
    elif _nibbles(be, block):
        ri = _empty(be, workspace, "nibbles", (min(h, coarse + 2 * r), _nibble_row_bytes(w, steps)), np.uint8)
    else:
        ri = _empty(be, workspace, "interleaved", (min(h, coarse + 2 * r), w * steps), np.uint64)
    cost = _padded(be, coarse, w, nb, np.uint8, workspace, "cost")
    down = _padded(be, k, w, nb, np.int16, workspace, "down")
    up = _padded(be, k, w, nb, np.int16, workspace, "up")
    state, state_min = _sgm_state(be, w, nb, workspace)
    bound = _empty(be, workspace, "bound", (2, max(k, coarse if not keep else k), nb + 1), np.int16)
    view = (block, first_step, steps)
    coarse_bands = [(y0, min(coarse, h - y0)) for y0 in range(0, h, coarse)]
    per_coarse = -(-coarse // k)                 # fine bands of a coarse band
    # the up sweep's states at band tops: slots 0 .. n_top - 1 at the tops of (coarse) bands
    # 1 .. last, then the fine bands' of the coarse band being run (sgm_band's regions: a sweep
    # reads one slot and writes the next, a band's up sweep runs in its slot; no copies)
    step = k if keep else coarse
    n_top = -(-h // step) - 1
    n_fine = 0 if keep else per_coarse - 1
    ckpt = _checkpoints(be, w, nb, paths, n_top + n_fine, workspace)
    if n_top + n_fine:
        # (one band, every image up to band_plan.WHOLE_BYTES: its sweeps read and write no slot)
        ocl.launch(be, _bucket_kernel(be, "sgm_guards", bucket), (ckpt[0].shape[0],), (1,), [], [ckpt[0], ckpt[1]],
                   (ckpt[0].data, ckpt[1].data, np.int32(w), np.int32(ckpt[0].shape[0])))

    def costs(y0, rows):
        ya = 0
        if not keep:
            ya, yb = max(0, y0 - r), min(h, y0 + rows + r)
            _interleave(be, cr, h, w, steps, nb, bucket=bucket, row0=ya, rows=yb - ya, ri=ri)
        _band_cost(be, cl_, ri, cost, None, y0, rows, 0, h, w, n, first_step, steps, block, workspace, bucket,
                   ri_row0=ya)

    # the band loop's launches with their arguments set once (ocl.PresetLaunch), where there is a
    # loop: one band (small images) launches each kernel once, cheaper than making its own kernel
    if h > k:
        knl, args = _band_sweep_args(be, cost, down, up, state, state_min, bound, ckpt, 0, 1, 0, h, w, n, p1, p2,
                                     paths, 0, 0, view, True, bucket)
        sweep_launch = ocl.PresetLaunch(be, knl, [cost], [down, up, state, state_min, bound, ckpt[0], ckpt[1]],
                                        args)
        select_launch = ocl.PresetLaunch(be, _bucket_kernel(be, "select_disparity", bucket), [down, up],
                                      [disp, disp_right, margin],
                                      _select_args(down, up, disp, disp_right, margin, 0, 1, w, n,
                                                   first_step // steps, steps, uniqueness, True, lr_fused or 0.0))

    def sweep(y0, rows, row0, init, active, write_up=True, src=-1, dst=-1, chain=0):
        """Both sweeps (``active`` 3) or the up sweep alone (2) of a band; the up sweep's states
        from slot ``src`` to slot ``dst`` (-1: the state's own rows; ``chain``: to the slots
        ``dst``, ``dst + 1``, ... of each ``chain`` rows from the top, :func:`_band_sweeps`)."""
        if h <= k:
            _band_sweeps(be, cost, down, up, state, state_min, bound, ckpt, y0, rows, row0, h, w, n, p1, p2,
                         paths, init=init, active=active, view=view, write_up=write_up, bucket=bucket, src=src,
                         dst=dst, chain=chain)
            return
        split = not write_up and paths == 4 and w >= 2 and not init      # as _band_sweep_args
        values = (y0, rows, init, active, int(write_up), row0, int(split), src, dst, chain)
        sweep_launch((2,), (1,), {i: np.int32(v) for i, v in zip(_SWEEP_BAND_ARGS, values)})

    def select(y0, rows):
        if h <= k:
            _select(be, down, up, disp, disp_right, margin, y0, rows, w, n, first_step // steps, steps,
                    uniqueness, bucket, lr_fused or 0.0)
            return
        select_launch((rows,), (1,), {5: np.int32(rows), 11: np.int32(y0)})

    # with the costs recomputed, 4 paths and nibble-plane costs, a coarse band's block costs and its
    # checkpointing vertical path run in one kernel going up (ckpt_cost): pass 1 writes no cost band
    # (1000 x 1500 x 383: 20 MB per coarse band, written and read again), pass 2 reads the costs
    # it stores while they are in L1 (block_cost + sgm_band 490 -> 340 ms, each launch waited for)
    fused = FUSED_CHECKPOINTS and not keep and paths == 4 and _nibbles(be, block)

    def fused_checkpoint(y0, rows, src, dst, store=False, v_rows=None, chain=0):
        """ckpt_cost on image rows y0 .. y0 + rows - 1: their costs (into ``cost`` where ``store``)
        and the vertical path of the bottom ``v_rows`` (default all) from slot ``src`` into slot
        ``dst`` (``chain``: the slots dst, dst + 1, ... of each ``chain`` rows).  Never from zeros:
        the image's last rows run sgm_band, whose init also sets the up sweep's own state rows."""
        ya, yb = max(0, y0 - r), min(h, y0 + rows + r)
        _interleave(be, cr, h, w, steps, nb, bucket=bucket, row0=ya, rows=yb - ya, ri=ri)
        splits = _cost_splits(be, w)
        scratch, cols = _block_scratch(be, w, nb, block, workspace)
        v_rows = rows if v_rows is None else v_rows
        ocl.launch(be, _bucket_kernel(be, "ckpt_cost", bucket), (splits,), (1,), [cl_, ri],
                   [scratch, ckpt[0], ckpt[1]] + ([cost] if store else []),
                   (cl_.data, ri.data, scratch.data, ckpt[0].data, ckpt[1].data, np.int32(h), np.int32(w),
                    np.int32(first_step), np.int32(steps), np.int32(y0), np.int32(rows), np.int32(splits),
                    np.int32(cols), np.int32(n), np.int32(ya), np.int16(p1), np.int16(p2), np.int32(src),
                    np.int32(dst), cost.data, np.int32(store), np.int32(0), np.int32(v_rows),
                    np.int32(chain if chain else v_rows)))

    if keep:     # the whole image's costs at once: one warm-up of the Hamming ring
        costs(0, h)
    # pass 1: up the image, writing the state at the top of (coarse) band b into slot b - 1: band
    # b's up sweep starts from slot b, the state after the first row of band b + 1 (the last
    # band: from zeros, in the state's own rows); with the costs kept, a coarse band is a band of k
    # rows, and the bands above the last one are swept in one launch (chained: each band's rows
    # into its slot; launches of 4 rows took about twice the time per row of 36-row ones)
    for b in range(n_top, 0, -1):
        y0 = b * step
        rows = min(step, h - y0)
        bottom = y0 + rows == h
        if keep and not bottom:
            sweep(step, y0 + rows - step, step, init=0, active=2, write_up=False, src=b, dst=0, chain=step)
            break
        if fused and not bottom:
            fused_checkpoint(y0, rows, b, b - 1)
            continue
        if not keep:
            costs(y0, rows)
        sweep(y0, rows, y0 if keep else 0, init=2 if bottom else 0, active=2, write_up=False,
              src=-1 if bottom else b, dst=b - 1)
    # pass 2: down the image, band by band: both sweeps of the band at once, then its winners
    for cb, (c0, crows) in enumerate(coarse_bands):
        bands = [(y0, min(k, c0 + crows - y0)) for y0 in range(c0, c0 + crows, k)]
        last_coarse = cb == len(coarse_bands) - 1
        # the slot the up sweep of this coarse band's last band starts from (-1: from zeros)
        below = -1 if last_coarse else cb
        if fused and len(bands) > 1 and not last_coarse:
            # the costs and the fine checkpoints below in one kernel going up
            fused_checkpoint(c0, crows, below, n_top, store=True, v_rows=crows - k, chain=k)
        elif not keep:
            costs(c0, crows)
            # the up state at the top of this coarse band's fine bands 1 .. last into fine slots
            # 0 .. last - 1 (n_top + f - 1), read from the coarse slot (not spent: the coarse
            # band's last fine band runs in it below); in one chained launch, but for the image's
            # last fine band, which starts from zeros (one work-item initialises the state)
            last_f, src = len(bands) - 1, below
            if last_coarse and last_f > 0:
                y0, rows = bands[last_f]
                sweep(y0, rows, y0 - c0, init=2, active=2, write_up=False, src=below, dst=n_top + last_f - 1)
                last_f, src = last_f - 1, n_top + last_f - 1
            if last_f > 0:
                y0, end = bands[1][0], sum(bands[last_f])
                sweep(y0, end - y0, y0 - c0, init=0, active=2, write_up=False, src=src, dst=n_top, chain=k)
        for f, (y0, rows) in enumerate(bands):
            last = y0 + rows == h
            if keep:
                slot = -1 if last else y0 // k
            else:
                slot = below if f == len(bands) - 1 else n_top + f
            sweep(y0, rows, y0 if keep else y0 - c0, init=(1 if y0 == 0 else 0) | (2 if last else 0), active=3,
                  src=slot, dst=slot)
            select(y0, rows)
    if left_right is not None and lr_fused is None:
        launch_left_right(be, disp, disp_right, margin, steps, left_right)
    if speckles is not None:
        # the right view's winners (not read again) are the union-find's scratch
        launch_speckles(be, disp, margin, disp_right, *speckles)
    return disp, disp_right, margin


def launch_left_right(be, disp, disp_right, margin, steps, tol):
    for a, name, dt in ((disp, "disp", np.float32), (disp_right, "disp_right", np.int32),
                        (margin, "margin", np.float32)):
        ocl.plain(be, a, name, dt, output=True)
    h, w = disp.shape
    if disp.size == 0:
        return disp, margin
    if not be.supports_float64:
        # no cl_khr_fp64: the float64 check on the host (ties must fall as the specification's)
        d, m = specs.left_right_reference(disp.get(), disp_right.get(), margin.get(), steps, tol)
        disp.set(d)
        margin.set(m)
        return disp, margin
    knl = _build(be, "left_right", LEFT_RIGHT=1)
    gsize, lsize = _row_grid(be, w, h)
    ocl.launch(be, knl, gsize, lsize, [disp_right], [disp, margin],
               (disp.data, disp_right.data, margin.data, np.int32(h), np.int32(w), np.int32(steps),
                np.float64(tol)))
    return disp, margin


def launch_sweep(be, state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius):
    ocl.plain(be, state, "state", np.float32, output=True)
    ls = ocl.plain(be, left_shifted, "left_shifted", np.float32)
    rs = ocl.plain(be, right_shifted, "right_shifted", np.float32)
    gl = ocl.plain(be, gain_left, "gain_left", np.float32)
    gr = ocl.plain(be, gain_right, "gain_right", np.float32)
    h, w = ls.shape
    ocl.launch(be, _stereo_kernel(be, "sweep_update"), (w, h), None, [ls, rs, gl, gr], [state],
                 (state.data, ls.data, rs.data, gl.data, gr.data, np.int32(h), np.int32(w),
                  np.int32(offset), np.float32(d), np.int32(radius)))
    return state


def launch_speckles(be, disp, margin, parent, max_size, max_diff):
    """The speckle filter of ``disp`` in place on a CPU device: bit for bit the map of
    :func:`gfgpu.stereo.postfilter.filter_speckles` and the confidence of
    :func:`~gfgpu.stereo.postfilter.apply_postfilter` (``margin`` 0 wherever the map is not finite).

    stereo.cl's union-find: two work-items label the two halves of the rows, one joins them at
    row ``h // 2``, a work-item per row marks the small regions.

    Parameters
    ----------
    disp : (H, W) float32 device array
        Disparities (px), NaN where invalid; filtered in place.
    margin : (H, W) float32 device array
        The confidence; set to 0 in place wherever the filtered map is not finite.
    parent : (H, W) int32 device array
        Scratch (overwritten: the union-find's trees).
    max_size : int
        Largest region (pixels) that is removed, >= 0 (0: only the confidence is set).
    max_diff : float
        Largest step (px) between 4-neighbours of one region, finite and >= 0 (compared in float64).

    Returns
    -------
    (disp, margin)

    Raises
    ------
    ValueError
        Shapes differ, ``max_size`` < 0, ``max_diff`` negative or not finite, or H W >= 2**31 - 1.
    TypeError
        An array of another dtype, or a device without ``cl_khr_fp64``.
    """
    for a, name, dt in ((disp, "disp", np.float32), (margin, "margin", np.float32), (parent, "parent", np.int32)):
        ocl.plain(be, a, name, dt, output=True)
    h, w = disp.shape
    if margin.shape != (h, w) or parent.shape != (h, w):
        raise ValueError(f"margin and parent must have disp's shape {(h, w)}, got {margin.shape} and {parent.shape}")
    if not be.supports_float64:
        raise TypeError("the speckle filter's joins are float64 differences: this OpenCL device has no cl_khr_fp64")
    if h * w >= 2**31 - 1:
        raise ValueError(f"the speckle filter's labels are int32: at most 2**31 - 2 pixels, got {h * w}")
    if int(max_size) != max_size or max_size < 0:
        raise ValueError(f"max_size must be an integer >= 0 pixels, got {max_size!r}")
    if not (np.isfinite(max_diff) and max_diff >= 0):
        raise ValueError(f"max_diff must be finite and >= 0 px, got {max_diff!r}")
    if disp.size == 0:
        return disp, margin
    # (a region has at most h w pixels: a larger size removes every region, as it does on the host)
    size = np.int32(min(int(max_size), h * w))
    diff = np.float64(max_diff)
    ocl.launch(be, _build(be, "speckle_label", SPECKLES=1), (2,), (1,), [disp], [parent],
               (disp.data, parent.data, np.int32(h), np.int32(w), diff))
    ocl.launch(be, _build(be, "speckle_seam", SPECKLES=1), (1,), (1,), [disp], [parent],
               (disp.data, parent.data, np.int32(h), np.int32(w), diff))
    ocl.launch(be, _build(be, "speckle_mark", SPECKLES=1), (h,), (1,), [parent], [disp, margin],
               (disp.data, margin.data, parent.data, np.int32(h), np.int32(w), size))
    return disp, margin
