"""Argument checks shared by the shading operators: images, masks and light directions."""

from __future__ import annotations

import math

import numpy as np

from .._core.arrays import host_array
from .._core.validation import work_dtype

__all__ = ["MIN_SLANT", "checked_image", "checked_mask", "check_contrast", "parse_light", "tilt_slant"]

#: Lights whose slant (angle from the viewing direction, radians) is below this have no usable
#: image-plane direction: the linear term of the reflectance map, which GSFS integrates, vanishes.
MIN_SLANT = math.radians(1.0)


def checked_image(image, name="image"):
    # any array kind (torch, DLPack, device arrays) is read on the host once, never "dtype object"
    arr = host_array(image, name)
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grey-level image, got shape {arr.shape}")
    if min(arr.shape) < 4:
        raise ValueError(f"{name} must be at least 4 x 4 pixels, got shape {arr.shape}")
    dtype = work_dtype(arr.dtype, name)     # the operators' policy: wide integers in float64
    arr = arr.astype(dtype, copy=False)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def checked_mask(mask, shape):
    if mask is None:
        return np.ones(shape, bool)
    m = host_array(mask, "mask")
    if m.shape != shape:
        raise ValueError(f"mask must have the image's shape {shape}, got {m.shape}")
    if m.dtype != bool:
        # 0/1 masks are masks; NaN or fractional values are not (astype(bool) would make them True)
        if m.dtype.kind not in "biuf" or not np.isin(m, (0, 1)).all():
            raise ValueError(f"mask must be boolean (True/False or 0/1), got dtype {m.dtype} with other values")
    m = m.astype(bool)
    if m.sum() < 16:
        raise ValueError(f"mask must select at least 16 pixels, got {int(m.sum())}")
    return m


def check_contrast(image, mask, name="image"):
    vals = image[mask].astype(np.float64)
    spread = float(vals.max() - vals.min())
    if not spread > 1e-6 * max(1.0, float(np.abs(vals).max())):
        raise ValueError(f"{name} is constant (range {spread:g}) over the analysed pixels: "
                         f"shading carries no shape")


def parse_light(light):
    """Unit light vector ``(l1, l2, l3)`` from a 3-vector or a ``(tilt, slant)`` pair.

    Parameters
    ----------
    light : sequence of 3 or 2 floats
        ``(l1, l2, l3)`` (any positive length; normalised), or ``(tilt, slant)`` in radians,
        ``tilt`` from +x toward +y (down the rows) and ``0 <= slant < pi/2`` from the viewer.

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    ValueError
        Wrong length, non-finite values, zero vector, or a light that does not face the viewer
        (``l3 <= 0`` or ``slant`` outside ``[0, pi/2)``): it would not light the visible surface.

    Examples
    --------
    >>> parse_light((1, 0, 1)).round(4).tolist()
    [0.7071, 0.0, 0.7071]
    """
    try:
        vals = [float(v) for v in light]
    except (TypeError, ValueError):
        raise TypeError(f"light must be a 3-vector (l1, l2, l3) or a pair (tilt, slant) of real "
                        f"numbers, got {light!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"light must be finite, got {light!r}")
    if len(vals) == 2:
        tilt, slant = vals
        if not 0.0 <= slant < math.pi / 2:
            raise ValueError(f"light slant must lie in [0, pi/2) radians (a light facing the "
                             f"viewer), got {slant!r}")
        return np.array([math.cos(tilt) * math.sin(slant), math.sin(tilt) * math.sin(slant),
                         math.cos(slant)])
    if len(vals) != 3:
        raise ValueError(f"light must have 3 components (l1, l2, l3) or 2 (tilt, slant), got {len(vals)}")
    v = np.array(vals)
    norm = float(np.linalg.norm(v))
    if norm == 0:
        raise ValueError("light must be a non-zero vector")
    v = v / norm
    if not v[2] > 0:
        raise ValueError(f"light {tuple(vals)} points away from the viewer (l3 <= 0): it cannot "
                         f"light the visible surface; l3 must be > 0")
    return v


def tilt_slant(light):
    return math.atan2(light[1], light[0]), math.acos(min(1.0, float(light[2])))
