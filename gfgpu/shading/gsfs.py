"""Green's-function shape from shading (GSFS, chapter §3, eqs. 30-33).

The matching image ``I2 = G_u * I1`` of a virtual light displacement along the light's
image-plane direction, and the depth ``Z = u·Ī2/k1`` with ``Ī2 = ½(G_u + H_u) * I1`` (eq. 32 with
``(a, b, c) = (½, -1, ½)``, ``docs/shading.md``), one exact O(N) recursion per line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .. import greens
from .._core.arrays import as_kind, host_array, kind_of
from .._core.lines import direction as _line_direction
from .._core.validation import finite_scalar, positive
from ..backends import resolve_backend
from ..filters import green_filter
from . import line_fit
from .light import estimate_illuminant, fit_depth_scale
from .params import MIN_SLANT, check_contrast, checked_image, checked_mask, parse_light, tilt_slant
from .scene import border_band, flat_background, has_background, quiet_sides

__all__ = ["shape_from_shading", "ShadingGreen", "resolve_light", "GSFS_U_FRACTION", "GSFS_MIN_U_FRACTION"]

#: GSFS matching constant u as a fraction of the path length of one digital line across the image
#: (the operator is then an integrator over the whole line; Notes of :func:`shape_from_shading`)
GSFS_U_FRACTION = 1.0

#: smallest explicit u, as a fraction of that line length: below it the operator stops
#: integrating the shading over the sizes an image holds (Notes of :func:`shape_from_shading`)
GSFS_MIN_U_FRACTION = 0.25


# the fused GSFS kernel ½(G_u + H_u)
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShadingGreen(greens.GreenKernel):
    """½(G_u + H_u) (eq. 9 and 33): the GSFS operator ``Ī2 = ½(G_u + H_u) * I1`` as ONE recursion.

    .. math:: c(x) = \\frac{1}{u} (\\sin(x/u) + \\cos(x/u))\\, e^{-x/u} \\quad (x > 0)

    Both kernels share the poles ``exp((-1 ± i)/u)``, so their half sum is one complex section
    ``lam = exp((-1+i)/u)``, ``kap = (1 - i) lam / u`` plus H_u's direct tap halved, ``1/(2u)``.
    Its transfer function is ``(1 + ε/2)/(1 + ε + ε²/2)``, ``ε = iuω``: about 1 for ``uω ≪ 1``
    and about ``1/(iuω)`` (an integrator, times 1/u) for ``uω ≫ 1``.
    """

    u: float

    def __post_init__(self):
        object.__setattr__(self, "u", positive("u", self.u))

    shift_invariant = True

    @property
    def tap(self):
        return 0.5 / self.u

    def __call__(self, x, x0):
        d = np.asarray(x, np.float64) - np.asarray(x0, np.float64)
        return 0.5 * (greens.g_uniform(d, self.u) + greens.h_homogeneous(d, self.u))

    def _section(self):
        lam = np.exp(complex(-1.0, 1.0) / self.u)
        return greens.Section(lam=lam, kap=(1.0 - 1.0j) * lam / self.u)



# GSFS
# --------------------------------------------------------------------------------------
def step_length(angle):
    """Euclidean length (pixels) of one step of a digital line at ``angle`` (:mod:`gfgpu._core.lines`)."""
    return 1.0 / max(abs(math.cos(angle)), abs(math.sin(angle)))


def line_extent(shape, angle):
    """Pixels of path covered by one digital line at ``angle`` across the image."""
    steep, _, _ = _line_direction(angle)
    steps = shape[0] if steep else shape[1]
    return steps * step_length(angle)


def resolve_light(image, light, mask):
    """The unit light and whether it was estimated; ``mask`` (all True: none given) is the object.

    The estimate is :func:`estimate_illuminant`'s 'background' method, which refuses images that
    do not determine the light, and reports lights it cannot tell from frontal as (0, 0, 1), so
    an image refused with an explicit light is refused with an estimated one too.
    """
    if light is None:
        est, _ = estimate_illuminant(image, None if mask.all() else mask)
        return est, True
    return parse_light(light), False


def _albedo(img, m):
    """ρ for k1='linear': the 'background' estimate, else Zheng & Chellappa's moments."""
    try:
        return estimate_illuminant(img, None if m.all() else m)[1]
    except ValueError:
        return estimate_illuminant(img, m, method="zheng-chellappa")[1]


def _integration_angle(light, direction, estimated):
    tilt, slant = tilt_slant(light)
    if direction is not None:
        return finite_scalar("direction", direction)   # radians
    if slant < MIN_SLANT:
        src = "the estimated light" if estimated else "light"
        raise ValueError(
            f"{src} ({light[0]:.4g}, {light[1]:.4g}, {light[2]:.4g}) is frontal (slant {math.degrees(slant):.2f} deg < "
            f"{math.degrees(MIN_SLANT):.0f} deg): its image-plane direction γ is undefined and the "
            f"linear reflectance term that GSFS integrates vanishes. Pass direction= (radians) to "
            f"choose the virtual light displacement, or use photometric_motion")
    return tilt


def shape_from_shading(image, *, light=None, u=None, k1="render", mask=None, direction=None,
                       boundary="auto", backend=None, device=None):
    """Depth from one shading image by Green's-function shape from shading (GSFS).

    Parameters
    ----------
    image : (H, W) array_like
        Shading image (Lambertian surface, one distant light).  float32/float64 kept,
        integers -> float32.  The image is used as is: no clipping, no normalisation.  Any
        array kind (numpy, torch, CuPy, JAX, any ``__dlpack__`` array, Warp, pyopencl) is read on
        the host (device memory copied there once); the depth comes back in the image's kind.
    light : sequence, optional
        Light as ``(l1, l2, l3)`` or ``(tilt, slant)`` (radians; see :func:`parse_light`).
        Default: estimated from the image by :func:`estimate_illuminant` (an object on a
        frontal reference plane: the plane's level over the object's brightest point); images
        that do not determine the light (no flat background, no surface facing the light)
        raise, and a light that cannot be told from frontal is estimated as (0, 0, 1), which
        raises like the explicit frontal light unless ``direction`` is given.
    u : float, optional
        Matching constant (virtual disparity, eq. 7), in pixels of path along γ.  Default:
        :data:`GSFS_U_FRACTION` (1) times the path length ``n`` of one digital line across the
        image along γ (the width for a light along x).  An explicit value must be at least
        :data:`GSFS_MIN_U_FRACTION` ``· n`` (a quarter line); larger values, up to many lines,
        change the result little (Notes, "What u does").
    k1 : {'render', 'linear'} or float, optional
        Depth scale of eq. 31.  ``'render'`` (default): the value whose Lambertian re-rendering
        best matches the image in least squares (:func:`fit_depth_scale`).  ``'linear'``:
        ``k1 = -ρ sin σ`` from the linearised reflectance map, with the albedo ρ of
        :func:`estimate_illuminant` (its 'zheng-chellappa' moments where the 'background'
        method refuses the image).  A float is used as given (non-zero).
    mask : (H, W) bool array_like, optional
        The object (default: none given).  With ``boundary`` 'auto' or 'background' the rest of
        the image is the reference plane: the shading is integrated inside the mask only, the
        depth is 0 on the pixels next to the mask along every line (where the object meets the
        plane) and outside it; where the mask reaches the image border the object is taken to
        be cut there.  The mask's pixels also give the light estimate and the k1 fit.  With
        ``boundary='free'`` it selects the pixels of the light estimate, k0, the zero-mean
        lines and the k1 fit.
    direction : float, optional
        Matching direction γ as an angle in radians from +x toward +y; default the light's
        tilt.  Required when the light is frontal (slant below :data:`MIN_SLANT`).
    boundary : {'auto', 'background', 'free'}, optional
        How the two constants that the integration leaves free on every line are fixed
        (Notes).  ``'background'``: an object on a flat reference plane, which the image
        border may cut.  ``'free'``: one global k0 and zero-mean lines.  ``'auto'``
        (default): ``'background'`` when a mask is given or :func:`has_background` (a quiet
        border, or a border band at least a quarter flat), else ``'free'``.
    backend, device : str, optional
        Where the line filtering runs (:func:`gfgpu.green_filter`).

    Returns
    -------
    ndarray, (H, W)
        Height toward the viewer, in pixel units, float32 (float64 for float64 input):
        above the reference plane (0 on the background) for ``'background'``, with zero mean
        over ``mask`` for ``'free'``.

    Raises
    ------
    ValueError
        Non-2-D, empty, constant or non-finite image; a light pointing away from the viewer;
        a frontal light without ``direction``; ``u`` below a quarter line (message gives the
        bound in pixels); ``k1 == 0`` or an unknown k1 string; bad ``boundary``/``mask``.
    TypeError
        Non-numeric image or parameters.

    Notes
    -----
    *Operator.*  Eq. 30 of DBPS with the second-order matching equation (7) integrated once
    along γ gives (``docs/derivations.md``, "Shape from shading")
    ``Z = u Ī2 / k1 − k0 (x + γy)/(k1 (1+γ²))`` (eq. 30-31)
    with ``Ī2 = I2 + (u/2)∂_γ I2`` and, in terms of the input, exactly
    ``Ī2 = ½(G_u + H_u) * I1``, i.e. eq. 32 with ``(a, b, c) = (½, -1, ½)``.  The k0 ramp of
    eq. 30 is the integral of the constant k0, so it is removed by filtering ``I1 − k0``.
    ``½(G_u + H_u)`` is one first-order complex recursion per line (:class:`ShadingGreen`),
    run causally along the digital lines at angle γ by :func:`gfgpu.green_filter` on the chosen
    backend, with ``I1 − k0 = 0`` beyond the image (``mode='constant'``: the surface continues
    as the reference plane).  Along an oblique line one step covers ``1/max(|cos γ|, |sin γ|)``
    pixels, so ``u`` in pixels is divided by that length to get the kernel's ``u`` in steps.
    The transfer function ``(1 + ε/2)/(1 + ε + ε²/2)``, ``ε = iuω``, times ``u`` tends to the
    integrator ``1/(iω)`` for ``uω ≫ 1``; with ``u`` = one line length that holds for every
    frequency a line can carry, so ``u Ī2`` is the path integral of ``I1 − k0`` along γ and,
    with the linearised Lambertian map ``I ≈ k0 − ρ sin σ ∂_γ Z``, the depth for
    ``k1 = −ρ sin σ``.

    *The two free constants of every line.*  Integrating along γ determines the depth on each
    line up to the homogeneous solutions of the integrated equation: a constant and, through
    the unknown k0, a ramp along the line (the integrator limit of eq. 34's solutions).  Depth
    variation across γ is unobservable from the linear term, so these constants must come
    from a prior, and the right prior depends on the scene:

    * an object on a flat background (``boundary='background'``): k0 is the background's
      intensity (median over the :func:`flat_background` pixels, or over the border band when
      there are none; a frontal plane gives exactly ``ρ l3``).  The object is everything but
      the :func:`flat_background` pixels, flat pockets it encloses included (the stationary
      shading where the normal faces the light looks flat), or the user's mask.  Only the object's shading is
      integrated, and the depth is fixed at 0 on the pixels next to the object along each line
      (where it meets the plane) and at the ends of lines that leave the image through a quiet
      side (:func:`quiet_sides`: there the border is the plane).  Where a line's fixed pixels
      bracket its object pixels, ``(c, a)`` are fitted in least squares (Dirichlet conditions,
      which also cancel each line's shading bias from the non-linear terms: shadows,
      ``1/|n|``); where the object runs into a busy side (a bust cut by the frame) only ``c``
      is fitted, since one end cannot fix a ramp; a line with no fixed pixel keeps the
      integral's own start, ``Z = 0`` where it enters the image.  Each of these rules was
      checked by switching it off on surfaces it was not chosen on (the survey's sphere and
      vase, whole and cut by the border, and two more held-out objects; docs/shading.md):
      the ramp and the quiet-side line ends are kept because they lower the error there;
      growing the flat set back toward the object and taking a free line's constant from its
      neighbours were dropped because they raised it.
      Known limits: a flat shelf that reaches the background counts as background, a
      background pocket enclosed by the object (a ring) counts as object, and lines that
      start or end inside an object the frame cuts keep each their own error (the survey's
      vase under a light with a vertical component), where Pentland's global inversion does
      better (docs/shading.md);
    * a textured surface filling the frame (``boundary='free'``): one global k0, the mean
      intensity (the surface has no mean slope along γ), which keeps each line's own
      end-to-end depth difference, and ``c`` gives every line zero mean depth (the minimum
      norm solution).

    ``'auto'`` chooses by :func:`has_background` (or 'background' when a mask is given).
    Pentland's FFT method instead discards
    each line's mean intensity and wraps it periodically, which is neither.

    *What u does.*  ``u·Ī2`` is a leaky integral of ``I1 − k0`` along γ whose memory is about
    ``u`` pixels: features much wider than ``u`` are passed through as shading (transfer
    about ``u``) instead of integrated, so for ``u`` of a few to a few tens of pixels the output
    is close to the shading image itself, whose correlation with the depth can be of either
    sign (on a 128-pixel bust, u = 2 or 10 gave r = −0.3 to 0.6).  The default (one line) makes
    it an integrator for every size a line holds; that is not a tuned value: u from a quarter
    line to 32 lines changed the benchmark's errors by at most about 20 % (docs/shading.md),
    and values below a quarter line raise.

    *Frontal light.*  For a light along the viewing direction γ is undefined and the linear
    term vanishes; GSFS refuses such a light unless ``direction`` is given, in which case the
    method runs as stated along that direction (its result is then not supported by the
    linearisation; docs/shading.md reports it).

    References
    ----------
    .. [1] J. R. A. Torreão, "A Green's function approach to shape from shading", Pattern
       Recognition 34:2367-2382, 2001.
    .. [2] Torreão, Victer and Fernandes, "Green's Functions of Matching Equations", 2007,
       §3, eqs. 29-34.
    .. [3] A. Pentland, "Linear shape from shading", IJCV 4:153-162, 1990.

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.shading import lambertian_shading, photometric_motion, shape_from_shading
    >>> yy, xx = np.mgrid[-32:32, -32:32] + 0.5
    >>> z = 8 * np.exp(-(xx**2 + yy**2) / 200)
    >>> img = lambertian_shading(z, (1, 0, 1))
    >>> est = shape_from_shading(img, light=(1, 0, 1), backend="numpy")
    >>> bool(np.corrcoef(est.ravel(), z.ravel())[0, 1] > 0.9)
    True
    """
    img = checked_image(host_array(image, "image"))    # any array kind, moved to the host once
    m = checked_mask(None if mask is None else host_array(mask, "mask"), img.shape)
    check_contrast(img, m)
    be = resolve_backend(backend, device)      # an unknown backend or device: refused before work
    if boundary not in ("auto", "background", "free"):
        raise ValueError(f"boundary must be 'auto', 'background' or 'free', got {boundary!r}")
    k1_given = _checked_k1(k1)
    L, estimated = resolve_light(img, light, m)
    angle = _integration_angle(L, direction, estimated)
    step = step_length(angle)
    u_px = _checked_u(u, line_extent(img.shape, angle))
    user_object = mask is not None and not m.all()
    if boundary == "auto":
        boundary = "background" if user_object or has_background(img, m) else "free"
    if boundary == "background":
        obj, k0 = _object_and_level(img, m, user_object)
    else:
        k0 = float(img[m].astype(np.float64).mean())
    centred = (img - np.asarray(k0, img.dtype)).astype(img.dtype, copy=False)
    if boundary == "background":
        # the background is the reference plane: it adds no slope, only noise, to the integral
        centred = np.where(obj, centred, 0).astype(img.dtype, copy=False)
    bar = green_filter(centred, ShadingGreen(u_px / step), angle=angle, mode="constant", cval=0.0, backend=be)
    z_unit = u_px * np.asarray(bar, np.float64)      # eq. 31 with k1 = 1, k0 ramp removed
    line, t = line_fit.line_coordinates(img.shape, angle)
    if boundary == "background":
        anchors = line_fit.boundary_anchors(obj, angle)
        if not user_object:
            # an object reaching a quiet side of the border meets the plane there
            anchors |= line_fit.line_ends_on(line, t, quiet_sides(img)) & obj
        # a line with no fixed pixel keeps Z = 0 where it enters the image (the integral's start):
        # taking its constant from the neighbouring lines instead did worse on the held-out set
        z_unit, _ = line_fit.fix_object(z_unit, line, t, obj, anchors)
        z_unit[~obj] = 0.0
    else:
        z_unit = line_fit.fix_zero_mean(z_unit, line, m.astype(np.float64))
        z_unit -= z_unit[m].mean()
    if k1_given is not None:
        scale = 1.0 / k1_given
    elif k1 == "render":
        scale, _, _ = fit_depth_scale(z_unit, img, L, m)
    else:
        _, slant = tilt_slant(L)
        albedo = _albedo(img, m)
        if math.sin(slant) * albedo == 0:
            raise ValueError("k1='linear' needs an oblique light (k1 = -ρ sin σ is 0 for a "
                             "frontal one); use k1='render'")
        scale = -1.0 / (albedo * math.sin(slant))
    return as_kind((scale * z_unit).astype(img.dtype), kind_of(image), image)


def _checked_k1(k1):
    """The number k1, or None for 'render'/'linear'; errors before any work."""
    if isinstance(k1, str):
        if k1 not in ("render", "linear"):
            raise ValueError(f"k1 must be 'render', 'linear' or a non-zero number, got {k1!r}")
        return None
    k = finite_scalar("k1", k1)
    if k == 0:
        raise ValueError("k1 must be non-zero (Z = u Ī2 / k1)")
    return k


def _checked_u(u, extent):
    """u in pixels: the default rule, or the user's value if the operator still integrates."""
    if u is None:
        return GSFS_U_FRACTION * extent
    u_px = positive("u", u)
    lo = GSFS_MIN_U_FRACTION * extent
    if u_px < lo:
        raise ValueError(
            f"u must be at least {lo:.4g} pixels here ({GSFS_MIN_U_FRACTION:g} of the {extent:.4g}-pixel "
            f"line along the light's direction), got {u!r}: a smaller u makes ½(G_u + H_u) pass the "
            f"shading through instead of integrating it, so the result is not a depth "
            f"(default: one line length)")
    return u_px


def _object_and_level(img, m, user_object):
    """The object pixels and the background's intensity k0, for the 'background' prior."""
    if user_object:
        # the user's object; k0 from the flat part of the rest of the image (else all of it)
        flat = flat_background(img) & ~m
        k0 = float(np.median(img[flat if flat.any() else ~m]))
        return m, k0
    flat = flat_background(img, m)
    k0 = float(np.median(img[flat if flat.any() else (border_band(img.shape) & m)]))
    # a flat pocket inside the object (where its shading is stationary, e.g. the point facing
    # the light) is object, not plane: Z = 0 fixed there would cut every line through it
    return ndimage.binary_fill_holes(~flat), k0
