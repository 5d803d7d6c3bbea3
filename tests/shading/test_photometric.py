"""Photometric motion (gfgpu.shading.photometric_motion)."""


import numpy as np

from gfgpu import shading

from .surfaces import grid, pearson


def test_photometric_motion_recovers_a_frontally_lit_cap(backend):
    y, x = grid()
    z = np.sqrt(48.0**2 - x * x - y * y)
    img = shading.lambertian_shading(z, (0, 0, 1)).astype(np.float32)
    est = shading.photometric_motion(img, light=(0, 0, 1), backend=backend.name)
    assert est.dtype == np.float32
    assert pearson(est, z) >= 0.95
