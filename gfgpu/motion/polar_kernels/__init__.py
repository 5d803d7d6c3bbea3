"""Device code of the polar resampling behind the spin and zoom blurs (:mod:`gfgpu.motion.polar`),
apart from the other motion kernels so that a spin or zoom builds only polar code: ``polar.cl``
(OpenCL), ``_warp.py`` (a Warp module of its own) and the launchers ``launch_to_polar``,
``launch_from_polar`` and ``launch_add_rows`` in ``_numpy.py``, ``_warp.py``, ``_opencl.py``,
registered by :mod:`gfgpu.motion.kernels`; specifications: :func:`gfgpu.motion.spec.to_polar_reference`,
:func:`~gfgpu.motion.spec.from_polar_reference`, :func:`~gfgpu.motion.spec.add_rows_reference`."""
