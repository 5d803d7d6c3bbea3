"""gfgpu.StereoMatcher: a matcher of fixed shape and range for streams of pairs, equal to
disparity() frame by frame, its buffers kept and no build after the first frame."""

import numpy as np
import pytest

import gfgpu
from gfgpu import stereo

from .scenes import random_dot_pair, slanted


def _frames(n, shape=(40, 72)):
    # a moving slanted surface: each frame another pair
    return [random_dot_pair(lambda yy, xx, k=k: slanted(yy, xx) + 0.3 * k, shape=shape, seed=k)[:2]
            for k in range(n)]


def _equal(got, want):
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_array_equal(np.nan_to_num(got), np.nan_to_num(want))


@pytest.mark.parametrize("options", [{}, {"min_disparity": -3, "subpixel_steps": 1, "paths": 8, "window": 5},
                                     {"subpixel_steps": 3, "subpixel": False, "lr_check": False, "uniqueness": 0}],
                         ids=["defaults", "steps1-8paths-w5", "steps3-no-checks"])
def test_matcher_equals_disparity_frame_by_frame(backend, options):
    frames = _frames(3)
    matcher = gfgpu.StereoMatcher(frames[0][0].shape, 14, backend=backend, **options)
    for left, right in frames:
        d, conf = matcher.compute(left, right, return_confidence=True)
        want, want_conf = stereo.disparity(left, right, 14, return_confidence=True, backend=backend, **options)
        _equal(d, want)
        np.testing.assert_array_equal(conf, want_conf)
        assert d.dtype == np.float32 and d.shape == left.shape
        _equal(matcher.compute(left, right), want)


def test_results_are_not_overwritten_by_the_next_frame(backend):
    (l0, r0), (l1, r1) = _frames(2)
    matcher = stereo.StereoMatcher(l0.shape, 14, backend=backend)
    first = matcher.compute(l0, r0)
    kept = first.copy()
    matcher.compute(l1, r1)
    _equal(first, kept)


def test_one_matcher_shared_by_threads(backend):
    """Frames from several threads on one matcher share its buffers: each still gets its own
    pair's map (they ran interleaved, and gave wrong maps or aborted PoCL, before a lock)."""
    import threading
    frames = _frames(4)
    matcher = stereo.StereoMatcher(frames[0][0].shape, 14, backend=backend)
    want = [stereo.disparity(left, right, 14, backend=backend) for left, right in frames]
    got, errors = {}, []

    def work(k):
        try:
            for rep in range(5):
                got[k, rep] = matcher.compute(*frames[k])
        except Exception as exc:    # reported below: a thread's exception does not fail the test
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for (k, _), d in got.items():
        _equal(d, want[k])


def test_buffers_kept_and_no_build_after_the_first_frame(require_backend):
    from gfgpu.backends.opencl import launch
    be = require_backend("opencl")
    frames = _frames(4, shape=(37, 61))
    matcher = stereo.StereoMatcher((37, 61), 13, backend=be)
    matcher.compute(*frames[0])
    buffers = {k: id(v) for k, v in {**matcher._buffers, **matcher._workspace}.items()}
    programs = len(launch._programs)
    assert buffers
    for left, right in frames[1:]:
        matcher.compute(left, right)
    assert len(launch._programs) == programs                 # nothing built after frame 1
    assert {k: id(v) for k, v in {**matcher._buffers, **matcher._workspace}.items()} == buffers


def test_band_matcher_reuses_its_bands_and_checkpoints(require_backend, monkeypatch):
    # several bands (checkpoints), costs kept and recomputed per band: the kept workspace
    # gives the same maps as fresh buffers on every frame
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("the band matcher runs on CPU devices only")
    monkeypatch.setattr("gfgpu.stereo.band_plan.BAND_BYTES", 1)
    monkeypatch.setattr("gfgpu.stereo.band_plan.WHOLE_BYTES", 0)
    frames = _frames(3, shape=(70, 64))
    for paths in (4, 8):
        matcher = stereo.StereoMatcher((70, 64), 12, min_disparity=-2, paths=paths, backend=be)
        for left, right in frames:
            _equal(matcher.compute(left, right),
                   stereo.disparity(left, right, 12, min_disparity=-2, paths=paths, backend=be))


def test_device_arrays_and_colour_in(backend):
    from gfgpu.backends import resolve_backend
    be = resolve_backend(backend)
    left, right = _frames(1)[0]
    matcher = stereo.StereoMatcher(left.shape, 14, backend=be)
    want = stereo.disparity(left, right, 14, backend=be)
    _equal(matcher.compute(be.asarray(left), be.asarray(right)), want)
    colour = np.repeat(left[..., None], 3, axis=2)
    _equal(matcher.compute(colour, np.repeat(right[..., None], 3, axis=2)),
           stereo.disparity(colour, np.repeat(right[..., None], 3, axis=2), 14, backend=be))


def test_bad_arguments_named_before_any_work():
    img = np.zeros((20, 30), np.float32)
    matcher = stereo.StereoMatcher((20, 30), 8, backend="numpy")
    with pytest.raises(ValueError, match="left must have the matcher's shape"):
        matcher.compute(np.zeros((20, 31)), img)
    with pytest.raises(ValueError, match="right must have the matcher's shape"):
        matcher.compute(img, np.zeros((21, 30)))
    with pytest.raises(ValueError, match="NaN"):
        matcher.compute(np.full((20, 30), np.nan), img)
    with pytest.raises(TypeError, match="return_confidence"):
        matcher.compute(img, img, return_confidence=1)
    for kwargs, err, what in (({"shape": (20,)}, ValueError, "shape"), ({"shape": (1, 30)}, ValueError, "shape"),
                              ({"max_disparity": 0}, ValueError, "max_disparity"),
                              ({"max_disparity": 4.5}, TypeError, "max_disparity"),
                              ({"min_disparity": -20000}, ValueError, "min_disparity"),
                              ({"window": 4}, ValueError, "window"),
                              ({"subpixel_steps": 5}, ValueError, "subpixel_steps"),
                              ({"paths": 6}, ValueError, "paths"), ({"p2": 10**5}, ValueError, "p2"),
                              ({"uniqueness": 101}, ValueError, "uniqueness"),
                              ({"lr_check": "yes"}, TypeError, "lr_check")):
        args = {"shape": (20, 30), "max_disparity": 8, **kwargs}
        with pytest.raises(err, match=what):
            stereo.StereoMatcher(args.pop("shape"), args.pop("max_disparity"), backend="numpy", **args)
    with gfgpu.working_set("64K"), pytest.raises(ValueError, match="working set"):
        stereo.StereoMatcher((400, 600), 255, backend="numpy")
