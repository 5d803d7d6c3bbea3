"""Motion blur and zoom: accuracy, speed beside OpenCV/scipy, and the README figure.

(a) accuracy: displacement of a blurred impulse (centroid) and of a blurred step edge versus
    the requested velocity; the zoom's mapping (output pixel x shows the input at the affine
    pre-image, i.e. a point p moves to x_U + (p - x_U)(1 + u1)), from the zoom of the
    coordinate images; for zoom-out (u1 < 0) by distance s from the fixed point relative to
    the distance S to the border (the kernel's tail reaches the border's mode extension);
(b) speed: Mpix/s of a horizontal motion blur of length L = 5, 25, 101 px on a SIZE x SIZE
    float32 image: gfgpu (one recursive pass, per backend) beside cv2.filter2D and
    scipy.ndimage.convolve1d with the equivalent line kernel (the G_u shift taps truncated at
    L + 1 taps: the same length of motion), and numpy.copyto (memory bound);
(c) ``--figure``: docs/motion_examples.png (uniform, zoom and rotation blur of the camera image);
(d) spin blur along the arcs (polar grid), its speed on a (SIZE/2)^2 image beside one
    scipy.ndimage.rotate;
(e) ``--targets``: psf="box" against supersampled renderings (512 exactly warped copies, cubic
    spline; for the field 512 samples along each pixel's own velocity) on a band-limited 256²
    image, mode wrap, 40-px margin: uniform (23, -9), zoom u1 = 0.12, spin 10 degrees, a smooth
    random field up to 15 px; and a spin by 1e-6 degrees against the image itself (what the
    polar grid's two resamplings leave of an image that does not move).
    The box speed rows sit beside cv2.filter2D with fspecial('motion')'s line kernel (L taps of
    1/L) and kornia.filters.motion_blur when installed.

Usage:  python benchmarks/motion.py [--size 4096] [--repeat 3] [--backends numpy,warp,opencl] [--figure]
        [--targets]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from gfgpu import greens
from gfgpu.motion import motion_blur

LENGTHS = (5, 25, 101)


def best_time(fn, repeat):
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), max(times)


def accuracy_table():
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
    errs = []
    for x0 in range(60, 70):
        img = np.zeros((300, 300))
        img[120 + x0 % 3, x0] = 1.0
        out = motion_blur(img, (4.0, 10.0), mode="constant", backend="numpy")
        yy, xx = np.mgrid[:300, :300]
        errs.append(((out * yy).sum() - (120 + x0 % 3) - 4, (out * xx).sum() - x0 - 10))
    errs = np.array(errs)
    rows.append(f"| impulse, oblique (vy, vx) = (4, 10), 10 positions | (4, 10) | mean ({4 + errs[:, 0].mean():.4f}, "
                f"{10 + errs[:, 1].mean():.4f}) | x: {np.abs(errs[:, 1]).max():.1e}, y per pixel: "
                f"{np.abs(errs[:, 0]).max():.2f}, y mean: {abs(errs[:, 0].mean()):.1e} |")
    x = np.arange(1024)
    for v in (7.5, 30.0):
        img = np.tile((x >= 300).astype(float), (4, 1))
        d = np.diff(motion_blur(img, (0.0, v), mode="nearest", backend="numpy")[2])
        pos = (d * (x[1:] - 0.5)).sum() / d.sum() - 299.5
        rows.append(f"| step edge, velocity (vy, vx) = (0, {v:g}) | {v:g} | {pos:.4f} | {abs(pos - v):.1e} |")
    yy, xx = np.mgrid[:512, :512].astype(float)
    c = (240.4, 256.0)   # (row, col)
    far = (np.abs(xx - c[1]) >= 5) & (np.abs(yy - c[0]) >= 5)
    for u1 in (0.02, 0.05, 0.25, 0.8, 1.5, 1.9):
        mx = motion_blur(xx, u1, kind="zoom", center=c, backend="numpy")
        my = motion_blur(yy, u1, kind="zoom", center=c, backend="numpy")
        err = np.maximum(np.abs(mx - (c[1] + (xx - c[1]) / (1 + u1))), np.abs(my - (c[0] + (yy - c[0]) / (1 + u1))))
        rows.append(f"| zoom u1 = {u1:g}: pre-image of every pixel (x and y) | x_U + (x - x_U)/(1+u1) | "
                    f"max error {err.max():.1e} (>= 5 px from x_U: {err[far].max():.1e}) | "
                    f"{err.max():.1e} |")
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
    # rotation: three moment-exact shears map linear content exactly; the shears' kernels reach
    # the border (mode 'nearest' here) from lines far from the centre at large angles
    yy, xx = np.mgrid[:1024, :1024].astype(float)
    c = (511.5, 511.5)   # (row, col)
    dy, dx = yy - c[0], xx - c[1]
    r = np.hypot(dx, dy)
    for degrees in (2.0, 10.0, 30.0):
        t = np.radians(degrees)
        mx = motion_blur(xx, degrees, kind="rotation", center=c, mode="nearest", backend="numpy")
        my = motion_blur(yy, degrees, kind="rotation", center=c, mode="nearest", backend="numpy")
        err = np.maximum(np.abs(mx - (c[1] + np.cos(t) * dx - np.sin(t) * dy)),
                         np.abs(my - (c[0] + np.sin(t) * dx + np.cos(t) * dy)))
        parts = [f"r <= {q}: {err[r <= q].max():.1e}" for q in (100, 200, 400)]
        rows.append(f"| rotation {degrees:g} deg: pre-image of every pixel, 1024^2 about its centre | "
                    f"c + R^-1 (q - c) | {', '.join(parts)} | {err[r <= 200].max():.1e} (r <= 200) |")
    return "\n".join(rows)


def speed_table(size, repeat, backends):
    rng = np.random.default_rng(0)
    img = rng.random((size, size), dtype=np.float32)
    mpix = size * size / 1e6
    out = np.empty_like(img)
    rows = [f"Horizontal motion blur of length L on a {size}x{size} float32 image: Mpix/s "
            f"(best of {repeat}; range in brackets).", "",
            "| method | " + " | ".join(f"L = {L}" for L in LENGTHS) + " |",
            "|---|" + "---|" * len(LENGTHS)]

    def fmt(t):
        return f"{mpix / t[0]:.0f} ({mpix / t[1]:.0f}-{mpix / t[0]:.0f})"

    for name in backends:
        try:
            cells = [fmt(best_time(lambda L=L, name=name: motion_blur(img, (0.0, float(L)), output=out,
                                                                      backend=name), repeat))
                     for L in LENGTHS]
        except Exception as exc:   # report an unusable backend, keep measuring the others
            cells = [f"unavailable: {type(exc).__name__}"] * len(LENGTHS)
        rows.append(f"| gfgpu.motion_blur, backend={name} (numpy in, output=) | " + " | ".join(cells) + " |")
        try:
            cells = [fmt(best_time(lambda L=L, name=name: motion_blur(img, (0.0, float(L)), psf="box", output=out,
                                                                      backend=name), repeat))
                     for L in LENGTHS]
        except Exception as exc:
            cells = [f"unavailable: {type(exc).__name__}"] * len(LENGTHS)
        rows.append(f"| gfgpu.motion_blur psf='box', backend={name} | " + " | ".join(cells) + " |")

    def taps(L):
        lam, kap, tap = greens.shift_coefficients(float(L))
        m = np.arange(1, L + 1)
        k = np.concatenate([[tap], np.real(kap * lam ** (m - 1))])
        return (k / k.sum()).astype(np.float32)

    try:
        import cv2
        cells = []
        for L in LENGTHS:
            k = taps(L)[::-1].copy()[None, :]    # correlation kernel; anchor at its right end
            cells.append(fmt(best_time(lambda k=k, L=L: cv2.filter2D(img, -1, k, dst=out, anchor=(L, 0),
                                                                     borderType=cv2.BORDER_REFLECT), repeat)))
        rows.append("| cv2.filter2D, line kernel of L + 1 taps | " + " | ".join(cells) + " |")
        cells = []
        for L in LENGTHS:
            k = np.full((1, L), 1.0 / L, np.float32)     # fspecial('motion', L, 0): L taps of 1/L
            cells.append(fmt(best_time(lambda k=k: cv2.filter2D(img, -1, k, dst=out, borderType=cv2.BORDER_REFLECT),
                                       repeat)))
        rows.append("| cv2.filter2D, fspecial('motion', L, 0) box kernel | " + " | ".join(cells) + " |")
    except ImportError:
        rows.append("| cv2.filter2D | (OpenCV not installed) |")
    from scipy import ndimage
    cells = []
    for L in LENGTHS:
        k = taps(L)
        cells.append(fmt(best_time(lambda k=k, L=L: ndimage.convolve1d(img, k, axis=1, output=out,
                                                                       mode="reflect", origin=-(L // 2)), repeat)))
    rows.append("| scipy.ndimage.convolve1d, L + 1 taps | " + " | ".join(cells) + " |")
    t = best_time(lambda: np.copyto(out, img), repeat)
    rows.append(f"| numpy.copyto (memory bound) | {fmt(t)} | | |")
    try:
        import kornia
        import torch
        ti = torch.from_numpy(img)[None, None]
        cells = [fmt(best_time(lambda L=L: kornia.filters.motion_blur(ti, L | 1, 0.0, 1.0), repeat)) for L in LENGTHS]
        rows.append("| kornia.filters.motion_blur (CPU, odd L) | " + " | ".join(cells) + " |")
    except ImportError:
        rows.append("| kornia.filters.motion_blur | (kornia not installed) | | |")
    return "\n".join(rows)


def rotation_speed_table(size, repeat, backends, degrees=10.0):
    """Spin blur along the arcs (polar grid) beside one scipy.ndimage.rotate.

    There is no library rotation *blur* to compare with; the usual way to synthesise one is to
    accumulate K rotated copies, K ~ the arc length r_max * theta in pixels (no gaps at the
    corners), each costing about one scipy.ndimage.rotate.
    """
    from scipy import ndimage
    rng = np.random.default_rng(1)
    img = rng.random((size, size), dtype=np.float32)
    out = np.empty_like(img)
    mpix = size * size / 1e6
    k_needed = int(np.ceil(np.hypot(size, size) / 2 * np.radians(degrees)))
    rows = [f"Rotation blur of {degrees:g} degrees about the centre of a {size}x{size} float32 image "
            f"(best of {repeat}):", "",
            "| method | time (ms) | Mpix/s |", "|---|---:|---:|"]
    for name in backends:
        for psf in ("box", "green"):
            try:
                t = best_time(lambda name=name, psf=psf: motion_blur(img, degrees, kind="rotation", psf=psf, output=out,
                                                                     backend=name), repeat)
                rows.append(f"| gfgpu.motion_blur(kind='rotation', psf='{psf}'), backend={name} | {t[0] * 1e3:.0f} | "
                            f"{mpix / t[0]:.1f} |")
            except Exception as exc:
                rows.append(f"| gfgpu rotation, backend={name} | unavailable: {type(exc).__name__} | |")
    t = best_time(lambda: ndimage.rotate(img, degrees, reshape=False, order=1, output=out), repeat)
    rows.append(f"| scipy.ndimage.rotate, order 1, ONE rotation (no blur) | {t[0] * 1e3:.0f} | "
                f"{mpix / t[0]:.0f} |")
    rows.append(f"| accumulating K = {k_needed} such rotations (gap-free blur at the corners), estimate | "
                f"{k_needed * t[0] * 1e3:.0f} | {mpix / (k_needed * t[0]):.1f} |")
    return "\n".join(rows)


def _half_field(shape):
    field = np.zeros((2,) + shape)
    field[1, :, shape[1] // 2:] = 25.0        # (rows, cols): the right half moves 25 px right
    return field


def _bandlimited(n, cut, seed=0):
    rng = np.random.default_rng(seed)
    f = np.fft.fft2(rng.standard_normal((n, n)))
    fy, fx = np.fft.fftfreq(n)[:, None], np.fft.fftfreq(n)[None, :]
    img = np.real(np.fft.ifft2(f * (np.hypot(fy, fx) < cut)))
    return img / img.std()


def _render(img, preimage, copies=512):
    """Average of ``copies`` exactly warped copies (cubic spline, scipy, periodic)."""
    from scipy import ndimage
    h, w = img.shape
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    coef = ndimage.spline_filter(img, 3, mode="grid-wrap")
    acc = np.zeros((h, w))
    for k in range(copies):
        py, px = preimage(yy, xx, (k + 0.5) / copies)
        acc += ndimage.map_coordinates(coef, [py, px], order=3, mode="grid-wrap", prefilter=False)
    return acc / copies


def targets_table(backends, size=256, margin=40):
    from scipy import ndimage
    c = (size - 1) / 2.0
    rng = np.random.default_rng(1)
    field = np.stack([ndimage.gaussian_filter(rng.standard_normal((size, size)), 24, mode="wrap") for _ in range(2)])
    field *= 15.0 / np.abs(field).max()
    a = 0.12 / 1.12

    def spin(yy, xx, t):
        th = np.radians(10.0) * t
        dy, dx = yy - c, xx - c
        return c + np.sin(th) * dx + np.cos(th) * dy, c + np.cos(th) * dx - np.sin(th) * dy

    cases = [("uniform (vy, vx) = (23, -9)", (23.0, -9.0), {}, lambda yy, xx, t: (yy - 23 * t, xx + 9 * t)),
             ("zoom u1 = 0.12 about the centre", 0.12, {"kind": "zoom"},
              lambda yy, xx, t: (c + (yy - c) * (1 - a * t), c + (xx - c) * (1 - a * t))),
             ("spin 10 deg about the centre", 10.0, {"kind": "rotation"}, spin),
             ("smooth random field, |v| <= 15 px", field, {}, lambda yy, xx, t: (yy - t * field[0], xx - t * field[1]))]
    rows = [f"psf='box', mode='wrap', band-limited {size}² image (noise cut at CUT cycles/px), float32 on each "
            f"backend, against 512 warped copies; ‖out − ref‖/‖ref‖ and max abs over the {margin}-px-margin interior "
            f"(target: rel. L2 <= 2 %).", "",
            "| case | cut | " + " | ".join(backends) + " |", "|---|---|" + "---|" * len(backends)]
    for cut in (0.25, 0.1):
        img = _bandlimited(size, cut)
        for name, vel, kw, pre in cases:
            ref = _render(img, pre)
            cells = []
            for b in backends:
                out = motion_blur(img.astype(np.float32), vel, psf="box", mode="wrap", backend=b, **kw)
                d = (out - ref)[margin:-margin, margin:-margin]
                r = ref[margin:-margin, margin:-margin]
                cells.append(f"{np.linalg.norm(d) / np.linalg.norm(r) * 100:.2f} % ({np.abs(d).max():.3f})")
            rows.append(f"| {name} | {cut} | " + " | ".join(cells) + " |")
        out = motion_blur(img.astype(np.float32), 1e-6, kind="rotation", psf="box", mode="wrap", backend=backends[0])
        d = (out - img)[margin:-margin, margin:-margin]
        rows.append(f"| spin by 1e-6 deg against the image ({backends[0]}) | {cut} | "
                    f"{np.linalg.norm(d) / np.linalg.norm(img[margin:-margin, margin:-margin]) * 100:.2f} % "
                    f"({np.abs(d).max():.3f}) |" + " |" * (len(backends) - 1))
    return "\n".join(rows)


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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--backends", default="numpy,warp,opencl")
    ap.add_argument("--figure", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--targets", action="store_true")
    args = ap.parse_args()
    if args.targets:
        print("## Targets (issue 15)\n")
        print(targets_table([b for b in args.backends.split(",") if b]))
    if not args.skip_accuracy:
        print("## Accuracy\n")
        print(accuracy_table())
    if not args.skip_speed:
        print("\n## Speed\n")
        backends = [b for b in args.backends.split(",") if b]
        print(speed_table(args.size, args.repeat, backends))
        print()
        print(rotation_speed_table(args.size // 2, args.repeat, backends))
    if args.figure:
        figure(os.path.join(os.path.dirname(__file__), "..", "docs", "motion_examples.png"))


if __name__ == "__main__":
    main()
