"""The host pool (gfgpu._core.hostpool): half-octave classes, reuse only of released blocks, the
held limit."""

import gc

import numpy as np
import pytest

from gfgpu._core.hostpool import PAGE, HostPool, size_class


@pytest.mark.parametrize("nbytes", [1, PAGE, PAGE + 1, 4_800_000, 5_720_000, 2**26, 2**26 + 1, 3 * 2**30])
def test_size_class_holds_the_request_within_a_half_octave(nbytes):
    size = size_class(nbytes)
    assert size >= nbytes and size % PAGE == 0
    assert size <= max(PAGE, 2**0.5 * nbytes) + PAGE
    assert size_class(size) == size


def test_blocks_are_page_aligned_writable_and_reused_only_once_released():
    pool = HostPool()
    a = pool.take((1000, 1200), np.float32)
    assert a.flags.c_contiguous and a.flags.writeable and a.ctypes.data % PAGE == 0
    a[...] = 7
    b = pool.take((1000, 1200), np.float32)           # a is alive: another block
    assert not np.shares_memory(a, b) and pool.stats == {"fresh": 2, "reused": 0}
    view = a[10:, ::2]
    address = a.ctypes.data
    del a                                              # a view keeps the block
    c = pool.take((1000, 1200), np.float32)
    assert not np.shares_memory(view, c) and pool.stats["fresh"] == 3
    assert (view == 7).all()
    del view
    gc.collect()
    d = pool.take((1100, 1300), np.float32)           # another shape of the class reuses it
    assert d.ctypes.data == address and pool.stats["reused"] == 1
    del b, c, d


def test_a_request_takes_a_held_block_of_its_class_or_the_next_only():
    pool = HostPool()
    big = pool.take((4096, 4096), np.float32)
    del big
    small = pool.take((3444, 3444), np.float32)        # the class below: the held block serves it
    assert pool.stats["reused"] == 1
    del small
    tiny = pool.take((1000, 1000), np.float32)          # far smaller: a fresh block, the big one stays held
    assert pool.stats["fresh"] == 2 and pool.held_bytes == size_class(4096 * 4096 * 4)
    del tiny


def test_the_held_bytes_stay_below_the_limit():
    pool = HostPool(limit=3 * size_class(2**20))
    arrays = [pool.take((2**18,), np.float32) for _ in range(6)]
    del arrays
    assert pool.held_bytes <= pool.limit
    pool.clear()
    assert pool.held_bytes == 0


def test_a_miss_frees_held_blocks_that_would_exceed_the_limit_beside_the_fresh_one():
    block = size_class(2**22)
    pool = HostPool(limit=3 * block)
    a, b = pool.take((2**20,), np.float32), pool.take((2**20,), np.float32)
    del a, b
    assert pool.held_bytes == 2 * block
    big = pool.take((2**21,), np.float32)               # 2 blocks' worth, no held block serves it: one goes
    assert pool.stats["fresh"] == 3 and pool.held_bytes == block
    del big                                              # held: the big one and the small one, trimmed to the limit
    assert pool.held_bytes <= pool.limit


def test_the_limit_comes_from_the_environment(monkeypatch):
    from gfgpu._core import hostpool
    monkeypatch.setenv("GFGPU_HOST_POOL", "64M")
    assert hostpool.new_pool().limit == 64 << 20
    monkeypatch.setenv("GFGPU_HOST_POOL", "0")
    pool = hostpool.new_pool()
    a = pool.take((2**20,), np.float32)
    del a
    assert pool.limit == 0 and pool.held_bytes == 0      # no reuse: every block freed at release
    monkeypatch.setenv("GFGPU_HOST_POOL", "lots")
    with pytest.raises(ValueError, match="GFGPU_HOST_POOL must be 0 .no reuse. or a positive byte count"):
        hostpool.new_pool()
    monkeypatch.delenv("GFGPU_HOST_POOL")
    assert hostpool.new_pool().limit == hostpool.DEFAULT_LIMIT == 256 << 20


def test_with_a_fence_blocks_are_freed_only_after_it_and_never_on_release():
    calls = []
    pool = HostPool(limit=0, fence=lambda: calls.append(len(pool._held)))
    a = pool.take((2**18,), np.float32)
    del a
    gc.collect()
    # released (a queued kernel may still write it): held, not freed, and no fence from the collector
    assert pool.held_bytes == size_class(2**20) and calls == []
    b = pool.take((2**16,), np.float32)                 # another class: the held block goes, after the fence
    assert calls == [0] and pool.held_bytes == 0
    del b
    pool.clear()
    assert calls == [0, 0] and pool.held_bytes == 0
    pool.clear()                                        # nothing held: no fence
    assert len(calls) == 2


def test_a_forked_child_starts_with_empty_pools_without_calling_the_fence():
    import os
    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    from gfgpu._core import hostpool
    pool = hostpool.new_pool(limit=2**30, fence=lambda: os._exit(3))
    a = pool.take((2**18,), np.float32)
    del a
    pid = os.fork()
    if pid == 0:
        os._exit(0 if pool.held_bytes == 0 else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


@pytest.mark.parametrize("value", ["abc", "-5", "1e9", "0M", "nan", "0.0.0"])
def test_a_bad_limit_in_the_environment_is_an_error_not_an_unavailable_backend(monkeypatch, value):
    # automatic selection used to take the error for a broken driver and fall back to numpy
    import subprocess
    import sys

    from gfgpu import backends
    monkeypatch.setenv("GFGPU_HOST_POOL", value)
    backends._automatic.cache_clear()
    for call in (lambda: backends.resolve_backend(), lambda: backends.get_backend("numpy")):
        with pytest.raises(ValueError, match=r"GFGPU_HOST_POOL must be 0 \(no reuse\) or a positive byte count"):
            call()
    backends._automatic.cache_clear()
    run = subprocess.run([sys.executable, "-m", "gfgpu", "shift", "--example", "camera", "--dx", "2", "-o",
                          "never-written.png"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 2 and "GFGPU_HOST_POOL" in run.stderr and "Traceback" not in run.stderr


@pytest.mark.parametrize("value, limit", [("0", 0), ("0.0", 0), ("64M", 64 << 20), (" 2G ", 2 << 30)])
def test_a_good_limit_in_the_environment(monkeypatch, value, limit):
    from gfgpu._core import hostpool
    monkeypatch.setenv("GFGPU_HOST_POOL", value)
    assert hostpool.default_limit() == limit
