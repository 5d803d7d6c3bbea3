"""The PyOpenCL backend (PoCL on the CPU, any OpenCL GPU) and its device code (``*.cl``).

Importing this package neither imports PyOpenCL nor creates a context.
"""

from .backend import OpenCLBackend, backend_for_queue, opencl_devices, unavailable_reason

__all__ = ["OpenCLBackend", "backend_for_queue", "opencl_devices", "unavailable_reason"]
