"""The oracles shared by the tests and the benchmarks; none reuses the recursions it checks.

* float64 direct-summation references: the closed-form kernel is evaluated at every (x, x0) pair
  and summed over an explicitly padded line (numpy.pad), O(n * (n + margin));
* Fourier transfer functions of the operators along a continuous direction, on periodic images
  (the accuracy of oblique passes: tests/_core/test_oblique.py, benchmarks/oblique.py).

The tests import it as ``oracle`` (pytest puts tests/ on the path: ``pythonpath`` in
pyproject.toml); a benchmark puts tests/ on ``sys.path`` first (see benchmarks/oblique.py).
"""
import math

import numpy as np

from gfgpu import greens

# scipy.ndimage mode -> numpy.pad mode
NP_PAD = {"constant": "constant", "nearest": "edge", "reflect": "symmetric",
          "mirror": "reflect", "wrap": "wrap"}


def pad_line(line, margin, mode, cval=0.0, side="left"):
    width = (margin, 0) if side == "left" else (0, margin)
    if mode == "constant":
        return np.pad(line, width, mode="constant", constant_values=cval)
    if mode == "mirror" and len(line) == 1:
        return np.pad(line, width, mode="edge")
    return np.pad(line, width, mode=NP_PAD[mode])


def kernel_margin(kernel_fn_extent, n):
    return kernel_fn_extent


def direct_line(line, kernel, mode, cval=0.0, anticausal=False, margin=None):
    """f[x] = Σ_{x0 <= x} G(x, x0) I_ext[x0] (causal) with G a closed form G(x, x0)."""
    line = np.asarray(line, np.float64)
    n = len(line)
    if anticausal:
        # mirror coordinates: x' = n-1-x; kernel positions mirrored accordingly
        return direct_line(line[::-1], _mirror(kernel, n), mode, cval, False, margin)[::-1]
    if margin is None:
        margin = _default_margin(kernel, n)
    ext = pad_line(line, margin, mode, cval)
    x0 = np.arange(-margin, n, dtype=np.float64)
    x = np.arange(n, dtype=np.float64)
    xx, xx0 = np.meshgrid(x, x0, indexing="ij")
    valid = xx0 > getattr(kernel, "x_min", -np.inf)
    g = np.zeros_like(xx)
    g[valid] = kernel(xx[valid], xx0[valid])
    return g @ ext


def _mirror(kernel, n):
    return kernel.mirrored(n)


def _default_margin(kernel, n):
    if isinstance(kernel, (greens.UniformGreen, greens.HomogeneousGreen)):
        return int(45 * kernel.u) + 8
    if isinstance(kernel, TapKernel):
        return kernel.margin
    lo = kernel.x_min
    return int(np.ceil(-lo)) - 1 if np.isfinite(lo) else 4 * n


class TapKernel:
    """A shift-invariant operator given by its taps w(m) (closed form), for shift/D/P."""
    x_min = -np.inf

    def __init__(self, taps, margin):
        self.taps = taps
        self.margin = margin

    def __call__(self, x, x0):
        return self.taps(np.asarray(x) - np.asarray(x0))

    def mirrored(self, n):
        return self


def direct_axis(image, kernel, axis, mode, cval=0.0, anticausal=False):
    """Direct summation along one axis of an N-D array."""
    img = np.moveaxis(np.asarray(image, np.float64), axis, -1)
    flat = img.reshape(-1, img.shape[-1])
    out = np.stack([direct_line(l, kernel, mode, cval, anticausal) for l in flat])
    return np.moveaxis(out.reshape(img.shape), -1, axis)

def relerr(out, ref):
    out = np.asarray(out, np.float64)
    ref = np.asarray(ref, np.float64)
    return np.linalg.norm(out - ref) / np.linalg.norm(ref)


def max_relerr(out, ref):
    """Largest absolute difference over the largest magnitude of ``ref`` (at least 1; 0 if empty)."""
    out, ref = np.asarray(out, np.float64), np.asarray(ref, np.float64)
    if not ref.size:
        return 0.0
    return float(np.max(np.abs(out - ref))) / max(1.0, float(np.max(np.abs(ref))))


# --------------------------------------------------------------------------------------
# Fourier transfer functions: the operators along the continuous direction, periodic images
# --------------------------------------------------------------------------------------
def direction_geometry(angle):
    """(steep, reverse, gamma), computed here from cos and sin (not with gfgpu._core.lines)."""
    c, s = math.cos(angle), math.sin(angle)
    if abs(s) > abs(c) + 1e-12:
        return True, s < 0, c / s
    return False, c < 0, s / c


def transfer_reference(image, program):
    """The continuous-direction operator of a uniform-motion program on a periodic image: each
    pass's taps w[k] along the step vector d (one step of the dominant axis) act as
    Σ_k w[k] I(p - k d), i.e. multiply the spectrum by W(ω·d) (the taps' DTFT)."""
    img = np.asarray(image, np.float64)
    h, w = img.shape
    wy = 2 * np.pi * np.fft.fftfreq(h)[:, None]
    wx = 2 * np.pi * np.fft.fftfreq(w)[None, :]
    spec = np.fft.fft2(img)
    for passes, _, angle in program.steps:     # oblique steps (an angle each)
        steep, reverse, gamma = direction_geometry(angle)
        dy, dx = (1.0, gamma) if steep else (gamma, 1.0)
        theta = (-1 if reverse else 1) * (wx * dx + wy * dy)
        total = 0
        for lp in passes:
            z = np.exp(-1j * theta * (-1 if lp.reverse else 1))
            resp = lp.tap + 0j
            for sec in lp.sections:     # Σ_{k>=1} Re(kap lam^(k-1)) z^k
                lam, kap = sec.lam, sec.kap
                resp = resp + 0.5 * (kap * z / (1 - lam * z) + np.conj(kap) * z / (1 - np.conj(lam) * z))
            total = total + resp
        spec = spec * total
    return np.real(np.fft.ifft2(spec))


def box_transfer_reference(img, velocity):
    """The uniform box exposure along the exact direction on a periodic image: the mean of the
    image translated by t·v, t in [0, 1], i.e. the spectrum times (1 - e^{-iφ}) / (iφ), φ = ω·v."""
    wy = 2 * np.pi * np.fft.fftfreq(img.shape[0])[:, None]
    wx = 2 * np.pi * np.fft.fftfreq(img.shape[1])[None, :]
    phi = wy * velocity[0] + wx * velocity[1]
    small = np.abs(phi) < 1e-12
    resp = np.where(small, 1.0, (1 - np.exp(-1j * phi)) / (1j * np.where(small, 1.0, phi)))
    return np.real(np.fft.ifft2(np.fft.fft2(img) * resp))
