"""Passes along oblique directions (gfgpu._core.oblique): the sheared operator against an
independent direct summation, the continuous-direction operator (its transfer function on a
periodic image), the displacement of every pixel's impulse response, and the per-line plans
the shears are built from (gfgpu._core.recursion.line_plans, gfgpu._core.shiftfit)."""
import math

import numpy as np
import pytest
from oracle import NP_PAD, box_transfer_reference, direct_line, direction_geometry, relerr, transfer_reference
from scipy.signal import lfilter

import gfgpu
from gfgpu import greens
from gfgpu._core import oblique, recursion, shiftfit
from gfgpu._core.passes import LinePass
from gfgpu._core.program import direction_steps
from gfgpu._core.recursion import MODES
from gfgpu.motion import motion_blur
from gfgpu.motion.uniform import uniform_motion_program

TOL = {np.float32: 1e-5, np.float64: 1e-12}
#: the issue's velocities (vy, vx) and their transposes
VELOCITIES = [(7, 30), (17, 40), (29, -13), (30, 7), (40, 17), (-13, 29)]


def _dtypes(backend):
    return [np.float32, np.float64] if backend.supports_float64 else [np.float32]


# --------------------------------------------------------------------------------------
# independent references
# --------------------------------------------------------------------------------------
def _thiran3(d):
    """Denominator (1, a1, a2, a3) of Thiran's third-order allpass of delay d, in closed form."""
    return [1.0, -3 * (d - 3) / (d + 1), 3 * (d - 3) * (d - 2) / ((d + 1) * (d + 2)),
            -(d - 3) * (d - 2) * (d - 1) / ((d + 1) * (d + 2) * (d + 3))]


def _allpass_taps(d, count=160):
    """Impulse response of Thiran's third-order allpass of delay d, by its difference equation."""
    a = _thiran3(d)
    impulse = np.zeros(count)
    impulse[0] = 1.0
    return lfilter(a[::-1], a, impulse)


def _pad_minor(plane, k, mode, cval):
    width = ((k, k), (0, 0))
    if mode == "constant":
        return np.pad(plane, width, mode="constant", constant_values=cval)
    if mode == "mirror" and plane.shape[0] == 1:
        return np.pad(plane, width, mode="edge")
    return np.pad(plane, width, mode=NP_PAD[mode])


def sheared_reference(image, kernels, angle, mode, cval=0.0, anticausal=False):
    """float64 direct summation of the sheared operator (module docstring of gfgpu._core.oblique).

    Column t of the image (rows: the minor axis) is read at ``l + r[t]`` from the image padded
    across the minor axis by numpy.pad and advanced by the delay ``d[t] = γ t - r[t]`` (0, or in
    [2.3, 3.3)) with the allpass taps (direct convolution), every line ``l`` is filtered with
    each closed-form kernel of ``kernels`` in turn by direct summation along the dominant axis
    (its own boundary extension, numpy.pad), then column t is delayed by ``d[t]`` and read back
    at ``m - r[t]``.
    """
    img = np.asarray(image, np.float64)
    steep, reverse, gamma = direction_geometry(angle)
    plane = img.T if steep else img                      # (minor, dominant)
    across, steps = plane.shape
    t = np.arange(steps)
    exact = gamma * t
    r = np.floor(exact - 1.3).astype(int) - 1
    whole = np.abs(exact - np.round(exact)) < 1e-12
    r[whole] = np.round(exact[whole]).astype(int)
    d = exact - r
    d[whole] = 0
    taps = 160
    lo, hi = -int(r.max()) - 2 * taps, across - 1 - int(r.min()) + 2 * taps    # lines computed
    pad = int(np.abs(r).max()) + 3 * taps + across
    padded = _pad_minor(plane, pad, mode, cval)
    ell = np.arange(lo, hi + 1)
    grid = padded[ell[:, None] + r[None, :] + pad, t[None, :]]       # (lines, steps)

    def delay_columns(a, ahead):
        out = a.copy()
        for k in range(steps):
            if d[k] == 0:
                continue
            col = np.zeros(len(a))
            for m, wm in enumerate(_allpass_taps(d[k], taps)):
                if ahead:       # out[l] = Σ w[m] a[l + m]
                    col[:len(a) - m] += wm * a[m:, k]
                else:           # out[l] = Σ w[m] a[l - m]
                    col[m:] += wm * a[:len(a) - m, k]
            out[:, k] = col
        return out

    rows = delay_columns(grid, True)
    for kernel in kernels:
        rows = np.stack([direct_line(line, kernel, mode, cval, anticausal=(reverse != anticausal)) for line in rows])
    back = delay_columns(rows, False)
    m = np.arange(across)
    out = back[(m[:, None] - r[None, :]) - lo, t[None, :]]
    return out.T if steep else out


def _kernel(name, n, reverse):
    far = -3.5 if not reverse else n - 1 + 3.5
    return {
        "G_u": greens.UniformGreen(2.3),
        "H_u": greens.HomogeneousGreen(1.7),
        "G_U1": greens.AffineGreen(0.6, far),
        "G_U2": greens.AffineGreenApprox(6.0, -40.0 if not reverse else n - 1 + 40.0),
    }[name]


def _image(rng, shape=(13, 17)):
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    return 1.0 + 0.3 * np.sin(xx / 3.0) + 0.2 * (yy > shape[0] // 2) + 0.1 * rng.standard_normal(shape)


# --------------------------------------------------------------------------------------
# the sheared operator, exactly
# --------------------------------------------------------------------------------------
ANGLES = {"30deg": math.pi / 6, "110deg": math.radians(110), "-160deg": math.radians(-160),
          "-75deg": math.radians(-75)}


_REFERENCES = {}


def _reference_case(kname, mode, direction, anticausal):
    """(image, kernel, reference) of one case, computed once for all backends."""
    key = (kname, mode, direction, anticausal)
    if key not in _REFERENCES:
        angle = ANGLES[direction]
        img = _image(np.random.default_rng(12345))
        steep, reverse, _ = direction_geometry(angle)
        kernel = _kernel(kname, img.shape[0] if steep else img.shape[1], reverse != anticausal)
        _REFERENCES[key] = img, kernel, sheared_reference(img, [kernel], angle, mode, 0.5, anticausal)
    return _REFERENCES[key]


@pytest.mark.parametrize("anticausal", [False, True])
@pytest.mark.parametrize("direction", list(ANGLES))
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kname", ["G_u", "H_u", "G_U1", "G_U2"])
def test_green_filter_along_an_angle_is_the_sheared_operator(backend, kname, mode, direction, anticausal):
    img, kernel, ref = _reference_case(kname, mode, direction, anticausal)
    for dtype in _dtypes(backend):
        out = gfgpu.green_filter(img.astype(dtype), kernel, angle=ANGLES[direction], mode=mode, cval=0.5,
                                 anticausal=anticausal, backend=backend)
        assert out.dtype == dtype and out.shape == img.shape
        err = relerr(out, ref)
        assert err <= TOL[dtype], f"{dtype.__name__}: relative error {err:.2e}"


@pytest.mark.parametrize("angle", [0.3, 1.2, -2.0, 2.8, math.pi / 4])
def test_both_layouts_give_the_same_result(backend, rng, angle):
    img = rng.standard_normal((2, 21, 26))
    steps, plane = direction_steps(3, [greens.UniformGreen(3.0).line_pass()], angle, None)
    passes = steps[0][0]
    for dtype in _dtypes(backend):
        src = backend.asarray(img.astype(dtype))
        outs = []
        for transposed in (False, True):
            dst = backend.empty(img.shape, dtype)
            oblique.run_oblique_passes(backend, src, dst, dtype, passes, "mirror", 0.0, angle, plane, transposed)
            outs.append(backend.to_host(dst))
        np.testing.assert_allclose(outs[0], outs[1], rtol=0, atol=1e-5 if dtype == np.float32 else 1e-12)


#: shallow and steep directions of both signs, a diagonal-ish one (slope near 1: the widest
#: spread of shear offsets within a vector of lanes)
SHEAR_ANGLES = [0.3, -2.9, 1.2, -1.9, 0.76]


def _oblique_against_numpy(be, img, angle, mode, transposed):
    """run_oblique_passes on ``be`` (float32 and, where it has it, float64) against the numpy
    backend's (the generic gather and per-line recursions), rel. L2 within TOL."""
    steps, plane = direction_steps(3, [greens.UniformGreen(3.0).line_pass()], angle, None)
    passes = steps[0][0]
    numpy_be = gfgpu.get_backend("numpy")
    ref = numpy_be.empty(img.shape, np.float64)
    oblique.run_oblique_passes(numpy_be, numpy_be.asarray(img), ref, np.float64, passes, mode, 0.4, angle, plane,
                               transposed)
    for dtype in _dtypes(be):
        dst = be.empty(img.shape, dtype)
        oblique.run_oblique_passes(be, be.asarray(img.astype(dtype)), dst, dtype, passes, mode, 0.4, angle, plane,
                                   transposed)
        err = relerr(be.to_host(dst), ref)
        assert err <= TOL[dtype], f"{dtype.__name__}: relative error {err:.2e}"


@pytest.mark.parametrize("transposed", [None, False, True])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("angle", SHEAR_ANGLES)
@pytest.mark.parametrize("shape", [(2, 45, 53), (1, 30, 21)], ids=str)
def test_every_shear_layout_matches_the_generic_path(backend, shape, angle, mode, transposed):
    """Every layout and boundary mode (OpenCL: each variant of its fused shear kernels, the CPU
    ones with partial vectors of steps, and work-items whose last vectors have no step) equals
    the numpy backend's gathers and per-line passes."""
    img = np.random.default_rng(31).standard_normal(shape)
    _oblique_against_numpy(backend, img, angle, mode, transposed)


@pytest.mark.parametrize("transposed", [False, True])
@pytest.mark.parametrize("angle", SHEAR_ANGLES)
def test_shears_in_gpu_launch_shapes(gpu_shaped, angle, transposed):
    """The GPU launch shapes (OpenCL: one step per work-item) forced on the CPU devices."""
    img = np.random.default_rng(32).standard_normal((2, 29, 38))
    for mode in ("reflect", "constant", "wrap"):
        _oblique_against_numpy(gpu_shaped, img, angle, mode, transposed)


def test_steps_along_one_direction_share_one_shear(backend, rng):
    """run_oblique_steps: the groups in turn between one shear and one shear back."""
    img = _image(rng, (15, 19))
    angle = 0.45
    a, b = greens.UniformGreen(1.5), greens.HomogeneousGreen(2.5)
    ref = sheared_reference(img, [a, b], angle, "reflect")
    for dtype in _dtypes(backend):
        src = backend.asarray(img.astype(dtype))
        dst = backend.empty(img.shape, dtype)
        oblique.run_oblique_steps(backend, src, dst, dtype, [[a.line_pass()], [b.line_pass()]], "reflect", 0.0,
                                  angle, (0, 1))
        assert relerr(backend.to_host(dst), ref) <= TOL[dtype]


@pytest.mark.parametrize("angle", [math.pi / 4, -3 * math.pi / 4, math.atan2(-1, 1)])
def test_a_translation_along_a_diagonal_moves_whole_pixels(backend, rng, angle):
    """A pass with offset n along a diagonal (no fraction) translates by n steps along the
    direction of traversal: (n sin, n cos) / max(|sin|, |cos|) pixels, read from the wrap extension."""
    img = rng.standard_normal((16, 16))
    n = 3
    lp = LinePass((), 1.0, False, n)
    steps, plane = direction_steps(2, [lp], angle, None)
    dy, dx = round(n * math.sin(angle) * math.sqrt(2)), round(n * math.cos(angle) * math.sqrt(2))
    expect = np.roll(img, (dy, dx), axis=(0, 1))
    dst = backend.empty(img.shape, np.float32)
    oblique.run_oblique_passes(backend, backend.asarray(img.astype(np.float32)), dst, np.float32, steps[0][0],
                               "wrap", 0.0, angle, plane)
    np.testing.assert_array_equal(backend.to_host(dst), expect.astype(np.float32))


@pytest.mark.parametrize("angle", [0.4, -2.3, 1.3])
def test_a_translated_pass_is_the_pass_then_the_translation(backend, rng, angle):
    """A pass with offset n along an oblique direction (mode wrap: the line's own period) equals
    the pass followed by the translation by n steps, inside the same shear."""
    img = rng.standard_normal((2, 17, 23))
    lp = greens.UniformGreen(1.7).line_pass()
    n = 4
    for dtype in _dtypes(backend):
        src = backend.asarray(img.astype(dtype))
        one, two = backend.empty(img.shape, dtype), backend.empty(img.shape, dtype)
        oblique.run_oblique_steps(backend, src, one, dtype, [[LinePass(lp.sections, lp.tap, False, n)]], "wrap", 0.0,
                                  angle, (1, 2))
        oblique.run_oblique_steps(backend, src, two, dtype, [[lp], [LinePass((), 1.0, False, n)]], "wrap", 0.0,
                                  angle, (1, 2))
        np.testing.assert_allclose(backend.to_host(one), backend.to_host(two), rtol=0,
                                   atol=2e-6 if dtype == np.float32 else 1e-12)


# --------------------------------------------------------------------------------------
# against the continuous direction
# --------------------------------------------------------------------------------------
def _torus_shape(velocity, b):
    """(H, W) on which the lines of this direction close on themselves: γ W ≡ 0 (mod H)."""
    return abs(velocity[0]) * b, abs(velocity[1]) * b


def _astronaut(shape):
    from skimage import data
    img = data.astronaut()[: shape[0], : shape[1]].astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    return img - img.mean()


@pytest.mark.parametrize("velocity", VELOCITIES, ids=str)
def test_motion_blur_follows_the_continuous_direction(backend, velocity):
    """rel. L2 error against the transfer function along the exact direction on a periodic image
    (the astronaut, mean removed, on a shape whose lines close: mode 'wrap' is then the torus)."""
    shape = _torus_shape(velocity, 12)
    img = _astronaut(shape)
    ref = transfer_reference(img, uniform_motion_program(2, velocity))
    for dtype in _dtypes(backend):
        out = motion_blur(img.astype(dtype), velocity, mode="wrap", backend=backend)
        assert relerr(out, ref) <= 1e-2, f"{dtype.__name__}: {relerr(out, ref):.2e}"     # measured 2.7e-3 .. 5.7e-3


def test_smooth_images_are_nearly_exact(backend):
    """A band-limited image (white noise below 1/8 of Nyquist): the resampling blur is small."""
    rng = np.random.default_rng(5)
    for velocity in [(7, 30), (-13, 29)]:
        shape = _torus_shape(velocity, 10)
        wy = np.fft.fftfreq(shape[0])[:, None] * 2
        wx = np.fft.fftfreq(shape[1])[None, :] * 2
        img = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * (np.hypot(wy, wx) <= 0.125)))
        ref = transfer_reference(img, uniform_motion_program(2, velocity))
        out = motion_blur(img.astype(np.float32), velocity, mode="wrap", backend=backend)
        assert relerr(out, ref) <= 1e-5        # measured 2.8e-7 (float32 rounding); second-order allpass 1.6e-4


#: velocities (vy, vx) and shapes on which their lines close (γ W ≡ 0 mod H, or γ H ≡ 0 mod W):
#: steep, shallow, near 45° and reversed
TORUS_CASES = [((23, -9), (230, 90)), ((3, 25), (96, 800)), ((25, 24), (100, 96)), ((-7, -30), (70, 300))]


@pytest.mark.parametrize("case", TORUS_CASES, ids=lambda c: str(c[0]))
def test_oblique_box_and_green_blur_at_a_quarter_cycle_per_pixel(backend, case):
    """Band-limited noise up to 0.25 cycles/px (a disc), mode 'wrap' on a shape whose lines close:
    the box and the Green blur along the exact direction, by Fourier, over the whole image
    (borders included). Measured 0.2-0.5 % on every backend (second-order allpass: 2.8-6.8 %)."""
    velocity, shape = case
    rng = np.random.default_rng(3)
    wy, wx = np.fft.fftfreq(shape[0])[:, None], np.fft.fftfreq(shape[1])[None, :]
    img = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * (np.hypot(wy, wx) < 0.25)))
    img /= img.std()
    refs = {"box": box_transfer_reference(img, velocity),
            "green": transfer_reference(img, uniform_motion_program(2, velocity))}
    for dtype in _dtypes(backend):
        for psf, ref in refs.items():
            out = motion_blur(img.astype(dtype), velocity, psf=psf, mode="wrap", backend=backend)
            assert relerr(out, ref) <= 1e-2, f"{psf}, {dtype.__name__}: {relerr(out, ref):.2e}"


@pytest.mark.parametrize("velocity", VELOCITIES, ids=str)
def test_every_pixel_moves_by_the_velocity(backend, velocity):
    """The centroid of the impulse response of a pixel in every column (row, when steep) of one
    period of the fractions ``γ t`` is the pixel plus the velocity (the issue asks for 0.05 px).

    The planes hold 6 velocity lengths of the kernel's tail; the rest (mode 'constant': lost) is
    accounted for exactly: along the line the response is the 1-D taps w[m], so its centroid is
    ``Σ m w / Σ w`` over the steps kept, times the step ``(vy, vx) / L``.
    """
    vy, vx = velocity
    steep = abs(vy) > abs(vx)
    length = max(abs(vy), abs(vx))
    dom_v, min_v = (vy, vx) if steep else (vx, vy)
    period = length                                   # γ t mod 1 repeats after |dominant| steps
    dom = 6 * length + period + 24
    # the whole line, 100 px from the edges (the column allpass's response, |pole| <= 0.71, is
    # below 1e-15 there: nothing of it leaves the plane)
    minor = -(-dom * abs(min_v) // length) + 200
    lam, kap, tap = greens.shift_coefficients(float(length))
    m = np.arange(dom)
    w = np.concatenate([[tap], np.real(kap * lam ** (m[1:] - 1))])
    planes, src, expect = [], [], []
    for k in range(period):
        t = 12 + k if dom_v > 0 else dom - 13 - k
        m0 = 100 if min_v > 0 else minor - 101
        kept = dom - t if dom_v > 0 else t + 1        # steps of the response inside the plane
        mean = (m[:kept] * w[:kept]).sum() / w[:kept].sum()
        plane = np.zeros((dom, minor) if steep else (minor, dom))
        pos = (t, m0) if steep else (m0, t)
        plane[pos] = 1.0
        planes.append(plane)
        src.append(pos)
        expect.append((mean * vy / length, mean * vx / length, w[:kept].sum()))
    stack = np.stack(planes)
    src, expect = np.array(src, np.float64), np.array(expect)
    yy, xx = np.mgrid[: stack.shape[1], : stack.shape[2]]
    for dtype in _dtypes(backend):
        out = motion_blur(stack.astype(dtype), velocity, mode="constant", backend=backend).astype(np.float64)
        mass = out.sum(axis=(1, 2))
        cy = (out * yy).sum(axis=(1, 2)) / mass - src[:, 0]
        cx = (out * xx).sum(axis=(1, 2)) / mass - src[:, 1]
        err = max(np.abs(cy - expect[:, 0]).max(), np.abs(cx - expect[:, 1]).max())
        assert np.abs(mass - expect[:, 2]).max() < 1e-5
        assert err < (1e-3 if dtype == np.float32 else 1e-8), f"{dtype.__name__}: centroid off by {err:.2e} px"
        # and against the velocity itself, whatever the truncation (the issue's target)
        full = max(np.abs(cy - vy).max(), np.abs(cx - vx).max())
        assert full < 0.05 or np.abs(expect[:, :2] - [vy, vx]).max() > 0.01


@pytest.mark.parametrize("angle", [0.3, -2.2, 1.9, math.atan2(13, -29)])
def test_linear_content_is_moved_exactly(backend, angle):
    """Both resamplings keep DC and the first moment, so on a ramp ``a·p + c`` any pass along the
    direction gives exactly ``Σw·(a·p + c) - (a·d) Σ m w`` (taps w along the step d), away from
    the borders."""
    h, w = 240, 250
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    a = (0.3, -0.2)
    ramp = a[0] * yy + a[1] * xx + 5.0
    u = 1.5
    taps = greens.g_uniform(np.arange(120.0), u)          # point samples, offset 0 ... 119
    dc, first = taps.sum(), (np.arange(120) * taps).sum()
    steep, reverse, gamma = direction_geometry(angle)
    sign = -1 if reverse else 1
    dy, dx = (sign * 1.0, sign * gamma) if steep else (sign * gamma, sign * 1.0)
    expect = dc * ramp - (a[0] * dy + a[1] * dx) * first
    inner = (yy > 100) & (yy < h - 100) & (xx > 100) & (xx < w - 100)     # beyond the columns' allpass tails
    for dtype in _dtypes(backend):
        out = gfgpu.green_filter(ramp.astype(dtype), greens.UniformGreen(u), angle=angle, mode="nearest",
                                 backend=backend)
        tol = 2e-5 if dtype == np.float32 else 1e-11
        assert np.abs(out - expect)[inner].max() < tol * np.abs(expect).max()


# --------------------------------------------------------------------------------------
# the per-line plans: vectorised coefficients and initial states
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("gamma", [7 / 30, -13 / 29, 0.3183, 0.5, -1e-3, 1 / 3 + 1e-9])
def test_column_delays_are_allpass_with_exact_moments(gamma):
    """The cascade of stages is Thiran's third-order allpass (its difference equation): unit
    magnitude, moments 0..6 of the taps equal d^p (maximally flat delay), decayed by the margin.
    gamma = 1/3 + 1e-9 puts delays within 1e-8 of 3, where the three poles gather near 0."""
    steps = 97
    stages, d, margin = oblique.column_delays(steps, gamma)
    assert len(stages) == 2
    count = 400
    m = np.arange(1, count)
    j = np.arange(count, dtype=np.float64)
    omega = np.linspace(0, np.pi, 9)
    for k in np.nonzero(d)[0]:
        assert 2.3 - 1e-12 <= d[k] < 3.3
        w = np.zeros(count)
        w[0] = 1.0
        for lam, kap, tap in stages:
            assert abs(lam[k]) < 0.72
            w = np.convolve(w, np.concatenate([[tap[k]], np.real(kap[k] * lam[k] ** (m - 1))]))[:count]
        np.testing.assert_allclose(w, _allpass_taps(d[k], count), rtol=0, atol=1e-13)
        for p in range(7):
            assert (j ** p * w).sum() == pytest.approx(d[k] ** p, rel=1e-11, abs=1e-11)
        if abs(d[k] - 3) > 0.05:        # and not beyond (at d = 3 the filter is the exact delay z^-3)
            assert (j ** 7 * w).sum() != pytest.approx(d[k] ** 7, rel=1e-6)
        np.testing.assert_allclose(np.abs(np.exp(-1j * np.outer(omega, j)) @ w), 1, atol=1e-12)   # no blur
        assert np.abs(w[margin:]).max() < 1e-17
    for _lam, kap, tap in stages:
        assert (tap[d == 0] == 1).all() and (kap[d == 0] == 0).all()
    assert oblique.column_delays(steps, gamma) is oblique.column_delays(steps, gamma)
    assert oblique.column_delays(steps, gamma, "<f4")[2] < margin      # float32 tolerance: shorter


def test_vectorised_shift_coefficients_match_the_scalar_fit():
    u = np.concatenate([np.geomspace(1e-4, 60, 300), [0.5, 1 / np.pi, 1 / (2 * np.pi), shiftfit.SMALL_SHIFT]])
    lam, kap, tap = greens.shift_coefficients_many(u)
    assert lam.shape == kap.shape == tap.shape == u.shape
    for i, v in enumerate(u):
        m = np.arange(1, int(80 * v) + 80)
        one = greens.shift_coefficients(float(v))
        assert one[0] == pytest.approx(lam[i], rel=1e-15)
        a = np.concatenate([[one[2]], np.real(one[1] * one[0] ** (m - 1))])
        b = np.concatenate([[tap[i]], np.real(kap[i] * lam[i] ** (m - 1))])
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
        k = np.arange(len(b))
        assert b.sum() == pytest.approx(1, abs=1e-12) and (k * b).sum() == pytest.approx(v, abs=1e-10 * max(v, 1))
    # any shape
    assert greens.shift_coefficients_many(np.full((2, 3), 0.7))[1].shape == (2, 3)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("n", [1, 2, 3, 7, 50, 200])
def test_line_plans_match_plan_pass_line_by_line(mode, n, dtype):
    passes = [greens.shift_pass(a) for a in (0.3, -0.7, 2.5, -11.0, 0.05, 40.0, -300.0)]
    passes += [None, greens.UniformGreen(1.3).line_pass(), greens.HomogeneousGreen(2.0).line_pass(reverse=True)]
    plans = recursion.plan_lines(passes, n, mode, dtype)
    assert plans.omega.dtype == (np.complex64 if dtype == np.float32 else np.complex128)
    rel = 1e-7 if dtype == np.float32 else 1e-13      # complex64 storage; float64 rounding of long series
    for i, lp in enumerate(passes):
        if lp is None:
            assert plans.tap[i] == 1 and plans.lam[i] == 0 and not plans.omega[i].any() and plans.omega_c[i] == 0
            continue
        one = recursion.plan_pass(lp, n, mode, dtype)
        assert plans.lam[i] == one.lam[0, 0] and plans.kap[i] == one.kap[0, 0] and plans.tap[i] == one.tap
        assert plans.reverse[i] == one.reverse
        assert plans.omega_c[i] == pytest.approx(one.omega_c[0], rel=1e-14, abs=1e-300)
        width = max(plans.omega.shape[1], one.omega.shape[1])
        a = np.pad(plans.omega[i].astype(np.complex128), (0, width - plans.omega.shape[1]))
        b = np.pad(one.omega[0], (0, width - one.omega.shape[1]))
        scale = max(np.abs(b).max(initial=0), 1e-300)
        # plan_pass truncates its series below tol relative to the largest weight
        assert np.abs(a - b).max(initial=0) <= scale * (rel + 10 * recursion.TOL[np.dtype(dtype)])


def test_line_plans_from_arrays():
    lam, kap, tap = greens.shift_coefficients_many([0.4, 2.0, 0.4])
    plans = recursion.line_plans(lam, kap, tap, [False, True, False], 9, "reflect", np.float64,
                                 identity=[False, False, True])
    assert plans.lines == 3 and plans.n == 9
    assert plans.tap[2] == 1 and plans.lam[2] == 0 and plans.kap[2] == 0 and not plans.omega[2].any()
    np.testing.assert_array_equal(plans.reverse, [False, True, False])
    with pytest.raises(ValueError, match="decaying"):
        recursion.line_plans([1.0 + 0j], [1.0], [0.0], [False], 4, "wrap", np.float64)
    with pytest.raises(ValueError, match="mode must be one of"):
        recursion.line_plans(lam, kap, tap, False, 9, "edge", np.float64)
    packed = plans.packed(np.float32)
    assert packed[4].dtype == np.float32 and packed[4].shape == plans.omega.shape + (2,)


# --------------------------------------------------------------------------------------
# issue 27: the graphics velocities, on smooth noise and impulses, box and Green PSFs
# --------------------------------------------------------------------------------------
#: the issue's velocities (vy, vx), their mirror images and transposes
ISSUE_VELOCITIES = [(2, 7), (7, 25), (23, 101), (-2, 7), (7, -25), (-23, -101), (7, 2), (-25, 7)]


def _gaussian_noise(shape, sigma, seed):
    """White noise filtered by a Gaussian of ``sigma`` px (periodic, by its transfer function)."""
    rng = np.random.default_rng(seed)
    wy = 2 * np.pi * np.fft.fftfreq(shape[0])[:, None]
    wx = 2 * np.pi * np.fft.fftfreq(shape[1])[None, :]
    img = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal(shape)) * np.exp(-0.5 * sigma**2 * (wy**2 + wx**2))))
    return img / img.std()


@pytest.mark.parametrize("velocity", ISSUE_VELOCITIES, ids=str)
def test_issue_velocities_follow_the_continuous_direction_on_smooth_noise(backend, velocity):
    """Gaussian-filtered noise (σ = 2 px) on a shape whose lines close (mode 'wrap' is the torus):
    box and Green blur within 1 % (rel. L2, 16-px margin) of the operator along the exact direction
    by Fourier.  Measured 0.016-0.027 % (float32) on numpy, Warp and OpenCL."""
    b = max(1, -(-128 // max(abs(velocity[0]), abs(velocity[1]))))
    shape = _torus_shape(velocity, b)
    if min(shape) < 48:
        shape = _torus_shape(velocity, b * -(-48 // min(shape)))
    img = _gaussian_noise(shape, 2.0, 11)
    refs = {"box": box_transfer_reference(img, velocity),
            "green": transfer_reference(img, uniform_motion_program(2, velocity))}
    inner = (slice(16, -16), slice(16, -16))
    for dtype in _dtypes(backend):
        for psf, ref in refs.items():
            out = motion_blur(img.astype(dtype), velocity, psf=psf, mode="wrap", backend=backend)
            err = relerr(out[inner], ref[inner])
            assert err <= 1e-2, f"{psf}, {dtype.__name__}: {err:.2e}"


@pytest.mark.parametrize("velocity", [(2, 7), (7, 25), (-25, 7), (-2, -7)], ids=str)
@pytest.mark.parametrize("psf", ["green", "box"])
def test_every_pixel_of_a_period_moves_by_the_velocity(backend, velocity, psf):
    """An impulse in each column (row, when steep) of one period of the shear's fractions, far
    from every edge (mode 'constant', the whole response kept): its centroid is the pixel plus the
    velocity (Green PSF) or half of it (box: the exposure's mean position), within 0.05 px
    (measured in float32: Green 6e-6 .. 6e-5 px, box 4e-8 .. 4e-6 px, every backend)."""
    vy, vx = velocity
    steep = abs(vy) > abs(vx)
    length = max(abs(vy), abs(vx))
    dom_v, min_v = (vy, vx) if steep else (vx, vy)
    # the response runs ahead along the motion only; the Green PSF's tail decays by e per length
    # (14 lengths: below 1e-6, its first moment's share below 1e-3 px)
    reach = (14 if psf == "green" else 1) * length
    dom = reach + length + 40
    minor = -(-dom * abs(min_v) // length) + 200
    planes, src = [], []
    for k in range(length):
        t = 20 + k if dom_v > 0 else dom - 21 - k
        m0 = 100 if min_v > 0 else minor - 101
        plane = np.zeros((dom, minor) if steep else (minor, dom))
        pos = (t, m0) if steep else (m0, t)
        plane[pos] = 1.0
        planes.append(plane)
        src.append(pos)
    stack, src = np.stack(planes), np.array(src, np.float64)
    expect = np.array([vy, vx], np.float64) * (1.0 if psf == "green" else 0.5)
    yy, xx = np.mgrid[: stack.shape[1], : stack.shape[2]]
    for dtype in _dtypes(backend):
        out = motion_blur(stack.astype(dtype), velocity, psf=psf, mode="constant", backend=backend)
        out = out.astype(np.float64)
        mass = out.sum(axis=(1, 2))
        cy = (out * yy).sum(axis=(1, 2)) / mass - src[:, 0]
        cx = (out * xx).sum(axis=(1, 2)) / mass - src[:, 1]
        err = max(np.abs(cy - expect[0]).max(), np.abs(cx - expect[1]).max())
        assert np.abs(mass - 1).max() < 1e-4
        assert err < 0.05, f"{dtype.__name__}: centroid off by {err:.3f} px"


@pytest.mark.parametrize("velocity", [(3, 11), (-11, 3)], ids=str)
def test_a_stack_is_blurred_plane_by_plane(backend, velocity):
    """Planes of a stack share one shear (one launch on the device): each equals its own blur."""
    rng = np.random.default_rng(8)
    stack = rng.standard_normal((3, 37, 53))
    for dtype in _dtypes(backend):
        for psf in ("green", "box"):
            whole = motion_blur(stack.astype(dtype), velocity, psf=psf, mode="constant", cval=0.3, backend=backend)
            for i in range(3):
                one = motion_blur(stack[i].astype(dtype), velocity, psf=psf, mode="constant", cval=0.3,
                                  backend=backend)
                np.testing.assert_allclose(whole[i], one, rtol=0, atol=TOL[dtype] * 10)


def test_thin_strips_along_steep_slopes_are_refused_before_work():
    """A sheared layout whose size the plane does not account for is refused (issue 31: 3 x 5000
    along (3, 7) would run on 11 M samples for 15,000 pixels); along the other axis it runs."""
    img = np.zeros((3, 5000), np.float32)
    for psf in ("box", "green"):
        with pytest.raises(ValueError, match="sheared samples"):
            motion_blur(img, (3, 7), psf=psf, backend="numpy")
        with pytest.raises(ValueError, match="sheared samples"):
            motion_blur(img.T.copy(), (7, 3), psf=psf, backend="numpy")
        with pytest.raises(ValueError, match="sheared samples"):
            gfgpu.green_filter(img, greens.UniformGreen(2.0), angle=math.atan2(3, 7), backend="numpy")
    assert motion_blur(img, (7, 3), backend="numpy").shape == img.shape
    assert oblique.layout_samples(3, 5000, math.atan2(3, 7), np.float32) > oblique.LAYOUT_FLOOR
