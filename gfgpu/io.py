"""Image files: reading (with bundled examples), display conversions and atomic writes.

Every output is written to a temporary file in the destination's directory and renamed into
place, so an interrupted run never leaves a partial file; inputs are never written.  Errors are
``OSError`` (unreadable or unwritable files) or ``ValueError`` (bad names or contents); the
command line turns them into one-line messages.
"""

from __future__ import annotations

import os
import tempfile
from importlib import resources

import numpy as np

__all__ = ["EXAMPLES", "example_image", "read_image", "write_atomic", "save_png", "save_npy",
           "to_display_8bit", "gradient_to_rgb", "colourise_disparity", "write_pfm", "read_pfm"]

#: bundled example images (gfgpu/data/NAME.png)
EXAMPLES = ("camera",)


def example_image(name):
    """A bundled example image (``gfgpu/data/NAME.png``) as an array; ``ValueError`` if unknown."""
    import imageio.v3 as iio
    if name not in EXAMPLES:
        raise ValueError(f"example must be one of {', '.join(EXAMPLES)}; got {name!r}")
    with resources.as_file(resources.files("gfgpu.data").joinpath(f"{name}.png")) as p:
        return iio.imread(p)


def read_image(path):
    """The image file ``path`` as an array (bit depth and channels as stored).

    Raises
    ------
    OSError
        The file cannot be opened (``FileNotFoundError``, ``PermissionError``, ...).
    ValueError
        Its contents cannot be decoded as an image (the message names the file).
    """
    import imageio.v3 as iio
    try:
        return iio.imread(path)
    except OSError:
        raise
    except ValueError as exc:
        raise ValueError(f"cannot read image {os.fspath(path)!r}: {exc}") from None


def write_atomic(path, write):
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``."""
    folder = os.path.dirname(os.path.abspath(path)) or "."
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=os.path.splitext(path)[1], prefix=".gfgpu-")
    os.close(fd)
    try:
        write(tmp)
        # mkstemp creates 0600 files; outputs get the usual permissions (0666 minus the umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def save_png(path, image):
    """Write an 8-bit (or 16-bit) image as PNG, atomically."""
    import imageio.v3 as iio
    write_atomic(path, lambda tmp: iio.imwrite(tmp, image, extension=".png"))


def save_npy(path, array):
    """Write the raw array as ``.npy``, atomically (whatever ``path``'s extension)."""
    def write(tmp):
        with open(tmp, "wb") as f:
            np.save(f, array)
    write_atomic(path, write)


def to_display_8bit(result, original):
    """Display conversion of a filtered image: round and clip to the input's value range."""
    if original.dtype == np.uint8:
        return np.clip(np.rint(result), 0, 255).astype(np.uint8)
    lo, hi = float(np.min(original)), float(np.max(original))
    scale = 255.0 / (hi - lo) if hi > lo else 1.0
    return np.clip(np.rint((result - lo) * scale), 0, 255).astype(np.uint8)


def gradient_to_rgb(gy, gx):
    """Colour-coded gradient (H, W, 3) uint8: hue = orientation, value = magnitude (robustly
    normalised to the 99.5th percentile)."""
    from skimage.color import hsv2rgb
    mag = np.hypot(gx, gy)
    top = np.percentile(mag, 99.5) or 1.0
    hsv = np.stack([(np.arctan2(gy, gx) / (2 * np.pi)) % 1.0, np.full(mag.shape, 0.8),
                    np.clip(mag / top, 0, 1)], axis=-1)
    return (hsv2rgb(hsv) * 255).round().astype(np.uint8)


# Turbo colour map (A. Mikhailov, Google, 2019), polynomial approximation: no matplotlib needed
_TURBO = np.array([
    [0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943],
    [0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604],
    [0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973]])


def colourise_disparity(disp, d_min, d_max):
    """(H, W, 3) uint8 Turbo image of ``disp`` scaled from ``d_min`` (blue) to ``d_max`` (red);
    NaN (rejected) pixels are black."""
    t = np.clip((np.nan_to_num(disp, nan=d_min) - d_min) / max(d_max - d_min, 1e-9), 0, 1)
    powers = t[..., None] ** np.arange(6)
    rgb = np.clip(powers @ _TURBO.T, 0, 1)
    rgb[~np.isfinite(disp)] = 0
    return (rgb * 255).round().astype(np.uint8)


def write_pfm(path, disp):
    """Write a greyscale PFM (little-endian float32, rows bottom to top; NaN kept, as Middlebury)."""
    data = np.asarray(disp, np.float32)
    with open(path, "wb") as f:
        f.write(f"Pf\n{data.shape[1]} {data.shape[0]}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(data[::-1]).astype("<f4").tobytes())


def read_pfm(path):
    """Read a greyscale PFM written by :func:`write_pfm` (or Middlebury's tools); ``ValueError``
    if the file is not one."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"Pf":
            raise ValueError(f"{path}: not a greyscale PFM")
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(4 * w * h), "<f4" if scale < 0 else ">f4")
    if data.size != w * h:
        raise ValueError(f"{path}: truncated PFM ({data.size} of {w * h} samples)")
    return data.reshape(h, w)[::-1].astype(np.float32)
