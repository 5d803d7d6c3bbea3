"""pytest configuration for the repository: ``tests/`` and the docstring examples in ``gfgpu/``.

At the repository root, this file makes pytest put the root first on ``sys.path``, so ``pytest``
tests this checkout's ``gfgpu`` even where a copy is installed as well.  The device modules in
``gfgpu/backends/warp/`` and ``gfgpu/backends/opencl/`` are collected for their docstring
examples only where that backend loads (Warp's kernel modules import ``warp`` when imported);
whether an unavailable backend skips or fails the tests is decided in ``tests/conftest.py``
(``GFGPU_TEST_BACKENDS``).
"""

from gfgpu.backends import get_backend


def _loads(name):
    try:
        get_backend(name)
    except Exception:  # an absent library or a broken driver: the tests say which
        return False
    return True


collect_ignore_glob = [f"gfgpu/backends/{name}/*.py" for name in ("warp", "opencl") if not _loads(name)]
