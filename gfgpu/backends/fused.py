"""Fused kernels: device kernels that an application registers beside the generic primitives.

The :class:`~gfgpu.backends.base.Backend` contract holds only what every operator needs (arrays,
the recursion primitive, a gather).  A stage that must be one kernel for speed (census, SGM
aggregation, disparity selection, non-maximum suppression) is a :class:`FusedKernel`: a name,
its numpy specification (the feature's ``spec.py``) and one launcher per backend, named as
``"module:function"`` (the feature's ``_numpy.py``, ``_warp.py``, ``_opencl.py``) and imported on
first use, so registering a kernel imports no device library.  A launcher is called as
``launcher(backend, *args)``.

The feature that needs a kernel registers it (``gfgpu.stereo.kernels``, ``gfgpu.motion.kernels``,
``gfgpu.edges.kernels``); this registry is the only place that imports a feature's device
modules, and the backends never import an application.
"""

from __future__ import annotations

import importlib

from .base import BackendUnavailable

__all__ = ["FusedKernel", "register", "registered"]

_REGISTRY = {}


class FusedKernel:
    """One fused kernel: ``kernel(backend, *args)`` runs the backend's launcher.

    Parameters
    ----------
    name : str
        Unique name, e.g. ``"stereo.census"``.
    spec : callable
        The numpy specification the launchers are tested against.
    launchers : dict of str
        Backend name -> ``"package.module:function"``.
    """

    def __init__(self, name, spec, launchers):
        self.name, self.spec = name, spec
        self.launchers = dict(launchers)
        self._loaded = {}

    def launcher(self, backend_name):
        """The launcher function of ``backend_name`` (imported on first use)."""
        fn = self._loaded.get(backend_name)
        if fn is None:
            where = self.launchers.get(backend_name)
            if where is None:
                raise BackendUnavailable(f"the {backend_name} backend has no {self.name} kernel "
                                         f"(implemented on: {', '.join(sorted(self.launchers))})")
            module, _, attr = where.partition(":")
            fn = self._loaded[backend_name] = getattr(importlib.import_module(module), attr)
        return fn

    def __call__(self, backend, *args, **kwargs):
        return self.launcher(backend.name)(backend, *args, **kwargs)

    def __repr__(self):
        return f"<gfgpu fused kernel {self.name!r} on {', '.join(sorted(self.launchers))}>"


def register(name, spec, **launchers):
    """Register (or return the already registered) fused kernel ``name``; see :class:`FusedKernel`."""
    kernel = _REGISTRY.get(name)
    if kernel is None:
        kernel = _REGISTRY[name] = FusedKernel(name, spec, launchers)
    elif kernel.spec is not spec or kernel.launchers != launchers:
        raise ValueError(f"fused kernel {name!r} is already registered with other launchers")
    return kernel


def registered():
    """All registered fused kernels, by name (those of the applications imported so far)."""
    return dict(_REGISTRY)
