"""GSFS rules that the rule check of benchmarks/shading.py switches off, or adds back.

``gfgpu.shading`` dropped two rules of its 'background' prior after this check (issue 32):
growing the flat background back toward the object (:func:`background_region`) and giving a
line without a fixed pixel the constant that best continues its neighbours
(:func:`fix_from_neighbours`).  Both are kept here, as they were, so that the check that dropped
them can be rerun; :func:`variant` patches them (or takes a kept rule out) for one run.  One
rule was added after the held-out run showed its need (flat pockets inside the object are
object); its variant takes it out, and the tuning set is its check.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import linalg as splinalg

from gfgpu._core.lines import direction as _line_direction
from gfgpu.shading import gsfs as _gsfs
from gfgpu.shading import line_fit as _line_fit
from gfgpu.shading.scene import FLAT_EROSION, FLAT_SMOOTHING, border_band, flat_background, noise_sigma


def _layout(angle):
    steep, _, gamma = _line_direction(angle)
    return steep, gamma


#: :func:`background_region` grows the flat set back over the margin that the smoothing and the
#: erosion of :func:`flat_background` cost, into pixels within this fraction of the image's
#: intensity range (or 3 noise sigmas) of the background's intensity
BACKGROUND_TOLERANCE = 0.02


def background_region(image, flat, level, mask=None):
    """The flat background grown over the margin that :func:`flat_background` leaves around it.

    The gradient test smooths by :data:`FLAT_SMOOTHING` and erodes by :data:`FLAT_EROSION`
    pixels, so the flat set stops short of the object by up to ``FLAT_EROSION + 2·FLAT_SMOOTHING``
    pixels.  This grows it back by as many steps (8-connected) into pixels whose intensity is
    within ``max(3 σ_n, BACKGROUND_TOLERANCE · range)`` of ``level`` (the background's
    intensity): where an object is cut by the image border, its runs along a line then start
    at the object, not several pixels before it.
    """
    img = np.asarray(image, np.float64)
    m = np.ones(img.shape, bool) if mask is None else mask
    vals = img[m]
    tol = max(3.0 * noise_sigma(img), BACKGROUND_TOLERANCE * float(vals.max() - vals.min()))
    near = (np.abs(img - level) <= tol) & m
    steps = FLAT_EROSION + int(math.ceil(2 * FLAT_SMOOTHING))
    return ndimage.binary_dilation(flat, np.ones((3, 3), bool), iterations=steps, mask=near) | flat


def fix_from_neighbours(z, angle, line, fixed):
    """``z + c[line]`` for the lines not ``fixed``: least cross-line differences to the others.

    Adjacent lines are adjacent pixels across the dominant axis; ``c`` minimises the sum over
    those pixel pairs of the squared depth difference, the fixed lines held (a tridiagonal
    system).  Without any fixed line the mean of ``c`` is held at 0.
    """
    steep, gamma = _layout(angle)
    zl = z.T if steep else z
    ll = line.T if steep else line
    n = int(line.max()) + 1
    free = ~fixed
    if not free.any():
        return z
    # pairs (m, t) - (m+1, t): lines l and l+1, difference d = z[m+1] - z[m]
    lab = ll[:-1].ravel()
    cnt = np.bincount(lab, minlength=n)[: n - 1]
    dsum = np.bincount(lab, (zl[1:] - zl[:-1]).ravel(), minlength=n)[: n - 1]
    # minimise Σ_l cnt_l (c_{l+1} − c_l + d_l)², d_l = dsum_l/cnt_l, over the free c (fixed c = 0)
    pos = np.full(n, -1)
    pos[free] = np.arange(int(free.sum()))
    k = int(free.sum())
    rows, cols, vals = [], [], []
    rhs = np.zeros(k)
    lo, hi = np.arange(n - 1), np.arange(1, n)
    use = cnt > 0
    lo, hi, cw, dd = lo[use], hi[use], cnt[use].astype(np.float64), dsum[use]
    # gradient of Σ cw (c_hi − c_lo)² + 2 dd (c_hi − c_lo): normal equations entry by entry
    for p_, q_, sgn in ((hi, lo, 1.0), (lo, hi, -1.0)):
        fp = free[p_]
        rows.append(pos[p_[fp]])
        cols.append(pos[p_[fp]])
        vals.append(cw[fp])
        both = fp & free[q_]
        rows.append(pos[p_[both]])
        cols.append(pos[q_[both]])
        vals.append(-cw[both])
        np.add.at(rhs, pos[p_[fp]], -sgn * dd[fp])
    ridge = 0.0 if fixed.any() else 1e-9 * max(1.0, float(cw.max()) if cw.size else 1.0)
    mat = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(k, k)) + ridge * sparse.identity(k, format="csr")
    diag = mat.diagonal()
    isolated = diag <= 0
    if isolated.any():       # a free line with no neighbour pairs: keep it as it is
        mat = mat + sparse.diags(isolated.astype(np.float64))
    c_free = splinalg.spsolve(mat.tocsc(), rhs)
    c = np.zeros(n)
    c[free] = c_free
    if not fixed.any():
        c -= c.mean()
    return z + c[line]


def c_only(z, line, t, obj, anchors):
    """fix_object without the ramp: each line's constant only."""
    n = int(line.max()) + 1
    w = anchors.astype(np.float64).ravel()
    s0 = np.bincount(line.ravel(), w, minlength=n)
    sz = np.bincount(line.ravel(), w * z.ravel(), minlength=n)
    c = -np.divide(sz, s0, out=np.zeros(n), where=s0 > 0)
    return z + c[line], s0 > 0


def _regrown_object_and_level(img, m, user_object):
    if user_object:
        return _ORIGINAL["object_and_level"](img, m, user_object)
    flat = flat_background(img, m)
    k0 = float(np.median(img[flat if flat.any() else (border_band(img.shape) & m)]))
    return ~background_region(img, flat, k0), k0       # as it was: no pocket filling either


def _unfilled_object_and_level(img, m, user_object):
    if user_object:
        return _ORIGINAL["object_and_level"](img, m, user_object)
    flat = flat_background(img, m)
    k0 = float(np.median(img[flat if flat.any() else (border_band(img.shape) & m)]))
    return ~flat, k0


def _with_neighbours(angle):
    def fix(z, line, t, obj, anchors):
        out, anchored = _ORIGINAL["fix_object"](z, line, t, obj, anchors)
        crossed = np.bincount(line.ravel(), obj.ravel().astype(np.float64), minlength=anchored.size) > 0
        return fix_from_neighbours(out, angle, line, anchored | ~crossed), anchored
    return fix


_ORIGINAL = {"object_and_level": _gsfs._object_and_level, "fix_object": _line_fit.fix_object,
             "quiet_sides": _gsfs.quiet_sides}

#: variant name -> what it changes (see :func:`variant`)
VARIANTS = ("all kept rules (default)", "- quiet-side line ends", "- ramp (two-sided lines)",
            "- pockets filled (added after the held-out run)", "+ regrown background (dropped)",
            "+ neighbour constants (dropped)")


@contextlib.contextmanager
def variant(name, angle):
    """Run GSFS with rule ``name`` switched off (-) or added back (+); ``angle`` the lines' direction."""
    patches = {"- quiet-side line ends": (_gsfs, "quiet_sides", lambda img, mask=None: (False,) * 4),
               "- ramp (two-sided lines)": (_line_fit, "fix_object", c_only),
               "- pockets filled (added after the held-out run)": (_gsfs, "_object_and_level",
                                                                   _unfilled_object_and_level),
               "+ regrown background (dropped)": (_gsfs, "_object_and_level", _regrown_object_and_level),
               "+ neighbour constants (dropped)": (_line_fit, "fix_object", _with_neighbours(angle))}
    if name not in patches:
        if name != VARIANTS[0]:
            raise ValueError(f"unknown variant {name!r}")
        yield
        return
    owner, attr, repl = patches[name]
    saved = getattr(owner, attr)
    setattr(owner, attr, repl)
    try:
        yield
    finally:
        setattr(owner, attr, saved)
