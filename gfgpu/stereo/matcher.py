"""A matcher object for streams of stereo pairs (video, robots): :class:`StereoMatcher`."""

from __future__ import annotations

import threading

import numpy as np

from .._core.arrays import as_kind, kind_of
from .._core.validation import flag
from ..backends import resolve_backend
from . import matching, postfilter

__all__ = ["StereoMatcher"]


class StereoMatcher:
    """Semi-global matcher of a fixed image size and disparity range, for streams of pairs.

    What :func:`gfgpu.stereo.disparity` does with ``method="sgm"`` for one pair, with the
    options checked, the memory checked and the device buffers (census codes, maps, the band
    matcher's volumes, path states and checkpoints) allocated once, at the first frame, and
    reused by every later one; the kernels are built at the first frame too (the same builds
    as ``disparity``'s), so later frames build nothing.  ``compute`` returns exactly what
    ``disparity`` returns for the same pair and options.  Like OpenCV's
    ``cv2.StereoSGBM_create(...).compute(left, right)`` and libSGM's ``StereoSGM(width,
    height, disparity_size, ...)``.

    Parameters
    ----------
    shape : (H, W) tuple of int
        Size of every view (grey (H, W) or colour (H, W, C) inputs of that size).
    max_disparity : int
        Largest disparity searched (px), ``min_disparity < max_disparity <= min_disparity +
        4096``.
    min_disparity : int, optional
        Smallest disparity searched (px, may be negative), ``|min_disparity| <= 16384``.
    window, subpixel, lr_check, subpixel_steps, census_radius, p1, p2, paths, uniqueness : optional
        As for :func:`gfgpu.stereo.disparity` (``"sgm"``): default block 3, half-pixel
        samples, penalties :func:`gfgpu.stereo.matching.default_penalties`, 4 paths,
        10 % uniqueness, the left-right check.
    speckle_size, speckle_range, min_confidence : optional
        The post-filters of :func:`gfgpu.stereo.disparity` (default: its ``"sgm"`` defaults, the
        speckle filter on, 25 px / 0.5 px), applied to every frame's map on the host.
    backend, device : optional
        Where the kernels run (as for :func:`gfgpu.stereo.disparity`).

    Attributes
    ----------
    shape : (int, int)
    min_disparity, max_disparity : int
    backend : gfgpu backend

    Raises
    ------
    ValueError
        ``shape`` not two integers >= 2, an empty or over-long range, an option outside its
        range (named), or more memory than the working set (before anything is allocated).
    TypeError
        Non-integer disparity bounds or options.

    Notes
    -----
    The right view's sub-pixel planes are computed on the host
    (:func:`gfgpu.stereo.matching.matching_views`, so that every backend matches the same
    bits), and each frame's images are uploaded; device arrays passed to :meth:`compute` are
    copied to the host for that (O(H·W)).  The maps are returned as numpy arrays.  A matcher may
    be shared between threads: its frames share its buffers, so their device work runs one frame
    at a time (a matcher per thread runs them concurrently).

    Examples
    --------
    >>> import numpy as np
    >>> from gfgpu.stereo import StereoMatcher, disparity
    >>> rng = np.random.default_rng(0)
    >>> right = rng.random((48, 96)).astype(np.float32)
    >>> left = np.roll(right, 5, axis=1)
    >>> matcher = StereoMatcher((48, 96), 12, backend="numpy")
    >>> d = matcher.compute(left, right)
    >>> bool(np.array_equal(d, disparity(left, right, 12, backend="numpy"), equal_nan=True))
    True
    >>> d, conf = matcher.compute(left, right, return_confidence=True)
    """

    def __init__(self, shape, max_disparity, *, min_disparity=0, window=None, subpixel=True, lr_check=True,
                 subpixel_steps=2, census_radius=3, p1=None, p2=None, paths=4, uniqueness=10,
                 speckle_size=postfilter.SPECKLE_SIZE, speckle_range=postfilter.SPECKLE_RANGE, min_confidence=0.0,
                 backend=None, device=None):
        # a tuple, list or 1-D array of two integers (numpy.array(img.shape[:2]) is one)
        shp = tuple(shape) if isinstance(shape, (tuple, list)) or np.ndim(shape) == 1 else None
        if shp is None or len(shp) != 2:
            raise ValueError(f"shape must be (H, W), got {shape!r}")
        h, w = (matching._int_arg(v, "shape") for v in shp)
        if min(h, w) < 2:
            raise ValueError(f"shape must be at least (2, 2), got {shape!r}")
        d_max = matching._int_arg(max_disparity, "max_disparity")
        d_min = matching._int_arg(min_disparity, "min_disparity")
        if not -4 * matching.MAX_RANGE <= d_min <= 4 * matching.MAX_RANGE:
            raise ValueError(f"min_disparity must satisfy |min_disparity| <= {4 * matching.MAX_RANGE}; got {d_min}")
        if not d_min < d_max <= d_min + matching.MAX_RANGE:
            raise ValueError(f"max_disparity must satisfy min_disparity ({d_min}) < max_disparity <= "
                             f"min_disparity + {matching.MAX_RANGE}; got {d_max}")
        self._subpixel, self._lr_check = flag("subpixel", subpixel), flag("lr_check", lr_check)
        (self._window, self._steps, self._radius, self._p1, self._p2, self._paths,
         self._uniqueness) = matching._sgm_options(window, subpixel_steps, census_radius, p1, p2, paths, uniqueness)
        self._post = postfilter.check_postfilter(speckle_size, speckle_range, min_confidence)
        self.shape = (h, w)
        self.min_disparity, self.max_disparity = d_min, d_max
        self.backend = resolve_backend(backend, device)
        matching._check_memory(self.backend, self.shape, d_max, d_min, "sgm", self._steps, self._paths,
                               self._window)
        self._buffers = {}       # disparity's own device buffers
        self._workspace = {}     # the fused matcher's (band volumes, states, checkpoints)
        # frames share those buffers: calls from several threads run one at a time
        self._lock = threading.Lock()

    def __repr__(self):
        return (f"StereoMatcher(shape={self.shape}, max_disparity={self.max_disparity}, "
                f"min_disparity={self.min_disparity}, window={self._window}, subpixel_steps={self._steps}, "
                f"paths={self._paths}, backend={self.backend.name!r})")

    def _view(self, image, name):
        if not isinstance(image, np.ndarray) and self.backend.owns(image):
            image = self.backend.to_host(image)
        img = matching.grey_image(image, name)
        if img.shape != self.shape:
            raise ValueError(f"{name} must have the matcher's shape {self.shape} (grey or colour), "
                             f"got {np.shape(image)}")
        return img

    def compute(self, left, right, *, return_confidence=False):
        """Disparity map of the left view of one pair, as :func:`gfgpu.stereo.disparity`.

        Parameters
        ----------
        left, right : (H, W) or (H, W, C) array_like, or device arrays of the matcher's backend
            The rectified pair, of the matcher's ``shape``.
        return_confidence : bool, optional
            Also return the confidence in [0, 1] (0 where NaN), as ``disparity``'s.

        Returns
        -------
        disparity : (H, W) float32 ndarray
            In px (a left pixel at column x matches the right pixel at x - d), NaN where no
            match is established.
        confidence : (H, W) float32 ndarray
            Only with ``return_confidence=True``.

        Raises
        ------
        ValueError
            A view of another shape, or NaN/inf values.
        TypeError
            Non-numeric images.
        """
        flag("return_confidence", return_confidence)
        lft = self._view(left, "left")
        rgt = self._view(right, "right")
        with self._lock:
            disp, conf = matching._sgm(self.backend, lft, rgt, self.min_disparity, self.max_disparity, self._steps,
                                       self._radius, self._window, self._p1, self._p2, self._paths, self._uniqueness,
                                       self._lr_check, lambda n: None, self._buffers, self._workspace)
        if not self._subpixel:
            disp = np.rint(disp * self._steps) / self._steps
        disp = disp.astype(np.float32)
        if self._post[0] or self._post[2]:
            disp, conf = postfilter.apply_postfilter(disp, conf, *self._post)
        # torch in, torch out (numpy and device arrays: numpy, as disparity() returns)
        return as_kind((disp, conf) if return_confidence else disp, kind_of(left), left)
