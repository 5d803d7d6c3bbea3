"""Image files for the command line: reading (with bundled examples) and atomic writes.

Every output is written to a temporary file in the destination's directory and renamed into
place, so an interrupted run never leaves a partial file; inputs are never written.
"""

from __future__ import annotations

import os
import tempfile
from importlib import resources

import numpy as np

#: bundled example images (gfgpu/data/NAME.png)
EXAMPLES = ("camera",)


def read_image(path, example=None):
    """``(array, label)`` of an image file or a bundled example; SystemExit with the reason."""
    import imageio.v3 as iio
    if example:
        if example not in EXAMPLES:
            raise SystemExit(f"--example must be one of {', '.join(EXAMPLES)}")
        with resources.as_file(resources.files("gfgpu.data").joinpath(f"{example}.png")) as p:
            return iio.imread(p), f"{example} (bundled)"
    if path is None:
        raise SystemExit("give an IMAGE path or --example camera")
    try:
        return iio.imread(path), path
    except (OSError, ValueError) as exc:
        raise SystemExit(f"cannot read image {path!r}: {exc}") from None


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
