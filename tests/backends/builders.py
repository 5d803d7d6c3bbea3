"""The registry of fused-kernel input builders, and what the builders share.

Each feature's builders live beside its tests, in ``tests/<feature>/kernel_inputs.py``, one per
kernel that :mod:`gfgpu.backends.fused` registers under ``"<feature>.<name>"``::

    @builds("stereo.census")
    def _census(be, kernel, rng):
        ...     # run ``kernel`` on ``be`` and ``kernel.spec`` on the same random inputs, compare

:func:`collect` imports every such module (a new feature folder with a ``kernel_inputs.py`` is
found without a list to edit); tests/backends/test_fused.py runs every builder on every backend
and fails for a registered kernel that has none.
"""
import importlib
from pathlib import Path

import numpy as np

#: the tests folder; its sub-folders are packages (``stereo``, ``motion``, ...) on the path
TESTS = Path(__file__).resolve().parents[1]
#: the module that holds a feature's builders, in each feature's test folder
MODULE = "kernel_inputs"

#: kernel name -> builder ``fn(backend, kernel, rng)``
BUILDERS = {}
TOL = {np.dtype(np.float32): 1e-5, np.dtype(np.float64): 1e-12}


def builds(name):
    """Register the decorated function as the input builder of the fused kernel ``name``; it must
    live in its feature's ``tests/<feature>/kernel_inputs.py`` and be the only one for ``name``."""
    feature = name.partition(".")[0]

    def register(fn):
        where = f"{feature}.{MODULE}"
        if fn.__module__ != where:
            raise ValueError(f"the input builder of {name!r} belongs in tests/{feature}/{MODULE}.py "
                             f"(module {where}), not in {fn.__module__}")
        other = BUILDERS.get(name)
        if other is not None and other.__qualname__ != fn.__qualname__:
            raise ValueError(f"two input builders for {name!r}: {other.__qualname__} and {fn.__qualname__}")
        BUILDERS[name] = fn
        return fn
    return register


def collect():
    """Import every feature's builders (``tests/*/kernel_inputs.py``); return the modules' names."""
    names = [f"{path.parent.name}.{MODULE}" for path in sorted(TESTS.glob(f"*/{MODULE}.py"))]
    for name in names:
        importlib.import_module(name)
    return names


def compare(got, ref, what):
    """Integer outputs bit for bit, float outputs to :data:`TOL` relative to the largest finite
    reference value (NaN where the reference has NaN)."""
    got, ref = np.asarray(got), np.asarray(ref)
    assert got.shape == ref.shape and got.dtype == ref.dtype, (what, got.shape, got.dtype, ref.shape, ref.dtype)
    if np.issubdtype(ref.dtype, np.integer):
        np.testing.assert_array_equal(got, ref, err_msg=what)
    else:
        tol = TOL[ref.dtype]
        scale = float(np.nanmax(np.abs(np.where(np.isfinite(ref), ref, 0)), initial=0.0))
        np.testing.assert_allclose(got, ref, rtol=tol, atol=tol * scale, equal_nan=True, err_msg=what)
