"""Spin and zoom at a new image size in one process (issue 27): what a new size redoes, counted, not timed.

A spin or zoom depends on the image size through its polar grid (rings, angles, bands): a new size
computes the plans of its new line lengths and the ray zoom's per-ring terms
(:func:`gfgpu.motion.zoom._segment_terms`), and nothing else: no kernel is built (sizes are
arguments), no fresh host memory is taken where the previous size's blocks serve (the host pool), and
the same size again computes, builds, takes and uploads nothing.  What a first call still pays beyond
this is the page faults of memory the process never touched (the first large call), not counted here
(docs/motion.md, "First call on a new shape").
"""

import numpy as np
import pytest
from counters import fresh_pool_blocks, program_builds

import gfgpu
from gfgpu._core import recursion
from gfgpu._core.hostpool import size_class
from gfgpu.motion import zoom
from gfgpu.motion.polar import polar_bands, zoom_window

CASES = [("rotation", 10.0, "green"), ("rotation", 10.0, "box"), ("zoom", 0.1, "green"), ("zoom", 0.1, "box")]
# the first size, then others whose polar workspace and image fall in the first's half-octave class or the
# one below (which the pool serves from the first's blocks; asserted below); rings 112, 112, 96.  Whole groups
# of 16 rings: a one-band spin grid (images up to ~180^2) with 8 mod 16 rings runs, and builds once, the
# box kernel's partial-group variant (docs/motion.md)
SHAPES = [(150, 140), (144, 144), (130, 130)]


def _workspace_bytes(shape, kind, value, itemsize):
    """Bytes of one polar workspace array (the largest band) of a spin or zoom about the centre."""
    h, w = shape
    cy, cx = (h - 1) / 2.0, (w - 1) / 2.0
    if kind == "rotation":
        bands = polar_bands(h, w, cy, cx, 1.0, split=True)
    else:
        bands = polar_bands(h, w, cy, cx, zoom_window(value, False)[1], False)
    return max(n_r * n_phi for _, n_r, n_phi, _, _ in bands) * itemsize


def _rings(shape):
    """Rings of the green zoom-in's one-band grid about the centre (its ray terms' length)."""
    h, w = shape
    return polar_bands(h, w, (h - 1) / 2.0, (w - 1) / 2.0)[0][1]


class _Counts:
    """What one call built, took from fresh memory, planned and uploaded (differences of counters)."""

    def __init__(self, be, uploads):
        self.be, self.uploads = be, uploads

    def _now(self):
        return (program_builds(self.be), fresh_pool_blocks(self.be), recursion._plan_cached.cache_info().misses,
                zoom._segment_terms.cache_info().misses, len(self.uploads))

    def __enter__(self):
        self.be.synchronize()
        self._start = self._now()
        return self

    def __exit__(self, *exc):
        self.be.synchronize()
        diff = [None if a is None else b - a for a, b in zip(self._start, self._now())]
        self.builds, self.fresh, self.plans, self.terms, _ = diff
        self.uploads_made = self.uploads[self._start[-1]:]      # the sizes of this call's uploads
        return False


@pytest.fixture
def uploads(backend, monkeypatch):
    """Host arrays ``backend.asarray`` uploaded from now on (their sizes), recorded."""
    made = []
    asarray = backend.asarray

    def counted(host, *args, **kwargs):
        made.append(np.asarray(host).nbytes)
        return asarray(host, *args, **kwargs)

    monkeypatch.setattr(backend, "asarray", counted)
    return made


@pytest.mark.parametrize("kind,value,psf", CASES)
def test_a_new_size_builds_nothing_and_the_same_size_again_redoes_nothing(backend, uploads, kind, value, psf, rng):
    be = backend
    for sizes in ([_workspace_bytes(s, kind, value, 4) for s in SHAPES], [h * w * 4 for h, w in SHAPES]):
        first = size_class(sizes[0])        # the premise of the pool count
        assert all(size_class(b) <= first <= size_class(size_class(b) + 1) for b in sizes), sizes
    assert len({_rings(s) for s in SHAPES}) > 1 and all(_rings(s) % 16 == 0 for s in SHAPES)
    images = [rng.random(s, dtype=np.float32) for s in SHAPES]
    # a rate the other tests do not use: the ray zoom's terms of these ring counts are computed here
    value = value * 1.0123
    zoom._segment_terms.cache_clear()       # process-wide: another backend's run made these ring counts
    gfgpu.motion.motion_blur(images[0], value, kind=kind, psf=psf, backend=be)
    rings = {_rings(images[0].shape)}
    for x in images[1:]:
        with _Counts(be, uploads) as new:
            out = np.array(gfgpu.motion.motion_blur(x, value, kind=kind, psf=psf, backend=be))
        assert new.builds in (None, 0), "a new size built a kernel"
        assert new.fresh in (None, 0), "a new size within the classes took fresh host memory"
        terms = int((kind, psf) == ("zoom", "green") and _rings(x.shape) not in rings)
        rings.add(_rings(x.shape))
        assert new.terms == terms, "the ray terms: once per ring count, for the green zoom only"
        if be.name == "opencl":     # (numpy's asarray is the input itself) a ring's tables, never image-sized
            assert all(n < x.nbytes // 4 for n in new.uploads_made), f"a new size uploaded {new.uploads_made} bytes"
        with _Counts(be, uploads) as again:
            repeat = np.array(gfgpu.motion.motion_blur(x, value, kind=kind, psf=psf, backend=be))
        assert again.builds in (None, 0) and again.fresh in (None, 0)
        assert again.plans == 0, "the same size planned again"
        assert again.terms == 0, "the same size computed the ray terms again"
        if be.name == "opencl":
            assert again.uploads_made == [], "the same size uploaded again (the small arrays are kept by content)"
        np.testing.assert_array_equal(repeat, out)


def _mean_correction_numpy_scalars(lam_full, kap_full, kap_own, s, u1):
    """The moments' recursion of :func:`gfgpu.motion.zoom._mean_correction` as it ran before (numpy
    scalars in the loop): the reference whose bits the Python-scalar loop must keep."""
    n = len(s)
    m0, m1, m_first = np.empty(n), np.empty(n), np.empty(n)
    f0 = f1 = f_first = 0j
    for k in range(n):
        own = kap_own[k].real
        m0[k], m1[k], m_first[k] = f0.real + own, f1.real + own * s[k], f_first.real + (own if k == 0 else 0.0)
        f0 = lam_full[k] * f0 + kap_full[k]
        f1 = lam_full[k] * f1 + kap_full[k] * s[k]
        f_first = lam_full[k] * f_first + (kap_full[k] if k == 0 else 0.0)
    excess = 1.0 - m0
    prev = np.empty(n)
    prev[1:] = s[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        d_prev = (s / (1.0 + u1) - m1 - excess * s) / (prev - s)
    d_prev[0] = 0.0
    d_prev[s <= 0] = 0.0
    if u1 < 0:
        d_prev[np.abs(m_first) > 1e-9] = 0.0
    excess = np.where(d_prev == 0.0, 0.0, excess)
    return d_prev, excess - d_prev


@pytest.mark.parametrize("u1", [0.1, -0.1, 0.02, -0.3, 0.9, 1.5, -0.8])
@pytest.mark.parametrize("s0,n", [(0.0, 1), (0.0, 3), (0.0, 1456), (0.5, 200), (7.25, 64)])
def test_the_ray_terms_keep_the_bits_of_the_numpy_scalar_recursion(u1, s0, n):
    lam_full, kap_full, kap_own, d_prev, d_own = zoom._segment_terms.__wrapped__(u1, s0, n)
    s = s0 + (np.arange(n - 1, -1, -1.0) if u1 < 0 else np.arange(n, dtype=np.float64))
    want_prev, want_own = _mean_correction_numpy_scalars(lam_full, kap_full, kap_own, s, u1)
    assert d_prev.tobytes() == want_prev.tobytes() and d_own.tobytes() == want_own.tobytes()


@pytest.mark.parametrize("shape", [(512, 512), (600, 560)])
def test_a_zoom_after_a_spin_takes_one_of_its_workspace_arrays_from_the_spins_block(backend, shape, rng):
    """The split spin grid's two arrays are one pool block of a zoom array's size class (its largest band is
    about half the zoom's one-band grid): a zoom after a spin takes one fresh workspace block, not two."""
    be = backend
    if getattr(be, "_host_pool", None) is None:
        pytest.skip(f"{be!r} keeps no host pool (memory is not counted here)")
    h, w = shape
    cy, cx = (h - 1) / 2.0, (w - 1) / 2.0
    spin = max(n_r * n_phi for _, n_r, n_phi, _, _ in polar_bands(h, w, cy, cx, 1.0, split=True))
    ring = polar_bands(h, w, cy, cx)[0]
    assert size_class(2 * (-(-spin // 64) * 64) * 4) == size_class(ring[1] * ring[2] * 4)     # the premise
    x = rng.random(shape, dtype=np.float32)
    out = np.empty_like(x)          # the caller's output: no pooled result block
    be.synchronize()
    be._host_pool.clear()           # blocks earlier tests released would serve the zoom too
    gfgpu.motion.motion_blur(x, 10.0, kind="rotation", backend=be, output=out)
    be.synchronize()
    before = fresh_pool_blocks(be)
    gfgpu.motion.motion_blur(x, 0.1, kind="zoom", psf="green", backend=be, output=out)
    be.synchronize()
    assert fresh_pool_blocks(be) - before == 1
