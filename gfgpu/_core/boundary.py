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
"""

from __future__ import annotations

import numpy as np

__all__ = ["MODES", "MODE_CODES", "PERIODIC_MODES", "check_mode", "extend_index", "period"]

#: the boundary modes, in the order error messages list them
MODES = ("constant", "nearest", "reflect", "mirror", "wrap")

#: the modes as device kernels number them (launchers pass every code to the kernels)
MODE_CODES = {"constant": 0, "nearest": 1, "wrap": 2, "reflect": 3, "mirror": 4}

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
