"""Baselines for benchmarks/shading.py: Pentland's linear SFS (1990) and Tsai & Shah (1994).

Both in numpy, from the papers, in gfgpu's conventions (gfgpu/shading/): ``p = ∂Z/∂x``
(columns), ``q = ∂Z/∂y`` (rows, downward), unit normal ``(-p, -q, 1)/sqrt(1 + p² + q²)``,
unit light ``(l1, l2, l3)`` with ``l3 > 0``, image ``ρ·max(0, n·L)``.
"""

from __future__ import annotations

import numpy as np


def pentland_linear(image, light, albedo=1.0, min_response=1e-3):
    """Pentland's linear shape from shading (FFT), A. Pentland, "Linear shape from shading",
    IJCV 4:153-162, 1990.

    The reflectance map is linearised about ``p = q = 0``:
    ``I ≈ ρ(l3 − l1 p − l2 q)``, so in the Fourier domain (ω in radians per pixel)
    ``F[I](ω) = −ρ i (l1 ω_x + l2 ω_y) F[Z](ω)`` for ω ≠ 0, and
    ``F[Z] = −F[I] / (ρ i (l1 ω_x + l2 ω_y))``.  Frequencies where ``|l1 ω_x + l2 ω_y|`` is
    below ``min_response`` (including ω = 0 and, for a frontal light, every frequency) carry no
    information and are set to 0, as in the paper; a frontal light therefore gives Z = 0.
    The FFT treats the image as periodic (no padding or windowing, as in the paper).
    """
    img = np.asarray(image, np.float64)
    h, w = img.shape
    wy = 2 * np.pi * np.fft.fftfreq(h)[:, None]
    wx = 2 * np.pi * np.fft.fftfreq(w)[None, :]
    resp = light[0] * wx + light[1] * wy
    spec = np.fft.fft2(img - img.mean())
    ok = np.abs(resp) > min_response
    zs = np.zeros_like(spec)
    zs[ok] = -spec[ok] / (albedo * 1j * resp[ok])
    return np.real(np.fft.ifft2(zs))


def tsai_shah(image, light, albedo=1.0, iterations=10, noise_variance=1e-8):
    """Tsai & Shah's linear-in-depth SFS (P.-S. Tsai and M. Shah, "Shape from shading using
    linear approximation", Image and Vision Computing 12(8):487-498, 1994).

    With backward differences ``p = Z[y, x] − Z[y, x−1]`` and ``q = Z[y, x] − Z[y−1, x]``, the
    irradiance equation ``f(Z) = I − ρ R(p, q) = 0`` is linearised in ``Z`` at each pixel and
    solved by Jacobi iterations from ``Z = 0``, in the paper's Kalman-gain form:
    ``K = S f' / (W + f'² S)``, ``Z ← Z − K f``, ``S ← (1 − K f') S``, with ``S = 1`` initially,
    ``f' = ∂f/∂Z = −ρ(R_p + R_q)`` and ``W = noise_variance`` (the paper's ``W_n``).  The first
    step is Newton's; later steps shrink as ``S`` does (a running average of the Newton
    targets).  ``iterations`` defaults to 10 (the paper reports convergence in a few).
    Pixels outside the image take the edge values (replicated).  The reflectance is not
    clipped at 0 inside the iteration (its derivative would vanish); a frontal light gives
    ``f' = 0`` at ``Z = 0`` and the iteration stays at the flat surface.
    """
    img = np.asarray(image, np.float64)
    l1, l2, l3 = (float(v) for v in light)
    z = np.zeros_like(img)
    s = np.ones_like(img)
    for _ in range(iterations):
        zx = np.concatenate([z[:, :1], z[:, :-1]], axis=1)
        zy = np.concatenate([z[:1, :], z[:-1, :]], axis=0)
        p, q = z - zx, z - zy
        norm = np.sqrt(1 + p * p + q * q)
        num = l3 - l1 * p - l2 * q
        # ∂R/∂p = (−l1 norm² − num p)/norm³, likewise for q; dp/dZ = dq/dZ = 1
        dr = ((-l1 - l2) * norm * norm - num * (p + q)) / norm**3
        f = img - albedo * num / norm
        df = -albedo * dr
        k = s * df / (noise_variance + df * df * s)
        z = z - k * f
        s = (1 - k * df) * s
    return z
