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
