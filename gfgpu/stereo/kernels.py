"""The fused kernels of the stereo matcher, registered with the backends.

Each is a :class:`~gfgpu.backends.fused.FusedKernel`: its numpy specification is in
:mod:`gfgpu.stereo.spec`, its launchers ``launch_<name>`` in this package's ``_numpy.py``,
``_warp.py`` and ``_opencl.py`` (with ``stereo.cl``), imported on first use so that registering
imports no device library.  Call as ``kernel(backend, *args)``.
"""

from __future__ import annotations

from ..backends.fused import register
from . import spec as specs

__all__ = ["census", "planes", "cost", "sgm", "select", "match", "left_right", "sweep"]


def _launchers(name):
    return {backend: f"{__package__}._{backend}:launch_{name}" for backend in ("numpy", "warp", "opencl")}


#: ``census(be, image, out, plane, radius)``: ``out[plane] = census_transform_reference(image, radius)``
#: (``image`` (H, W) float32, ``out`` (S, H, W) uint64 device arrays)
census = register("stereo.census", specs.census_transform_reference, **_launchers("census"))

#: ``planes(be, right, out, steps)``: ``out = subpixel_planes_reference(right, steps)``, the right
#: view's sub-pixel planes (``right`` (H, W) float32, scaled as ``disparity`` scales it; ``out``
#: (steps, H, W) float32; float64 recursions: the OpenCL kernel needs ``cl_khr_fp64``)
planes = register("stereo.planes", specs.subpixel_planes_reference, **_launchers("planes"))

#: ``cost(be, census_left, census_right, out, first_step, steps, block)``: ``out =
#: census_cost_reference(census_left[0], census_right, first_step, n_disp, steps, block)`` (block sums
#: shifted right by ``spec.cost_shift(block)`` bits, then saturated)
#: (``census_left`` (1, H, W), ``census_right`` (steps, H, W) uint64; ``out`` (H, W, D) int16)
cost = register("stereo.cost", specs.census_cost_reference, **_launchers("cost"))

#: ``sgm(be, cost, out, p1, p2, paths)``: ``out = sgm_aggregate_reference(cost, p1, p2, paths)``
sgm = register("stereo.sgm", specs.sgm_aggregate_reference, **_launchers("sgm"))

#: ``select(be, aggregated, disp, disp_right, margin, d_min, steps, uniqueness)``: the outputs of
#: ``select_disparity_reference`` written into ``disp`` (H, W) float32, ``disp_right`` (H, W) int32
#: and ``margin`` (H, W) float32
#: (aggregated costs below 32767, int16's largest value marking "no candidate"; the OpenCL kernel
#: is built for ``steps`` 1..4, as ``disparity``'s ``subpixel_steps``)
select = register("stereo.select", specs.select_disparity_reference, **_launchers("select"))

#: ``match(be, census_left, census_right, disp, disp_right, margin, first_step, n_disp, steps, block, p1,
#: p2, paths, uniqueness, budget)``: cost, aggregation and selection in one
#: (``semi_global_match_reference``; ``census_left`` (1, H, W), ``census_right`` (steps, H, W) uint64;
#: outputs as for ``select``; ``first_step`` a multiple of ``steps``); on CPUs the OpenCL launcher
#: streams bands of rows instead of holding (H, W, D) volumes, and keeps the byte costs of the whole
#: image only if that fits ``budget`` bytes (None: no limit); ``workspace=dict`` (keyword, Warp and
#: OpenCL) keeps the launcher's own buffers in that dict across calls (:class:`StereoMatcher`);
#: ``left_right=tol`` (keyword, OpenCL) returns the maps checked as ``left_right`` checks them (the
#: CPU band matcher in its selection, row by row); ``speckles=(max_size, max_diff)`` (keyword, OpenCL
#: CPU devices with fp64) returns the map speckle-filtered as ``postfilter.filter_speckles`` filters
#: it (bit for bit) and the confidence 0 wherever that map is NaN, ``disp_right`` overwritten
match = register("stereo.match", specs.semi_global_match_reference, **_launchers("match"))

#: ``left_right(be, disp, disp_right, margin, steps, tol)``: ``disp, margin =
#: left_right_reference(disp, disp_right, margin, steps, tol)`` in place on the maps of ``select`` /
#: ``match`` (device arrays; float64 arithmetic, so the OpenCL kernel needs ``cl_khr_fp64``, else
#: the check runs on the host)
left_right = register("stereo.left_right", specs.left_right_reference, **_launchers("left_right"))

#: ``sweep(be, state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius)``:
#: ``sweep_update_reference`` in place on device arrays (float32)
sweep = register("stereo.sweep", specs.sweep_update_reference, **_launchers("sweep"))
