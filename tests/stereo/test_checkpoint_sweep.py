"""The CPU band matcher's checkpointing up sweeps (``_opencl.launch_match``, stereo.cl's
``sgm_band`` with ``write_up = 0``): the states at several bands' tops are written by one *chained*
launch (the rows in groups of the band's rows, each group into its own checkpoint slot, starting
from the slot of the group below), with the costs kept (pass 1: every band above the last in one
launch) and recomputed per coarse band (pass 2: a coarse band's fine bands in one launch, the
image's last fine band apart, which starts from zeros); the maps stay the numpy specification's bit
for bit on small images forced through that path (odd widths, negative ranges, 4 and 8 paths)."""

import numpy as np
import pytest

from gfgpu.stereo import _opencl, band_plan, kernels
from gfgpu.stereo import spec as specs


def _cpu_opencl(require_backend):
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on OpenCL CPU devices")
    return be


def _codes(rng, h, w, steps, shift, flip):
    # census-like codes: the right view the left one shifted by `shift` px with some bits flipped
    left = rng.integers(0, 2**48, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**48, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def _match(be, left, right, first, n, steps, paths):
    h, w = left.shape[1:]
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, 3, 5, 40, paths, 10, None)
    return [be.to_host(o) for o in outs]


def _checkpoint_launches(monkeypatch):
    """Record (rows, chain) of every checkpointing sgm_band launch of the band loop, and the rows of
    every ckpt_cost launch (costs and vertical path fused)."""
    from gfgpu.backends.opencl import launch as ocl
    seen, fused = [], []
    real, real_launch = ocl.PresetLaunch.__call__, ocl.launch

    def call(self, gsize, lsize, changes):
        if self.function_name == "sgm_band" and int(changes[14]) == 0:     # write_up = 0
            seen.append((int(changes[8]), int(changes[28])))
        return real(self, gsize, lsize, changes)

    def launch(be, knl, *args):
        if knl.function_name == "ckpt_cost":
            fused.append(int(args[-1][10]))
        return real_launch(be, knl, *args)
    monkeypatch.setattr(ocl.PresetLaunch, "__call__", call)
    monkeypatch.setattr(ocl, "launch", launch)
    return seen, fused


# (h, w, samples, steps, first step, band rows k, fine bands per coarse band, paths): odd widths
# (the split at w // 2 with an odd half; 3 and 1 columns: fewer than the cost kernel's column
# ranges), negative and positive ranges, a last coarse band and a last fine band shorter than the
# others (down to one row), bands of one row, 8 paths (one work-item: the diagonals need the whole row)
CASES = [(29, 27, 21, 2, -6, 3, 3, 4), (23, 31, 17, 1, 2, 2, 4, 4), (26, 33, 33, 2, -10, 4, 3, 4),
         (17, 25, 15, 3, 0, 1, 5, 4), (17, 3, 9, 2, -3, 2, 3, 4), (17, 1, 9, 2, 0, 2, 3, 4),
         (25, 29, 21, 2, -4, 3, 2, 8), (19, 23, 9, 1, -3, 2, 3, 8)]


@pytest.mark.parametrize("keep,nibbles", [(False, True), (False, False), (True, True)])
@pytest.mark.parametrize("h,w,n,steps,first,k,per_coarse,paths", CASES)
def test_chained_checkpoints_match_the_specification(require_backend, monkeypatch, keep, nibbles, h, w, n, steps,
                                                     first, k, per_coarse, paths):
    # nibbles: the 3 x 3 costs from nibble planes where the CPU allows (then, with 4 paths and the
    # costs recomputed, pass 1 runs ckpt_cost: costs and vertical path fused), else forced off
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(_opencl, "USE_NIBBLES", nibbles)
    fuses = not keep and paths == 4 and _opencl._nibbles(be, 3)
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    if not keep:
        monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w_=1, n_=1: min(h_, k))
    monkeypatch.setattr(band_plan, "fine_rows", lambda: k)
    monkeypatch.setattr(band_plan, "coarse_rows", lambda h_, paths_, k_, w_=1, n_=1: min(h_, per_coarse * k_))
    plan = band_plan.match_plan(h, w, n, paths)
    assert plan.keep == keep and plan.rows == k and (keep or plan.rows < plan.coarse < h)
    seen, fused = _checkpoint_launches(monkeypatch)
    left, right = _codes(np.random.default_rng(h * w), h, w, steps, 2, 0.25)
    got = _match(be, left, right, first * steps, n, steps, paths)
    want = specs.semi_global_match_reference(left[0], right, first * steps, n, steps, 3, 5, 40, paths, 10)
    for g, r in zip(got, want):
        np.testing.assert_array_equal(g, r)
    # the launches: with the costs kept, the last band alone (from zeros) and every band above it
    # in one chained launch; recomputed, per coarse band pass 1's sweep and pass 2's one chained
    # launch of its fine bands below the first (the last coarse band: two, its last fine band from
    # zeros); where it fuses, ckpt_cost for both but in the last coarse band (sgm_band's init)
    tops = -(-h // (k if keep else plan.coarse)) - 1
    if keep:
        assert fused == []
        want = ([(h - tops * k, 0)] if tops else []) + ([((tops - 1) * k, k)] if tops > 1 else [])
        assert seen == want
        return
    coarse = [min(plan.coarse, h - c0) for c0 in range(0, h, plan.coarse)]
    fine = [-(-rows // k) for rows in coarse]
    last = [(coarse[-1] - k * (fine[-1] - 1), 0)] if fine[-1] > 1 else []          # from zeros
    last += [(k * (fine[-1] - 2), k)] if fine[-1] > 2 else []
    first = [(coarse[-1], 0)] if tops else []                                        # pass 1, from zeros
    if fuses:
        assert fused == [plan.coarse] * (tops - 1) + [rows for rows, f in zip(coarse[:-1], fine) if f > 1]
        assert seen == first + last
    else:
        assert fused == []
        assert seen == first + [(plan.coarse, 0)] * (tops - 1) + [
            (rows - k, k) for rows, f in zip(coarse[:-1], fine) if f > 1] + last


def test_a_broken_chain_changes_the_maps(require_backend, monkeypatch):
    # the chained sweeps' groups matter: groups of one row more than the bands (each slot holding
    # the state of another row than its band's top) give other maps than the specification's
    be = _cpu_opencl(require_backend)
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    monkeypatch.setattr(band_plan, "band_rows", lambda h_, paths_, w_=1, n_=1: min(h_, 3))
    monkeypatch.setattr(band_plan, "fine_rows", lambda: 3)
    monkeypatch.setattr(band_plan, "coarse_rows", lambda h_, paths_, k_, w_=1, n_=1: min(h_, 4 * k_))
    h, w, n, steps, first = 29, 27, 21, 2, -6
    left, right = _codes(np.random.default_rng(7), h, w, steps, 2, 0.25)
    want = specs.semi_global_match_reference(left[0], right, first, n, steps, 3, 5, 40, 4, 10)
    for g, r in zip(_match(be, left, right, first, n, steps, 4), want):
        np.testing.assert_array_equal(g, r)
    from gfgpu.backends.opencl import launch as ocl
    real = ocl.PresetLaunch.__call__

    real_launch = ocl.launch

    def shifted(self, gsize, lsize, changes):
        if self.function_name == "sgm_band" and int(changes[28]) > 0:
            changes = dict(changes)
            changes[28] = np.int32(int(changes[28]) + 1)
        return real(self, gsize, lsize, changes)

    def shifted_fused(be_, knl, gsize, lsize, arrays_in, arrays_out, args):
        if knl.function_name == "ckpt_cost" and int(args[-1]) < int(args[-2]):       # chain < v_rows
            args = (*args[:-1], np.int32(int(args[-1]) + 1))
        return real_launch(be_, knl, gsize, lsize, arrays_in, arrays_out, args)
    monkeypatch.setattr(ocl.PresetLaunch, "__call__", shifted)
    monkeypatch.setattr(ocl, "launch", shifted_fused)
    got = _match(be, left, right, first, n, steps, 4)
    assert any(not np.array_equal(g, r, equal_nan=True) for g, r in zip(got, want))


def test_sweep_argument_positions():
    # the band loop sets the per-band arguments by position: chain is the last of sgm_band's
    assert _opencl._SWEEP_BAND_ARGS[-1] == 28
