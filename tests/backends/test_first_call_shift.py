"""``shift`` at a sequence of new image sizes in one process (issue 26): what a new size computes,
builds, allocates and uploads, counted, not timed.

A translated step of ``shift`` depends on the image size only through its line length ``n``: the
plan of its pass on the window of ``n + 2 pad`` samples (a few scalars and two broadcast views:
the boundary series are cached by what they depend on), the window index of ``n + 2 pad`` entries
and, on a device, their two uploads.  Nothing else may be redone at a new size: no kernel is
built (sizes are arguments), no fresh host memory is taken within a size class (the host pool),
no boundary series is summed.  A second call at a size computes and uploads nothing.

What this leaves of a first call's time (helper-54, measured on PoCL, 2 cores): the page faults of
the pool blocks' pages beyond what the previous, smaller size touched (new memory: ~450 faults at
1100 x 1300 after 1000 x 1200 float32) and the input's first read from memory; neither is counted
here.
"""

import numpy as np
import pytest
from counters import fresh_pool_blocks, program_builds

import gfgpu
from gfgpu._core import program, recursion, translation
from gfgpu._core.hostpool import size_class

SHIFT = (2.5, -1.5)          # benchmarks/filters.py's first-call row: a translated pass on each axis
STEPS = 2                    # translated steps of SHIFT on a 2-D image, one pass each
# float32 sizes of one half-octave class (47-64 pages; float64: 92-128 pages, one class too)
SHAPES = [(200, 240), (220, 260), (203, 259), (240, 219), (195, 266), (250, 262)]


def _indexprogram_builds():
    """Window or gather indices computed so far (cache misses of their builders)."""
    return sum(f.cache_info().misses for f in (program.line_window, translation.translate_index,
                                                translation.crop_index))


def _count_uploads(be, monkeypatch):
    """``{"plan": n, "index": n}``: the misses of the backend's plan and index upload caches
    (keyed by the identity of the plan or index they hold), counted from now on (the methods are
    wrapped on the instance until the test ends); None where the backend uploads nothing."""
    plan_method = next((m for m in ("_plan_buffers", "_plan_arrays") if hasattr(be, m)), None)
    if plan_method is None or not hasattr(be, "_index_array"):
        return None
    counts = {"plan": 0, "index": 0}

    def wrap(name, table, kind, key_of):
        method = getattr(be, name)

        def counted(obj, *args, **kwargs):
            hit = getattr(be, table).get(key_of(obj, *args))
            if hit is None or hit[0] is not obj:
                counts[kind] += 1
            return method(obj, *args, **kwargs)

        monkeypatch.setattr(be, name, counted)

    wrap(plan_method, "_plans", "plan", lambda plan, dtype: (id(plan), dtype))
    wrap("_index_array", "_indices", "index", lambda index, size: id(index))
    return counts


class _Counts:
    """What one call computed, built, allocated and uploaded (differences of the counters)."""

    def __init__(self, be, series, uploads):
        self.be, self.series, self.uploads = be, series, uploads

    def __enter__(self):
        be = self.be
        be.synchronize()
        self.series.clear()
        self._start = (program_builds(be), fresh_pool_blocks(be), recursion._plan_cached.cache_info().misses,
                       _indexprogram_builds(), None if self.uploads is None else dict(self.uploads))
        return self

    def __exit__(self, *exc):
        be = self.be
        be.synchronize()
        builds, fresh, plans, indices, uploads = self._start
        self.builds = None if builds is None else program_builds(be) - builds
        self.fresh = None if fresh is None else fresh_pool_blocks(be) - fresh
        self.plans = recursion._plan_cached.cache_info().misses - plans
        self.indices = _indexprogram_builds() - indices
        self.summed = len(self.series)
        if uploads is None:
            self.plan_uploads = self.index_uploads = None
        else:
            self.plan_uploads = self.uploads["plan"] - uploads["plan"]
            self.index_uploads = self.uploads["index"] - uploads["index"]
        return False


@pytest.fixture
def series(monkeypatch):
    """The boundary series summed for a plan's section (recursion._line_initial_weights), recorded."""
    summed = []
    sum_series = recursion._line_initial_weights

    def counted(lam, *args, **kwargs):
        if lam.size == 1:
            summed.append(args[1])
        return sum_series(lam, *args, **kwargs)

    monkeypatch.setattr(recursion, "_line_initial_weights", counted)
    return summed


def _forget_line_caches():
    """Plans and indices cached by line length (process-wide: another test may have made a length
    of this sequence, whose first call would then compute less than counted here)."""
    for f in (recursion._plan_cached, program.line_window, program._covers, translation.translate_index,
              translation.crop_index):
        f.cache_clear()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_each_new_size_redoes_only_what_its_line_lengths_need(backend, dtype, series, rng, monkeypatch):
    be = backend
    _forget_line_caches()
    uploads = _count_uploads(be, monkeypatch)
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip(f"{be!r} has no float64")
    nbytes = [int(np.prod(s)) * np.dtype(dtype).itemsize for s in SHAPES]
    assert len({size_class(b) for b in nbytes}) == 1        # the premise of the pool count
    images = [rng.random(s).astype(dtype) for s in SHAPES]
    gfgpu.shift(images[0], SHIFT, backend=be)
    previous = images[0]
    for x in images[1:]:
        with _Counts(be, series, uploads) as new:
            out = np.array(gfgpu.shift(x, SHIFT, backend=be))    # a copy: the pooled result goes back
        assert new.builds in (None, 0), "a new size built a kernel"
        assert new.fresh in (None, 0), "a new size within the class took fresh host memory"
        assert new.summed == 0, "a new size summed a boundary series again"
        assert new.plans == STEPS, "one plan per translated pass, no more"
        if be.recurses_windows:
            assert new.indices == STEPS          # one window index per step
        else:
            assert new.indices == 2 * STEPS      # a gather into the padded window and one out of it
        assert new.plan_uploads in (None, STEPS)
        assert new.index_uploads in (None, STEPS if be.recurses_windows else 2 * STEPS)
        # the same size again: nothing computed, nothing uploaded, the same bits
        with _Counts(be, series, uploads) as again:
            repeat = np.array(gfgpu.shift(x, SHIFT, backend=be))
        assert (again.builds in (None, 0) and again.fresh in (None, 0) and again.summed == again.plans
                == again.indices == 0 and again.plan_uploads in (None, 0) and again.index_uploads in (None, 0))
        np.testing.assert_array_equal(repeat, out)
        # and back to the previous size, still cached: nothing computed or uploaded either
        with _Counts(be, series, uploads) as back:
            gfgpu.shift(previous, SHIFT, backend=be)
        assert back.plans == back.indices == back.summed == 0 and back.plan_uploads in (None, 0)
        assert back.index_uploads in (None, 0) and back.fresh in (None, 0)
        previous = x


@pytest.mark.parametrize("mode", ["reflect", "mirror", "nearest", "wrap", "grid-constant"])
def test_a_new_size_has_the_bits_of_the_reference_of_that_size_in_every_mode(backend, mode, rng):
    """The plans and indices a new size reuses or extends give what the float64 spec gives there
    (numpy, its own gather path), at every size of the sequence."""
    be = backend
    for shape in SHAPES[:4]:
        x = rng.random(shape, dtype=np.float32)
        got = gfgpu.shift(x, SHIFT, mode=mode, backend=be)
        want = gfgpu.shift(x.astype(np.float64), SHIFT, mode=mode, backend="numpy")
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
