"""Device code of the per-pixel velocity fields (:mod:`gfgpu.motion.field`), apart from the other
motion kernels so that a field call builds only field code: ``field.cl`` (OpenCL), ``_warp.py`` (a
Warp module of its own) and the launchers ``launch_field_blur`` in ``_numpy.py``, ``_warp.py``,
``_opencl.py``, registered by :mod:`gfgpu.motion.kernels`; specification:
:func:`gfgpu.motion.spec.field_blur_reference`."""
