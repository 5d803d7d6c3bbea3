"""numpy launchers of the stereo fused kernels: the specifications themselves, written into the outputs
(registered by :mod:`gfgpu.stereo.kernels`)."""

from __future__ import annotations

import numpy as np

from . import spec as specs


def launch_census(be, image, out, plane, radius):
    out[plane] = specs.census_transform_reference(image, radius)
    return out


def launch_planes(be, right, out, steps):
    # the host's batched recursions (bit for bit the specification's, which runs a row at a time)
    from .matching import subpixel_planes
    out[...] = subpixel_planes(np.asarray(right, np.float32), steps)
    return out


def launch_cost(be, census_left, census_right, out, first_step, steps, block):
    out[...] = specs.census_cost_reference(census_left[0], census_right, first_step, out.shape[2], steps,
                                           block)
    return out


def launch_sgm(be, cost, out, p1, p2, paths):
    out[...] = specs.sgm_aggregate_reference(cost, p1, p2, paths)
    return out


def launch_select(be, aggregated, disp, disp_right, margin, d_min, steps, uniqueness):
    disp[...], disp_right[...], margin[...] = specs.select_disparity_reference(aggregated, d_min, steps,
                                                                               uniqueness)
    return disp, disp_right, margin


def launch_match(be, census_left, census_right, disp, disp_right, margin, first_step, n_disp, steps, block,
                 p1, p2, paths, uniqueness, budget=None, workspace=None):
    disp[...], disp_right[...], margin[...] = specs.semi_global_match_reference(
        census_left[0], census_right, first_step, n_disp, steps, block, p1, p2, paths, uniqueness)
    return disp, disp_right, margin


def launch_left_right(be, disp, disp_right, margin, steps, tol):
    disp[...], margin[...] = specs.left_right_reference(disp, disp_right, margin, steps, tol)
    return disp, margin


def launch_sweep(be, state, left_shifted, right_shifted, gain_left, gain_right, offset, d, radius):
    return specs.sweep_update_reference(state, left_shifted, right_shifted, gain_left, gain_right, offset,
                                        d, radius)
