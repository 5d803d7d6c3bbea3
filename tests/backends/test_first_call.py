"""The first call at a new image size, in a process that has run the operator at another (issue 26):
what it reuses, counted, not timed, and that the reuse changes no bit of any result.

Plans are cached by what they depend on (gfgpu._core.recursion, twosided, oblique: a line
length beyond a section's reach changes a few scalars of its window, an oblique direction's column
filters are a table per direction).
"""

import numpy as np
import pytest

import gfgpu
from gfgpu import greens
from gfgpu._core import lines, oblique, program, recursion, twosided

G = greens.UniformGreen(3.0)
OPERATORS = {
    "shift": lambda x, be: gfgpu.shift(x, (2.5, -1.5), backend=be),
    "green_filter rows": lambda x, be: gfgpu.green_filter(x, G, axis=1, backend=be),
    "green_filter columns mirror": lambda x, be: gfgpu.green_filter(x, G, axis=0, mode="mirror", backend=be),
    "green_filter wrap": lambda x, be: gfgpu.green_filter(x, G, axis=1, mode="wrap", backend=be),
    "green_filter oblique": lambda x, be: gfgpu.green_filter(x, G, angle=0.3, backend=be),
    "green_filter steep": lambda x, be: gfgpu.green_filter(x, G, angle=-2.0, mode="wrap", backend=be),
    "derivative": lambda x, be: gfgpu.derivative(x, 1.0, backend=be),
    "gradient": lambda x, be: np.stack(gfgpu.gradient(x, 1.0, backend=be)),
    "canny": lambda x, be: gfgpu.canny(x, 1.0, backend=be),
}


def _forget_plans():
    """Drop every cached plan, window and design (the next call computes them all afresh)."""
    for f in (recursion._plan_cached, recursion._reach, recursion._pole_cached, recursion._columns_cached,
              twosided._plan_cached, twosided._weights_cached, oblique.column_delays, oblique._column_plans,
              oblique.shear_plan, lines.shear_maps, lines.shear_geometry, program.line_window, program.line_index,
              program._covers):
        f.cache_clear()
    for table in (recursion._weights, recursion._windows, twosided._states_cache, oblique._directions):
        table.clear()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", sorted(OPERATORS))
def test_a_call_at_a_new_size_has_the_bits_of_one_with_nothing_cached(backend, name, dtype, rng):
    if dtype == np.float64 and not backend.supports_float64:
        pytest.skip(f"{backend!r} has no float64")
    op = OPERATORS[name]
    first, second = (rng.random(s).astype(dtype) for s in ((100, 120), (110, 130)))
    op(first, backend)
    out = op(second, backend)
    _forget_plans()
    fresh = op(second, backend)
    assert out.dtype == fresh.dtype and out.shape == fresh.shape
    np.testing.assert_array_equal(out, fresh)
    op(first, backend)        # and back to the first size, the larger one's tables serving it
    np.testing.assert_array_equal(op(second, backend), fresh)


def test_the_benchmarks_second_size_sums_no_series_and_designs_only_new_columns(backend, rng, monkeypatch):
    """benchmarks/filters.py's first-call table: 1000 x 1200, then 1100 x 1300.  Before the caches,
    every plan's geometric series and Thiran's design of every column again (1300 eigenvalue
    problems) at the second size."""
    be = backend
    series, designed = [], []
    sum_series, design = recursion._line_initial_weights, oblique.allpass_delay

    def summed(lam, *args, **kwargs):
        if lam.size == 1:        # a plan's section (per-line plans of many lines are another matter)
            series.append(args[1])
        return sum_series(lam, *args, **kwargs)

    monkeypatch.setattr(recursion, "_line_initial_weights", summed)

    def counted(d):
        designed.append(len(d))
        return design(d)

    monkeypatch.setattr(oblique, "allpass_delay", counted)
    oblique.column_delays.cache_clear()
    ops = [OPERATORS[name] for name in ("shift", "green_filter rows", "green_filter oblique")]
    a, b = (rng.random(s, dtype=np.float32) for s in ((1000, 1200), (1100, 1300)))
    for op in ops:
        op(a, be)
    be.synchronize()
    series.clear()
    designed.clear()
    for op in ops:
        op(b, be)
    be.synchronize()
    assert series == []
    assert sum(designed) <= 1300 - 1200      # the new columns only
    oblique.column_delays.cache_clear()
