"""Which block cost the CPU band matcher builds (``_opencl._nibbles``): the nibble-plane kernel on
PoCL x86 with AVX2 also where the CPU has AVX512-VPOPCNTDQ (its vpopcntq kernel's 16-bit running
sums took 1.7x as long at 1000 x 1500 x 383), and the maps of both kernels on such a CPU equal to
the numpy specification's, at 1000 x 1500's sample count (383: 24 vectors, a 16-lane tail past the
nibble kernel's 32-byte vectors) in coarse bands whose costs are computed twice."""

import numpy as np
import pytest

from gfgpu import stereo
from gfgpu.stereo import _opencl, band_plan

from .scenes import random_dot_pair, square


def _pocl_x86_cpu():
    be = stereo.matching.resolve_backend("opencl", None)
    if be.kind != "cpu" or not _opencl._pocl_x86(be):
        pytest.skip("the nibble-plane cost is built for PoCL on x86-64 CPUs")
    return be


@pytest.mark.parametrize("flags, want", [
    ({"avx2"}, True),
    ({"avx2", "avx512bw", "avx512_vpopcntdq"}, True),     # was the interleaved vpopcntq kernel
    ({"sse4_1"}, False),                                   # no 32-byte vpshufb
])
def test_nibbles_chosen_with_and_without_vpopcntdq(monkeypatch, flags, want):
    be = _pocl_x86_cpu()
    monkeypatch.setattr(_opencl, "_CPU_FLAGS", frozenset(flags))
    assert _opencl._nibbles(be, 3) is want
    assert _opencl._nibbles(be, 5) is False                # byte sums of a 3 x 3 block only
    monkeypatch.setattr(_opencl, "USE_NIBBLES", False)
    assert _opencl._nibbles(be, 3) is False                # forced off


def test_nibbles_and_vpopcntq_kernels_equal_spec_in_coarse_bands(monkeypatch):
    # both kernels built as on an AVX512-VPOPCNTDQ CPU (-D VPOPCNTQ where the interleaved codes run),
    # 383 samples per pixel (max_disparity 191, half-pixel samples), the costs recomputed per
    # coarse band (bands of 4 rows, coarse bands of 8)
    be = _pocl_x86_cpu()
    flags = _opencl._host_cpu_flags()
    if "avx2" not in flags:
        pytest.skip("the nibble kernel needs AVX2")
    monkeypatch.setattr(band_plan, "WHOLE_BYTES", 0)
    monkeypatch.setattr(band_plan, "KEEP_BYTES", 0)
    left, right = random_dot_pair(square, shape=(29, 230))[:2]
    want = stereo.disparity(left, right, 191, backend="numpy")
    assert np.isfinite(want).mean() > 0.1
    for use in (True, False):
        monkeypatch.setattr(_opencl, "USE_NIBBLES", use)
        assert _opencl._nibbles(be, 3) is use
        got = stereo.disparity(left, right, 191, backend=be)
        np.testing.assert_array_equal(got, want)
