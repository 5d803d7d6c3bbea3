"""OpenCL launchers of the polar kernels (``polar.cl``), registered by :mod:`gfgpu.motion.kernels`;
specifications: :mod:`gfgpu.motion.spec`."""

from __future__ import annotations

import numpy as np

from ..._core import boundary
from ..._core.lru import LRU
from ...backends.opencl import launch as ocl

#: work-group size of the polar resampling kernels on a GPU (None: the driver's choice)
_LOCAL = None

#: work-group size of every polar kernel on a CPU device, fixed: PoCL builds a kernel once per
#: work-group size, and its own choice follows the global size, so with the driver's choice each new
#: image shape rebuilt the kernels (0.2-1 s each: a first spin on a new 2048^2 shape took 3.5-6 s)
_CPU_GROUP = (8, 1)

#: whether from_polar computes each pixel's angle in the kernel on a CPU (float positions), instead of
#: reading an angle map of the image's shape (:func:`launch_from_polar`)
_INLINE_ANGLE = True

#: angles per work-item of the scalar to_polar on a CPU
_CHUNK = 16

#: lanes of the explicit-vector kernels (to_polar_vec, from_polar_vec; VW in polar.cl) and the rings
#: (to_polar_vec) or rows (from_polar_vec) each of their work-items runs in turn (RB in polar.cl)
_VW = 8
_RB = 8


def _vector(be):
    """Whether the explicit-vector kernels run: on a CPU device (a GPU runs one sample per work-item)."""
    return be.kind == "cpu"

#: coefficients that to_polar materialises beyond every border in 'constant' and 'nearest' mode
#: (read clamped beyond them: the extension to z^32, below 1e-18)
_PAD = 32


#: device arrays kept per (context, key): the cosines and sines of a ring's angles, the pixels' angles
#: about a centre (:func:`_kept`); few, since each is a few tens of MB at most
_KEPT = LRU(6)


#: small device arrays (a ring's cosines and sines, ring weights, per-ring scales: tens of kB at most) kept
#: by their content: every call on one shape uploads the same ones, and each upload is a blocking copy that
#: waits for every queued kernel (the host could not prepare the next launches meanwhile)
_SMALL = LRU(64)


def _kept(be, key, make, cache=None):
    """The device array ``make()`` for ``key`` on ``be``'s context, made once (a bounded LRU): the
    plans of the polar grid every call about one centre on one shape shares."""
    return (_KEPT if cache is None else cache).get((be.context, *key), make)


def _uploaded(be, host):
    """``host`` (a small array) on the device, uploaded once per content (:data:`_SMALL`)."""
    host = np.ascontiguousarray(host)
    key = ("small", host.dtype.str, host.shape, host.tobytes())
    return _kept(be, key, lambda: be.asarray(host), _SMALL)


def _constants():
    """The ``-D`` defines that carry constants of the Python definitions: the mode codes
    (:mod:`gfgpu._core.boundary`), the spline's pole and edge weights (:mod:`gfgpu._core.bspline`).
    Read at each build, so the kernels cannot drift from them (the same values every call: one
    build); sizes are arguments."""
    return dict(**ocl.spline_defines(), PAD=_PAD)


def _setup(be, a):
    """The kernel build's dtype and the position type (double where the device has it)."""
    return np.dtype(a.dtype), (np.float64 if be.supports_float64 else np.float32)


def _code(mode):
    """The integer code of boundary ``mode`` that the kernels take (gfgpu._core.boundary.MODE_CODES)."""
    return boundary.MODE_CODES[mode]


def _kernel(be, name, dtype, pos, grid=None, **defines):
    grid = pos if grid is None else grid
    return ocl.kernel(be, __package__, "polar.cl", name, dtype, POS="double" if pos == np.float64 else "float",
                      GRID="double" if grid == np.float64 else "float", GRID_IS_FLOAT=int(grid == np.float32),
                      **_constants(), **defines)


def _grid(dtype, pos):
    """Positions of the polar resampling: the image's own precision (float32: 1e-7 relative,
    1e-4 px on a ring of radius 1500, far below the spline's own resampling error)."""
    return np.float32 if dtype == np.float32 else pos


def _range(be, size):
    """``(global, local)`` of a launch over ``size`` work-items: whole groups of :data:`_CPU_GROUP` on a
    CPU device, of :data:`_LOCAL` elsewhere (the kernels check bounds)."""
    if be.kind == "cpu" and _CPU_GROUP is not None:
        return tuple(-(-n // g) * g for n, g in zip(size, _CPU_GROUP)), _CPU_GROUP
    return _global(size), _LOCAL


def _global(size):
    """The global size rounded up to whole work-groups of ``_LOCAL`` (the kernels check bounds)."""
    if _LOCAL is None:
        return size
    return tuple(-(-n // g) * g for n, g in zip(size, _LOCAL))


def launch_to_polar(be, coef, out, cy, cx, r0, mode, cval):
    coef = ocl.starting(be, coef, "coef")
    obuf, ooff = ocl.written(be, out, "out")
    dtype, pos = _setup(be, coef)
    grid = _grid(dtype, pos)
    bsz, h, w = (int(s) for s in coef.shape)
    n_r, n_phi = int(out.shape[1]), int(out.shape[2])
    def make_trig():
        phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
        return be.asarray(np.stack([np.cos(phi), np.sin(phi)], axis=1).astype(grid).reshape(-1))
    trig = _kept(be, ("trig", n_phi, np.dtype(grid).str), make_trig, _SMALL)
    fast = {}
    if mode in ("constant", "nearest"):
        # the extension materialised _PAD coefficients beyond every border, then read clamped
        h, w, cy, cx = h + 2 * _PAD, w + 2 * _PAD, cy + _PAD, cx + _PAD
        padded = be.empty((bsz, h, w), dtype)
        ocl.launch(be, _kernel(be, "pad_coef", dtype, pos), *_range(be, (w, h)), [coef], [padded],
                   (coef.data, padded.data, np.int32(h - 2 * _PAD), np.int32(w - 2 * _PAD), np.int32(bsz),
                    np.int32(_code(mode)), dtype.type(cval)))
        coef, mode, fast = padded, "nearest", {"MODE_Y": _code("nearest"), "MODE_X": _code("nearest")}
    else:
        # the modes as build constants where every coefficient read lies within one period of the image
        reach = r0 + n_r + 3
        if (h > 3 and w > 3 and cy - reach >= -(h - 3) and cy + reach <= 2 * h - 4 and cx - reach >= -(w - 3)
                and cx + reach <= 2 * w - 4):
            fast = {"MODE_Y": _code(mode), "MODE_X": _code(mode)}
    if fast and _vector(be) and n_phi % _VW == 0 and n_r % _RB == 0:
        # a CPU: _VW adjacent angles in explicit vectors (PoCL does not vectorise across work-items here),
        # _RB rings in turn (each ring's taps about a pixel from the last ring's: cached)
        ocl.launch(be, _kernel(be, "to_polar_vec", dtype, pos, grid, RB=_RB, **fast),
                   *_range(be, (n_phi // _VW, n_r // _RB)), [coef, trig], [out],
                   (coef.data, obuf, ooff, trig.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                    np.int32(bsz), grid(cy), grid(cx), np.int32(r0)))
        return out
    chunk = _CHUNK if be.kind == "cpu" else 1
    ocl.launch(be, _kernel(be, "to_polar", dtype, pos, grid, CHUNK=chunk, **fast),
               *_range(be, (-(-n_phi // chunk), n_r)), [coef, trig], [out],
               (coef.data, obuf, ooff, trig.data, np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi),
                np.int32(bsz), grid(cy), grid(cx), np.int32(r0), np.int32(_code(mode)), dtype.type(cval)))
    return out


def launch_from_polar(be, pcoef, base, out, cy, cx, r0, r_lo, r_hi, wcoef=None, only_band=False):
    pcoef = ocl.starting(be, pcoef, "pcoef")     # an offset view (the spin's workspace block) without a copy
    obuf, ooff = ocl.written(be, out, "out")
    bbuf, boff = ocl.written(be, base, "base")      # base may be out
    dtype, pos = _setup(be, pcoef)
    grid = _grid(dtype, pos)
    bsz, n_r, n_phi = (int(s) for s in pcoef.shape)
    h, w = int(out.shape[1]), int(out.shape[2])
    x0, y0, x1, y1 = 0, 0, w, h
    reach = min(float(r_hi), 4.0 * (h + w))     # beyond every pixel: the centre lies within 2 diagonals
    in_place = bbuf == obuf and boff == ooff
    # pixels beyond the band's radii keep out's values (in place: base's): none but the band's are written
    only_band = bool(only_band) or in_place
    if only_band:        # only the pixels within r_hi of the centre change
        x0, y0 = max(0, int(np.floor(cx - reach))), max(0, int(np.floor(cy - reach)))
        x1, y1 = min(w, int(np.ceil(cx + reach)) + 1), min(h, int(np.ceil(cy + reach)) + 1)
        if x1 <= x0 or y1 <= y0:
            return out
    # radius within the band's rings (mirrored at their ends), angle within one turn: always near
    fast = {"MODE_Y": _code("mirror"), "MODE_X": _code("wrap")} if n_r > 3 and n_phi > 3 else {}
    if wcoef is None:
        weights = np.ones(4, dtype)
    else:
        # the ring weights' coefficients with their mirror extension (rings -1 .. n_r + 1)
        wcoef = np.asarray(wcoef, np.float64).reshape(-1)
        weights = wcoef[boundary.extend_index(np.arange(-1, n_r + 2), n_r, "mirror")].astype(dtype)
    weights = _uploaded(be, weights)

    def make_angles():
        angles = be.empty((h, w), grid)
        ocl.launch(be, _kernel(be, "angle_map", dtype, pos, grid), *_range(be, (w, h)), [], [angles],
                   (angles.data, np.int32(h), np.int32(w), grid(cy), grid(cx)))
        return angles
    vector = bool(fast) and _vector(be)
    # a CPU with float positions computes each pixel's angle in the kernel, in vectors (angle_of_v: the
    # map's values to the bit): a map of the image's size is new memory and a pass on every new shape or
    # centre (16 MB and 11-90 ms at 2048^2, a third of a first spin's extra time), read back at every call
    inline = vector and grid == np.float32 and _INLINE_ANGLE
    if inline:
        angles = _kept(be, ("no angles",), lambda: be.empty((16,), grid))     # an unused argument
    else:
        angles = _kept(be, ("angles", h, w, float(cy), float(cx), np.dtype(grid).str), make_angles)
    common = (np.int32(h), np.int32(w), np.int32(n_r), np.int32(n_phi), np.int32(bsz), grid(cy), grid(cx),
              np.int32(r0), grid(r_lo), grid(reach))
    if vector:
        # a CPU: _VW adjacent pixels of a row in explicit vectors (a box's last columns one by one), _RB rows
        # in turn (whose polar taps lie about a pixel apart: cached); pixels beyond the band keep base (in
        # place: rewritten unchanged)
        ocl.launch(be, _kernel(be, "from_polar_vec", dtype, pos, grid, RB=_RB, INLINE_ANGLE=int(inline), **fast),
                   *_range(be, (-(-(x1 - x0) // _VW), -(-(y1 - y0) // _RB))), [pcoef, base, weights, angles], [out],
                   (pcoef.data, bbuf, obuf, ooff, *common, np.int32(x0), np.int32(y0), np.int32(x1 - x0),
                    np.int32(y1 - y0), boff, weights.data, np.int32(wcoef is not None), angles.data, np.int32(w),
                    np.int32(not only_band)))
        return out
    ocl.launch(be, _kernel(be, "from_polar", dtype, pos, grid, **fast), *_range(be, (x1 - x0, y1 - y0)),
               [pcoef, base, weights, angles], [out],
               (pcoef.data, bbuf, obuf, ooff, *common,
                np.int32(x0), np.int32(y0), np.int32(x1 - x0), np.int32(y1 - y0), boff, weights.data,
                np.int32(wcoef is not None), np.int32(not only_band), angles.data))
    return out


def launch_add_rows(be, src, dst, scale):
    sbuf, soff = ocl.written(be, src, "src")        # src may be dst
    dbuf, doff = ocl.written(be, dst, "dst")
    dtype, pos = _setup(be, dst)
    bsz, n, m = (int(s) for s in dst.shape)
    weights = _uploaded(be, np.asarray(scale, dtype))
    if _vector(be):        # 64 elements of a row per work-item, in explicit vectors
        ocl.launch(be, _kernel(be, "add_rows_vec", dtype, pos), *_range(be, (-(-m // 64), bsz * n)), [src, weights],
                   [dst],
                   (sbuf, dbuf, doff, weights.data, np.int32(n), np.int32(m), np.int32(bsz * n), soff))
        return dst
    ocl.launch(be, _kernel(be, "add_rows", dtype, pos), *_range(be, (m, bsz * n)), [src, weights], [dst],
               (sbuf, dbuf, doff, weights.data, np.int32(n), np.int32(m), np.int32(bsz * n), soff))
    return dst
