"""Surfaces with their slopes, rendered Lambertian, shared by the shading tests."""
import math

import numpy as np

from gfgpu import shading

SIZE = 64


def grid(size=SIZE):
    c = (size - 1) / 2
    yy, xx = np.mgrid[:size, :size].astype(np.float64)
    return yy - c, xx - c


def sphere(size=SIZE):
    y, x = grid(size)
    r = 0.35 * size
    inside = x * x + y * y < r * r
    z = np.where(inside, np.sqrt(np.clip(r * r - x * x - y * y, 0, None)), 0.0)
    zz = np.maximum(z, 1e-3 * r)
    return z, np.where(inside, -x / zz, 0.0), np.where(inside, -y / zz, 0.0)


def gaussians(size=SIZE):
    y, x = grid(size)
    z, p, q = (np.zeros_like(x) for _ in range(3))
    for cx, cy, a, w in [(-12, -10, 7, 8), (15, -12, 5, 6), (0, 14, 8, 7), (-15, 15, 4, 4.5)]:
        g = a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * w * w))
        z += g
        p += -g * (x - cx) / (w * w)
        q += -g * (y - cy) / (w * w)
    return z, p, q


def texture(size=SIZE, seed=3):
    """A smooth random surface filling the frame (no background), RMS slope 0.4."""
    from scipy import ndimage
    rng = np.random.default_rng(seed)
    z = ndimage.gaussian_filter(rng.standard_normal((size, size)), 4.0, mode="reflect")
    q, p = np.gradient(z)
    z *= 0.4 / math.sqrt(float((p * p + q * q).mean()))
    q, p = np.gradient(z)
    return z, p, q


def render(p, q, light):
    L = shading.parse_light(light)
    return np.maximum(0.0, (L[2] - L[0] * p - L[1] * q) / np.sqrt(1 + p * p + q * q))


def pearson(a, b):
    return float(np.corrcoef(np.ravel(a), np.ravel(b))[0, 1])


def gauss_bump(n=64):
    yy, xx = np.mgrid[-n // 2:n // 2, -n // 2:n // 2] + 0.5
    return 8 * np.exp(-(xx**2 + yy**2) / 200)


def cut_sphere(n=64):
    yy, xx = np.mgrid[:n, :n] + 0.5
    return np.sqrt(np.clip(20.0**2 - xx**2 - (yy - n / 2) ** 2, 0, None))


def survey_sphere():
    """The SFS survey's sphere (Zhang et al. 1999): r = 52 on x, y in [-63, 64]; Z and analytic slopes."""
    y, x = np.mgrid[-63:65, -63:65].astype(np.float64)
    s = 52.0**2 - x * x - y * y
    inside = s > 0
    z = np.sqrt(np.where(inside, s, 0.0))
    zz = np.where(inside, np.maximum(z, 1e-3), 1.0)
    return z, np.where(inside, -x / zz, 0.0), np.where(inside, -y / zz, 0.0)


def survey_vase():
    """The survey's vase: Z = sqrt(f(y)² − x²), f(y) = 0.15 − 0.1 y (6y+1)² (y−1)² (3y−2), in pixels."""
    n = 128
    h = 1.0 / (n - 1)
    yy, xx = np.mgrid[:n, :n].astype(np.float64)
    x, y = -0.5 + h * xx, h * yy
    a, b, c = 6 * y + 1, y - 1, 3 * y - 2
    f = 0.15 - 0.1 * y * a * a * b * b * c
    df = -0.1 * (a * a * b * b * c + y * (12 * a * b * b * c + 2 * a * a * b * c + 3 * a * a * b * b))
    s = f * f - x * x
    inside = s > 0
    root = np.sqrt(np.where(inside, s, 0.0))
    rr = np.where(inside, np.maximum(root, 1e-3 * h), 1.0)
    return root / h, np.where(inside, -x / rr, 0.0), np.where(inside, f * df / rr, 0.0)


def light_error_deg(est, light):
    return math.degrees(math.acos(min(1.0, float(np.dot(est, shading.parse_light(light))))))


def ellipsoid_on_plane(size=96):
    """A half ellipsoid (semi-axes 0.36, 0.22, 0.2 of size, rotated 25 deg) on the plane Z = 0."""
    y, x = grid(size)
    a, b, c = 0.36 * size, 0.22 * size, 0.2 * size
    th = math.radians(25)
    xr, yr = x * math.cos(th) + y * math.sin(th), -x * math.sin(th) + y * math.cos(th)
    s = 1 - (xr / a) ** 2 - (yr / b) ** 2
    inside = s > 0
    z = np.where(inside, c * np.sqrt(np.clip(s, 0, None)), 0.0)
    zz = np.maximum(z, 1e-3 * c)
    dxr, dyr = -c * c * xr / (a * a * zz), -c * c * yr / (b * b * zz)
    p = np.where(inside, dxr * math.cos(th) - dyr * math.sin(th), 0.0)
    q = np.where(inside, dxr * math.sin(th) + dyr * math.cos(th), 0.0)
    return z, p, q
