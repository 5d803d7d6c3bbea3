"""Accuracy of the velocity fields' Gauss rule (the default) against the exact cells and a rendering.

For each image (Gaussian-filtered noise sigma = 2 px, band-limited noise cut 0.25 and 0.1
cycles/px, the camera photograph) and each field (the benchmark's smooth field scaled to a peak
|v| from 0.3 to 30 px; a discontinuous field: two halves moving in different directions), prints
the rel. L2 and max abs error of ``motion_blur`` (numpy, float64, mode wrap, 16-px margin) under
the Gauss rule and under the exact cells against the supersampled rendering (>= 512 exactly warped
copies, benchmarks/motion_refs.py) and of the Gauss rule against the exact cells.

Usage:  python benchmarks/field_rule.py [--side 128] [--copies 512] [--backend numpy]
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import motion_refs as refs  # noqa: E402

from gfgpu.motion import motion_blur  # noqa: E402

MARGIN = 16


def bandlimited(n, cut, seed=0):
    rng = np.random.default_rng(seed)
    f = np.fft.fft2(rng.standard_normal((n, n)))
    fy, fx = np.fft.fftfreq(n)[:, None], np.fft.fftfreq(n)[None, :]
    img = np.real(np.fft.ifft2(f * (np.hypot(fy, fx) < cut)))
    return img / img.std()


def photograph(n):
    import imageio.v3 as iio
    with resources.as_file(resources.files("gfgpu.data").joinpath("camera.png")) as p:
        cam = iio.imread(p).astype(np.float64)
    if cam.ndim == 3:
        cam = cam[..., :3].mean(-1)
    y0, x0 = (cam.shape[0] - n) // 2, (cam.shape[1] - n) // 2
    crop = cam[y0:y0 + n, x0:x0 + n]
    return (crop - crop.mean()) / crop.std()


def split_field(n, vmax):
    """Discontinuous: the left half moves (0.6, 0.8) vmax, the right half (-0.8, 0.6) vmax, and a still square."""
    field = np.zeros((2, n, n))
    field[0, :, : n // 2], field[1, :, : n // 2] = 0.6 * vmax, 0.8 * vmax
    field[0, :, n // 2:], field[1, :, n // 2:] = -0.8 * vmax, 0.6 * vmax
    field[:, n // 4: n // 2, n // 4: n // 2] = 0.0
    return field


def exact_cells(img, field, psf, backend):
    """The exact cells without the cost refusal (``most=0``: every path its own cells of <= 1 px)."""
    from gfgpu.backends import get_backend
    from gfgpu.motion import kernels, spec
    from gfgpu.motion.spline import spline_coefficients
    be = get_backend(backend)
    shape = (1,) + img.shape
    coef = spline_coefficients(be, be.asarray(img[None]), np.float64, shape, ("wrap", "wrap"))
    out = be.empty(shape, np.float64)
    code = spec.PSF_CODES[psf, True]
    kernels.field_blur(be, coef, be.asarray(np.ascontiguousarray(field)), out, code, 1.0, "wrap", 0.0, 0)
    return be.to_host(out)[0]


def errors(out, ref):
    d, r = (out - ref)[MARGIN:-MARGIN, MARGIN:-MARGIN], ref[MARGIN:-MARGIN, MARGIN:-MARGIN]
    return float(np.linalg.norm(d) / np.linalg.norm(r)), float(np.abs(d).max())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", type=int, default=128)
    ap.add_argument("--copies", type=int, default=512)
    ap.add_argument("--backend", default="numpy")
    ap.add_argument("--peaks", default="0.3,1,3,10,30")
    opts = ap.parse_args(argv)
    n = opts.side
    images = {"noise sigma 2": refs.texture((n, n), seed=3), "band-limited 0.25": bandlimited(n, 0.25, 1),
              "band-limited 0.1": bandlimited(n, 0.1, 2), "photograph": photograph(n)}
    peaks = [float(p) for p in opts.peaks.split(",")]
    print("| image | field | psf | Gauss vs rendering | exact vs rendering | Gauss vs exact |")
    print("|---|---|---|---|---|---|")
    for name, img in images.items():
        for kind in ("smooth", "split"):
            for peak in peaks:
                if kind == "smooth":
                    field = refs.velocity_field((n, n), peak).astype(np.float64)
                else:
                    field = split_field(n, peak)
                for psf in ("box", "green"):
                    cells = refs.time_cells(psf, peak, opts.copies)
                    ref = refs.render(img, lambda yy, xx, t, f=field: (yy - t * f[0], xx - t * f[1]), cells, "wrap")
                    fast = motion_blur(img, field, psf=psf, mode="wrap", backend=opts.backend)
                    exact = exact_cells(img, field, psf, opts.backend)
                    cols = [errors(fast, ref), errors(exact, ref), errors(fast, exact)]
                    print(f"| {name} | {kind}, |v| <= {peak:g} | {psf} | "
                          + " | ".join(f"{100 * a:.3f} % ({b:.4f})" for a, b in cols) + " |", flush=True)


if __name__ == "__main__":
    main()
