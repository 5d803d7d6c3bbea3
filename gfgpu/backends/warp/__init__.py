"""The NVIDIA Warp backend (``cpu`` and ``cuda:N``) and its device code.

Importing this package neither imports nor initialises Warp: ``recurse.py``, ``edges.py`` and
``stereo.py`` hold the Warp kernels and are imported when first launched.
"""

from .backend import WarpBackend, cuda_driver_present, unavailable_reason, warp_devices

__all__ = ["WarpBackend", "cuda_driver_present", "unavailable_reason", "warp_devices"]
