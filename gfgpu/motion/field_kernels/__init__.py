"""Device code of the per-pixel velocity fields (:mod:`gfgpu.motion.field`), apart from the other
motion kernels so that a field call builds only field code: ``field.cl`` (OpenCL), the Warp
modules ``_warp.py`` (the default Gauss rule) and ``_warp_exact.py`` (the exact rule: Warp builds a
module whole at its first launch, so each rule's first call builds only its own kernel), and the
launchers ``launch_field_rule`` and ``launch_field_blur`` in ``_numpy.py``, ``_opencl.py`` and
the two Warp modules, registered by :mod:`gfgpu.motion.kernels`; specifications:
:func:`gfgpu.motion.spec.field_rule_reference`, :func:`gfgpu.motion.spec.field_blur_reference`."""
