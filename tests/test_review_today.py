"""Review of the host pool, GIF and CLI changes: faults found, each as a test that failed before.

The pool cases run in a child process: a deadlock is a timeout there, not a hung test run.
"""

import subprocess
import sys

import pytest

DEADLOCK = r"""
import gc, sys
import numpy as np
from gfgpu._core.hostpool import HostPool

pool = HostPool(limit=1 << 16, fence=(lambda: None) if sys.argv[1] == "fence" else None)
class Cycle:
    pass
warm = [pool.take((64, 64), np.float32) for _ in range(3)]
del warm
# a collection may run at any allocation inside take's locked section; if it collects a cycle
# that holds a pool array, the block's finaliser runs there
for threshold in range(1, 60):
    gc.collect(); gc.disable()
    c = Cycle(); c.self = c; c.array = pool.take((64, 65), np.float32)
    del c
    gc.set_threshold(threshold); gc.enable()
    a = pool.take((64, 64), np.float32)
    del a
    gc.disable()
gc.enable(); gc.set_threshold(700, 10, 10)
assert pool.held_bytes <= pool.limit, pool.held_bytes
print("ok")
"""


@pytest.mark.parametrize("fence", ["fence", "none"])
def test_a_block_released_by_the_collector_inside_take_does_not_deadlock(fence):
    try:
        run = subprocess.run([sys.executable, "-c", DEADLOCK, fence], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("HostPool.take deadlocked: a finaliser released a block inside its locked section")
    assert run.returncode == 0 and run.stdout.strip() == "ok", (run.returncode, run.stderr[-2000:])


def test_a_forked_child_drops_the_fence_of_its_parents_pools():
    import os

    from gfgpu._core.hostpool import new_pool

    calls = []
    pool = new_pool(limit=0, fence=lambda: calls.append(os.getpid()))
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:       # the parent's queue is not the child's: its fence must not run there
        try:
            import numpy as np
            a = pool.take((1024, 1024), np.float32)
            del a
            pool.take((2048, 1024), np.float32)
            pool.clear()
            os.write(w, b"1" if not calls else b"0")
        finally:
            os._exit(0)
    os.close(w)
    got = os.read(r, 1)
    os.waitpid(pid, 0)
    assert got == b"1"


@pytest.mark.parametrize("colour", [False, True])
def test_a_gif_holds_every_frame_even_one_equal_to_the_one_before(tmp_path, colour):
    # Pillow's save_all drops a frame equal to its predecessor (adding its duration to it): a
    # still stretch of an animation, or gfgpu frames of a flat image, read back fewer frames
    import imageio.v3 as iio
    import numpy as np
    from PIL import Image

    from gfgpu.io import save_gif

    rng = np.random.default_rng(0)
    shape = (3, 10, 12, 3) if colour else (3, 10, 12)
    a, b = (rng.integers(0, 8, shape[1:], dtype=np.uint8) * 32 for _ in range(2))
    frames = np.stack([a, a, b])
    save_gif(tmp_path / "a.gif", frames, fps=10)
    back = iio.imread(tmp_path / "a.gif", index=None)
    assert back.shape[0] == 3
    back = back[..., :3] if colour else (back if back.ndim == 3 else back[..., 0])
    np.testing.assert_array_equal(back, frames)
    assert [f.shape[0] for f in iio.imiter(tmp_path / "a.gif")] == [10, 10, 10]
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 3 and im.info["loop"] == 0 and im.info["duration"] == 100


def test_gfgpu_frames_of_a_flat_image_writes_as_many_gif_frames_as_pngs(tmp_path):
    import imageio.v3 as iio
    import numpy as np

    from gfgpu.cli import main

    iio.imwrite(tmp_path / "flat.png", np.full((20, 30), 90, np.uint8))
    assert main(["frames", str(tmp_path / "flat.png"), "-o", str(tmp_path / "out"), "--dx", "5", "-n", "4",
                 "-q", "--backend", "numpy"]) in (0, None)
    gif = iio.imread(tmp_path / "out" / "frames.gif", index=None)
    pngs = sorted((tmp_path / "out").glob("frame_*.png"))
    assert len(pngs) == 4 and gif.shape[0] == 4
    for png, frame in zip(pngs, gif):
        np.testing.assert_array_equal(frame if frame.ndim == 2 else frame[..., 0], iio.imread(png))
