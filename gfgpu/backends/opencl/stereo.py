"""OpenCL launchers of the stereo matcher's fused kernels (``stereo.cl``), registered by
:mod:`gfgpu.stereo.kernels`; specifications: the ``*_reference`` functions of
:mod:`gfgpu.backends.specs` (``SGM_PATHS`` gives the path order the SGM launch follows).
"""

from __future__ import annotations

import numpy as np


def _plain(be, a, name, dtype):
    """``a`` checked as this context's C-contiguous array of ``dtype`` without an offset
    (stereo.cl takes plain pointers); offset views are copied."""
    if not be.owns(a):
        raise TypeError(f"{name} must be a pyopencl.array.Array in the context of {be.device}, "
                        f"got {type(a).__name__}")
    if np.dtype(a.dtype) != np.dtype(dtype):
        raise TypeError(f"{name} must be {np.dtype(dtype)}, got {a.dtype}")
    return a if a.offset == 0 and a.flags.c_contiguous else a.copy()

def _stereo_kernel(be, name, n_disp=None):
    """A kernel of stereo.cl; those of the cost volumes are built for their ``n_disp``."""
    defines = {} if n_disp is None else {"N_DISP": int(n_disp)}
    return be._kernel(name, np.dtype(np.float32), source="stereo.cl", **defines)

def _check_written(a, name):
    if a.offset != 0 or not a.flags.c_contiguous:
        raise ValueError(f"{name} must be a C-contiguous array without offset")

def launch_census(be, image, out, plane, radius):
    image = _plain(be, image, "image", np.float32)
    _plain(be, out, "out", np.uint64)
    _check_written(out, "out")
    h, w = image.shape
    knl = be._kernel("census", np.dtype(np.float32), source="stereo.cl", CENSUS_RADIUS=int(radius))
    be._launch(knl, (w, h), None, [image], [out],
                 (image.data, out.data, np.int64(plane * h * w), np.int32(h), np.int32(w),
                  np.int32(radius)))
    return out

def launch_cost(be, census_left, census_right, out, first_step, steps, block):
    cl_ = _plain(be, census_left, "census_left", np.uint64)
    cr = _plain(be, census_right, "census_right", np.uint64)
    _plain(be, out, "out", np.int16)
    _check_written(out, "out")
    h, w, n = out.shape
    if out.size == 0:
        return out
    # interleaved right codes -> uchar Hamming volume -> running block sums (stereo.cl)
    ri = be.empty((h, w * steps), np.uint64)
    be._launch(_stereo_kernel(be, "census_interleave", n), (w, h), None, [cr], [ri],
                 (cr.data, ri.data, np.int32(h), np.int32(w), np.int32(steps)))
    ham = be.empty((h, w, n), np.uint8)
    be._launch(_stereo_kernel(be, "census_hamming", n), (w, h), None, [cl_, ri], [ham],
                 (cl_.data, ri.data, ham.data, np.int32(h), np.int32(w), np.int32(first_step),
                  np.int32(steps)))
    group = be._group()
    be._launch(_stereo_kernel(be, "block_sum", n), (-(-h // group) * group,), (group,), [ham], [out],
                 (ham.data, out.data, np.int32(h), np.int32(w), np.int32(block), np.int32(first_step),
                  np.int32(steps)))
    return out

def launch_sgm(be, cost, out, p1, p2, paths):
    cost = _plain(be, cost, "cost", np.int16)
    _plain(be, out, "out", np.int16)
    _check_written(out, "out")
    h, w, n = cost.shape
    if cost.size == 0:
        return out
    if not (0 <= p1 <= 8191 and 0 <= p2 <= 8191):
        raise ValueError(f"p1 and p2 must be 0..8191 (int16 path costs), got p1={p1}, p2={p2}")
    if be.kind == "cpu":
        # two sweeps over the image (one per core), the cost volume read once per sweep
        nv = -(-n // 16)
        state = be.empty((2, 5, 16 + (w + 2) * (nv * 16 + 16)), np.int16)
        state_min = be.empty((2, 4, w + 2), np.int16)
        back = be.empty((h, w, n), np.int16)
        be._launch(_stereo_kernel(be, "sgm_two_sweeps", n), (2,), (1,), [cost],
                     [out, back, state, state_min],
                     (cost.data, out.data, back.data, state.data, state_min.data, np.int32(h),
                      np.int32(w), np.int16(p1), np.int16(p2), np.int32(paths == 8)))
        group = be._group()
        be._launch(_stereo_kernel(be, "add_volume", n), (-(-h // group) * group,), (group,),
                     [back], [out], (out.data, back.data, np.int32(h), np.int32(w)))
        return out
    knl = _stereo_kernel(be, "sgm_line_pair", n)
    group = be._group()   # GPU: a warp's multiple
    # each launch sweeps a direction of gfgpu.backends.specs.SGM_PATHS and its opposite
    for i, (dy, dx) in enumerate(((0, 1), (1, 0), (1, 1), (1, -1))[:paths // 2]):
        count = w if dx == 0 else h if dy == 0 else h + w - 1
        be._launch(knl, (-(-count // group) * group,), (group,), [cost], [out],
                     (cost.data, out.data, np.int32(h), np.int32(w), np.int32(dy), np.int32(dx),
                      np.int16(p1), np.int16(p2), np.int32(i > 0)))
    return out

def launch_select(be, aggregated, disp, disp_right, margin, d_min, steps, uniqueness):
    agg = _plain(be, aggregated, "aggregated", np.int16)
    for a, name, dt in ((disp, "disp", np.float32), (disp_right, "disp_right", np.int32),
                        (margin, "margin", np.float32)):
        _plain(be, a, name, dt)
        _check_written(a, name)
    h, w, n = agg.shape
    if agg.size == 0:
        return disp, disp_right, margin
    if n > 32767:
        raise ValueError(f"aggregated must have at most 32767 disparity samples (int16 lane "
                         f"indices in select_disparity), got {n}")
    group = be._group()
    be._launch(_stereo_kernel(be, "select_disparity", n), (-(-h // group) * group,), (group,),
                 [agg], [disp, disp_right, margin],
                 (agg.data, disp.data, disp_right.data, margin.data, np.int32(h), np.int32(w),
                  np.int32(d_min), np.int32(steps), np.int32(uniqueness)))
    return disp, disp_right, margin

def launch_sweep(be, state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius):
    _plain(be, state, "state", np.float32)
    _check_written(state, "state")
    ls = _plain(be, left_shifted, "left_shifted", np.float32)
    rs = _plain(be, right_shifted, "right_shifted", np.float32)
    gl = _plain(be, gain_left, "gain_left", np.float32)
    gr = _plain(be, gain_right, "gain_right", np.float32)
    h, w = ls.shape
    be._launch(_stereo_kernel(be, "sweep_update"), (w, h), None, [ls, rs, gl, gr], [state],
                 (state.data, ls.data, rs.data, gl.data, gr.data, np.int32(h), np.int32(w),
                  np.int32(offset), np.float32(d), np.int32(radius)))
    return state
