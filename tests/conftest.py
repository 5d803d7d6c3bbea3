import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))

from gfgpu.backends import BACKENDS, BackendUnavailable, get_backend


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
    except (BackendUnavailable, Exception) as exc:  # report, never fail, when a backend is absent
        return None, f"{name} backend unavailable: {exc}"


_STATE = {name: _available(name) for name in BACKENDS}


@pytest.fixture(params=BACKENDS)
def backend(request):
    be, why = _STATE[request.param]
    if be is None:
        pytest.skip(why)
    return be


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
