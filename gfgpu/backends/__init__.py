"""Backend registry and the one device-resolution rule.

Resolution, first match wins:

1. an explicit ``backend=`` / ``device=`` argument;
2. the input array's own device: a ``warp.array`` or a ``pyopencl.array.Array`` stays where it
   is, and so does a foreign CUDA array (torch, CuPy, JAX, anything with ``__dlpack__`` or
   ``__cuda_array_interface__``: the Warp backend on its device, or one error naming its device
   and the backends that could take it); host memory (numpy, a CPU tensor) goes on to 3.;
3. the innermost ``with gfgpu.use_backend(...)`` block;
4. the ``GFGPU_BACKEND`` environment variable (``name`` or ``name:device``, e.g. ``warp:cuda:1``);
5. automatic: a CUDA GPU through Warp, then an OpenCL GPU, then OpenCL on the CPU, then Warp on
   the CPU, then numpy.  Devices are never ranked by reported memory.

Nothing here creates a context or compiles a kernel until a backend is first used.
"""

from __future__ import annotations

import contextlib
import contextvars
import copyreg
import os
import threading
from dataclasses import dataclass
from functools import cache, lru_cache

from .._core import arrays, hostpool
from . import opencl, warp
from .base import Backend, BackendUnavailable
from .numpy import NumpyBackend

__all__ = ["Backend", "BackendUnavailable", "BACKENDS", "get_backend", "resolve_backend",
           "use_backend", "devices", "DeviceInfo", "backend_request", "check_backend_name"]

BACKENDS = ("numpy", "warp", "opencl")

_current = contextvars.ContextVar("gfgpu_backend", default=None)


def check_backend_name(name):
    """``name`` if it is a backend name; ``ValueError`` listing the names otherwise."""
    if name not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)}; got {name!r}")
    return name


def _device_key(device):
    # devices may be given as strings, ints or library objects; the cache key must be hashable
    try:
        hash(device)
        return device
    except TypeError:
        return id(device)


_BUILD_LOCK = threading.RLock()


def _make(name, device_key, device):
    with _BUILD_LOCK:     # threads (e.g. of a Dask worker) build one backend, not several
        be = _construct(name, device_key, device)
    be._pid = os.getpid()
    if device is None or isinstance(device, (str, int)):
        be._requested = device   # pickles as get_backend(name, device): same request elsewhere
    copyreg.pickle(type(be), _reduce)
    return be


def backend_request(be):
    """``(name, device)`` such that ``get_backend(name, device)`` builds ``be``'s equivalent in
    another process: the request that made it where there was one, else its device spec."""
    requested = getattr(be, "_requested", False)
    return (be.name, requested) if requested is not False else be.spec


def _reduce(be):
    # backends pickle by name and device, rebuilt by get_backend in the receiving process
    # (device contexts and queues do not pickle)
    return (get_backend, backend_request(be))


@cache
def _construct(name, device_key, device):
    if name == "numpy":
        if device not in (None, "host", "cpu"):
            raise BackendUnavailable(f"the numpy backend runs on the host only; got device={device!r}")
        return NumpyBackend()
    if name == "warp":
        return warp.WarpBackend(device)
    return opencl.OpenCLBackend(device)


def get_backend(name, device=None) -> Backend:
    """The (cached) backend ``name`` on ``device``; raises BackendUnavailable with the reason."""
    check_backend_name(name)
    if isinstance(device, (list, tuple, dict, set, bool, float)):
        raise TypeError(f"device must be a name such as 'cpu' or 'cuda:0', an index, or a device object; "
                        f"got {device!r}")
    if isinstance(device, str) and device.isdigit():
        device = int(device)
    hostpool.default_limit()    # a bad GFGPU_HOST_POOL is the user's error, not an unavailable backend
    try:
        return _make(name, _device_key(device), device)
    except BackendUnavailable:
        raise
    except ImportError as exc:
        raise BackendUnavailable(f"backend {name!r} is unavailable: {exc}") from exc


def _parse_spec(spec):
    if isinstance(spec, Backend):
        return spec
    name, _, device = str(spec).partition(":")
    return get_backend(name.strip(), device or None)


@lru_cache(maxsize=1)
def _automatic():
    hostpool.default_limit()    # raised here, not taken for a broken driver below
    reasons = []
    for name, want in (("warp", "cuda"), ("opencl", "gpu"), ("opencl", "cpu"), ("warp", "cpu")):
        try:
            if name == "warp":
                if want == "cuda" and not warp.cuda_driver_present():
                    continue   # decided without initialising Warp
                devs = [d for d in warp.warp_devices() if d.startswith(want)]
                if devs:
                    return get_backend("warp", devs[0])
            else:
                devs = [i for i, d, kind in opencl.opencl_devices()
                        if kind == want and opencl.build_failure(d) is None]
                if devs:
                    return get_backend("opencl", devs[0])
        except Exception as exc:  # a broken driver must not stop the fallback chain
            reasons.append(f"{name}/{want}: {exc}")
    return get_backend("numpy")


def array_backend(array):
    """The backend that computes on ``array`` where it lives (a warp or pyopencl array, a
    foreign CUDA array), or None for host memory (numpy, CPU tensors: the rule goes on).

    Raises
    ------
    BackendUnavailable
        A foreign array in device memory that no usable backend reads: the message names its
        device and the backends that could take it.
    """
    mod = type(array).__module__
    if mod.startswith("warp"):
        return get_backend("warp", str(array.device))
    if mod.startswith("pyopencl"):
        return opencl.backend_for_queue(array.queue)
    kind = arrays.kind_of(array)
    if kind is None or kind.on_host:
        return None
    if not kind.on_cuda:
        raise BackendUnavailable(kind.refusal("input", "no gfgpu backend reads that memory"))
    device = kind.device       # "cuda" for __cuda_array_interface__ (it names no device): the current one
    try:
        return get_backend("warp", device)
    except BackendUnavailable as exc:
        others = ", ".join(n for n in BACKENDS if n != "warp")
        raise BackendUnavailable(kind.refusal("input", f"the warp backend there is unavailable ({exc}), and the "
                                                       f"other backends ({others}) cannot read CUDA memory")) from exc


def _after_fork_in_child():
    # a forked child never reuses its parent's contexts and queues: backends are rebuilt on
    # first use (OpenCL refuses with a clear message: its runtimes hang after a fork)
    _construct.cache_clear()
    _automatic.cache_clear()


os.register_at_fork(after_in_child=_after_fork_in_child)


def _own(be):
    """``be``, or its equivalent rebuilt in this process if it was made before a fork."""
    if getattr(be, "_pid", os.getpid()) != os.getpid():
        return get_backend(*backend_request(be))
    return be


def resolve_backend(backend=None, device=None, array=None) -> Backend:
    """Apply the resolution rule above; see the module docstring."""
    if isinstance(backend, Backend):
        return _own(backend)
    if backend is not None:
        return get_backend(check_backend_name(backend), device)
    if device is not None:
        raise ValueError("device= needs backend= as well (e.g. backend='warp', device='cuda:0')")
    if array is not None:
        owner = array_backend(array)
        if owner is not None:
            return owner
    ctx = _current.get()
    if ctx is not None:
        return _own(ctx)
    env = os.environ.get("GFGPU_BACKEND")
    if env:
        name = env.partition(":")[0].strip()
        if name not in BACKENDS:       # say where the name came from: no argument named it
            raise ValueError(f"the environment variable GFGPU_BACKEND={env!r} names no backend: it must be "
                             f"one of {', '.join(BACKENDS)} (optionally 'name:device', e.g. warp:cuda:0), "
                             f"or be unset")
        return _parse_spec(env)
    return _automatic()


@contextlib.contextmanager
def use_backend(backend, device=None):
    """Run the enclosed gfgpu calls on ``backend`` (a name, ``"name:device"``, or a Backend).

    Examples
    --------
    >>> import gfgpu, numpy as np
    >>> with gfgpu.use_backend("numpy"):
    ...     out = gfgpu.shift(np.eye(8), (0.0, 1.5))
    """
    be = _parse_spec(backend) if device is None else get_backend(check_backend_name(backend), device)
    token = _current.set(be)
    try:
        yield be
    finally:
        _current.reset(token)


@dataclass(frozen=True)
class DeviceInfo:
    backend: str
    device: str
    kind: str
    usable: bool
    note: str = ""

    def __str__(self):
        state = "usable" if self.usable else f"unavailable: {self.note}"
        return f"{self.backend:7s} {self.device:40s} {self.kind:5s} {state}"


def devices():
    """Every backend/device gfgpu can see, usable or not (with the reason)."""
    out = [DeviceInfo("numpy", "host", "cpu", True, "float64 reference, vectorised over lines")]
    try:
        why = warp.unavailable_reason()
        if why:
            out.append(DeviceInfo("warp", "-", "-", False, why))
        else:
            for d in warp.warp_devices():
                out.append(DeviceInfo("warp", d, "gpu" if d.startswith("cuda") else "cpu", True))
            if not any(d.startswith("cuda") for d in warp.warp_devices()):
                why = "no GPU found by Warp" if warp.cuda_driver_present() else "no NVIDIA CUDA driver (libcuda)"
                out.append(DeviceInfo("warp", "cuda", "gpu", False, why))
    except Exception as exc:
        out.append(DeviceInfo("warp", "-", "-", False, str(exc)))
    try:
        why = opencl.unavailable_reason()
        if why:
            out.append(DeviceInfo("opencl", "-", "-", False, why))
        else:
            for idx, dev, kind in opencl.opencl_devices():
                broken = opencl.build_failure(dev)
                out.append(DeviceInfo("opencl", f"{idx}: {dev.name.strip()} ({dev.platform.name.strip()})",
                                      kind, broken is None, broken or ""))
    except Exception as exc:
        out.append(DeviceInfo("opencl", "-", "-", False, str(exc)))
    return out
