"""Fixtures shared by the tests: the ``backend`` each test runs on, and a seeded ``rng``.

Every test that takes ``backend`` runs once per backend of :data:`gfgpu.BACKENDS`.  A backend
that does not load here (no library, no driver, no device) is skipped, with the reason, unless
it is named in the environment variable ``GFGPU_TEST_BACKENDS`` (comma-separated, e.g.
``numpy,warp,opencl``, as CI sets it): a requested backend that does not load fails every test
that uses it, so a run cannot pass by skipping.  Unknown names in the variable are an error.

An entry may name a device as ``GFGPU_BACKEND`` does, ``name:device`` (``warp:cuda:0``,
``opencl:0``): the ``backend`` fixture then runs on each device named for that backend instead
of its default device, and ``require_backend(name)`` returns the first of them.  When every
entry names a device (a device run, e.g. ``warp:cuda:0,opencl:1`` on a GPU machine), only those
devices run: backends not named and tests that use neither fixture (host-only tests, docstring
examples) are skipped.
"""

import os

import numpy as np
import pytest

from gfgpu.backends import BACKENDS, get_backend

REQUEST_VARIABLE = "GFGPU_TEST_BACKENDS"


def parse_request(value=None):
    """The entries of ``GFGPU_TEST_BACKENDS`` (``value`` if given) as ``(name, device)`` pairs,
    ``device`` None where the entry names none; ValueError for a name that is not a backend."""
    value = os.environ.get(REQUEST_VARIABLE, "") if value is None else value
    entries = []
    for item in (n.strip() for n in value.split(",")):
        if item:
            name, _, device = item.partition(":")
            entries.append((name.strip(), device.strip() or None))
    unknown = [n for n, _ in entries if n not in BACKENDS]
    if unknown:
        raise ValueError(f"{REQUEST_VARIABLE}={value!r} names unknown backend(s) "
                         f"{', '.join(map(repr, unknown))}; the backends are {', '.join(BACKENDS)} "
                         f"(each entry 'name' or 'name:device', e.g. warp:cuda:0)")
    return list(dict.fromkeys(entries))


def requested_backends(value=None):
    """The backend names listed in ``GFGPU_TEST_BACKENDS`` (``value`` if given); ValueError for
    a name that is not a backend."""
    return frozenset(name for name, _ in parse_request(value))


def spec_of(name, device):
    return name if device is None else f"{name}:{device}"


def _available(name, device=None):
    try:
        be = get_backend(name, device)
        # one tiny call proves the device really works (driver, compiler)
        from gfgpu import greens
        from gfgpu._core import recursion
        plan = recursion.plan_pass(greens.UniformGreen(1.0).line_pass(), 4, "nearest", np.float32)
        src = be.asarray(np.ones((1, 1, 4), np.float32))
        be.recurse(src, be.empty((1, 1, 4), np.float32), 2, plan)
        be.synchronize()
        return be, None
    except Exception as exc:  # reported by the fixture: a skip, or a failure where requested
        return None, f"{spec_of(name, device)} backend unavailable: {type(exc).__name__}: {exc}"


try:
    ENTRIES, _REQUEST_ERROR = parse_request(), None
except ValueError as exc:
    ENTRIES, _REQUEST_ERROR = [], str(exc)
REQUESTED = frozenset(name for name, _ in ENTRIES)
#: every entry names a device: only those devices run, host-only tests skip
DEVICE_RUN = bool(ENTRIES) and all(device is not None for _, device in ENTRIES)


def _specs_of(name):
    """The (name, device) pairs the ``backend`` fixture runs for backend ``name``."""
    named = [(n, d) for n, d in ENTRIES if n == name and d is not None]
    if named:
        return named
    return [] if DEVICE_RUN else [(name, None)]


PARAMS = [pair for name in BACKENDS for pair in _specs_of(name)]


def pytest_configure(config):
    if _REQUEST_ERROR:
        raise pytest.UsageError(_REQUEST_ERROR)


_STATE = {} if _REQUEST_ERROR else {pair: _available(*pair) for pair in PARAMS}
DEVICE_RUN_SKIP = (f"host-only test: {REQUEST_VARIABLE}={os.environ.get(REQUEST_VARIABLE, '')!r} names "
                   f"devices only (a device run)")


def _use(pair):
    be, why = _STATE[pair]
    if be is None:
        if pair[0] in REQUESTED:
            pytest.fail(f"{why} (requested by {REQUEST_VARIABLE}={os.environ[REQUEST_VARIABLE]!r})",
                        pytrace=False)
        pytest.skip(why)
    return be


def use_backend_or_skip(name):
    """The backend ``name`` for a test (on the first device ``GFGPU_TEST_BACKENDS`` names for
    it, if any), or skip the test where it does not load; a backend named in
    ``GFGPU_TEST_BACKENDS`` that does not load fails the test instead."""
    pairs = _specs_of(name)
    if not pairs:
        pytest.skip(f"{name} is not named in {REQUEST_VARIABLE}={os.environ.get(REQUEST_VARIABLE)!r} "
                    f"(a device run)")
    return _use(pairs[0])


@pytest.fixture(params=PARAMS, ids=[spec_of(*pair) for pair in PARAMS])
def backend(request):
    return _use(request.param)


@pytest.fixture
def require_backend():
    """``require_backend(name)``: the backend ``name``, with the skip/fail rule of ``backend``
    (for tests about one backend)."""
    return use_backend_or_skip


@pytest.fixture
def cpu_opencl(require_backend):
    """The OpenCL backend on a CPU device, for the engine's CPU-device paths (bands, row tiles,
    streamed stores, two-sided kernels); skipped on a GPU device."""
    be = require_backend("opencl")     # fails, not skips, where GFGPU_TEST_BACKENDS asks for OpenCL
    if be.kind != "cpu":
        pytest.skip("a CPU-device path of the OpenCL engine")
    return be


@pytest.fixture
def opencl_cpu_device():
    """A ``pyopencl.Device`` of the CPU that gfgpu would run on (it passes the build probes); for
    tests of the probe itself.  Skipped where there is none."""
    pytest.importorskip("pyopencl")
    from gfgpu.backends.opencl import backend as clb
    if clb.unavailable_reason() is not None:
        pytest.skip(f"no usable OpenCL device: {clb.unavailable_reason()}")
    cpus = [d for _, d, k in clb.opencl_devices() if k == "cpu" and clb.build_failure(d) is None]
    if not cpus:
        pytest.skip("no usable OpenCL CPU device")
    return cpus[0]


def pytest_collection_modifyitems(config, items):
    if not DEVICE_RUN:
        return
    skip = pytest.mark.skip(reason=DEVICE_RUN_SKIP)
    for item in items:
        if not {"backend", "require_backend"} & set(getattr(item, "fixturenames", ())):
            item.add_marker(skip)


def pytest_report_header(config):
    lines = []
    for pair in PARAMS:
        be, why = _STATE[pair]
        state = f"{be.device}" if be is not None else why
        lines.append(f"gfgpu {spec_of(*pair)}: {state}{' (required)' if pair[0] in REQUESTED else ''}")
    if DEVICE_RUN:
        lines.append(f"gfgpu: device run ({REQUEST_VARIABLE}); host-only tests skip")
    return lines


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def gpu_shaped_backend(name):
    """A new backend of ``name`` on its CPU device whose launches take the GPU shapes (``kind``
    "gpu": one line per work-item, block-parallel lines, GPU group sizes, device-side finite
    checks and copies), so the branches a GPU takes run, forced, on the CPU devices."""
    be = use_backend_or_skip(name)
    if be.kind != "cpu":
        return be     # a real GPU: its own shapes are the GPU shapes
    if name == "opencl":
        from gfgpu.backends.opencl.backend import OpenCLBackend
        forced = OpenCLBackend(be.queue)
    else:
        from gfgpu.backends.warp.backend import WarpBackend
        forced = WarpBackend(be.wp_device.alias)
    forced.kind = "gpu"
    return forced


@pytest.fixture(params=["warp", "opencl"])
def gpu_shaped(request):
    """Each device backend forced into its GPU launch shapes (:func:`gpu_shaped_backend`)."""
    return gpu_shaped_backend(request.param)
