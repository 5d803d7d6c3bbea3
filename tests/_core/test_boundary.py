"""The boundary modes (gfgpu._core.boundary): the index map against numpy.pad and scipy.ndimage,
one definition for every host copy, and device kernels that take the mode codes from the Python
definitions instead of retyping them (the stereo constants: tests/stereo/test_constants.py)."""
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from gfgpu._core import boundary
from gfgpu._core.boundary import MODE_CODES, MODES, PERIODIC_MODES, check_mode, extend_index, period

ROOT = Path(__file__).resolve().parents[2]

#: scipy.ndimage's mode -> the numpy.pad mode that extends a line the same way
NP_PAD = {"constant": "constant", "nearest": "edge", "reflect": "symmetric", "mirror": "reflect", "wrap": "wrap"}

#: explicit tables: the index of samples -4 .. 5 of lines of 1 and 2 samples (-1: cval)
SMALL = {
    (1, "constant"): [-1, -1, -1, -1, 0, -1, -1, -1, -1, -1],
    (1, "nearest"): [0] * 10,
    (1, "reflect"): [0] * 10,
    (1, "mirror"): [0] * 10,
    (1, "wrap"): [0] * 10,
    (2, "constant"): [-1, -1, -1, -1, 0, 1, -1, -1, -1, -1],
    (2, "nearest"): [0, 0, 0, 0, 0, 1, 1, 1, 1, 1],
    (2, "reflect"): [0, 1, 1, 0, 0, 1, 1, 0, 0, 1],        # b a | a b | b a a b
    (2, "mirror"): [0, 1, 0, 1, 0, 1, 0, 1, 0, 1],         # a b a | b a b
    (2, "wrap"): [0, 1, 0, 1, 0, 1, 0, 1, 0, 1],
}


def padded_index(n, k, mode):
    """The index of every sample of a line of ``n`` padded by ``k`` on both sides, by numpy.pad of
    the indices themselves (-1 where the pad is cval)."""
    idx = np.arange(n)
    if mode == "constant":
        return np.pad(idx, k, mode="constant", constant_values=-1)
    return np.pad(idx, k, mode=NP_PAD[mode])


# --------------------------------------------------------------------------------------
# the index map
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
@pytest.mark.parametrize("mode", MODES)
def test_extend_index_is_numpy_pad(mode, n):
    k = 5 * n + 3                                       # several periods on both sides
    i = np.arange(-k, n + k)
    got = extend_index(i, n, mode)
    assert got.dtype == np.int64 and got.shape == i.shape
    np.testing.assert_array_equal(got, padded_index(n, k, mode))


@pytest.mark.parametrize("n", [1, 2, 3, 6])
@pytest.mark.parametrize("mode", MODES)
def test_extend_index_is_scipy_ndimage(mode, n):
    """The names mean what scipy.ndimage's filters do: a correlation with a one-hot kernel reads
    the extended line at ``x + s``."""
    line = np.arange(1.0, n + 1)                        # sample j holds j + 1
    reach = 3 * n + 2
    for s in range(-reach, reach + 1):
        weights = np.zeros(2 * reach + 1)
        weights[reach + s] = 1.0
        out = ndimage.correlate1d(line, weights, mode=mode, cval=-9.0)
        seen = np.where(out == -9.0, -1, out.astype(np.int64) - 1)
        np.testing.assert_array_equal(extend_index(np.arange(n) + s, n, mode), seen, err_msg=f"shift {s}")


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("n", [1, 2])
def test_extend_index_of_the_shortest_lines(n, mode):
    assert extend_index(np.arange(-4, 6), n, mode).tolist() == SMALL[n, mode]


@pytest.mark.parametrize("n", [1, 2, 5, 8])
@pytest.mark.parametrize("mode", MODES)
def test_extend_index_far_beyond_the_line(mode, n):
    """Indices of 1e15 and beyond, negative and positive: the numpy.pad table of one period, read
    at the index reduced by Python's exact integer arithmetic."""
    far = [10**15 + r for r in range(-3, 4)] + [2**53 + 1, 2**62 - 1]
    i = far + [-v for v in far]
    got = extend_index(i, n, mode)
    if mode == "constant":
        assert (got == -1).all()
        return
    if mode == "nearest":
        assert got.tolist() == [n - 1 if v > 0 else 0 for v in i]
        return
    p = {"wrap": n, "reflect": 2 * n, "mirror": max(2 * n - 2, 1)}[mode]
    table = padded_index(n, p, mode)[p:]                # samples 0 .. n + p - 1
    assert got.tolist() == [int(table[v % p]) for v in i]


def test_extend_index_takes_scalars_and_empty_arrays():
    assert extend_index(-1, 4, "reflect") == 0 and extend_index(5, 4, "wrap") == 1
    assert np.ndim(extend_index(-1, 4, "mirror")) == 0
    empty = extend_index(np.zeros((0, 3), np.int32), 4, "mirror")
    assert empty.shape == (0, 3) and empty.dtype == np.int64


def test_unknown_modes_are_refused_with_the_modes_listed():
    message = "mode must be one of constant, nearest, reflect, mirror, wrap; got 'symmetric'"
    for call in (lambda: check_mode("symmetric"), lambda: extend_index([0, -1], 4, "symmetric"),
                 lambda: period(4, "symmetric")):
        with pytest.raises(ValueError, match=re.escape(message)):
            call()
    assert check_mode("wrap") == "wrap"


@pytest.mark.parametrize("n", [1, 2, 3, 6])
@pytest.mark.parametrize("mode", MODES)
def test_period_is_the_period_of_the_extension(mode, n):
    table = padded_index(n, 8 * n + 4, mode)
    p = period(n, mode)
    if mode not in PERIODIC_MODES:
        assert p is None
        return
    assert (table[p:] == table[:-p]).all()
    smallest = next(q for q in range(1, p + 1) if (table[q:] == table[:-q]).all())
    assert smallest == p or (n, mode) == (1, "reflect")      # one sample repeats with any period


def test_the_mode_codes_number_every_mode_once():
    assert set(MODE_CODES) == set(MODES) and set(PERIODIC_MODES) <= set(MODES)
    assert sorted(MODE_CODES.values()) == list(range(len(MODES)))
    assert all(type(code) is int for code in MODE_CODES.values())


def test_the_host_copies_are_the_one_definition():
    """The names the index map, the codes and the mode check had before are the definitions of
    gfgpu._core.boundary, not copies."""
    from gfgpu._core import lines, recursion, translation
    from gfgpu.motion import spec as motion_spec
    assert not hasattr(recursion, "extension_index") and not hasattr(lines, "_extend")   # the old copies
    assert recursion.MODES is MODES and recursion.check_mode is check_mode
    assert motion_spec.MODE_CODES is MODE_CODES and motion_spec.extend_index is extend_index
    for mode in MODES:
        for n, offset, pad in ((1, 3, 2), (5, -7, 4), (6, 40, 3)):
            # the translated window, its offset reduced by whole periods (or saturated beyond the line)
            np.testing.assert_array_equal(extend_index(np.arange(n + 2 * pad) - pad - offset, n, mode),
                                          translation.window_index(n, offset, pad, mode))


# --------------------------------------------------------------------------------------
# device code takes its constants from the Python definitions
# --------------------------------------------------------------------------------------
def _source(path):
    return (ROOT / path).read_text(encoding="utf-8")


def _code_lines(text, comment):
    """The lines of ``text`` without their comments (``comment`` = "//" or "#")."""
    return [line.split(comment)[0] for line in text.splitlines()]


def test_motion_device_code_names_the_codes_it_compares():
    """No boundary-mode or PSF code is written as a number in motion.cl or the Warp kernels (the
    launchers pass MODE_* / PSF_* defines and Warp constants from the Python definitions)."""
    numbered = re.compile(r"\b(mode(_x|_y)?|psf)\s*(==|!=|>=|<=|<|>)\s*-?\d")
    for path, comment in (("gfgpu/motion/motion.cl", "//"), ("gfgpu/motion/_warp.py", "#")):
        bad = [line.strip() for line in _code_lines(_source(path), comment) if numbered.search(line)]
        assert not bad, f"{path} compares codes as numbers: {bad}"
    cl = _source("gfgpu/motion/motion.cl")
    assert "MODE_X < 1" not in cl and "jf, 4, 2," not in cl
    assert "jf, 4, 2," not in _source("gfgpu/motion/_warp.py")


def test_opencl_motion_kernels_take_the_mode_codes_from_boundary(require_backend, monkeypatch, rng):
    """Built with the codes permuted, every motion kernel still extends by the right mode: the
    codes reach the kernels only through the launcher's defines and arguments."""
    be = require_backend("opencl")
    from gfgpu.motion import kernels
    from gfgpu.motion import spec as specs
    permuted = {"constant": 3, "nearest": 4, "wrap": 0, "reflect": 1, "mirror": 2}
    assert all(permuted[m] != MODE_CODES[m] for m in MODES)
    for mode, code in permuted.items():
        monkeypatch.setitem(boundary.MODE_CODES, mode, code)

    def close(got, ref, what):
        ref = np.asarray(ref)
        got = be.to_host(got).reshape(ref.shape)
        assert np.abs(got - ref).max() <= 2e-5 * max(1.0, np.abs(ref).max()), what

    src = rng.standard_normal((1, 7, 33)).astype(np.float32)       # no vector kernel: 7 rows, 33 columns
    for mode in MODES:
        for axis in (1, 2):
            dst = be.empty(src.shape, np.float32)
            kernels.box_lines(be, be.asarray(src), dst, axis, -20.5, 1.0, 3.25, 1.0, mode, 0.7)
            close(dst, specs.box_lines_reference(src, axis, -20.5, 1.0, 3.25, 1.0, mode, 0.7), f"box_lines {mode}")
    coef = rng.standard_normal((1, 12, 14)).astype(np.float32)
    field = (rng.standard_normal((2, 12, 14)) * 4).astype(np.float32)
    for mode in MODES:
        out = be.empty(coef.shape, np.float32)
        kernels.field_blur(be, be.asarray(coef), be.asarray(field), out, 0, 2.0, mode, 0.3)
        close(out, specs.field_blur_reference(coef, field, 0, 2.0, mode, 0.3), f"field_blur {mode}")
    pcoef = rng.standard_normal((1, 18, 64)).astype(np.float32)     # radius mirrored, angle wrapped
    base = rng.standard_normal((1, 20, 24)).astype(np.float32)
    back = be.empty(base.shape, np.float32)
    kernels.from_polar(be, be.asarray(pcoef), be.asarray(base), back, 9.5, 11.2, 0, 0.0, np.inf)
    close(back, specs.from_polar_reference(pcoef, base, 9.5, 11.2, 0, 0.0, np.inf), "from_polar")
