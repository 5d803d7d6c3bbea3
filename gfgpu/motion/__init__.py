"""Motion blur, zoom and frame synthesis with the Green's filters (chapter §1, §6).

The chapter's Green's functions are point-spread functions that *move* image content and add
the blur of that motion: G_u (eq. 9) along a direction for uniform motion, and the exact affine
G_U^(1) (eq. 11-12) for a zoom about a fixed point.  Every operator is a fixed number of O(N)
recursive passes: the cost per pixel does not depend on the blur length or the zoom factor.

Coordinates, as everywhere in gfgpu (and in scipy.ndimage and scikit-image): every pair is in
array-axis order, rows then columns.  A uniform velocity is ``(vy, vx)`` pixels (``vy`` down the
rows, ``vx`` right along the columns), a zoom rate pair ``(u1_y, u1_x)``, a centre ``(row, col)``,
and :func:`estimate_translation` returns ``(dy, dx)``.  Rotations are in degrees, positive
counter-clockwise on screen; colour images take ``channel_axis``.  ``docs/motion.md`` has the
method and its measured accuracy.

Modules: ``blur`` (:func:`motion_blur`), ``uniform``, ``zoom`` and ``rotation`` (one kind of
motion each), ``kinds`` (the table of the kinds of motion and the PSFs, which every entry point
dispatches through: :func:`motion_blur`, :func:`synthesize_motion`, :func:`gfgpu.dask.motion_blur`,
``gfgpu batch blur``, ``gfgpu blur``/``gfgpu frames``), ``frames`` (sequences and in-between
frames), ``params`` (argument parsing).

References
----------
.. [1] J. R. A. Torreão, S. M. C. Victer, J. L. Fernandes, "Green's Functions of Matching
   Equations: A Unifying Approach for Low-level Vision Problems", 2007, eqs. 9-12 and §1, §6.
.. [2] J. Ferreira Jr., J. R. A. Torreão et al., "Motion synthesis through 1D affine
   matching", Pattern Analysis and Applications, doi:10.1007/s10044-007-0078-6.
"""

from .blur import motion_blur
from .frames import estimate_translation, interpolate_frames, synthesize_motion
from .uniform import uniform_motion_program
from .zoom import zoom_cell_weights

__all__ = ["motion_blur", "synthesize_motion", "interpolate_frames", "estimate_translation",
           "uniform_motion_program", "zoom_cell_weights"]
