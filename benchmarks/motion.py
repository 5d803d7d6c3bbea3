"""Motion blur side by side: speed and accuracy of every kind against its peers and issue 27's targets.

One run prints (Markdown) and optionally writes as JSON (``--json PATH``):

1. **Speed** (float32, numpy in and out with ``output=``, the backends of ``--backends``): uniform
   axis-aligned (0, L), L = 5/25/101, and oblique (2, 7), (7, 25), (23, 101) with their mirror
   images (signs flipped) on SIZE²; a velocity field (2, S, S) with |v| up to 30 px, spin 10° and
   zoom 0.1 on S², S = SIZE/2; green and box PSFs.  Each gfgpu row's *first call* runs on a
   shape no call of the process has seen, within 80 rows and columns of n² (multiples of 16;
   its time scaled to n²), after calls on a 128² image with the same parameters (which build
   the kernels); the *steady state* is the best of the calls on n² after one warm-up call (none
   for a peer whose call takes longer than ``--budget``: it builds nothing).  Peers in
   the same run: ``cv2.filter2D`` with the equivalent 2-D kernels (a box along the segment,
   MATLAB's ``fspecial('motion')``, the sampled G_u; each only as large as its support, anchored
   as the blur displaces), ``kornia.filters.motion_blur`` (torch CPU), the usual accumulation of
   K warped copies (``cv2.remap``/``cv2.warpAffine``) for fields, spin and zoom, and
   ``numpy.copyto`` (the memory bound).  A call whose time, estimated from the 128² calls
   (256², 512², ... while fixed costs may inflate the estimate), exceeds ``--call-limit`` seconds
   is not run at full size: its row shows the estimate, marked "est.".  Steady calls stop after
   ``--repeat`` calls or ``--budget`` seconds (at least one).
2. **Accuracy** on Gaussian-filtered white noise (sigma = 2 px), float32, each backend, 16-px
   margin: oblique blurs against the same operator along the continuous direction (its Fourier
   transfer function, on shapes whose lines close on the torus, mode wrap) and their impulse
   centroids (one impulse per phase of the line's fractions, mode constant); oblique, field,
   spin and zoom against supersampled renderings (>= 512 exactly warped copies, cubic spline,
   weighted by a Gauss-Legendre quadrature of the PSF in time); the field on every backend
   against the first; a spin by 1e-6 degrees against the image.
3. **Record** (numpy, float64): impulse centroids and step edges along axes and diagonals, and
   the zoom's pre-image (the zoom of the coordinate images), as measured since issue 15.

Every row states its target (issue 27's acceptance; issue 15's 2 % for renderings issue 27 sets
no bound on) and PASS/FAIL computed from the measurement; "est." where the figure is an estimate.
The load (``uptime``) is printed at the start and the end: timings on a shared machine are
inflated by it.

Usage:  python benchmarks/motion.py [--size 4096] [--repeat 3] [--backends opencl[,warp,numpy]]
        [--quick] [--json PATH] [--skip-speed] [--skip-accuracy] [--skip-record] [--figure]
        [--section axis|oblique|field|polar ...]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import gfgpu
from gfgpu.motion import motion_blur, uniform_motion_program

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import motion_refs as refs  # noqa: E402

# The continuous-direction oracles are the tests' (tests/oracle.py); tests/ is no package.
sys.path.insert(0, str(HERE.parent / "tests"))
from oracle import box_transfer_reference, transfer_reference  # noqa: E402

LENGTHS = (5, 25, 101)
OBLIQUE = ((2, 7), (7, 25), (23, 101))
PSFS = ("green", "box")
FIELD_MAX = 30.0
SPIN_DEGREES = 10.0
ZOOM_U1 = 0.1
PROBE = 128            # side of the image that builds the kernels and estimates a call's time
MARGIN = 16

# issue 27's acceptance
OBLIQUE_MPIX = {"green": 150.0, "box": 100.0}
OBLIQUE_VS_CV2 = 1.5
FIELD_MPIX = {"green": 10.0, "box": 20.0}
POLAR_WARM_S = 0.25
POLAR_FIRST_RATIO = 1.5
OBLIQUE_TRANSFER = 0.01
CENTROID_PX = 0.05
FIELD_RENDER = 0.02
RENDER = 0.02            # issue 15's bound for the renderings issue 27 sets none on
AGREE = 1e-4             # backends equal within float32 rounding: of max |out|
# "nothing slower than today": issue 27's measured axis-aligned rows (4096², OpenCL), Mpix/s
AXIS_TODAY = {"green": (403.0, 407.0, 396.0), "box": (147.0, 157.0, 177.0)}


# --------------------------------------------------------------------------------------
# measurement
# --------------------------------------------------------------------------------------
@dataclass
class Timing:
    pixels: int                   # of the image the steady calls ran on
    steady: float                 # seconds, best of the steady calls (or the estimate)
    calls: int                    # steady calls made (0: estimated)
    first: float | None = None    # seconds, the first call on a fresh shape, scaled to ``pixels``
    first_shape: tuple | None = None   # that fresh shape
    first_raw: float | None = None     # seconds, as measured on it
    probe: int = 0                # estimated: the side of the square image it was timed on

    @property
    def mpix(self):
        return self.pixels / 1e6 / self.steady

    @property
    def estimated(self):
        return self.calls == 0


@dataclass
class Row:
    section: str
    case: str
    method: str
    target: str = ""
    met: bool | None = None
    timing: Timing | None = None
    value: float | None = None        # accuracy rows: the measurement
    unit: str = ""
    note: str = ""
    error: str = ""                   # the exception a call raised (the run goes on)


def _call(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def npix(shape):
    return int(np.prod(shape))


#: fresh shapes differ from the measured one by FRESH_STEP x (-FRESH_MAX .. FRESH_MAX) rows and
#: columns: multiples of 16, as the vector lanes of the CPU kernels (a partial group of lines can
#: take a slower path: a horizontal box blur on 4095 x 4096 ran 5-7x slower than on 4096² on
#: the OpenCL CPU device when this was written)
FRESH_STEP, FRESH_MAX = 16, 5


class Bench:
    """The options, the fresh shapes and the rows of one run."""

    def __init__(self, opts):
        self.opts = opts
        self.rows = []
        self.section_s = {}
        self.used = set()
        pad = FRESH_STEP * FRESH_MAX
        self.base = np.random.default_rng(0).random((opts.size + pad, opts.size + pad), dtype=np.float32)
        steps = range(-FRESH_MAX, FRESH_MAX + 1)
        self.offsets = sorted(((i, j) for i in steps for j in steps if (i, j) != (0, 0)),
                              key=lambda ij: (max(abs(ij[0]), abs(ij[1])), ij))

    def image(self, shape):
        """A contiguous float32 image of ``shape`` (cut from one random image)."""
        return np.ascontiguousarray(self.base[: shape[0], : shape[1]])

    def fresh(self, shape):
        """A shape within FRESH_STEP * FRESH_MAX rows and columns of ``shape`` (FRESH_MAX for
        images under 1024²) that no call of this run has seen (kept in ``used``)."""
        step = FRESH_STEP if min(shape) >= 1024 else 1          # small (--quick) images: within a few %
        for i, j in self.offsets:
            cand = (shape[0] + step * i, shape[1] + step * j)
            if cand not in self.used and min(cand) > 0:
                self.used.add(cand)
                return cand
        raise RuntimeError(f"no fresh shape left near {shape}: fewer rows or backends per run")

    def measure(self, make, shape, fresh=True):
        """Time ``make(shape)()``: probe calls on small images (which build the kernels) estimate
        the call; then the first call on a fresh shape (``fresh``), one warm-up call on ``shape``
        and steady calls on it (``--repeat``, ``--budget``)."""
        opts = self.opts
        shape = tuple(shape)
        self.used.add(shape)
        estimate, side = self.estimate(make, shape)
        if estimate > opts.call_limit:
            return Timing(npix(shape), estimate, 0, probe=side)
        timing = Timing(npix(shape), 0.0, 0)
        if fresh:
            timing.first_shape = self.fresh(shape)
            timing.first_raw = _call(make(timing.first_shape))
            timing.first = timing.first_raw * npix(shape) / npix(timing.first_shape)
        fn = make(shape)
        if fresh or estimate < opts.budget:             # the warm-up: this shape's first call is not steady
            fn()                                        # (a peer's slow call has no plans to build: no warm-up)
        times = []
        while len(times) < opts.repeat and (not times or sum(times) < opts.budget):
            times.append(_call(fn))
        timing.steady, timing.calls = min(times), len(times)
        return timing

    def estimate(self, make, shape):
        """``(seconds, side)``: a call on ``shape`` estimated from one on ``side``², from PROBE up,
        the side doubled while the estimate exceeds ``--call-limit`` (fixed costs inflate it on
        small images) and the next probe costs under a quarter of the limit."""
        limit = self.opts.call_limit
        side = PROBE
        while True:
            probe_shape = (min(shape[0], side), min(shape[1], side))
            self.used.add(probe_shape)
            probe = make(probe_shape)
            probe()                                     # kernel builds, plans for this shape
            scale = npix(shape) / npix(probe_shape)
            t = _call(probe)
            if t * scale > limit:                       # a second look: one slow call may be the machine
                t = min(t, _call(probe))
            if t * scale <= limit or probe_shape == tuple(shape) or 4 * t > limit / 4:
                return t * scale, side
            side *= 2

    def add(self, row):
        self.rows.append(row)
        return row


def guarded(fn, *args):
    """``fn(*args)``, or the exception's name and message (a peer or backend that fails is
    reported in its row; the run goes on)."""
    try:
        return fn(*args), ""
    except Exception as exc:
        return None, f"{type(exc).__name__}: {str(exc).splitlines()[0][:120] if str(exc) else ''}"


# --------------------------------------------------------------------------------------
# the calls: gfgpu and its peers, each ``make(shape) -> zero-argument call``
# --------------------------------------------------------------------------------------
def gfgpu_call(bench, velocity, backend, **kw):
    def make(shape):
        img = bench.image(shape)
        out = np.empty_like(img)
        v = velocity(shape) if callable(velocity) else velocity
        return lambda: motion_blur(img, v, output=out, backend=backend, **kw)
    return make


def cv2_filter_call(bench, kernel_anchor):
    ker, anchor = kernel_anchor

    def make(shape):
        import cv2  # here, so that a missing peer is a row's error (guarded), not the run's
        img = bench.image(shape)
        out = np.empty_like(img)
        return lambda: cv2.filter2D(img, -1, ker, dst=out, anchor=anchor, borderType=cv2.BORDER_REFLECT)
    return make


def kornia_call(bench, velocity):
    import kornia
    import torch
    size = int(math.ceil(math.hypot(*velocity))) | 1
    angle = math.degrees(math.atan2(-velocity[0], velocity[1]))

    def make(shape):
        t = torch.from_numpy(bench.image(shape))[None, None]

        def run():
            with torch.inference_mode():
                kornia.filters.motion_blur(t, size, angle, 0.0, border_type="reflect")
        return run
    return make, size


def copyto_call(bench):
    def make(shape):
        img = bench.image(shape)
        out = np.empty_like(img)
        return lambda: np.copyto(out, img)
    return make


def remap_field_call(bench, samples):
    """The usual post-process: ``samples`` bilinear taps along each pixel's own velocity."""

    def make(shape):
        import cv2  # here, so that a missing peer is a row's error (guarded), not the run's
        img = bench.image(shape)
        field = refs.velocity_field(shape, FIELD_MAX)
        yy, xx = np.mgrid[: shape[0], : shape[1]].astype(np.float32)
        acc = np.empty_like(img)

        def run():
            acc.fill(0)
            for t in (np.arange(samples, dtype=np.float32) + 0.5) / samples:     # float32 maps, as cv2 needs
                cv2.add(acc, cv2.remap(img, xx - t * field[1], yy - t * field[0], cv2.INTER_LINEAR,
                                       borderMode=cv2.BORDER_REFLECT), dst=acc)
            np.multiply(acc, 1.0 / samples, out=acc)
        return run
    return make


def warp_affine_call(bench, copies, matrix):
    """``copies`` affine warps (``matrix(shape, t)``, t in [0, 1]) accumulated: the usual spin
    or zoom blur."""

    def make(shape):
        import cv2  # here, so that a missing peer is a row's error (guarded), not the run's
        img = bench.image(shape)
        acc = np.empty_like(img)

        def run():
            acc.fill(0)
            for t in (np.arange(copies) + 0.5) / copies:
                cv2.add(acc, cv2.warpAffine(img, matrix(shape, t), shape[::-1], flags=cv2.INTER_LINEAR,
                                            borderMode=cv2.BORDER_REFLECT), dst=acc)
            np.multiply(acc, 1.0 / copies, out=acc)
        return run
    return make


def spin_matrix(shape, t):
    import cv2
    return cv2.getRotationMatrix2D(((shape[1] - 1) / 2, (shape[0] - 1) / 2), SPIN_DEGREES * t, 1.0)


def zoom_matrix(shape, t):
    import cv2
    a = ZOOM_U1 / (1 + ZOOM_U1)       # the pre-image moves linearly: c + (x - c)(1 - a t)
    return cv2.getRotationMatrix2D(((shape[1] - 1) / 2, (shape[0] - 1) / 2), 0.0, 1.0 / (1 - a * t))


def corner_radius(shape):
    return math.hypot(shape[0] - 1, shape[1] - 1) / 2


# --------------------------------------------------------------------------------------
# speed sections
# --------------------------------------------------------------------------------------
def speed_row(bench, section, case, method, make, shape, fresh=True):
    timing, err = guarded(bench.measure, make, shape, fresh)
    return bench.add(Row(section, case, method, timing=timing, error=err))


def peer_rows(bench, section, case, velocity, shape):
    """cv2.filter2D with the three line kernels and kornia: ``{kind: Row}``."""
    peers = {}
    kernels = (("box", "box along the segment", lambda: refs.box_line_kernel(velocity)),
               ("fspecial", "fspecial('motion')", lambda: (refs.fspecial_motion(
                   math.hypot(*velocity), math.degrees(math.atan2(-velocity[0], velocity[1]))), None)),
               ("green", "sampled G_u (tail < 1e-3)", lambda: refs.green_line_kernel(velocity)))
    for kind, label, build in kernels:
        built, err = guarded(build)
        if built is None:
            peers[kind] = bench.add(Row(section, case, f"cv2.filter2D, {label}", error=err))
            continue
        ker, anchor = built
        anchor = (-1, -1) if anchor is None else anchor         # fspecial's kernel is centred
        peers[kind] = speed_row(bench, section, case, f"cv2.filter2D, {label} ({ker.shape[0]}x{ker.shape[1]})",
                                cv2_filter_call(bench, (ker, anchor)), shape, fresh=False)
    made, err = guarded(kornia_call, bench, velocity)
    if made is None:
        bench.add(Row(section, case, "kornia.filters.motion_blur", error=err))
    else:
        make, size = made
        speed_row(bench, section, case, f"kornia.filters.motion_blur, torch CPU, {size}x{size}", make, shape,
                  fresh=False)
    return peers


def verdict(row, ok, target):
    row.target = target
    if row.timing is not None:
        row.met = bool(ok(row.timing))
    return row


def axis_section(bench):
    size, section = bench.opts.size, "uniform, axis-aligned"
    shape = (size, size)
    for i, L in enumerate(LENGTHS):
        case = f"(0, {L})"
        for psf in PSFS:
            for b in bench.opts.backends:
                row = speed_row(bench, section, case, f"gfgpu psf='{psf}', {b}",
                                gfgpu_call(bench, (0.0, float(L)), b, psf=psf), shape)
                today = AXIS_TODAY[psf][i]
                verdict(row, lambda t, today=today: t.mpix >= today, f">= {today:g} Mpix/s (issue 27's 'now')")
        peer_rows(bench, section, case, (0.0, float(L)), shape)
    speed_row(bench, section, f"{size}²", "numpy.copyto (memory bound)", copyto_call(bench), shape, fresh=False)


def mirrors(v):
    return [(sy * v[0], sx * v[1]) for sy, sx in ((1, 1), (-1, 1), (1, -1), (-1, -1))]


def oblique_target(psf, peers):
    """issue 27's bound for an oblique row: ``(Mpix/s needed, its statement)``; the peer is cv2
    with the G_u kernel (green) or the faster of the two box kernels (box)."""
    floor = OBLIQUE_MPIX[psf]
    kinds = ("green",) if psf == "green" else ("box", "fspecial")
    timings = [peers[k].timing for k in kinds if peers[k].timing is not None]
    if not timings:
        return floor, f">= {floor:g} Mpix/s (no cv2 peer)"
    peer = max(t.mpix for t in timings)
    need = max(floor, OBLIQUE_VS_CV2 * peer)
    which = "G_u kernel" if psf == "green" else "faster box kernel"
    return need, f">= {floor:g} and >= {OBLIQUE_VS_CV2:g} x cv2 {which} ({peer:.0f}): {need:.0f} Mpix/s"


def oblique_section(bench):
    size, section = bench.opts.size, "uniform, oblique"
    shape = (size, size)
    needs = []
    for v in OBLIQUE:
        peers = peer_rows(bench, section, f"{v} (peers: any sign)", v, shape)
        for m in mirrors(v):
            for psf in PSFS:
                need, target = oblique_target(psf, peers)
                for b in bench.opts.backends:
                    row = speed_row(bench, section, str(m), f"gfgpu psf='{psf}', {b}",
                                    gfgpu_call(bench, m, b, psf=psf), shape)
                    verdict(row, lambda t, need=need: t.mpix >= need, target)
                    needs.append((row, need))
    copy = speed_row(bench, section, f"{size}²", "numpy.copyto (memory bound)", copyto_call(bench), shape,
                     fresh=False)
    note_copy_bound(needs, copy)


def note_copy_bound(needs, copy):
    """Note on each ``(row, Mpix/s needed)`` whose bound exceeds the copy's rate in the same run: a
    blur reads the image and writes its result at least once, so nothing can meet it (cv2 runs a
    3 x 8 box kernel at about the copy's rate; 1.5 times that is out of reach).  The verdict stands."""
    if copy.timing is None:
        return
    for row, need in needs:
        if need > copy.timing.mpix:
            row.note = (f"bound above the copy ({copy.timing.mpix:.0f} Mpix/s, numpy.copyto in this run): "
                        f"no blur that reads and writes the image meets it")


def field_section(bench):
    n, section = bench.opts.size // 2, "velocity field"
    shape = (n, n)
    case = f"(2, {n}, {n}), |v| <= {FIELD_MAX:g}"
    field = lambda s: refs.velocity_field(s, FIELD_MAX)
    for psf in ("box", "green"):
        for b in bench.opts.backends:
            row = speed_row(bench, section, case, f"gfgpu psf='{psf}', {b}", gfgpu_call(bench, field, b, psf=psf),
                            shape)
            floor = FIELD_MPIX[psf]
            verdict(row, lambda t, floor=floor: t.mpix >= floor, f">= {floor:g} Mpix/s")
    samples = int(math.ceil(FIELD_MAX)) + 1
    made, err = guarded(remap_field_call, bench, samples)
    if made is None:
        bench.add(Row(section, case, "cv2.remap", error=err))
    else:
        speed_row(bench, section, case, f"{samples} x cv2.remap (bilinear) along each pixel's velocity, box",
                  made, shape, fresh=False)
    speed_row(bench, section, f"{n}²", "numpy.copyto (memory bound)", copyto_call(bench), shape, fresh=False)


def polar_section(bench):
    n, section = bench.opts.size // 2, "spin and zoom"
    shape = (n, n)
    r = corner_radius(shape)
    cases = ((f"spin {SPIN_DEGREES:g} deg", SPIN_DEGREES, "rotation", spin_matrix,
              int(math.ceil(r * math.radians(SPIN_DEGREES))) + 1),
             (f"zoom {ZOOM_U1:g}", ZOOM_U1, "zoom", zoom_matrix, int(math.ceil(r * ZOOM_U1 / (1 + ZOOM_U1))) + 1))
    for case, value, kind, matrix, copies in cases:
        for psf in PSFS:
            for b in bench.opts.backends:
                row = speed_row(bench, section, case, f"gfgpu psf='{psf}', {b}",
                                gfgpu_call(bench, value, b, kind=kind, psf=psf), shape)
                verdict(row, lambda t: t.steady <= POLAR_WARM_S and t.first is not None
                        and t.first <= POLAR_FIRST_RATIO * t.steady,
                        f"warm <= {POLAR_WARM_S:g} s, first <= {POLAR_FIRST_RATIO:g} x warm")
        made, err = guarded(warp_affine_call, bench, copies, matrix)
        if made is None:
            bench.add(Row(section, case, "cv2.warpAffine", error=err))
        else:
            speed_row(bench, section, case, f"{copies} x cv2.warpAffine (bilinear) accumulated, box", made, shape,
                      fresh=False)
    speed_row(bench, section, f"{n}²", "numpy.copyto (memory bound)", copyto_call(bench), shape, fresh=False)


# --------------------------------------------------------------------------------------
# accuracy sections
# --------------------------------------------------------------------------------------
def accuracy_row(bench, section, case, method, value, bound, unit="rel. L2", target=None, note="", error=""):
    """A measurement against an upper bound (``bound`` None: no target)."""
    met = None if bound is None or value is None or not np.isfinite(value) else bool(value <= bound)
    if target is None:
        target = "" if bound is None else (f"<= {bound * 100:g} %" if unit == "rel. L2" else f"<= {bound:g} {unit}")
    return bench.add(Row(section, case, method, target=target, met=met, value=value, unit=unit, note=note,
                         error=error))


def torus_shape(v, side):
    """``(|vy| b, |vx| b)``, both sides >= ``side``: every line closes on itself on the torus (on
    other shapes a line's wrap onto its own start differs from the torus for any line-based method)."""
    b = math.ceil(side / min(abs(v[0]), abs(v[1])))
    return abs(v[0]) * b, abs(v[1]) * b


def continuous_reference(img, v, psf):
    if psf == "box":
        return box_transfer_reference(img, v)
    return transfer_reference(img, uniform_motion_program(2, v))


def oblique_accuracy(bench):
    section = "accuracy, oblique"
    side = bench.opts.torus_side
    for v0 in OBLIQUE:
        for v in mirrors(v0):
            img = refs.texture(torus_shape(v, side))
            for psf in PSFS:
                ref, err = guarded(continuous_reference, img, v, psf)
                stack = refs.centroid_planes(v, psf, bench.opts.phases)
                for b in bench.opts.backends:
                    out, err2 = (None, err) if ref is None else guarded(
                        lambda b=b, img=img, v=v, psf=psf: motion_blur(img.astype(np.float32), v, psf=psf, mode="wrap",
                                                                   backend=b))
                    value = None if out is None else refs.rel_l2(out, ref, MARGIN)
                    accuracy_row(bench, section, str(v), f"psf='{psf}', {b}: vs continuous direction (Fourier), "
                                 f"{img.shape[0]}x{img.shape[1]} torus", value, OBLIQUE_TRANSFER, error=err2)
                    out, err3 = guarded(lambda b=b, stack=stack, v=v, psf=psf: motion_blur(stack[0], v, psf=psf,
                                                                                    mode="constant", backend=b))
                    value = None if out is None else refs.centroid_error(out, stack[1], stack[2])
                    accuracy_row(bench, section, str(v), f"psf='{psf}', {b}: impulse centroid, {len(stack[0])} phases",
                                 value, CENTROID_PX, unit="px", error=err3)
        rendered_oblique(bench, v0, side)


def rendered_oblique(bench, v, side):
    img = refs.texture(torus_shape(v, side))
    length = math.hypot(*v)
    for psf in PSFS:
        cells = refs.time_cells(psf, length, bench.opts.min_copies)
        ref = refs.render(img, refs.translate(v), cells, "wrap")
        for b in bench.opts.backends:
            out, err = guarded(lambda b=b, psf=psf: motion_blur(img.astype(np.float32), v, psf=psf, mode="wrap",
                                                                backend=b))
            value = None if out is None else refs.rel_l2(out, ref, MARGIN)
            accuracy_row(bench, "accuracy, oblique", str(v), f"psf='{psf}', {b}: vs rendering ({len(cells[0])} copies)",
                         value, RENDER, target=f"<= {RENDER * 100:g} % (issue 15)", error=err)


def field_accuracy(bench):
    section = "accuracy, field"
    n = bench.opts.field_side
    img = refs.texture((n, n), seed=3)
    field = refs.velocity_field((n, n), FIELD_MAX)
    for psf in ("box", "green"):
        cells = refs.time_cells(psf, FIELD_MAX, bench.opts.min_copies)
        ref = refs.render(img, lambda yy, xx, t: (yy - t * field[0], xx - t * field[1]), cells, "wrap")
        outs = {}
        for b in bench.opts.backends:
            out, err = guarded(lambda b=b, psf=psf: motion_blur(img.astype(np.float32), field, psf=psf, mode="wrap",
                                                                 backend=b))
            outs[b] = out
            value = None if out is None else refs.rel_l2(out, ref, MARGIN)
            accuracy_row(bench, section, f"{n}x{n}, |v| <= {FIELD_MAX:g}",
                         f"psf='{psf}', {b}: vs rendering ({len(cells[0])} copies)", value, FIELD_RENDER, error=err)
        field_agreement(bench, section, f"{n}x{n}, |v| <= {FIELD_MAX:g}", psf, outs)


def field_agreement(bench, section, case, psf, outs):
    done = {b: o for b, o in outs.items() if o is not None}
    if len(done) < 2:
        accuracy_row(bench, section, case, f"psf='{psf}': backends agree", None, None, unit="of max |out|",
                     target=f"<= {AGREE:g} of max |out|", note="one backend run (add --backends numpy,warp,opencl)")
        return
    first, *others = done
    scale = float(np.abs(done[first]).max())
    worst = max(float(np.abs(np.asarray(done[o], np.float64) - done[first]).max()) for o in others) / scale
    accuracy_row(bench, section, case, f"psf='{psf}': {', '.join(others)} against {first}, max |diff|", worst, AGREE,
                 unit="of max |out|")


def polar_cases(n, min_copies):
    """``{(kind, psf): (pre-image, quadrature)}`` of the spin and the zoom about the centre of n²."""
    c = (n - 1) / 2.0
    arc = corner_radius((n, n)) * math.radians(SPIN_DEGREES)     # px the farthest pixel turns
    a = ZOOM_U1 / (1 + ZOOM_U1)                                   # the box zoom's pre-image: c + (x - c)(1 - a t)
    radial = corner_radius((n, n)) * a
    density, end, core = refs.green_zoom_density(ZOOM_U1)
    return {("rotation", "box"): (refs.spin(SPIN_DEGREES, c, c), refs.time_cells("box", arc, min_copies)),
            ("rotation", "green"): (refs.spin(SPIN_DEGREES, c, c), refs.time_cells("green", arc, min_copies)),
            ("zoom", "box"): (refs.scale_about(c, c, lambda t: 1 - a * t), refs.time_cells("box", radial, min_copies)),
            ("zoom", "green"): (refs.scale_about(c, c, lambda tau: math.exp(-tau)),
                                refs.quadrature(density, end, corner_radius((n, n)), core=core,
                                                min_copies=min_copies))}


def polar_accuracy(bench):
    section = "accuracy, spin and zoom"
    n = bench.opts.polar_side
    img = refs.texture((n, n), seed=5)
    for (kind, psf), (pre, cells) in polar_cases(n, bench.opts.min_copies).items():
        value = SPIN_DEGREES if kind == "rotation" else ZOOM_U1
        label = f"spin {SPIN_DEGREES:g} deg" if kind == "rotation" else f"zoom {ZOOM_U1:g}"
        ref = refs.render(img, pre, cells, "reflect")
        for b in bench.opts.backends:
            out, err = guarded(lambda b=b, value=value, kind=kind, psf=psf: motion_blur(
                img.astype(np.float32), value, kind=kind, psf=psf, mode="reflect", backend=b))
            rel = None if out is None else refs.rel_l2(out, ref, MARGIN)
            accuracy_row(bench, section, f"{label}, {n}x{n}",
                         f"psf='{psf}', {b}: vs rendering ({len(cells[0])} copies)", rel, RENDER,
                         target=f"<= {RENDER * 100:g} % (issue 15)", error=err)
    for b in bench.opts.backends:
        out, err = guarded(lambda b=b: motion_blur(img.astype(np.float32), 1e-6, kind="rotation", psf="box",
                                                   mode="reflect", backend=b))
        rel = None if out is None else refs.rel_l2(out, img, MARGIN)
        accuracy_row(bench, section, f"spin 1e-6 deg, {n}x{n}", f"psf='box', {b}: vs the image itself", rel, None,
                     note="no target: what the polar grid's resamplings leave", error=err)


# --------------------------------------------------------------------------------------
# the record (issue 15's accuracy table, numpy float64)
# --------------------------------------------------------------------------------------
def record_table():
    rows = ["| test | requested | measured | error (px) |", "|---|---|---|---|"]
    for v in [(0.0, 5.0), (0.0, 12.5), (-25.0, 0.0), (0.0, -40.3), (9.5, 9.5), (17.0, -17.0)]:   # (vy, vx)
        img = np.zeros((1024, 1024))
        y0, x0 = int(512 - 6 * v[0]), int(512 - 6 * v[1])   # room for the kernel's tail
        img[y0, x0] = 1.0
        out = motion_blur(img, v, mode="constant", backend="numpy")
        yy, xx = np.mgrid[:1024, :1024]
        cy, cx = (out * yy).sum() / out.sum() - y0, (out * xx).sum() / out.sum() - x0
        rows.append(f"| impulse, velocity (vy, vx) | ({v[0]:g}, {v[1]:g}) | ({cy:.4f}, {cx:.4f}) | "
                    f"{max(abs(cy - v[0]), abs(cx - v[1])):.1e} |")
    x = np.arange(1024)
    for v in (7.5, 30.0):
        img = np.tile((x >= 300).astype(float), (4, 1))
        d = np.diff(motion_blur(img, (0.0, v), mode="nearest", backend="numpy")[2])
        pos = (d * (x[1:] - 0.5)).sum() / d.sum() - 299.5
        rows.append(f"| step edge, velocity (vy, vx) = (0, {v:g}) | {v:g} | {pos:.4f} | {abs(pos - v):.1e} |")
    rows += zoom_record()
    return "\n".join(rows)


def zoom_record():
    rows = []
    yy, xx = np.mgrid[:512, :512].astype(float)
    c = (240.4, 256.0)   # (row, col)
    far = (np.abs(xx - c[1]) >= 5) & (np.abs(yy - c[0]) >= 5)
    for u1 in (0.02, 0.05, 0.25, 0.8, 1.5, 1.9):
        mx = motion_blur(xx, u1, kind="zoom", center=c, backend="numpy")
        my = motion_blur(yy, u1, kind="zoom", center=c, backend="numpy")
        err = np.maximum(np.abs(mx - (c[1] + (xx - c[1]) / (1 + u1))), np.abs(my - (c[0] + (yy - c[0]) / (1 + u1))))
        rows.append(f"| zoom u1 = {u1:g}: pre-image of every pixel (x and y) | x_U + (x - x_U)/(1+u1) | "
                    f"max error {err.max():.1e} (>= 5 px from x_U: {err[far].max():.1e}) | {err.max():.1e} |")
    # zoom-out: the kernel reads outward to infinity with a power-law tail ~ (s/x0)^alpha, so the
    # border's mode extension (here 'nearest') biases outputs at a distance s that is not small
    # beside the distance S from the fixed point to the border; measured on a long line
    n, cx = 2001, 1000.0
    line = np.tile(np.arange(n, dtype=float), (3, 1))
    d = np.abs(np.arange(n) - cx)
    for u1 in (-0.1, -0.3, -0.5, -0.8):
        out = motion_blur(line, (0.0, u1), kind="zoom", center=(1, cx), mode="nearest", backend="numpy")[1]
        err = np.abs(out - (cx + (np.arange(n) - cx) / (1 + u1)))
        parts = [f"s <= S/{r}: {err[(d >= 5) & (d <= cx / r)].max():.3f}" for r in (3, 10, 50)]
        rows.append(f"| zoom-out u1 = {u1:g}: pre-image, line of {n} px about its centre (S = {cx:g}) | "
                    f"x_U + (x - x_U)/(1+u1) | max error for s >= 5 px: {', '.join(parts)}; "
                    f"s < 5 px: {err[d < 5].max():.3f} | {err[(d >= 5) & (d <= cx / 10)].max():.3f} (s <= S/10) |")
    return rows


# --------------------------------------------------------------------------------------
# the README figure
# --------------------------------------------------------------------------------------
def _half_field(shape):
    field = np.zeros((2,) + shape)
    field[1, :, shape[1] // 2:] = 25.0        # (rows, cols): the right half moves 25 px right
    return field


def figure(path):
    from importlib import resources

    import imageio.v3 as iio
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with resources.as_file(resources.files("gfgpu.data").joinpath("camera.png")) as p:
        cam = iio.imread(p).astype(np.float32)
    panels = [("input", cam),
              ("uniform, velocity (vy, vx) = (0, 30)", motion_blur(cam, (0.0, 30.0), backend="numpy")),
              ("uniform, (-12, 20), displace=False", motion_blur(cam, (-12.0, 20.0), displace=False,
                                                                  backend="numpy")),
              ("zoom-in u1 = 0.08 about (row, col) = (200, 250)",
               motion_blur(cam, 0.08, kind="zoom", center=(200, 250), backend="numpy")),
              ("zoom-in u1 = 0.15, psf='box' (along the rays)",
               motion_blur(cam, 0.15, kind="zoom", psf="box", center=(200, 250), backend="numpy")),
              ("spin 12 deg about (200, 250), psf='box', displace=False",
               motion_blur(cam, 12.0, kind="rotation", psf="box", center=(200, 250), displace=False,
                           backend="numpy")),
              ("per-pixel field: left half still, right half (0, 25)", motion_blur(cam, _half_field(cam.shape),
                                                                                 psf="box", backend="numpy"))]
    fig, axes = plt.subplots(2, 4, figsize=(16, 8.4))
    axes = axes.ravel()
    axes[-1].axis("off")
    for ax, (title, im) in zip(axes, panels):
        ax.imshow(im, cmap="gray", vmin=0, vmax=255)
        ax.set_title(title, fontsize=10)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")


# --------------------------------------------------------------------------------------
# output
# --------------------------------------------------------------------------------------
def _met(row):
    if row.met is None:
        return "—"
    verdict_ = "PASS" if row.met else "FAIL"
    return verdict_ + (" (est.)" if row.timing is not None and row.timing.estimated else "")


def _note(row):
    return "; ".join(filter(None, [row.note, row.error and f"error: {row.error}"]))


def _seconds(t):
    return "—" if t is None else f"{t:.3f}"


def speed_markdown(rows):
    lines = ["| case | method | first call, fresh shape (s, scaled to n²) | steady (s) | Mpix/s | target | met "
             "| note |",
             "|---|---|---:|---:|---:|---|---|---|"]
    for r in rows:
        t = r.timing
        if t is None:
            cells = ["—", "—", "—"]
        elif t.estimated:
            cells = ["—", f"~{t.steady:.1f} (est. from {t.probe}²)", f"~{t.mpix:.2g} (est.)"]
        else:
            cells = [_seconds(t.first), f"{t.steady:.3f} (best of {t.calls})", f"{t.mpix:.3g}"]
        lines.append(f"| {r.case} | {r.method} | " + " | ".join(cells) + f" | {r.target} | {_met(r)} | {_note(r)} |")
    return "\n".join(lines)


def accuracy_markdown(rows):
    lines = ["| case | method | measured | target | met | note |", "|---|---|---:|---|---|---|"]
    for r in rows:
        if r.value is None:
            value = "—"
        elif r.unit == "rel. L2":
            value = f"{r.value * 100:.2g} %"
        else:
            value = f"{r.value:.2e} {r.unit}"
        lines.append(f"| {r.case} | {r.method} | {value} | {r.target} | {_met(r)} | {_note(r)} |")
    return "\n".join(lines)


def timed_section(bench, section, run, speed):
    """Run a section and print its table and wall time (also kept for the JSON)."""
    t0 = time.perf_counter()
    run(bench)
    bench.section_s[section] = time.perf_counter() - t0
    rows = [r for r in bench.rows if r.section == section]
    print(f"\n### {section}\n")
    print(speed_markdown(rows) if speed else accuracy_markdown(rows))
    print(f"\n({section}: {bench.section_s[section]:.0f} s)", flush=True)


def machine():
    def run(cmd):
        try:
            return subprocess.run(cmd, capture_output=True, text=True, cwd=HERE, timeout=20).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    versions = {"gfgpu": gfgpu.__version__, "numpy": np.__version__, "python": platform.python_version()}
    for name in ("cv2", "torch", "kornia", "pyopencl", "warp"):
        try:
            versions[name] = __import__(name).__version__
        except Exception:
            versions[name] = None
    return {"uptime": run(["uptime"]), "cpus": os.cpu_count(), "platform": platform.platform(),
            "commit": run(["git", "describe", "--always", "--dirty"]), "versions": versions,
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}


def summary(bench):
    verdicts = [r.met for r in bench.rows if r.met is not None]
    passed = sum(verdicts)
    return f"{passed} PASS, {len(verdicts) - passed} FAIL, {len(bench.rows) - len(verdicts)} rows without a verdict"


def write_json(path, bench, meta):
    rows = []
    for r in bench.rows:
        d = asdict(r)
        if r.timing is not None:
            d["timing"]["mpix_per_s"] = r.timing.mpix
            d["timing"]["estimated"] = r.timing.estimated
            d["timing"]["mpix_first"] = None if r.timing.first is None else r.timing.pixels / 1e6 / r.timing.first
        rows.append(d)
    Path(path).write_text(json.dumps({"meta": meta, "rows": rows}, indent=1, default=float))
    print(f"\nwrote {path}")


# --------------------------------------------------------------------------------------
def parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096, help="side of the uniform images (field, spin, zoom: half)")
    ap.add_argument("--repeat", type=int, default=3, help="steady calls per row, at most")
    ap.add_argument("--budget", type=float, default=8.0, help="seconds of steady calls per row before stopping")
    ap.add_argument("--call-limit", type=float, default=30.0,
                    help="a call estimated slower than this (s) is not run at full size")
    ap.add_argument("--backends", default="opencl", help="comma-separated: opencl, warp, numpy")
    ap.add_argument("--quick", action="store_true", help="small sizes and fewer copies: a smoke run")
    ap.add_argument("--json", metavar="PATH", help="write every row and the machine's state as JSON")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--skip-record", action="store_true", help="skip issue 15's numpy accuracy table")
    ap.add_argument("--figure", action="store_true", help="write docs/motion_examples.png")
    ap.add_argument("--section", action="append", choices=("axis", "oblique", "field", "polar"),
                    help="run only these speed and accuracy sections (repeatable; default all)")
    # older commands' --targets: the renderings are now rows of the accuracy section
    ap.add_argument("--targets", action="store_true", help=argparse.SUPPRESS)
    opts = ap.parse_args(argv)
    opts.backends = [b for b in opts.backends.split(",") if b]
    if opts.size < PROBE and not opts.quick:
        ap.error(f"--size must be at least {PROBE} (or use --quick)")
    if opts.repeat < 1:
        ap.error("--repeat must be at least 1")
    # accuracy sizes: torus sides, field and polar images, fewest copies of a rendering
    opts.torus_side, opts.field_side, opts.polar_side, opts.min_copies, opts.phases = 128, 128, 256, 512, None
    if opts.quick:
        opts.size = min(opts.size, 128)
        opts.repeat, opts.budget = 1, 1.0
        opts.torus_side, opts.field_side, opts.polar_side, opts.min_copies, opts.phases = 40, 40, 48, 64, 4
        opts.skip_record = True
    return opts


def main(argv=None):
    start = time.perf_counter()
    opts = parse(argv)
    bench = Bench(opts)
    meta = {"start": machine(), "args": {k: v for k, v in vars(opts).items()}}
    print(f"# Motion blur side by side ({meta['start']['date']}, gfgpu {meta['start']['commit']}, "
          f"{meta['start']['cpus']} CPUs)\n\nload at start: `{meta['start']['uptime']}`")
    print(f"\nbackends {', '.join(opts.backends)}; {opts.size}² (field, spin, zoom {opts.size // 2}²), float32; "
          f"steady: best of at most {opts.repeat} calls or {opts.budget:g} s; first call: on a fresh shape after "
          f"calls on {PROBE}² (or larger) images with the same parameters; calls estimated over "
          f"{opts.call_limit:g} s are not run at full size (shown as estimates).")
    if not opts.skip_speed:
        print("\n## Speed")
        for key, section, run in (("axis", "uniform, axis-aligned", axis_section),
                                  ("oblique", "uniform, oblique", oblique_section),
                                  ("field", "velocity field", field_section),
                                  ("polar", "spin and zoom", polar_section)):
            if opts.section is None or key in opts.section:
                timed_section(bench, section, run, speed=True)
    if not opts.skip_accuracy:
        print("\n## Accuracy (Gaussian-filtered noise, sigma = 2 px, float32, 16-px margin)")
        for key, section, run in (("oblique", "accuracy, oblique", oblique_accuracy),
                                  ("field", "accuracy, field", field_accuracy),
                                  ("polar", "accuracy, spin and zoom", polar_accuracy)):
            if opts.section is None or key in opts.section:
                timed_section(bench, section, run, speed=False)
    if not opts.skip_record:
        print("\n## Record: impulses, step edges and the zoom's pre-image (numpy, float64)\n")
        print(record_table())
    if opts.figure:
        figure(HERE.parent / "docs" / "motion_examples.png")
    meta["end"] = machine()
    meta["wall_s"] = time.perf_counter() - start
    meta["section_s"] = bench.section_s
    print(f"\n{summary(bench)}. Wall time {meta['wall_s']:.0f} s; load at end: `{meta['end']['uptime']}`")
    if opts.json:
        write_json(opts.json, bench, meta)


if __name__ == "__main__":
    main()
