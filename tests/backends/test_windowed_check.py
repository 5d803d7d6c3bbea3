"""The finite check rides on a translated step's windowed pass (one read of the input) where that
pass reads every sample, and falls back to a check of its own where it does not."""

import numpy as np
import pytest

import gfgpu
from gfgpu._core.program import window_reads_all
from gfgpu.greens import translation_passes

SHIFTS = [(0, 2.5), (-3.25, 0), (7.75, -12.5)]


def counting(be, monkeypatch):
    """Count ``be``'s stand-alone input checks (restored after the test)."""
    calls = []
    check = be.input_finite

    def counted(host, data):
        calls.append(1)
        return check(host, data)
    monkeypatch.setattr(be, "input_finite", counted)
    return calls


def _windowed(backend):
    if not backend.recurses_windows:
        pytest.skip(f"{backend.name} runs translated steps as gathers around the pass")
    return backend


@pytest.mark.parametrize("mode", ["reflect", "mirror", "nearest", "wrap"])
@pytest.mark.parametrize("where", ["first", "middle", "last"])
@pytest.mark.parametrize("bad", [np.nan, -np.inf, 3e38])
def test_a_nonfinite_sample_anywhere_is_refused_by_the_fused_check(backend, mode, where, bad, rng):
    be = _windowed(backend)
    for shape in [(37, 70), (300, 33)]:
        x = rng.standard_normal(shape).astype(np.float32)
        flat = x.reshape(-1)
        flat[{"first": 0, "middle": flat.size // 2 + 1, "last": flat.size - 1}[where]] = bad
        for s in SHIFTS:
            if not np.isfinite(bad):
                with pytest.raises(ValueError, match="NaN or infinite"):
                    gfgpu.shift(x, s, mode=mode, backend=be)
            else:    # beyond the range limit: scaled, computed, scaled back (as numpy's float64);
                # the tolerance is relative to the input's peak (a spike moved out of the image
                # leaves the reference a tail far below float32's resolution of that peak)
                want = gfgpu.shift(x.astype(np.float64), s, mode=mode, backend="numpy")
                got = gfgpu.shift(x, s, mode=mode, backend=be)
                assert np.isfinite(got).all() and np.abs(got - want).max() <= 2e-6 * bad, (shape, s)


def test_the_check_rides_on_the_first_windowed_pass(backend, rng, monkeypatch):
    be = _windowed(backend)
    calls = counting(be, monkeypatch)
    x = rng.standard_normal((64, 80)).astype(np.float32)
    for s in SHIFTS:
        want = gfgpu.shift(x.astype(np.float64), s, backend="numpy")
        got = gfgpu.shift(x, s, backend=be)
        assert np.abs(got - want).max() <= 2e-6 * np.abs(want).max()
    assert not calls


def test_a_window_that_skips_samples_falls_back_to_its_own_check(backend, rng, monkeypatch):
    """'constant' far beyond the line: the window reads none of the first samples, whose NaN must
    still be refused (by the stand-alone check)."""
    be = _windowed(backend)
    n, s = 80, 40.5
    passes = translation_passes(-s)
    assert not window_reads_all(n, passes, passes[0].offset, "constant", np.float32)
    calls = counting(be, monkeypatch)
    x = rng.standard_normal((16, n)).astype(np.float32)
    x[:, -1] = np.nan                     # moved out of the image: never read by the pass
    with pytest.raises(ValueError, match="NaN or infinite"):
        gfgpu.shift(x, (0, -s), mode="grid-constant", backend=be)
    assert len(calls) == 1


def test_gpu_shaped_windowed_passes_check_the_input(gpu_shaped, rng, monkeypatch):
    calls = counting(gpu_shaped, monkeypatch)
    x = rng.standard_normal((37, 70)).astype(np.float32)
    for s in SHIFTS:
        want = gfgpu.shift(x.astype(np.float64), s, backend="numpy")
        got = gfgpu.shift(x, s, backend=gpu_shaped)
        assert np.abs(got - want).max() <= 2e-6 * np.abs(want).max()
    assert not calls
    x[-1, -1] = np.nan
    for s in SHIFTS:
        with pytest.raises(ValueError, match="NaN or infinite"):
            gfgpu.shift(x, s, backend=gpu_shaped)
