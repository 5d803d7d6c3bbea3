"""The two free constants of every GSFS integration line: where the depth is fixed, and the fits.

Integrating the shading along γ leaves, on every digital line, a constant ``c`` and a ramp
``a·t`` undetermined (Notes of :func:`gfgpu.shading.shape_from_shading`).  This module finds the
pixels where a prior fixes the depth and fits ``(c, a)`` line by line:

* ``object`` prior: the depth is 0 (the reference plane) at the pixels just outside the object
  along each line (:func:`boundary_anchors`).  A line whose anchors lie on both sides of its
  object pixels gets ``c`` and ``a`` (Dirichlet conditions at both ends); a line cut by the image
  border on one side gets ``c`` only, since one end cannot fix a ramp; a line that is object from
  border to border keeps its integral's start (Z = 0 where it enters the image).
* ``free`` prior: every line has zero weighted mean (:func:`fix_zero_mean`).

Lines are those of :mod:`gfgpu._core.lines` at integer offsets ``r[t] = floor(γt + ½)``, laid out
as ``minor x major`` (``t`` the step along the dominant axis): pixel ``(m, t)`` is on line
``m − r[t]`` and its neighbours on the same line are ``(m ± (r[t±1] − r[t]), t ± 1)``.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .._core.lines import direction as _line_direction

__all__ = ["line_coordinates", "boundary_anchors", "line_ends_on", "fix_object", "fix_zero_mean"]


def _layout(angle):
    steep, _, gamma = _line_direction(angle)
    return steep, gamma


def _offsets(steps, gamma):
    return np.floor(gamma * np.arange(steps) + 0.5).astype(np.int64)


def line_coordinates(shape, angle):
    """Line index (0-based) and step position ``t`` of every pixel, for lines at ``angle``."""
    steep, gamma = _layout(angle)
    h, w = shape
    yy, xx = np.mgrid[:h, :w]
    t, minor = (yy, xx) if steep else (xx, yy)
    r = _offsets(h if steep else w, gamma)
    line = minor - r[t]
    return line - line.min(), t.astype(np.float64)


def _along(a, gamma, sign):
    """``out[m, t] = a[m + sign·(r[t+sign] − r[t]), t + sign]`` (False beyond the image)."""
    n_minor, n_major = a.shape
    out = np.zeros_like(a)
    if n_major < 2:
        return out
    dr = np.diff(_offsets(n_major, gamma))
    src_t = np.arange(1, n_major) if sign > 0 else np.arange(n_major - 1)
    step = dr if sign > 0 else -dr
    rows = np.arange(n_minor)[:, None] + step[None, :]
    ok = (rows >= 0) & (rows < n_minor)
    vals = a[np.clip(rows, 0, n_minor - 1), src_t[None, :]] & ok
    if sign > 0:
        out[:, :-1] = vals
    else:
        out[:, 1:] = vals
    return out


def boundary_anchors(obj, angle):
    """Pixels outside ``obj`` whose previous or next pixel along their line is in ``obj``.

    They are where every run of object pixels along a line starts and ends inside the image;
    where the object reaches the image border its runs have no anchor on that side.
    """
    steep, gamma = _layout(angle)
    a = obj.T if steep else obj
    near = _along(a, gamma, 1) | _along(a, gamma, -1)
    out = ~a & near
    return out.T if steep else out


def line_ends_on(line, t, sides):
    """First and last pixel of every line, where every image side it lies on is in ``sides``.

    ``sides`` is ``(top, bottom, left, right)`` bools (:func:`gfgpu.shading.scene.quiet_sides`).
    """
    n = int(line.max()) + 1
    idx = np.arange(n)
    lo = ndimage.minimum(t, line, idx)
    hi = ndimage.maximum(t, line, idx)
    ends = (t == lo[line]) | (t == hi[line])
    h, w = line.shape
    ok = np.ones(line.shape, bool)
    edges = [(np.s_[0, :], sides[0]), (np.s_[h - 1, :], sides[1]), (np.s_[:, 0], sides[2]), (np.s_[:, w - 1], sides[3])]
    for sl, quiet in edges:
        if not quiet:
            ok[sl] = False
    return ends & ok


def _per_line(lab, n, weights, values):
    return np.bincount(lab, (weights * values).ravel(), minlength=n)


def fix_zero_mean(z, line, weights):
    """``z + c[line]`` with ``c`` giving every line zero ``weights``-weighted mean."""
    n = int(line.max()) + 1
    lab = line.ravel()
    cnt = _per_line(lab, n, weights, 1.0)
    c = -np.divide(_per_line(lab, n, weights, z), cnt, out=np.zeros(n), where=cnt > 0)
    return z + c[line]


def fix_object(z, line, t, obj, anchors):
    """Fit ``c`` (and ``a``, when the anchors bracket the object) so the anchors lie at Z = 0.

    Returns the corrected depth and a bool per line: whether it had anchors.
    """
    n = int(line.max()) + 1
    lab = line.ravel()
    idx = np.arange(n)
    w = anchors.astype(np.float64)
    s0, s1, s2 = (_per_line(lab, n, w, v) for v in (1.0, t, t * t))
    sz, stz = _per_line(lab, n, w, z), _per_line(lab, n, w, t * z)
    anchored = s0 > 0
    # a line's ramp is fixed only by anchors on both sides of its object pixels
    inf = np.inf
    free = obj & ~anchors
    obj_lo = ndimage.minimum(np.where(free, t, inf), line, idx)
    obj_hi = ndimage.maximum(np.where(free, t, -inf), line, idx)
    anc_lo = ndimage.minimum(np.where(anchors, t, inf), line, idx)
    anc_hi = ndimage.maximum(np.where(anchors, t, -inf), line, idx)
    two_sided = anchored & (anc_lo < obj_lo) & (anc_hi > obj_hi)
    det = s0 * s2 - s1 * s1
    ramp = two_sided & (det > 1e-9 * np.maximum(s0 * s2, 1e-300))
    a = np.zeros(n)
    a[ramp] = -(s0[ramp] * stz[ramp] - s1[ramp] * sz[ramp]) / det[ramp]
    c = -np.divide(sz + a * s1, s0, out=np.zeros(n), where=anchored)
    return z + c[line] + a[line] * t, anchored
