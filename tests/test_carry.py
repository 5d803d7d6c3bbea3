"""Exact state carry (gfgpu._core.carry): a pass cut into segments equals the uncut pass."""
import numpy as np
import pytest
from oracle import direct_axis

from gfgpu import greens
from gfgpu._core import carry
from gfgpu._core.recursion import MODES, plan_pass, run_reference

PASSES = {
    "G_u(3)": greens.UniformGreen(3.0).line_pass(),
    "G_u(40) anticausal": greens.UniformGreen(40.0).line_pass(reverse=True),
    "shift(-7.3)": greens.shift_pass(-7.3),
    "H_u(4) anticausal": greens.HomogeneousGreen(4.0).line_pass(reverse=True),
    "G_U1(0.3, -5)": greens.AffineGreen(0.3, -5.0).line_pass(),
    "G_U2(2, -3)": greens.AffineGreenApprox(2.0, -3.0).line_pass(),
}


def _segmented(backend, lines, plan, bounds, cval, dtype):
    segs = carry.segments(plan, bounds, dtype)
    ends = [carry.end_state(s, lines[slice(*s.tail_rows)]) for s in segs]
    initial = sum(carry.boundary_state(s, lines[slice(*s.head_rows)], cval) for s in segs)
    states = carry.carry_scan(segs, ends, initial)
    out = np.empty_like(lines)
    for s, state in zip(segs, states):
        block = np.ascontiguousarray(lines[s.start:s.stop])
        y = backend.empty((1,) + block.shape, dtype)
        carry.zero_state_pass(backend, backend.asarray(block[None]), y, 1, [s])
        host = backend.to_host(y)[0]
        carry.add_correction(s, host, state)
        out[s.start:s.stop] = host
    return out


@pytest.mark.parametrize("name", list(PASSES))
@pytest.mark.parametrize("mode", MODES)
def test_segments_equal_uncut_pass(name, mode, rng):
    n, m = 240, 5
    lines = rng.standard_normal((n, m))
    plan = plan_pass(PASSES[name], n, mode, np.float64)
    ref = run_reference(lines, plan, cval=0.7)
    from gfgpu.backends import get_backend
    for bounds in ([0, 1, 50, 51, 170, 239, 240], [0, 120, 240], [0, 240]):
        out = _segmented(get_backend("numpy"), lines, plan, bounds, 0.7, np.float64)
        assert np.abs(out - ref).max() <= 1e-12 * np.abs(ref).max(), bounds


@pytest.mark.parametrize("mode", ["reflect", "wrap"])
def test_segments_on_every_backend_float32(backend, mode, rng):
    n, m = 300, 33
    lines = rng.standard_normal((n, m)).astype(np.float32)
    plan = plan_pass(greens.UniformGreen(25.0).line_pass(reverse=True), n, mode, np.float32)
    ref = run_reference(lines.astype(np.float64), plan_pass(greens.UniformGreen(25.0).line_pass(reverse=True),
                                                            n, mode, np.float64))
    out = _segmented(backend, lines, plan, [0, 7, 100, 101, 299, 300], 0.0, np.float32)
    assert np.linalg.norm(out - ref) <= 1e-6 * np.linalg.norm(ref)


def test_segmented_against_direct_summation(rng):
    """Independent of the recursion: closed-form G_u summed directly over the padded line."""
    n = 200
    image = rng.standard_normal((n, 3))
    kernel = greens.UniformGreen(6.0)
    ref = direct_axis(image, kernel, 0, "mirror")
    plan = plan_pass(kernel.line_pass(), n, "mirror", np.float64)
    from gfgpu.backends import get_backend
    out = _segmented(get_backend("numpy"), image, plan, [0, 13, 14, 90, 200], 0.0, np.float64)
    assert np.linalg.norm(out - ref) <= 1e-12 * np.linalg.norm(ref)


def test_weights_are_trimmed_to_the_decay_length():
    plan = plan_pass(greens.UniformGreen(2.0).line_pass(), 5000, "reflect", np.float32)
    seg = carry.segments_at(plan, 1000, 4000, np.float32)
    # |lambda| = exp(-1/2): weights fall below 1e-10 after about 2 ln(1e10) = 46 samples
    assert 30 < seg.end_weights.shape[1] < 60 and 30 < seg.response.shape[1] < 60
    assert seg.boundary.shape[1] == 0 and not seg.boundary_c.any()


def test_bad_bounds():
    plan = plan_pass(greens.UniformGreen(2.0).line_pass(), 10, "reflect", np.float64)
    with pytest.raises(ValueError, match="bounds"):
        carry.segments(plan, [0, 5, 5, 10], np.float64)
    with pytest.raises(ValueError, match="bounds"):
        carry.segments(plan, [0, 5, 9], np.float64)
    with pytest.raises(ValueError, match="segment"):
        carry.segments_at(plan, 4, 11, np.float64)
