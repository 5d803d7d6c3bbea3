"""The array protocols: arrays of the GPU ecosystem in, the same kind out.

Any input that offers ``__dlpack__`` / ``__dlpack_device__`` (PyTorch, CuPy, JAX, numpy >= 1.22,
any DLPack producer) or ``__cuda_array_interface__`` (Numba) is a *foreign* array here: not
numpy and not a backend's own kind (``warp.array``, ``pyopencl.array.Array``, which the
resolution rule hands to their backend).  This module is the one place that reads those
protocols:

- :func:`kind_of` says what a foreign array is and where its memory lives (:class:`ArrayKind`);
- :func:`take` turns it into what the resolved backend computes on, without a copy: a host
  array becomes a numpy view (``numpy.from_dlpack``); a CUDA array becomes the backend's own
  device array through the backend's ``from_dlpack`` method (the Warp backend's, on the array's
  own device, the producer's stream respected), since only device code may import Warp;
- :func:`as_kind` hands a result back as the caller's kind, on the caller's device (torch in,
  torch out; CuPy in, CuPy out; JAX in, JAX out), again through DLPack, without a copy;
- :func:`host_array` is for the functions that compute on the host: any kind, moved to the
  host once (a copy only for device memory), or one clear ``TypeError``.

Where an array cannot be used where it lives (a CUDA array with no CUDA backend, memory of a
device no backend reads) the error names the array's device and the backends that could take
it (:meth:`ArrayKind.refusal`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

__all__ = ["ArrayKind", "kind_of", "take", "as_kind", "host_array", "DLPACK_CPU", "DLPACK_CUDA"]

# DLPack's DLDeviceType codes (dlpack.h)
DLPACK_CPU, DLPACK_CUDA, DLPACK_CUDA_HOST, DLPACK_CUDA_MANAGED = 1, 2, 3, 13
_DEVICE_NAMES = {1: "cpu", 2: "cuda", 3: "cuda_host", 4: "opencl", 7: "vulkan", 8: "metal", 9: "vpi", 10: "rocm",
                 11: "rocm_host", 12: "ext_dev", 13: "cuda", 14: "oneapi", 15: "webgpu", 16: "hexagon", 17: "maia"}
#: memory numpy reads in place (pinned CUDA host memory is host memory)
_HOST_TYPES = (DLPACK_CPU, DLPACK_CUDA_HOST)
#: memory a CUDA backend reads in place (managed memory is addressable from the device)
_CUDA_TYPES = (DLPACK_CUDA, DLPACK_CUDA_MANAGED)
#: the backends' own array kinds: the resolution rule hands them to their backend
_OWN_LIBRARIES = ("warp", "pyopencl")


@dataclass(frozen=True)
class ArrayKind:
    """What a foreign array is and where its memory lives.

    ``library`` is the producer's top-level module (``"torch"``, ``"cupy"``, ``"jaxlib"``, ...),
    ``name`` its type for messages (``"torch.Tensor"``), ``device_type`` / ``device_id`` the
    DLPack device (:data:`DLPACK_CPU`, :data:`DLPACK_CUDA`, ...; ``device_id`` -1 for a
    ``__cuda_array_interface__`` array: the current CUDA device), ``protocol`` ``"dlpack"`` or
    ``"cuda_array_interface"``.
    """

    library: str
    name: str
    device_type: int
    device_id: int
    protocol: str = "dlpack"
    type: type | None = None

    @property
    def on_host(self):
        """Host memory: computed on as a numpy view."""
        return self.device_type in _HOST_TYPES

    @property
    def on_cuda(self):
        """CUDA device memory: computed on by a CUDA backend on that device."""
        return self.device_type in _CUDA_TYPES

    @property
    def device(self):
        """The device as the backends name it: ``"cpu"``, ``"cuda:0"``, ``"rocm:1"``."""
        if self.on_host:
            return "cpu"
        base = _DEVICE_NAMES.get(self.device_type, f"device type {self.device_type}")
        return base if self.device_id < 0 else f"{base}:{self.device_id}"

    def refusal(self, name, why):
        """The one message for an array that cannot be used where it lives: its device, why,
        and the backends that could take it."""
        takers = (f"the warp backend on {self.device} (backend='warp', device={self.device!r}, or no backend=)"
                  if self.on_cuda else "none: no gfgpu backend reads this device's memory")
        return (f"{name} is a {self.name} on {self.device}; {why}. Backends that can take it: {takers}. "
                f"No copy is made to another device: move the array yourself (e.g. tensor.cpu()) to use another "
                f"backend")


def kind_of(array, own=False):
    """The :class:`ArrayKind` of a foreign array, or None for numpy arrays, scalars, sequences and
    (unless ``own``) the backends' own kinds, ``warp.array`` and ``pyopencl.array.Array``.

    Raises
    ------
    TypeError
        If the array's ``__dlpack_device__`` fails.
    """
    if array is None or isinstance(array, (type, np.ndarray, np.generic, list, tuple, int, float, complex, bool)):
        return None
    typ = type(array)
    library = typ.__module__.split(".")[0]
    if library in _OWN_LIBRARIES and not own:
        return None
    name = f"{library}.{typ.__qualname__}"
    if library == "pyopencl" and hasattr(array, "queue"):
        return ArrayKind(library, name, 4, 0, "opencl", typ)     # no DLPack: read back with .get()
    if hasattr(array, "__dlpack__") and hasattr(array, "__dlpack_device__"):
        try:
            dev_type, dev_id = array.__dlpack_device__()
        except Exception as exc:
            raise TypeError(f"{name}.__dlpack_device__() failed: {exc}") from exc
        return ArrayKind(library, name, int(dev_type), int(dev_id), "dlpack", typ)
    if hasattr(array, "__cuda_array_interface__"):
        return ArrayKind(library, name, DLPACK_CUDA, -1, "cuda_array_interface", typ)
    return None


def _dlpack_view(array, kind, name):
    """A numpy view of host memory through DLPack (no copy)."""
    try:
        view = np.from_dlpack(array)
    except Exception as exc:      # e.g. torch: "Can't export tensors that require gradient"
        raise TypeError(f"{name} ({kind.name} on {kind.device}) cannot be read through DLPack: {exc}") from exc
    return view


def take(array, kind, backend, name="input"):
    """``array`` (a foreign array of ``kind``) as what ``backend`` computes on, without a copy.

    Host memory: a numpy view (every backend reads host arrays).  CUDA memory: the backend's
    own device array, from its ``from_dlpack(array)`` method (the Warp backend's wraps the
    memory on the array's device, the producer's stream respected); a backend without one, or
    on another device, is refused with :meth:`ArrayKind.refusal`.

    Raises
    ------
    TypeError
        The array's memory is not where ``backend`` computes, or the producer refuses to
        export it (e.g. a torch tensor that requires grad).
    """
    if kind.on_host:
        return _dlpack_view(array, kind, name)
    importer = getattr(backend, "from_dlpack", None) if kind.on_cuda else None
    if importer is None:
        raise TypeError(kind.refusal(name, f"the {backend.name} backend ({backend.device}) cannot read that memory"))
    try:
        device_array = importer(array)
    except Exception as exc:      # e.g. a dtype or rank the backend's arrays cannot hold
        raise TypeError(f"{name} ({kind.name} on {kind.device}) cannot be taken by {backend!r}: {exc}") from exc
    if not backend.owns(device_array):
        raise TypeError(kind.refusal(name, f"the backend chosen, {backend.name} on {backend.device}, runs on "
                                           f"another device"))
    return device_array


#: the module whose ``from_dlpack`` makes each library's arrays (looked up, never imported: the
#: caller's array proves that it is loaded)
_FROM_DLPACK = {"torch": "torch", "cupy": "cupy", "jax": "jax.numpy", "jaxlib": "jax.numpy"}


def _converter(kind, like):
    """The caller's ``from_dlpack``: its library's, or its array-API namespace's; None if none."""
    module = sys.modules.get(_FROM_DLPACK.get(kind.library, ""))
    if module is not None and hasattr(module, "from_dlpack"):
        return module.from_dlpack
    namespace = getattr(like, "__array_namespace__", None)
    if namespace is not None:
        try:
            return namespace().from_dlpack
        except Exception:     # a namespace that cannot be had: results stay as computed
            return None
    return None


def as_kind(result, kind, like):
    """``result`` (a numpy array, a backend's device array, or a tuple of them) as the caller's
    kind ``kind`` (that of the caller's array ``like``), through DLPack, without a copy.

    A host result for a caller whose array lives on a device (a function that computes on the
    host) is moved to that device once (torch, CuPy, JAX).  A kind whose library offers no
    ``from_dlpack`` (torch's, or an array-API namespace's) gets the result as computed: a numpy
    array for host memory, the backend's device array otherwise.
    """
    if kind is None:
        return result
    if isinstance(result, tuple):
        return tuple(as_kind(r, kind, like) for r in result)
    if not hasattr(result, "__dlpack__") or kind.library in _OWN_LIBRARIES:
        return result
    convert = _converter(kind, like)
    if convert is None:
        return result
    if isinstance(result, np.ndarray):
        # numpy exports only writeable, aligned arrays; a fresh result is one
        result = result if result.flags.writeable else result.copy()
        out = convert(result)
        return out if kind.on_host else _to_device(out, kind, like)
    return convert(result)


def _to_device(host, kind, like):
    """A host result (already the caller's kind) moved to the caller's array's device once."""
    if kind.library == "torch":
        return host.to(like.device)
    if kind.library == "cupy":
        with sys.modules["cupy"].cuda.Device(kind.device_id):
            return sys.modules["cupy"].asarray(host)
    if kind.library in ("jax", "jaxlib"):
        jax = sys.modules.get("jax")
        devices = getattr(like, "devices", None)
        if jax is not None and devices is not None:
            return jax.device_put(host, next(iter(devices())))
    return host


def host_array(array, name):
    """``array`` as a numpy array, for a function that computes on the host.

    numpy arrays and sequences pass as they are (``numpy.asarray``); a foreign or backend array
    in host memory is a view through DLPack (no copy); one in device memory (CUDA, OpenCL) is
    copied to the host once (DLPack's copy to the CPU, else the library's own read-back).

    Raises
    ------
    TypeError
        The array cannot be read (named by ``name``), or it is not numeric.
    """
    kind = kind_of(array, own=True)
    if kind is None:
        arr = np.asarray(array)
    elif kind.on_host and kind.protocol == "dlpack":
        arr = _dlpack_view(array, kind, name)
    else:
        arr = _copy_to_host(array, kind, name)
    if arr.dtype == object:
        raise TypeError(f"{name} must be a numeric array, got {type(array).__name__} (no array protocol: "
                        f"numpy, __array__, __dlpack__ or __cuda_array_interface__)")
    return arr


#: the libraries' own read-back of device memory, where DLPack cannot copy to the CPU
_READ_BACK = {"torch": lambda a: a.cpu().numpy(), "cupy": lambda a: a.get(),
              "pyopencl": lambda a: a.get(), "warp": lambda a: a.numpy()}


def _copy_to_host(array, kind, name):
    if kind.protocol == "dlpack":
        try:
            return np.from_dlpack(array, device="cpu", copy=True)    # DLPack >= 1.0 producers
        except Exception:    # an older producer or numpy: the library's own read-back below
            pass
    read = _READ_BACK.get(kind.library, np.asarray)      # JAX: __array__ copies to the host
    try:
        return np.asarray(read(array))
    except Exception as exc:
        raise TypeError(f"{name} ({kind.name} on {kind.device}) could not be copied to the host: {exc}; "
                        f"copy it to the host first") from exc
