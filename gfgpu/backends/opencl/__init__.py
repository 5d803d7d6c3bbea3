"""The PyOpenCL backend (PoCL on the CPU, any OpenCL GPU): the recursion primitive's device code
(``recurse.cl``, ``recurse_lines.cl``) and the launch toolkit (``launch.py``) with which the features'
kernels (``gfgpu/<feature>/*.cl``, launched from ``_opencl.py``) are built and run.

Importing this package neither imports PyOpenCL nor creates a context.
"""

from .backend import OpenCLBackend, backend_for_queue, build_failure, opencl_devices, unavailable_reason

__all__ = ["OpenCLBackend", "backend_for_queue", "build_failure", "opencl_devices", "unavailable_reason"]
