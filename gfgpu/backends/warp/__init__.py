"""The NVIDIA Warp backend (``cpu`` and ``cuda:N``) and its device code.

Importing this package neither imports nor initialises Warp: ``recurse.py`` holds the recursion
primitive's Warp kernels and is imported when the backend is created; ``launch.py`` is the toolkit
with which the features' Warp kernels (``gfgpu/<feature>/_warp.py``) are launched.
"""

from .backend import WarpBackend, cuda_driver_present, unavailable_reason, warp_devices

__all__ = ["WarpBackend", "cuda_driver_present", "unavailable_reason", "warp_devices"]
