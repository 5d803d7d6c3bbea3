"""The two-sided step kernels of an OpenCL CPU device (gfgpu/backends/opencl/twosided.cl:
``two_sided`` along columns, ``two_sided_rows`` along rows) against a float64 reference that does
not share their algorithm: each pass's taps (``tap`` at 0, ``Re(kap lam^(m-1))`` at ``m >= 1``)
summed directly over the line padded by its boundary mode (numpy.pad).

Shapes cover lines shorter than a tile and than a chunk, odd widths and heights, partial vectors
and bands, single lines, 3-D stacks; every mode with a non-zero cval; one and two inputs and
outputs; the finite check's verdict for a bad sample anywhere; outputs that are numpy arrays
wrapped at any element offset (``output=``); and the public derivative / gradient on top.
"""

import numpy as np
import pytest
from oracle import NP_PAD

import gfgpu
from gfgpu import greens
from gfgpu._core.twosided import plan_two_sided
from gfgpu.edges import operator

MODES = ["reflect", "nearest", "wrap", "constant", "mirror"]
TOL = {np.float32: 1e-5, np.float64: 1e-12}
CVALS = (0.7, -0.3)


def _taps(lp, length):
    """Taps of one pass at offsets 0 .. length - 1 (float64, the section's closed form)."""
    m = np.arange(length)
    h = np.where(m == 0, lp.tap, 0.0)
    for s in lp.sections:
        lam, kap = complex(s.lam), complex(s.kap)
        h = h + np.where(m >= 1, (kap * lam ** np.maximum(m - 1, 0)).real, 0.0)
    return h


def _margin(passes):
    """Samples after which every tap is below 1e-20 of the first."""
    worst = max(abs(complex(s.lam)) for lp in passes for s in lp.sections)
    return int(np.ceil(np.log(1e-20) / np.log(worst))) + 2 if worst > 0 else 2


def direct(lines, passes, mode, cval):
    """Sum of ``passes`` along axis 0 of ``lines`` (n, k), by direct summation in float64."""
    x = np.asarray(lines, np.float64)
    n = x.shape[0]
    pad = _margin(passes)
    if mode == "constant":
        ext = np.pad(x, ((pad, pad), (0, 0)), mode="constant", constant_values=cval)
    elif mode == "mirror" and n == 1:
        ext = np.pad(x, ((pad, pad), (0, 0)), mode="edge")
    else:
        ext = np.pad(x, ((pad, pad), (0, 0)), mode=NP_PAD[mode])
    out = np.zeros_like(x)
    for lp in passes:
        h = _taps(lp, pad + 1)
        for m in range(pad + 1):
            j = pad - m if not lp.reverse else pad + m
            out += h[m] * ext[j:j + n]
    return out


def _passes(kind):
    """(P, D): the chapter's operator, the one-signed one (real poles), P at another scale."""
    if kind == "chapter":
        return greens.projection_passes(1.3), greens.derivative_passes(1.3)
    if kind == "one-signed":
        return operator.projection_passes(1.1), operator.derivative_passes(1.1)
    return greens.projection_passes(0.6), greens.derivative_passes(1.7)


def _as_lines(a, axis):
    """(B, N, M) array -> (line length, lines) with the lines along ``axis``."""
    return np.moveaxis(a, axis, 0).reshape(a.shape[axis], -1)


def _run(be, plan, xs, axis, cvals=CVALS, check=False, dsts=None):
    from gfgpu.backends.opencl.twosided import run_two_sided
    if dsts is None:
        dsts = [be.empty(xs[0].shape, xs[0].dtype) for _ in plan.inputs]
    verdict = run_two_sided(be, [be.asarray(x) for x in xs], dsts, axis, plan, cvals, check=check)
    return verdict, [be.to_host(d) for d in dsts]


def _check_outputs(got, xs, spec, axis, mode, cvals, dtype):
    for g, (i, passes) in zip(got, spec):
        ref = direct(_as_lines(xs[i], axis), passes, mode, cvals[i])
        err = np.abs(_as_lines(g, axis) - ref).max()
        assert err <= TOL[dtype] * max(np.abs(ref).max(), 1.0), (mode, err)


# (B, N, M): lines shorter than a tile (8 float32 rows) and a chunk (16), odd sizes, one line,
# several images, rows beyond a vector of rows
SHAPES = [(1, 5, 7), (2, 9, 33), (1, 1, 3), (3, 1, 5), (1, 17, 1), (1, 70, 40), (2, 41, 19), (1, 23, 131),
          (4, 3, 50)]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("axis", [1, 2])
@pytest.mark.parametrize("shape", SHAPES)
def test_steps_match_direct_sums(cpu_opencl, dtype, axis, shape, rng):
    be = cpu_opencl
    n = shape[axis]
    for kind, mode, outputs in (("chapter", "reflect", "D"), ("chapter", "nearest", "PD"),
                                ("ratio", "wrap", "DP2"), ("one-signed", "constant", "PD"),
                                ("chapter", "mirror", "DP2"), ("one-signed", "mirror", "D"),
                                ("ratio", "constant", "D")):
        P, D = _passes(kind)
        spec = {"PD": [(0, P), (0, D)], "D": [(0, D)], "DP2": [(0, D), (1, P)]}[outputs]
        plan = plan_two_sided(spec, n, mode, dtype)
        xs = [rng.standard_normal(shape).astype(dtype) for _ in set(plan.inputs)]
        verdict, got = _run(be, plan, xs, axis, check=True)
        assert verdict is True
        _check_outputs(got, xs, spec, axis, mode, CVALS, dtype)


@pytest.mark.parametrize("axis", [1, 2])
def test_long_lines_and_stacks(cpu_opencl, axis, rng):
    """Lines of many chunks and bands, a 3-D stack, every mode."""
    be = cpu_opencl
    shape = (3, 37, 203) if axis == 2 else (3, 203, 37)
    P, D = _passes("chapter")
    x = rng.standard_normal(shape).astype(np.float32)
    for mode in MODES:
        spec = [(0, P), (0, D)]
        plan = plan_two_sided(spec, shape[axis], mode, np.float32)
        _, got = _run(be, plan, [x], axis)
        _check_outputs(got, [x], spec, axis, mode, CVALS, np.float32)


@pytest.mark.parametrize("axis", [1, 2])
def test_check_sees_every_sample(cpu_opencl, axis, rng):
    """The finite check rides on the backward sweep: a NaN, an infinity or a sample beyond the
    range limit anywhere in input 0 (ends, chunks, the last partial vector) is seen; input 1 is
    not checked."""
    be = cpu_opencl
    shape = (2, 19, 45)
    P, D = _passes("chapter")
    plan = plan_two_sided([(0, D), (1, P)], shape[axis], "reflect", np.float32)
    x = rng.standard_normal(shape).astype(np.float32)
    y = rng.standard_normal(shape).astype(np.float32)
    assert _run(be, plan, [x, y], axis, check=True)[0] is True
    for where in ((0, 0, 0), (1, 18, 44), (0, 7, 20), (1, 10, 3), (0, 3, 40)):
        for bad in (np.nan, -np.inf, 2.0**70):
            z = x.copy()
            z[where] = bad
            assert _run(be, plan, [z, y], axis, check=True)[0] is False, (where, bad)
    y[0, 5, 5] = np.nan
    assert _run(be, plan, [x, y], axis, check=True)[0] is True


@pytest.mark.parametrize("axis", [1, 2])
@pytest.mark.parametrize("offset", [0, 1, 3, 4, 7, 12])
@pytest.mark.parametrize("shape", [(1, 128, 160), (2, 550, 16), (1, 600, 32)])
def test_numpy_outputs_at_any_offset(cpu_opencl, axis, offset, shape, rng):
    """Outputs that are numpy arrays starting at any element of a cache line (a caller's output=,
    wrapped in place): the tiles and vectors align to them or fall back (rows of one chunk or
    less after the aligned start), the same values."""
    be = cpu_opencl
    P, D = _passes("chapter")
    spec = [(0, P), (0, D)]
    plan = plan_two_sided(spec, shape[axis], "reflect", np.float32)
    x = rng.standard_normal(shape).astype(np.float32)
    size = int(np.prod(shape))
    hosts = [np.zeros(size + 64, np.float32)[16 + offset:16 + offset + size].reshape(shape) for _ in range(2)]
    dsts = [be.host_result(shape, np.float32, into=h) for h in hosts]
    assert all(d.gfgpu_host is h for d, h in zip(dsts, hosts))     # used in place (64 KiB and more)
    _, got = _run(be, plan, [x], axis, dsts=dsts)
    _check_outputs(got, [x], spec, axis, "reflect", CVALS, np.float32)
    _, plain = _run(be, plan, [x], axis)
    for g, p in zip(got, plain):
        np.testing.assert_array_equal(g, p)


def test_refusals(cpu_opencl, rng):
    from gfgpu.backends.opencl.twosided import run_two_sided, takes
    be = cpu_opencl
    x = be.asarray(rng.standard_normal((1, 9, 10)).astype(np.float32))
    plan = plan_two_sided([(0, greens.derivative_passes(1.0))], 10, "reflect", np.float32)
    with pytest.raises(ValueError, match="axis must be 1"):
        run_two_sided(be, [x], [be.empty(x.shape, np.float32)], 0, plan)
    with pytest.raises(ValueError, match="lines of 10"):
        run_two_sided(be, [x], [be.empty(x.shape, np.float32)], 1, plan)
    with pytest.raises(ValueError, match="overlaps"):
        run_two_sided(be, [x], [x], 2, plan)
    units = int(be.cl_device.max_compute_units)
    assert takes(be, (1, 3, 64), 1) and takes(be, (1, 8 * units, 100), 2)
    # a band's scratch holds whole vectors of BAND cache lines per row: narrow columns would need
    # many times the image (the generic passes run them), float64 bands are half as wide
    assert not takes(be, (1, 3, 5), 1) and not takes(be, (1, 16384, 8), 1)
    assert takes(be, (1, 3, 16), 1, np.float64) and not takes(be, (1, 3, 31), 1, np.float32)
    assert takes(be, (1, 3, 43), 1, nin=1, nout=2) and not takes(be, (1, 3, 42), 1, nin=1, nout=2)
    assert not takes(be, (1, 8 * units - 1, 100), 2)       # too few rows: the generic primitive
    assert not takes(be, (1, 64 * units, 1 << 16), 2)      # rows beyond the scratch
    assert not takes(be, (1, 64, 64), 0)
    assert not takes(gfgpu.backends.get_backend("numpy"), (1, 64, 64), 1)


def separable_direct(img, d_axis, axes, mode, cval, P, D):
    """P along the other axes, then D along ``d_axis`` (the program's order), by direct sums in float64."""
    out = img.astype(np.float64)
    for ax in [a for a in axes if a != d_axis] + [d_axis]:
        lines = np.moveaxis(out, ax, 0)
        summed = direct(lines.reshape(lines.shape[0], -1), D if ax == d_axis else P, mode, cval)
        out = np.moveaxis(summed.reshape(lines.shape), 0, ax)
    return out


@pytest.mark.parametrize("mode", MODES)
def test_public_calls_match_direct_sums(cpu_opencl, mode, rng):
    """derivative (both axes, into output=) and gradient of an image and a 3-D stack on the
    OpenCL CPU device against the separable direct sums: P along the other axes, D along one."""
    be = cpu_opencl
    cval = 1.3
    P, D = greens.projection_passes(1.2), greens.derivative_passes(1.2)

    def ref(img, d_axis, axes):
        return separable_direct(img, d_axis, axes, mode, cval, P, D)

    img = (rng.random((45, 77)) * 10).astype(np.float32)
    for axis in (0, 1):
        out = np.full(img.shape, 5.0, np.float32)
        got = gfgpu.derivative(img, 1.2, axis=axis, output=out, mode=mode, cval=cval, backend=be)
        assert got is out
        r = ref(img, axis, (0, 1))
        assert np.abs(out - r).max() <= 4 * TOL[np.float32] * np.abs(r).max()
    for got, d_axis in zip(gfgpu.gradient(img, 1.2, mode=mode, cval=cval, backend=be), (0, 1)):
        r = ref(img, d_axis, (0, 1))
        assert np.abs(got - r).max() <= 4 * TOL[np.float32] * np.abs(r).max()
    vol = (rng.random((3, 21, 34)) * 10).astype(np.float32)
    for got, d_axis in zip(gfgpu.gradient(vol, 1.2, axes=(1, 2), mode=mode, cval=cval, backend=be), (1, 2)):
        r = ref(vol, d_axis, (1, 2))
        assert np.abs(got - r).max() <= 4 * TOL[np.float32] * np.abs(r).max()


@pytest.mark.parametrize("axis", [0, 1])
def test_public_refusal_leaves_output(cpu_opencl, axis, rng):
    """A non-finite image is refused whichever axis the first (checked) step runs along, before
    the caller's output is written."""
    img = rng.random((40, 300)).astype(np.float32)
    img[31, 257] = np.inf
    out = np.full_like(img, 3.0)
    with pytest.raises(ValueError, match="NaN or infinite"):
        gfgpu.derivative(img, 1.0, axis=axis, output=out, backend=cpu_opencl)
    assert (out == 3.0).all()
    with pytest.raises(ValueError, match="NaN or infinite"):
        gfgpu.gradient(img, 1.0, backend=cpu_opencl)
