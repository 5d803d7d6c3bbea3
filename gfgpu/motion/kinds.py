"""The kinds of motion and the point-spread functions, in one table that every entry point reads.

A kind of motion is one :class:`MotionKind`: how its ``velocity`` is read and checked, what it
is at the fraction ``t`` of the exposure (the frames of :func:`~gfgpu.motion.synthesize_motion`),
how it runs (the apply functions of :mod:`~gfgpu.motion.uniform`, :mod:`~gfgpu.motion.box`,
:mod:`~gfgpu.motion.field`, :mod:`~gfgpu.motion.zoom` and :mod:`~gfgpu.motion.polar`), and which
axes of the image plane a Dask chunk must hold whole (none: exact across chunks, the recursion
state carried between them).  :func:`gfgpu.motion_blur`, :func:`gfgpu.synthesize_motion`,
:func:`gfgpu.dask.motion_blur`, ``gfgpu batch blur`` and the ``gfgpu blur``/``gfgpu frames``
commands all dispatch through :data:`MOTIONS` and :data:`PSFS`, so each offers every kind and
every point-spread function of the table.

Coordinates are array-axis order: velocities ``(vy, vx)``, zoom rates ``(u1_y, u1_x)``, fields
``(2, H, W)`` (rows, cols components), centres ``(row, col)``.

Examples
--------
>>> KINDS, tuple(PSFS)
(('uniform', 'zoom', 'rotation'), ('green', 'box'))
>>> mk = motion_kind("zoom", 0.3)
>>> mk.name, mk.parse(0.3), mk.whole_axes((0.3, 0.3), "green")
('zoom', (0.3, 0.3), (-2, -1))
>>> [round(r, 4) for r in mk.at((0.44, 0.44), 0.5)]      # constant rate: (1 + u1)^t - 1
[0.2, 0.2]
>>> motion_kind("uniform", np.zeros((2, 4, 5))).name       # a (2, H, W) velocity is a field
'field'
>>> motion_kind("spin", 1.0)
Traceback (most recent call last):
...
ValueError: kind must be one of uniform, zoom, rotation; got 'spin'
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._core.job import apply_program, copy_of_input
from .box import apply_uniform_box
from .field import apply_field, check_field, is_field
from .params import center_point, velocity_pair, zoom_factors
from .polar import apply_radial_green_zoom, apply_radial_zoom, apply_spin
from .polar import check_center as check_polar_center
from .rotation import rotation_angle
from .spec import PSF_CODES
from .uniform import uniform_motion_program
from .zoom import apply_zoom

__all__ = ["PointSpread", "MotionKind", "PSFS", "MOTIONS", "KINDS", "psf_name", "check_kind", "motion_kind"]


# --------------------------------------------------------------------------------------
# point-spread functions
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PointSpread:
    """A point-spread function along the path: its name and a one-line description."""

    name: str
    summary: str

    def code(self, displace):
        """The fused kernels' number of this PSF (:data:`gfgpu.motion.spec.PSF_CODES`)."""
        return PSF_CODES[self.name, bool(displace)]


#: the point-spread functions, the default first (names as in :data:`gfgpu.motion.spec.PSF_CODES`)
PSFS = {p.name: p for p in (
    PointSpread("green", "the chapter's G_u: a comet-like smear whose mean is exactly the displacement "
                         "(default)"),
    PointSpread("box", "a uniform exposure over the whole path (a camera's open shutter)"),
)}


def psf_name(psf):
    """``psf`` checked against :data:`PSFS`."""
    if not isinstance(psf, str) or psf not in PSFS:
        raise ValueError(f"psf must be one of {', '.join(map(repr, PSFS))}, got {psf!r}")
    return psf


# --------------------------------------------------------------------------------------
# the kinds of motion
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MotionKind:
    """One kind of motion: everything an entry point needs to offer it.

    Attributes
    ----------
    name : str
        Its key in :data:`MOTIONS`.
    kind : str
        The ``kind=`` argument that selects it (``'uniform'`` for a velocity field, which its
        ``(2, H, W)`` shape tells apart).
    form : str
        How its ``velocity`` is written, for messages: ``"(vy, vx)"``, ``"u1"``, ...
    takes_field : bool
        Whether its ``velocity`` is a per-pixel field ``(2, H, W)`` (an array of 3 dimensions):
        ``kind`` and the velocity's shape select the entry (:func:`motion_kind`).
    uses_center : bool
        Whether ``center`` is its fixed point (ignored otherwise).
    parse : callable ``(velocity) -> params``
        The velocity checked (ValueError/TypeError naming it and its range), before any work.
    fit : callable ``(params, shape) -> params``
        The parameters checked against the image's shape ``(..., H, W)`` (a field's shape).
    center : callable ``(center, height, width) -> (row, col) or None``
        The fixed point checked (None where the kind has none).
    at : callable ``(params, t) -> velocity``
        The velocity of the fraction ``t`` in [0, 1] of the motion: what frame ``k`` of ``n``
        (``t = k / (n - 1)``) shows in :func:`~gfgpu.motion.synthesize_motion`.
    run : callable ``(job, params, psf, center, displace, mode, cval, quadrature) -> result``
        Applies it to a :class:`~gfgpu._core.job.Job` (``center`` as checked by ``center``;
        ``quadrature`` the velocity fields' rule, :data:`gfgpu.motion.field.FIELD_RULES`).
    whole_axes : callable ``(params, psf) -> tuple of int``
        The image-plane axes (``-2`` rows, ``-1`` cols) that one Dask chunk must hold whole, or
        ``()``: the motion runs as ``program``'s recursive passes, exact across chunks along an
        axis (the state carried between them; :func:`gfgpu.dask.run_program` holds the plane
        whole for a pass in an oblique direction).
    program : callable ``(ndim, params, displace) -> Program`` or None
        The recursive passes where ``whole_axes`` is empty.
    """

    name: str
    kind: str
    form: str
    takes_field: bool
    uses_center: bool
    parse: Callable
    fit: Callable
    center: Callable
    at: Callable
    run: Callable
    whole_axes: Callable
    program: Callable | None = None


def _no_center(center, height, width):
    return None


def _same(params, shape):
    return params


def _whole_plane(params, psf):
    return (-2, -1)


# uniform motion ------------------------------------------------------------------------
def _uniform_parse(velocity):
    vy, vx = velocity_pair(velocity)
    uniform_motion_program(2, (vy, vx))          # checks the length (at most 1e9 px)
    return vy, vx


def _uniform_run(job, params, psf, center, displace, mode, cval, quadrature):
    vy, vx = params
    if psf == "box" and (vy, vx) != (0.0, 0.0):
        return apply_uniform_box(job, vy, vx, displace, mode, job.scaled(cval))   # cval in job.data's units
    return apply_program(job, uniform_motion_program(job.ndim, (vy, vx), displace), mode, cval)


def _uniform_whole_axes(params, psf):
    vy, vx = params
    if psf == "green" or (vy, vx) == (0.0, 0.0):
        return ()                                # the G_u passes (carried along an axis, whole if oblique)
    if vy == 0.0:
        return (-1,)                             # the box along the rows' lines: whole rows
    if vx == 0.0:
        return (-2,)                             # along the columns: whole columns
    return (-2, -1)                              # an oblique box: the sheared layout of the plane


# velocity field ------------------------------------------------------------------------
def _field_run(job, field, psf, center, displace, mode, cval, quadrature):
    return apply_field(job, field, PSFS[psf].code(displace), mode, job.scaled(cval), quadrature)


# zoom ----------------------------------------------------------------------------------
def _zoom_center(center, height, width):
    cy, cx = center_point(center, height, width)
    if not (0.0 <= cy <= height - 1 and 0.0 <= cx <= width - 1):
        raise ValueError(f"center (row, col) = ({cy:g}, {cx:g}) must lie inside the image, "
                         f"0 <= row <= {height - 1} and 0 <= col <= {width - 1}")
    return cy, cx


def _zoom_run(job, params, psf, center, displace, mode, cval, quadrature):
    """G_U^(1) separably for two rates; else along the rays of the polar grid (G_U^(1) or box),
    or the box's affine field for two rates."""
    u1y, u1x = params
    cy, cx = center
    # cval in job.data's units (scaled near the dtype's limit); the polar paths scale it after
    # their cost refusal, which reads no pixel
    if psf == "green" and u1y != u1x:
        return apply_zoom(job, u1y, u1x, center, mode, job.scaled(cval))
    if u1x == 0.0 and u1y == 0.0:
        return job.finish(copy_of_input(job))
    if psf == "green":
        return apply_radial_green_zoom(job, u1x, cy, cx, mode, cval)
    if u1y == u1x:
        return apply_radial_zoom(job, u1x, cy, cx, displace, mode, cval)
    height, width = job.shape[-2], job.shape[-1]
    yy, xx = np.mgrid[:height, :width].astype(np.float64)
    field = np.stack([(u1y / (1.0 + u1y)) * (yy - cy), (u1x / (1.0 + u1x)) * (xx - cx)])
    return apply_field(job, check_field(field, job.shape), PSFS["box"].code(displace), mode, job.scaled(cval),
                       quadrature)


# rotation ------------------------------------------------------------------------------
def _rotation_center(center, height, width):
    cy, cx = center_point(center, height, width)
    check_polar_center(cy, cx, height, width)
    return cy, cx


def _rotation_run(job, degrees, psf, center, displace, mode, cval, quadrature):
    return apply_spin(job, degrees, center[0], center[1], psf, displace, mode, cval)


#: every kind of motion, by name (a velocity field is selected by ``kind='uniform'`` and its shape)
MOTIONS = {m.name: m for m in (
    MotionKind("uniform", "uniform", "(vy, vx) pixels (rows, cols)", False, False,
               parse=_uniform_parse, fit=_same, center=_no_center,
               at=lambda v, t: (float(v[0] * t), float(v[1] * t)),
               run=_uniform_run, whole_axes=_uniform_whole_axes,
               program=lambda ndim, v, displace: uniform_motion_program(ndim, v, displace)),
    MotionKind("field", "uniform", "a velocity field (2, H, W) (rows, cols components)", True, False,
               parse=np.asarray, fit=check_field, center=_no_center,
               at=lambda field, t: np.asarray(field, np.float64) * float(t),
               run=_field_run, whole_axes=_whole_plane),
    MotionKind("zoom", "zoom", "u1 or (u1_y, u1_x)", False, True,
               parse=zoom_factors, fit=_same, center=_zoom_center,
               # a constant zoom rate: the scale grows geometrically, (1 + u1)^t
               at=lambda u, t: ((1.0 + u[0]) ** t - 1.0, (1.0 + u[1]) ** t - 1.0),
               run=_zoom_run, whole_axes=_whole_plane),
    MotionKind("rotation", "rotation", "degrees", False, True,
               parse=rotation_angle, fit=_same, center=_rotation_center,
               at=lambda degrees, t: float(degrees * t),
               run=_rotation_run, whole_axes=_whole_plane),
)}

#: the ``kind=`` names, in table order
KINDS = tuple(dict.fromkeys(m.kind for m in MOTIONS.values()))


def check_kind(kind):
    """``kind`` checked against :data:`KINDS`."""
    if not isinstance(kind, str) or kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    return kind


def motion_kind(kind, velocity):
    """The :class:`MotionKind` that ``kind`` and the shape of ``velocity`` select."""
    check_kind(kind)
    field = is_field(velocity)
    for m in MOTIONS.values():
        if m.kind == kind and m.takes_field == field:
            return m
    if field:
        takes = " or ".join(repr(m.kind) for m in MOTIONS.values() if m.takes_field)
        raise ValueError(f"a velocity field (2, H, W) goes with kind={takes}, got kind={kind!r}")
    raise ValueError(f"kind={kind!r} takes a velocity field (2, H, W), got {np.ndim(velocity)} dimension(s)")
