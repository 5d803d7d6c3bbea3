"""Fixtures shared by the tests: the ``backend`` each test runs on, and a seeded ``rng``.

Every test that takes ``backend`` runs once per backend of :data:`gfgpu.BACKENDS`.  A backend
that does not load here (no library, no driver, no device) is skipped, with the reason, unless
it is named in the environment variable ``GFGPU_TEST_BACKENDS`` (comma-separated, e.g.
``numpy,warp,opencl``, as CI sets it): a requested backend that does not load fails every test
that uses it, so a run cannot pass by skipping.  Unknown names in the variable are an error.
"""

import os

import numpy as np
import pytest

from gfgpu.backends import BACKENDS, get_backend

REQUEST_VARIABLE = "GFGPU_TEST_BACKENDS"


def requested_backends(value=None):
    """The backend names listed in ``GFGPU_TEST_BACKENDS`` (``value`` if given); ValueError for
    a name that is not a backend."""
    value = os.environ.get(REQUEST_VARIABLE, "") if value is None else value
    names = [n.strip() for n in value.split(",") if n.strip()]
    unknown = [n for n in names if n not in BACKENDS]
    if unknown:
        raise ValueError(f"{REQUEST_VARIABLE}={value!r} names unknown backend(s) "
                         f"{', '.join(map(repr, unknown))}; the backends are {', '.join(BACKENDS)}")
    return frozenset(names)


def _available(name):
    try:
        be = get_backend(name)
        # one tiny call proves the device really works (driver, compiler)
        from gfgpu import greens
        from gfgpu._core import recursion
        plan = recursion.plan_pass(greens.UniformGreen(1.0).line_pass(), 4, "nearest", np.float32)
        src = be.asarray(np.ones((1, 1, 4), np.float32))
        be.recurse(src, be.empty((1, 1, 4), np.float32), 2, plan)
        be.synchronize()
        return be, None
    except Exception as exc:  # reported by the fixture: a skip, or a failure where requested
        return None, f"{name} backend unavailable: {type(exc).__name__}: {exc}"


try:
    REQUESTED, _REQUEST_ERROR = requested_backends(), None
except ValueError as exc:
    REQUESTED, _REQUEST_ERROR = frozenset(), str(exc)


def pytest_configure(config):
    if _REQUEST_ERROR:
        raise pytest.UsageError(_REQUEST_ERROR)


_STATE = {} if _REQUEST_ERROR else {name: _available(name) for name in BACKENDS}


def use_backend_or_skip(name):
    """The backend ``name`` for a test, or skip the test where it does not load; a backend named
    in ``GFGPU_TEST_BACKENDS`` that does not load fails the test instead."""
    be, why = _STATE[name]
    if be is None:
        if name in REQUESTED:
            pytest.fail(f"{why} (requested by {REQUEST_VARIABLE}={os.environ[REQUEST_VARIABLE]!r})",
                        pytrace=False)
        pytest.skip(why)
    return be


@pytest.fixture(params=BACKENDS)
def backend(request):
    return use_backend_or_skip(request.param)


@pytest.fixture
def require_backend():
    """``require_backend(name)``: the backend ``name``, with the skip/fail rule of ``backend``
    (for tests about one backend)."""
    return use_backend_or_skip


def pytest_report_header(config):
    lines = []
    for name in BACKENDS:
        be, why = _STATE[name]
        state = f"{be.device}" if be is not None else why
        lines.append(f"gfgpu {name}: {state}{' (required)' if name in REQUESTED else ''}")
    return lines


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
