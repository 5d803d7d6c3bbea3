"""Boundary modes: where sample ``i`` of a line of ``n`` samples lands, for scipy.ndimage's modes.

A line ``a b c d`` extends beyond its ends as scipy.ndimage's filters extend it (the same as
``numpy.pad`` with the mode in the last column):

=========  ==========================  =======================  ============
mode       extension                   left of ``a b c d``      numpy.pad
=========  ==========================  =======================  ============
constant   ``cval``                    ``k k k k | a b c d``    constant
nearest    edge value                  ``a a a a | a b c d``    edge
reflect    half-sample symmetric       ``d c b a | a b c d``    symmetric
mirror     whole-sample symmetric      ``d c b | a b c d``      reflect
wrap       periodic                    ``a b c d | a b c d``    wrap
=========  ==========================  =======================  ============

(``mirror`` on a line of one sample repeats it, as ``nearest`` does.)  The right end is the
left end's rule on the reversed line.  :func:`extend_index` is the one host definition of this
index map; device kernels, which cannot call Python, implement the same map on the integer codes
of :data:`MODE_CODES`, which their launchers pass to them (``-D MODE_*`` defines, or Warp
constants) rather than retyping.

scipy's names
-------------
The public operators take every name of scipy.ndimage, with scipy's meaning
(:func:`filter_mode`, :func:`interpolation_mode`).  For filters (convolutions, recursions,
derivatives) scipy's ``grid-*`` names are aliases: ``grid-constant`` is ``constant``,
``grid-wrap`` is ``wrap``, ``grid-mirror`` is ``reflect``.  For interpolation (``shift``) two
names differ from their ``grid-*`` twin, as in scipy's ``map_coordinate``
(``scipy/ndimage/src/ni_interpolation.c``):

=============  ==============================================================================
mode           value at a source coordinate ``c`` of a line of ``n`` samples
=============  ==============================================================================
constant       the interpolant of the ``mirror`` extension at ``c`` for ``0 <= c <= n - 1``,
               ``cval`` anywhere else (no tolerance: ``c = -1e-16`` is ``cval``)
grid-constant  the interpolant of the ``cval`` extension (this module's ``constant``)
wrap           the interpolant of the ``mirror`` extension at ``c`` folded into
               ``[0, n - 1]`` with period ``n - 1`` (:func:`fold_coordinate`)
grid-wrap      the interpolant of the period-``n`` extension (this module's ``wrap``)
=============  ==============================================================================

:func:`interpolation_branch` tells, per source coordinate, which of these applies; the
engine's five modes above stay what the kernels compute.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MODES", "MODE_CODES", "PERIODIC_MODES", "SCIPY_MODES", "check_mode", "extend_index", "period",
           "filter_mode", "interpolation_mode", "fold_coordinate", "interpolation_branch"]

#: the boundary modes, in the order error messages list them
MODES = ("constant", "nearest", "reflect", "mirror", "wrap")

#: the modes as device kernels number them (launchers pass every code to the kernels)
MODE_CODES = {"constant": 0, "nearest": 1, "wrap": 2, "reflect": 3, "mirror": 4}

#: every name of scipy.ndimage's ``mode``, in the order error messages list them
SCIPY_MODES = ("reflect", "grid-mirror", "constant", "grid-constant", "nearest", "mirror", "wrap", "grid-wrap")

#: scipy's ``grid-*`` names: the mode of :data:`MODES` they are
_GRID_ALIASES = {"grid-mirror": "reflect", "grid-constant": "constant", "grid-wrap": "wrap"}

#: the modes whose extension repeats with a period (:func:`period`); the others extend by one value
PERIODIC_MODES = ("wrap", "reflect", "mirror")


def check_mode(mode):
    """``mode`` if it is one of :data:`MODES`.

    Raises
    ------
    ValueError
        For any other value.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    return mode


def period(n, mode):
    """The period of the extension of a line of ``n >= 1`` samples by ``mode``: ``n`` (wrap),
    ``2 n`` (reflect), ``max(2 n - 2, 1)`` (mirror); None for ``"constant"`` and ``"nearest"``,
    which extend by one value."""
    check_mode(mode)
    return {"wrap": n, "reflect": 2 * n, "mirror": max(2 * n - 2, 1)}.get(mode)


def extend_index(i, n, mode):
    """Index into ``[0, n)`` of sample ``i`` of a line of ``n`` samples extended by ``mode``.

    Parameters
    ----------
    i : array_like of int
        Sample positions, any integers (negative, or beyond the line by many periods).
    n : int
        Samples in the line, ``n >= 1``.
    mode : str
        One of :data:`MODES` (table in the module docstring).

    Returns
    -------
    ndarray of int64
        ``i``'s shape: ``i`` itself inside the line; beyond it the sample the extension
        repeats there, or -1 where it is ``cval`` (``"constant"``).

    Raises
    ------
    ValueError
        ``mode`` is not one of :data:`MODES`.

    Examples
    --------
    >>> extend_index([-3, -2, -1, 0, 3, 4, 5], 4, "reflect").tolist()
    [2, 1, 0, 0, 3, 3, 2]
    >>> extend_index([-3, -2, -1, 0, 3, 4, 5], 4, "mirror").tolist()
    [3, 2, 1, 0, 3, 2, 1]
    """
    check_mode(mode)
    i = np.asarray(i, np.int64)
    if mode == "constant":
        return np.where((i >= 0) & (i < n), i, -1)
    if mode == "nearest":
        return np.clip(i, 0, n - 1)
    if mode == "wrap":
        return np.mod(i, n)
    if mode == "reflect":                       # d c b a | a b c d | d c b a
        q = np.mod(i, 2 * n)
        return np.where(q < n, q, 2 * n - 1 - q)
    if n == 1:                                  # mirror: d c b | a b c d | c b a
        return np.zeros_like(i)
    q = np.mod(i, 2 * n - 2)
    return np.where(q < n, q, 2 * n - 2 - q)


def _scipy_name(mode, argument="mode"):
    if not isinstance(mode, str) or mode not in SCIPY_MODES:
        raise ValueError(f"{argument} must be one of {', '.join(SCIPY_MODES)} (scipy.ndimage's names); "
                         f"got {mode!r}")
    return mode


def filter_mode(mode):
    """The mode of :data:`MODES` that scipy's name ``mode`` means for a filter.

    scipy.ndimage's filters treat ``grid-constant`` as ``constant``, ``grid-wrap`` as
    ``wrap`` and ``grid-mirror`` as ``reflect``; the other names are :data:`MODES` themselves.

    Raises
    ------
    ValueError
        ``mode`` is not one of :data:`SCIPY_MODES`.

    Examples
    --------
    >>> filter_mode("grid-wrap"), filter_mode("constant")
    ('wrap', 'constant')
    """
    return _GRID_ALIASES.get(_scipy_name(mode), mode)


def interpolation_mode(mode):
    """``(engine mode, rule)`` of scipy's name ``mode`` for interpolation (``shift``).

    ``engine mode`` is the mode of :data:`MODES` the interpolant is computed on; ``rule`` is
    None where that is the whole story, else ``"constant"`` or ``"wrap"``: scipy's
    interpolation-only meanings, computed on the ``mirror`` extension and then read at the
    coordinates :func:`interpolation_branch` gives (module docstring).

    Raises
    ------
    ValueError
        ``mode`` is not one of :data:`SCIPY_MODES`.

    Examples
    --------
    >>> interpolation_mode("constant"), interpolation_mode("grid-constant")
    (('mirror', 'constant'), ('constant', None))
    """
    if _scipy_name(mode) in ("constant", "wrap"):
        return "mirror", mode
    return _GRID_ALIASES.get(mode, mode), None


def fold_coordinate(c, n):
    """scipy's ``wrap`` map of source coordinates ``c`` (float) onto ``[0, n - 1]``, period ``n - 1``.

    As scipy's ``map_coordinate`` computes it (truncating division, so that ``c = -(n - 1)``
    lands on ``n - 1`` and ``c = n - 1`` stays there); ``n <= 1`` maps everything to 0.

    Returns
    -------
    (ndarray of float64, ndarray of int64)
        The folded coordinate ``c - (n - 1) k`` and the number of periods ``k``.

    Examples
    --------
    >>> c, k = fold_coordinate([-3.0, -1.0, 0.5, 3.0, 4.0], 4)
    >>> c.tolist(), k.tolist()
    ([3.0, 2.0, 0.5, 3.0, 1.0], [-2, -1, 0, 0, 1])
    """
    c = np.asarray(c, np.float64)
    if n <= 1:
        return np.zeros_like(c), np.zeros(c.shape, np.int64)
    size = n - 1
    k = np.zeros(c.shape, np.int64)
    low, high = c < 0, c > n - 1
    k[low] = -(np.trunc(-c[low] / size).astype(np.int64) + 1)
    k[high] = np.trunc(c[high] / size).astype(np.int64)
    return c - size * k, k


def interpolation_branch(c, n, rule):
    """Where the interpolant of the ``mirror`` extension is read for scipy's ``rule`` mode.

    Parameters
    ----------
    c : array_like of float
        Source coordinates on a line of ``n`` samples (``i - shift`` for a shift).
    n : int
        Samples in the line.
    rule : {'constant', 'wrap'}
        The second value of :func:`interpolation_mode`.

    Returns
    -------
    ndarray of int8
        ``c``'s shape: 0 where the value is the interpolant at ``c`` itself, 1 where it is the
        interpolant at ``c - (n - 1)`` (``wrap``, an odd number of folds: the ``mirror``
        extension has period ``2 (n - 1)``, so an even number of folds reads ``c`` itself), -1
        where it is ``cval`` (``constant``, ``c`` outside ``[0, n - 1]``).

    Examples
    --------
    >>> interpolation_branch([-0.5, 0.0, 3.0, 3.5], 4, "constant").tolist()
    [-1, 0, 0, -1]
    >>> interpolation_branch([-4.0, -1.0, 1.0, 4.0, 7.0], 4, "wrap").tolist()
    [0, 1, 0, 1, 0]
    """
    c = np.asarray(c, np.float64)
    if rule == "constant":
        return np.where((c >= 0) & (c <= n - 1), 0, -1).astype(np.int8)
    if rule == "wrap":
        return (np.mod(fold_coordinate(c, n)[1], 2)).astype(np.int8)
    raise ValueError(f"rule must be 'constant' or 'wrap', got {rule!r}")
