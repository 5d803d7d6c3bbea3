"""Figures for the README: the chapter's Figs. 1, 2 and 4 (G_u, D, H_u against x/u) from the
library's own closed forms, plus the discrete shift operator's taps and an example gradient.

Run:  python docs/make_figures.py   (writes docs/kernels.png and docs/gradient_camera.png)
"""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import gfgpu
from gfgpu import greens

HERE = os.path.dirname(os.path.abspath(__file__))


def kernels_figure(path):
    u = 1.0
    x = np.linspace(-2, 10, 1201)
    xd = np.linspace(-10, 10, 2001)
    fig, axs = plt.subplots(1, 4, figsize=(15, 3.2))
    axs[0].plot(x, greens.g_uniform(x, u), color="C0")
    axs[0].set_title("Fig. 1: $G_u(x)$ (eq. 9)")
    axs[1].plot(xd, greens.edge_derivative(xd, u), color="C1", label="D(x), a=1.1, η=3.5")
    axs[1].plot(xd, greens.d_uniform(xd, u), color="C1", ls=":", label="$D_u$ (eq. 19)")
    axs[1].legend(fontsize=8)
    axs[1].set_title("Fig. 2: D(x) (eq. 25-26)")
    xh = np.linspace(1e-6, 10, 1000)
    axs[2].plot(np.r_[-2, 0, xh], np.r_[0, 0, greens.h_homogeneous(xh, u)], color="C2")
    axs[2].set_title("Fig. 4: $H_u(x)$ (eq. 33)")
    for a in axs[:3]:
        a.axhline(0, color="k", lw=0.5)
        a.set_xlabel("x / u")
    # the discrete shift operators used by gfgpu.shift: unit gain, mean exactly u
    for i, s in enumerate((0.5, 1.0, 3.0)):
        lp = greens.shift_pass(s)
        m = np.arange(0, 400)   # long enough for the sums; the plot shows the first 16
        taps = np.concatenate([[lp.tap], lp.sections[0].taps(m[1:])])
        axs[3].plot(m[:16] + 0.08 * i, taps[:16], "o-", ms=3,
                    label=f"u = {s}: Σw = {taps.sum():.6f}, Σmw = {(m * taps).sum():.6f}")
    axs[3].set_title("gfgpu.shift taps (discrete G_u)")
    axs[3].set_xlabel("m (pixels)")
    axs[3].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def gradient_figure(path):
    from importlib import resources

    import imageio.v3 as iio
    img = iio.imread(resources.files("gfgpu.data").joinpath("camera.png")).astype(np.float32)
    fig, axs = plt.subplots(1, 3, figsize=(12, 4.2))
    axs[0].imshow(img, cmap="gray")
    axs[0].set_title("input")
    for ax, u in zip(axs[1:], (0.5, 2.0)):
        gy, gx = gfgpu.gradient(img, u, backend="numpy")
        ax.imshow(np.hypot(gx, gy), cmap="magma", vmax=np.percentile(np.hypot(gx, gy), 99.5))
        ax.set_title(f"|∇I| with D(x), u = {u}")
    for a in axs:
        a.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    kernels_figure(os.path.join(HERE, "kernels.png"))
    gradient_figure(os.path.join(HERE, "gradient_camera.png"))
    print("wrote docs/kernels.png, docs/gradient_camera.png")
