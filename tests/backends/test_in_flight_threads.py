"""Host arrays wrapped for an OpenCL device stay alive until their own thread's commands are done.

A CPU device reads numpy arrays in place (``host_view``, ``host_result``); the backend keeps each
wrapped array until a blocking command shows that the in-order queue has run past it.  Such a
command shows it only for the commands its own thread has enqueued: another thread may have
wrapped an array and not yet enqueued the kernel that reads it.  The backend used to keep one
list for all threads, and any thread's blocking read cleared it.
"""

import gc
import threading
import weakref

import numpy as np
import pytest

import gfgpu


def _opencl_cpu(require_backend):
    be = require_backend("opencl")
    if be.kind != "cpu":
        pytest.skip("only a CPU device reads host arrays in place")
    return be


def test_a_read_in_another_thread_keeps_this_threads_host_arrays(require_backend):
    be = _opencl_cpu(require_backend)
    wrapped, release, refs = threading.Event(), threading.Event(), []

    def wrapper():
        host = np.ones((512, 512), np.float32)      # large enough to be read in place
        refs.append(weakref.ref(host))
        be.host_view(host)                          # the device array and the host array dropped:
        del host                                    # only the in-flight list holds the memory
        wrapped.set()
        release.wait(60)
        be.to_host(be.asarray(np.zeros(4, np.float32)))   # a blocking read of its own

    thread = threading.Thread(target=wrapper)
    thread.start()
    try:
        assert wrapped.wait(60)
        be.to_host(be.asarray(np.zeros(4, np.float32)))   # this thread's blocking read
        gc.collect()
        assert refs[0]() is not None, "another thread's blocking read released a wrapped host array"
    finally:
        release.set()
        thread.join(60)
    gc.collect()
    assert refs[0]() is None, "the thread's own blocking read kept its wrapped host array"


def test_a_finish_releases_the_host_arrays_of_ended_threads(require_backend):
    be = _opencl_cpu(require_backend)
    refs = []

    def wrapper():
        host = np.ones((512, 512), np.float32)
        refs.append(weakref.ref(host))
        be.host_view(host)

    thread = threading.Thread(target=wrapper)
    thread.start()
    thread.join(60)
    gc.collect()
    assert refs[0]() is not None
    be.synchronize()
    gc.collect()
    assert refs[0]() is None, "synchronize kept the wrapped host array of a thread that has ended"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_two_threads_shift_at_once(require_backend, dtype):
    """Two threads call gfgpu.shift on one OpenCL backend at once; each result is the numpy one."""
    be = require_backend("opencl")
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("the device has no float64")
    rng = np.random.default_rng(3)
    images = [rng.standard_normal((300 + 17 * k, 260 + 11 * k)).astype(dtype) for k in range(6)]
    shifts = [(0.5 + 0.25 * k, -2.5 + 0.75 * k) for k in range(6)]
    refs = [gfgpu.shift(im, s, mode="mirror", backend="numpy") for im, s in zip(images, shifts)]
    failures, start = [], threading.Barrier(2)

    def worker(order):
        start.wait(60)
        for _ in range(4):
            for k in order:
                out = gfgpu.shift(images[k], shifts[k], mode="mirror", backend=be)
                err = np.max(np.abs(out - refs[k]))
                if not err <= (2e-5 if dtype == np.float32 else 1e-12):
                    failures.append((k, err))

    threads = [threading.Thread(target=worker, args=(order,)) for order in (range(6), range(5, -1, -1))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(600)
    assert not any(t.is_alive() for t in threads)
    assert not failures, failures
