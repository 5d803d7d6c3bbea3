"""The standard synthetic surfaces of the shape-from-shading survey, for benchmarks/shading.py.

R. Zhang, P.-S. Tsai, J. E. Cryer and M. Shah, "Shape from shading: a survey", IEEE Trans. PAMI
21(8):690-706, 1999, §5.1 ("synthetic images"), 128 x 128 images:

* **sphere**: ``Z(x, y) = sqrt(r² − x² − y²)`` inside ``x² + y² <= r²``, 0 outside, ``r = 52``,
  ``−63 <= x, y <= 64`` (pixel units);
* **vase**: ``Z(x, y) = sqrt(f(y)² − x²)`` where ``f(y)² > x²``, 0 outside, with
  ``f(y) = 0.15 − 0.1·y·(6y + 1)²·(y − 1)²·(3y − 2)``, ``−0.5 <= x <= 0.5``, ``0 <= y <= 1``
  sampled on 128 x 128 pixels (y = 0 the top row); here in pixel units (``Z / h``, ``h = 1/127``
  the sample spacing), so the vase's widest point (f = 0.28) is 36 px high.

The survey's third synthetic surface (Mozart, a laser-scanned head) and its real images were
distributed by ftp from eustis.cs.ucf.edu; that data is not available to this benchmark, so no
scanned surface is included.  The survey's lights are (0, 0, 1), (1, 0, 1) and (5, 5, 7); the
table adds their mirror images (−1, 0, 1), (0, 1, 1) and (1, 1, 2).

Both are given with analytic gradients ``(p, q) = (∂Z/∂x, ∂Z/∂y)`` (x the column, y the row,
downward); at the occluding contour, where the slope is infinite, ``|∇Z|`` is capped at 1000.
"""

from __future__ import annotations

import numpy as np

SIZE = 128
SLOPE_CAP = 1000.0


def _capped(p, q, inside):
    g = np.hypot(p, q)
    k = np.where(g > SLOPE_CAP, SLOPE_CAP / np.maximum(g, 1e-300), 1.0)
    return np.where(inside, p * k, 0.0), np.where(inside, q * k, 0.0)


def survey_sphere():
    """(Z, p, q) of the survey's sphere, r = 52 on x, y in [−63, 64]; (128, 128) float64."""
    y, x = np.mgrid[-63:65, -63:65].astype(np.float64)
    r = 52.0
    s = r * r - x * x - y * y
    inside = s > 0
    z = np.sqrt(np.where(inside, s, 0.0))
    zz = np.where(inside, z, 1.0)
    p, q = _capped(-x / zz, -y / zz, inside)
    return z, p, q


def vase_profile(y):
    """The survey's vase radius ``f(y)`` and ``f'(y)`` (y in [0, 1], image-width units)."""
    a, b, c = 6 * y + 1, y - 1, 3 * y - 2
    f = 0.15 - 0.1 * y * a * a * b * b * c
    # d/dy of y a² b² c: a²b²c + y(12 a b² c + 2 a² b c + 3 a² b²)
    df = -0.1 * (a * a * b * b * c + y * (12 * a * b * b * c + 2 * a * a * b * c + 3 * a * a * b * b))
    return f, df


def survey_vase():
    """(Z, p, q) of the survey's vase in pixel units; (128, 128) float64."""
    h = 1.0 / (SIZE - 1)
    yy, xx = np.mgrid[:SIZE, :SIZE].astype(np.float64)
    x, y = -0.5 + h * xx, h * yy
    f, df = vase_profile(y)
    s = f * f - x * x
    inside = s > 0
    root = np.sqrt(np.where(inside, s, 0.0))
    z = root / h
    rr = np.where(inside, root, 1.0)
    # Z = root/h, ∂/∂col = h ∂/∂x, ∂/∂row = h ∂/∂y
    p, q = _capped(-x / rr, f * df / rr, inside)
    return z, p, q


#: the survey's surfaces: name -> () -> (Z, p, q)
SURVEY = {"sphere": survey_sphere, "vase": survey_vase}

#: the survey's lights and their mirror images (l2 > 0 points down the rows)
SURVEY_LIGHTS = {"(0,0,1)": (0.0, 0.0, 1.0), "(1,0,1)": (1.0, 0.0, 1.0), "(5,5,7)": (5.0, 5.0, 7.0),
                 "(-1,0,1)": (-1.0, 0.0, 1.0), "(0,1,1)": (0.0, 1.0, 1.0), "(1,1,2)": (1.0, 1.0, 2.0)}
