"""The GPU-shaped matcher (OpenCL ``sgm_groups.cl``, Warp's group kernels in ``_warp.py``: a
work-group / block per line, the disparity samples across its work-items, a uint8 cost and one
int16 sum volume) forced on the CPU devices, against ``semi_global_match_reference`` bit for bit:
odd and tiny shapes, rows not a multiple of the cost kernel's column tile, sample counts not a
multiple of the lanes, one sample, every option of the branch, every input dtype through
``disparity``."""

import numpy as np
import pytest
from scipy import ndimage

from gfgpu import stereo
from gfgpu.backends.opencl import launch
from gfgpu.stereo import kernels
from gfgpu.stereo import spec as specs

from .scenes import random_dot_pair, shifted_pair

# conftest's gpu_shaped fixture (the backend on its CPU device taking the GPU launch shapes) for one
# backend; OpenCL's tests reach its launcher's internals (group shapes), Warp's have their own below
opencl = pytest.mark.parametrize("gpu_shaped", ["opencl"], indirect=True)
warp = pytest.mark.parametrize("gpu_shaped", ["warp"], indirect=True)


def _codes(rng, h, w, steps, shift, flip, bits=48):
    left = rng.integers(0, 2**bits, (1, h, w), dtype=np.uint64)
    right = rng.integers(0, 2**bits, (steps, h, w), dtype=np.uint64)
    right[0] = np.roll(left[0], -shift, axis=1) ^ (rng.random((h, w)) < flip).astype(np.uint64)
    return left, right


def _check(be, left, right, first, n, steps, block, p1, p2, paths, uniq, shape=None, workspace=None):
    from gfgpu.stereo import _opencl_groups
    h, w = left.shape[1:]
    outs = be.empty((h, w), np.float32), be.empty((h, w), np.int32), be.empty((h, w), np.float32)
    if shape is None:      # through the registered kernel: the launchers' GPU branches
        extra = {} if workspace is None else {"workspace": workspace}
        kernels.match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, block, p1, p2, paths,
                      uniq, None, **extra)
    else:
        _opencl_groups.launch_match(be, be.asarray(left), be.asarray(right), *outs, first, n, steps, block, p1,
                                    p2, paths, uniq, workspace, shape=shape)
    ref = specs.semi_global_match_reference(left[0], right, first, n, steps, block, p1, p2, paths, uniq)
    what = f"{h}x{w} n={n} steps={steps} first={first} block={block} p=({p1},{p2}) paths={paths} " \
           f"uniq={uniq} shape={shape}"
    for got, want in zip(outs, ref):
        np.testing.assert_array_equal(be.to_host(got), want, err_msg=what)


@opencl
def test_group_matcher_bit_exact_on_awkward_shapes(gpu_shaped):
    # 1..3 rows, 1..5 columns (one partial lane group everywhere), 33 and 70 columns (partial
    # column tiles of the cost kernel), one sample, ranges below, straddling and beyond the
    # image, 1..4 sub-pixel steps, 4 and 8 paths, blocks 1..15
    rng = np.random.default_rng(0)
    cases = [(h, w, n) for h in (1, 2, 3) for w, n in ((1, 16), (2, 1), (3, 17), (5, 33))]
    cases += [(11, 33, 45), (7, 70, 1), (13, 35, 97)]
    for i, (h, w, n) in enumerate(cases):
        steps, paths = 1 + i % 4, (4, 8)[i % 2]
        first = (-2 * n, -n // 2, 0, 3)[i % 4] // steps * steps
        block = (1, 3, 5, 15)[i % 4]
        left, right = _codes(rng, h, w, steps, 2, 0.05)
        _check(gpu_shaped, left, right, first, n, steps, block, 5, 40, paths, (0, 10, 100)[i % 3])


@opencl
def test_group_matcher_saturated_codes_and_largest_penalties(gpu_shaped):
    # full 64-bit codes and 15x15 blocks (sums up to 14400, saturated at 254); the largest p2 that
    # disparity's int16 guard admits, and p1 = 0 or p1 = p2
    from gfgpu.stereo import matching
    rng = np.random.default_rng(2)
    for paths in (4, 8):
        p2 = (matching._INT16_MAX - 1) // paths - specs.COST_MAX
        for p1 in (0, p2):
            left, right = _codes(rng, 9, 21, 1, 3, 0.5, bits=64)
            _check(gpu_shaped, left, right, -2, 33, 1, 15, p1, p2, paths, 0)


@opencl
@pytest.mark.parametrize("shape", [(1, 8), (4, 3), (8, 2), (16, 1)])
def test_chunk_edges_between_many_lanes(gpu_shaped, shape):
    # small work-groups put a chunk edge (d - 1, d + 1 through local memory) next to most samples;
    # n below, at and above a multiple of the chunk, lanes without samples
    rng = np.random.default_rng(3)
    lanes, ch = shape
    for i, n in enumerate(sorted({1, ch, ch + 1, lanes * ch - 1, lanes * ch} & set(range(1, lanes * ch + 1)))):
        steps, paths = 1 + i % 3, (8, 4)[i % 2]
        left, right = _codes(rng, 6 + i, 13 + 3 * i, steps, 1, 0.1)
        _check(gpu_shaped, left, right, -(n // 3) // steps * steps, n, steps, 3, 6, 90, paths, 10, shape=shape)


@opencl
@pytest.mark.parametrize("tile, rows, local", [(8, 3, None), (32, 5, 4000), (32, 32, 0)])
def test_cost_kernels_in_every_tiling(gpu_shaped, monkeypatch, tile, rows, local):
    # group_cost_columns in tiles of 8 columns and bands of 3 or 5 rows (partial tiles and bands:
    # the column sums' first rows and their running sums across a band), tiles cut by a small
    # local-memory budget, and group_cost where no 8 columns fit (local 0); windows 1 to 15
    from gfgpu.stereo import _opencl_groups
    monkeypatch.setattr(_opencl_groups, "COST_TILE", tile)
    monkeypatch.setattr(_opencl_groups, "COST_ROWS", rows)
    if local is not None:
        monkeypatch.setattr(_opencl_groups, "COST_LOCAL_BYTES", local)
    rng = np.random.default_rng(10)
    for i, (h, w, n, block) in enumerate([(13, 29, 20, 1), (11, 19, 33, 3), (7, 41, 9, 7), (16, 17, 45, 15)]):
        lanes, ch = _opencl_groups.group_shape(n)
        want = 0 if local == 0 else min(tile, (local or 10**9) // 2 // (lanes * ch) - (block - 1))
        assert _opencl_groups.cost_tile(gpu_shaped, lanes, ch, block) == (want if want >= 8 else 0)
        steps = 1 + i % 3
        left, right = _codes(rng, h, w, steps, 2, 0.05)
        _check(gpu_shaped, left, right, -steps * 2, n, steps, block, 5, 40, 4, 10)


@opencl
def test_group_matcher_holds_one_sum_volume(gpu_shaped):
    # memory: a uint8 cost and one int16 sum volume (3 bytes per sample), kept in the workspace
    rng = np.random.default_rng(4)
    left, right = _codes(rng, 8, 30, 2, 2, 0.05)
    workspace = {}
    _check(gpu_shaped, left, right, -4, 25, 2, 3, 54, 576, 4, 10, shape=(32, 1), workspace=workspace)
    volumes = sorted((np.dtype(dt).name, shape) for (_, shape, dt) in workspace)
    assert volumes == [("int16", (8, 30, 25)), ("uint8", (8, 30, 25))]


@opencl
def test_memory_estimate_counts_three_bytes_per_sample(gpu_shaped):
    # disparity_memory (what disparity checks the working set against) counts the two volumes
    from gfgpu.stereo import matching
    n = 63 * 2 + 1
    need = stereo.disparity_memory((100, 200), 63, backend=gpu_shaped)
    assert need == matching._sgm_base((100, 200), 2) + 3 * 100 * 200 * n


@opencl
def test_one_build_for_every_count_of_a_group_shape(gpu_shaped):
    # the kernels are built for (lanes, samples per lane) only: 33..64 samples share a build
    from gfgpu.stereo._opencl_groups import group_shape
    assert [group_shape(n) for n in (1, 32, 33, 256, 257, 383, 512, 513, 1024, 16385)] == [
        (32, 1), (32, 1), (32, 2), (32, 8), (64, 5), (64, 6), (64, 8), (128, 5), (128, 8), (128, 129)]
    for n in range(1, 3000):
        lanes, ch = group_shape(n)
        assert lanes * (ch - 1) < n <= lanes * ch
    rng = np.random.default_rng(5)
    left, right = _codes(rng, 5, 40, 1, 2, 0.05)
    _check(gpu_shaped, left, right, 0, 40, 1, 3, 54, 576, 4, 10)
    built = len(launch._programs)
    for n in (33, 51, 64):
        _check(gpu_shaped, left, right, -3, n, 1, 3, 54, 576, 4, 10)
    assert len(launch._programs) == built


def _pairs():
    rng = np.random.default_rng(5)
    tex = ndimage.gaussian_filter(rng.random((30, 57)), 2) > 0.5
    yield "bool", tex, np.roll(tex, -6, axis=1)
    left, right, _ = random_dot_pair(lambda yy, xx: 6 + 4 * np.sin(xx / 20.0) + yy / 50, shape=(29, 71), seed=1)
    yield "uint8", np.rint(left).astype(np.uint8), np.rint(right).astype(np.uint8)
    yield "uint16", (np.rint(left) * 257).astype(np.uint16), (np.rint(right) * 257).astype(np.uint16)
    yield "int32", np.rint(left).astype(np.int32) - 300, np.rint(right).astype(np.int32) - 300
    yield "float64", left.astype(np.float64) / 255, right.astype(np.float64) / 255
    left, right = shifted_pair(5, shape=(21, 45), seed=2)
    yield "float32", left, right
    yield "subnormal", left * np.float32(1e-41), right * np.float32(1e-41)


@opencl
@pytest.mark.parametrize("options", [
    dict(), dict(paths=8, subpixel_steps=1), dict(window=5, min_disparity=-3, subpixel_steps=3),
    dict(window=1, uniqueness=0, subpixel_steps=4), dict(window=15, paths=8, uniqueness=30, speckle_size=0)])
def test_disparity_maps_identical_to_numpy_for_every_dtype(gpu_shaped, options):
    for what, left, right in _pairs():
        want, conf_want = stereo.disparity(left, right, 9, return_confidence=True, backend="numpy", **options)
        got, conf = stereo.disparity(left, right, 9, return_confidence=True, backend=gpu_shaped, **options)
        np.testing.assert_array_equal(got, want, err_msg=f"{what} {options}")
        np.testing.assert_array_equal(conf, conf_want, err_msg=f"{what} {options}")


@opencl
def test_out_of_range_arguments_are_refused_by_name(gpu_shaped):
    from gfgpu.stereo import _opencl_groups
    rng = np.random.default_rng(6)
    left, right = _codes(rng, 4, 9, 1, 1, 0.1)
    cl, cr = gpu_shaped.asarray(left), gpu_shaped.asarray(right)
    outs = [gpu_shaped.empty((4, 9), dt) for dt in (np.float32, np.int32, np.float32)]
    top = _opencl_groups.PENALTY_MAX
    assert top + specs.COST_MAX < _opencl_groups.PATH_PAD <= 32767
    for args, match in (((0, 5, 1, 3, 6, top + 1), "p2"), ((0, 0, 1, 3, 6, 90), "n_disp"),
                        ((0, 40000, 1, 3, 6, 90), "n_disp")):
        with pytest.raises(ValueError, match=match):
            _opencl_groups.launch_match(gpu_shaped, cl, cr, *outs, *args, 4, 10)
    with pytest.raises(ValueError, match="shape"):
        _opencl_groups.launch_match(gpu_shaped, cl, cr, *outs, 0, 9, 1, 3, 6, 90, 4, 10, shape=(4, 2))


# --------------------------------------------------------------------------------------
# Warp: a block of threads per line (tile reductions).  A CPU device runs blocks of several
# threads only with wp.config.enable_cpu_blocks (Warp's cooperative CPU blocks): these tests turn
# it on; without it the forced branch keeps the whole-volume kernels (last test)
# --------------------------------------------------------------------------------------
@pytest.fixture
def cpu_blocks(monkeypatch):
    import warp as wp
    monkeypatch.setattr(wp.config, "enable_cpu_blocks", True)


def _volumes(workspace):
    return sorted((np.dtype(dt).name, name) for (name, _, dt) in workspace)


@warp
def test_warp_group_matcher_bit_exact(gpu_shaped, cpu_blocks, monkeypatch):
    # blocks of 4 and 8 lanes (group_lanes on the CPU), so chunk edges between lanes, lanes
    # without samples and n = 1; tiny and odd shapes, ranges below, straddling and beyond the
    # image, steps 1-4, paths 4 and 8, windows 1-15, uniqueness 0-100, the largest p2; the costs
    # in partial tiles and bands
    from gfgpu.stereo import _warp, matching
    from gfgpu.stereo._warp import group_lanes
    rng = np.random.default_rng(8)
    cases = [(1, 1, 1), (3, 5, 9), (2, 33, 17), (11, 35, 31), (7, 20, 64), (9, 13, 40), (6, 19, 8)]
    assert sorted({group_lanes(n, cuda=False) for _, _, n in cases}) == [4, 8]
    for i, (h, w, n) in enumerate(cases):
        steps, paths = 1 + i % 4, (4, 8)[i % 2]
        first = (-2 * n, -n // 2, 0, 3)[i % 4] // steps * steps
        block = (1, 3, 5, 15)[i % 4]
        p1, p2 = (5, 40) if i < 6 else (0, (matching._INT16_MAX - 1) // paths - specs.COST_MAX)
        left, right = _codes(rng, h, w, steps, 2, 0.05, bits=64 if i == 6 else 48)
        # the cost's column sums in tiles of 32 or 8 columns and bands of 32 or 3 rows
        monkeypatch.setattr(_warp, "COST_TILE", (32, 8)[i % 2])
        monkeypatch.setattr(_warp, "COST_ROWS", (32, 3)[i // 2 % 2])
        workspace = {}
        _check(gpu_shaped, left, right, first, n, steps, block, p1, p2, paths, (0, 10, 100)[i % 3],
               workspace=workspace)
        assert _volumes(workspace) == [("int16", "column_sums"), ("int16", "sum"), ("uint8", "cost")]


def test_warp_group_lanes():
    pytest.importorskip("warp")
    from gfgpu.stereo._warp import GROUP_CHUNK, group_lanes
    for n in range(1, 3000, 7):
        cuda, cpu = group_lanes(n), group_lanes(n, cuda=False)
        assert cuda % 32 == 0 and cuda * GROUP_CHUNK >= n > (cuda - 32) * GROUP_CHUNK
        assert cpu & (cpu - 1) == 0 and cpu * GROUP_CHUNK >= n and (cpu == 4 or n > cpu * GROUP_CHUNK // 2)


@warp
@pytest.mark.parametrize("options", [dict(), dict(paths=8, window=5, min_disparity=-3, subpixel_steps=3)])
def test_warp_disparity_maps_identical_to_numpy_for_every_dtype(gpu_shaped, cpu_blocks, options):
    for what, left, right in _pairs():
        want, conf_want = stereo.disparity(left, right, 7, return_confidence=True, backend="numpy", **options)
        got, conf = stereo.disparity(left, right, 7, return_confidence=True, backend=gpu_shaped, **options)
        np.testing.assert_array_equal(got, want, err_msg=f"{what} {options}")
        np.testing.assert_array_equal(conf, conf_want, err_msg=f"{what} {options}")


@warp
def test_warp_without_cpu_blocks_keeps_the_whole_volumes(gpu_shaped):
    import warp as wp
    if not gpu_shaped.wp_device.is_cpu:
        pytest.skip("a CUDA device runs blocks of threads")
    assert not wp.config.enable_cpu_blocks
    rng = np.random.default_rng(9)
    left, right = _codes(rng, 5, 17, 2, 2, 0.05)
    workspace = {}
    _check(gpu_shaped, left, right, -2, 9, 2, 3, 54, 576, 4, 10, workspace=workspace)
    assert _volumes(workspace) == [("int16", "aggregated"), ("int16", "cost"), ("int32", "path_scratch")]
