"""float64 direct-summation references. They share no algorithm with the recursions:
the closed-form kernel is evaluated at every (x, x0) pair and summed over an explicitly
padded line (numpy.pad), O(n * (n + margin))."""
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
