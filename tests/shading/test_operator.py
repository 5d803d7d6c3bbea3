"""The GSFS operator: ``ShadingGreen``, the fused ½(G + H) kernel, its closed form and the eq. 32
identity (docs/derivations.md)."""


import numpy as np
import pytest

import gfgpu
from gfgpu import shading
from gfgpu.greens import HomogeneousGreen, UniformGreen


@pytest.mark.parametrize("u", [0.7, 3.0, 25.0])
def test_fused_kernel_is_half_sum_of_g_and_h(backend, rng, u):
    img = rng.standard_normal((9, 80))
    be = backend.name
    half = 0.5 * (gfgpu.green_filter(img, UniformGreen(u), mode="reflect", backend=be)
                  + gfgpu.green_filter(img, HomogeneousGreen(u), mode="reflect", backend=be))
    fused = gfgpu.green_filter(img, shading.ShadingGreen(u), mode="reflect", backend=be)
    np.testing.assert_allclose(fused, half, rtol=0, atol=1e-12 * np.abs(half).max())


def test_fused_kernel_matches_its_closed_form():
    u = 4.0
    line = np.zeros(200)
    line[10] = 1.0
    out = gfgpu.green_filter(line, shading.ShadingGreen(u), mode="constant", backend="numpy")
    ref = shading.ShadingGreen(u)(np.arange(200), 10)
    np.testing.assert_allclose(out, ref, atol=1e-14)


def test_eq32_identity_holds_to_third_order():
    """Ī2 = ½(G+H)*I1 equals I2 + (½G − G*H + ½H)*I2, I2 = G*I1, up to O((uω)³) (docs/derivations.md)."""
    u, n = 20.0, 4096
    errs = []
    for k in (16, 8):          # uω = 0.49, 0.25: halving uω must cut the error about 8-fold
        x = np.arange(n)
        i1 = np.cos(2 * np.pi * k * x / n)
        f = lambda img, kern: gfgpu.green_filter(img, kern, mode="wrap", backend="numpy")
        G, H = UniformGreen(u), HomogeneousGreen(u)
        lhs = f(i1, shading.ShadingGreen(u))
        i2 = f(i1, G)
        rhs = i2 + 0.5 * f(i2, G) - f(f(i2, H), G) + 0.5 * f(i2, H)
        errs.append(np.abs(lhs - rhs).max())
    uw = u * 2 * np.pi * 16 / n
    assert errs[0] < 1.5 * 0.75 * uw**3          # residual (3/4)|ε|³, docs/derivations.md
    assert 5.0 < errs[0] / errs[1] < 11.0        # third order: ratio 2³ = 8
