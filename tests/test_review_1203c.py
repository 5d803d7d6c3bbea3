"""Review of d71635a/eaaa03c/2d3c7ca (the OpenCL probe's child), 423e5c2 (a missing CLI input
before the backend line), 3fa88f0 (gfgpu._core.lru.LRU and its users) and f74ad48 (two-sided
column steps declined where their scratch exceeds the inputs and outputs).

The probe is driven through fake ``subprocess.Popen`` children and a temporary XDG_CACHE_HOME
(never the real ~/.cache); the CLI through :func:`gfgpu.cli.main` on files under tmp_path; the LRU
directly and through shift/green_filter/motion_blur against a call with every cache cleared; the
two-sided steps against the float64 numpy backend with ``be.empty`` spied on.
"""

import os
import subprocess
import threading
import time

import numpy as np
import pytest
from oracle import max_relerr

import gfgpu
from gfgpu import greens
from gfgpu._core.lru import LRU
from gfgpu.cli import main

# ---------------------------------------------------------------------------------------------
# d71635a + eaaa03c + 2d3c7ca: the probe's child
# ---------------------------------------------------------------------------------------------




class _Child:
    """A fake probe child: ``script`` is a list of what each communicate() does in turn, either
    ("timeout", partial) (raises TimeoutExpired whose output is ``partial``, bytes as CPython
    gives it even in text mode) or (out, err, returncode)."""

    made = []

    def __init__(self, script):
        self.script, self.returncode, self.killed, self.timeouts = list(script), None, False, []
        _Child.made.append(self)

    def communicate(self, timeout=None):
        self.timeouts.append(timeout)
        step = self.script.pop(0) if len(self.script) > 1 else self.script[0]
        if step[0] == "timeout" and not self.killed:
            raise subprocess.TimeoutExpired("child", timeout, output=step[1])
        if step[0] == "timeout":        # killed: what it had printed
            return (step[1].decode() if isinstance(step[1], bytes) else step[1]), ""
        out, err, code = step
        self.returncode = code
        return out, err

    def kill(self):
        self.killed = True
        self.returncode = -9


@pytest.fixture
def probe_env(opencl_cpu_device, tmp_path, monkeypatch):
    from gfgpu.backends.opencl import probe
    dev = opencl_cpu_device
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    _Child.made = []

    def use(*script):
        monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: _Child(script))

    use.monkeypatch = monkeypatch
    return probe, dev, use, tmp_path / "cache" / "gfgpu" / "opencl-probe"


def _kept(folder):
    return [p.read_text() for p in folder.iterdir()] if folder.exists() else []


def test_probe_a_child_killed_by_a_signal_after_compiling_names_its_exit_status(probe_env):
    """A compiler that crashes without a word (SIGSEGV: Python prints nothing, status -11) after
    "compiling": the verdict must say how the child ended, not echo the child's own progress
    line "compiling" (which build_failure would show as "cannot compile kernels (16-wide
    vectors: compiling)")."""
    probe, dev, use, kept = probe_env
    use(("compiling\n", "", -11))
    verdict = probe.wide_vector_failure(dev)
    assert verdict is not None
    assert verdict != "compiling" and "-11" in verdict, verdict
    assert _kept(kept) == [verdict]


def test_probe_a_child_exiting_nonzero_after_compiling_with_no_stderr(probe_env):
    probe, dev, use, kept = probe_env
    use(("compiling\n", "", 1))
    verdict = probe.wide_vector_failure(dev)
    assert verdict and "exit status 1" in verdict, verdict


def test_probe_partial_output_as_bytes_then_str_after_the_wait(probe_env, capsys):
    """CPython's TimeoutExpired carries bytes even for a text-mode child; the probe must wait on
    and read the str of the second communicate(): a working device, a kept empty verdict."""
    probe, dev, use, kept = probe_env
    use(("timeout", b"compiling\n"), ("compiling\nok\n", "", 0))
    assert probe.wide_vector_failure(dev, timeout=30) is None
    assert _kept(kept) == [""]
    err = capsys.readouterr().err.splitlines()
    assert len([line for line in err if "testing the OpenCL device" in line]) == 1, err
    (child,) = _Child.made
    assert child.timeouts[0] <= 3 and sum(t for t in child.timeouts[:2]) <= 30


def test_probe_hung_child_with_bytes_partial_is_a_kept_timeout(probe_env):
    probe, dev, use, kept = probe_env
    use(("timeout", b"compiling\n"))
    verdict = probe.wide_vector_failure(dev, timeout=5)
    assert verdict == "a 16-wide vector kernel did not finish within 5 s"
    assert _kept(kept) == [verdict]
    assert _Child.made[0].killed


def test_probe_ok_then_stderr_noise_is_a_working_device(probe_env):
    """stderr (PoCL warnings, an 'error' word among them) does not turn a child that printed ok
    and exited 0 into a failure: the lines of err come before out's."""
    probe, dev, use, kept = probe_env
    use(("compiling\nok\n", "pocl warning: error reading the kernel cache, rebuilt", 0))
    assert probe.wide_vector_failure(dev) is None
    assert _kept(kept) == [""]


def test_probe_ok_not_the_last_stdout_line_with_status_zero(probe_env):
    """The child printed "ok" (the kernel's result was checked) and exited 0; a line after it on
    stdout (an interpreter's exit hook) must not keep a failure that refuses the device for good."""
    probe, dev, use, kept = probe_env
    use(("compiling\nok\nexit hook: bye\n", "", 0))
    assert probe.wide_vector_failure(dev) is None
    assert _kept(kept) == [""]


def test_probe_ok_with_nonzero_status_is_not_an_ok_verdict(probe_env):
    """The child printed ok, then ended with SIGABRT (a runtime crashing at exit): whatever the
    probe decides, a kept failure whose reason is "ok" (build_failure: "cannot compile kernels
    (16-wide vectors: ok)") says nothing; it must name how the child ended."""
    probe, dev, use, kept = probe_env
    use(("compiling\nok\n", "", -6))
    verdict = probe.wide_vector_failure(dev)
    assert verdict is None or (verdict != "ok" and "-6" in verdict), verdict


def test_probe_stderr_without_a_final_newline_is_not_glued_to_stdout(probe_env):
    """err + out are joined before splitting lines: an abort message without its newline ran
    into the child's "compiling" line ("LLVM ERROR: xcompiling")."""
    probe, dev, use, kept = probe_env
    use(("compiling\n", "LLVM ERROR: Do not know how to scalarize", -6))
    assert probe.wide_vector_failure(dev) == "LLVM ERROR: Do not know how to scalarize"


def test_probe_a_child_failing_before_the_compiler_keeps_nothing(probe_env):
    probe, dev, use, kept = probe_env
    use(("", "Traceback ...\nAssertionError: device order changed\n", 1))
    assert probe.wide_vector_failure(dev) is None
    assert _kept(kept) == []
    # and the word inside another (not the progress line) is no verdict either
    use(("recompiling the world\n", "Error\n", 1))
    assert probe.wide_vector_failure(dev) is None
    assert _kept(kept) == []


def test_probe_whitespace_verdict_is_a_working_device_and_no_child(probe_env, monkeypatch):
    probe, dev, use, kept = probe_env
    path = probe._verdict_path(dev)
    os.makedirs(os.path.dirname(path))
    with open(path, "w") as f:
        f.write("  \n\t \n")

    def no_child(*a, **k):
        raise AssertionError("probed again although a verdict is kept")

    monkeypatch.setattr(subprocess, "Popen", no_child)
    assert probe.wide_vector_failure(dev) is None
    with open(path, "w") as f:
        f.write("  LLVM ERROR: x \n")
    assert probe.wide_vector_failure(dev) == "LLVM ERROR: x"


@pytest.mark.parametrize("timeout", [0, 1, 2.5])
def test_probe_timeout_below_three_seconds_waits_no_longer_than_it(probe_env, timeout, capsys):
    probe, dev, use, kept = probe_env
    use(("timeout", b"compiling\n"))
    verdict = probe.wide_vector_failure(dev, timeout=timeout)
    assert verdict == f"a 16-wide vector kernel did not finish within {timeout} s"
    (child,) = _Child.made
    waited = [t for t in child.timeouts if t is not None]
    assert sum(waited) <= timeout, child.timeouts
    assert all(t >= 0 for t in waited)
    err = capsys.readouterr().err.splitlines()
    assert len([line for line in err if "testing the OpenCL device" in line]) <= 1, err


def test_probe_two_threads_on_one_device_run_one_child_and_print_once(probe_env, capsys):
    """Two threads of one process reaching the probe of one device at once (two first calls on
    a fresh machine): the child is the expensive part (up to 90 s on a broken PoCL), so it runs
    once, and the waiting line is printed once."""
    probe, dev, use, kept = probe_env
    started = threading.Barrier(2)
    script = (("timeout", b"compiling\n"), ("compiling\nok\n", "", 0))

    class Slow(_Child):
        def communicate(self, timeout=None):
            time.sleep(0.2)     # both threads inside the wait at once
            return super().communicate(timeout)

    answers, errors = [], []

    def work():
        try:
            started.wait()
            answers.append(probe.wide_vector_failure(dev, timeout=30))
        except Exception as exc:    # reported below
            errors.append(exc)

    use.monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: Slow(script))
    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    assert answers == [None, None]
    assert _kept(kept) == [""]
    err = capsys.readouterr().err.splitlines()
    assert len(_Child.made) == 1, f"{len(_Child.made)} probe children for one device"
    assert len([line for line in err if "testing the OpenCL device" in line]) == 1, err


# ---------------------------------------------------------------------------------------------
# 423e5c2: the CLI refuses an input it cannot read before the backend line
# ---------------------------------------------------------------------------------------------
IMAGE_COMMANDS = [["blur", "--dx", "3"], ["shift", "--dx", "1"], ["gradient"], ["canny"], ["frames", "--dx", "3"],
                  ["depth"]]


def _run(capsys, argv):
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _refused(code, out, err, *names):
    assert code == 2, (code, out, err)
    assert " backend " not in out, out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for name in names:
        assert name in lines[0], (name, lines[0])


def _out_path(cmd, tmp_path):
    return str(tmp_path / ("frames" if cmd == "frames" else "out.png"))


@pytest.fixture
def cli_dir(tmp_path, monkeypatch):
    d = tmp_path / "work"
    d.mkdir()
    monkeypatch.chdir(d)
    return d


def _listing(d):
    return sorted(str(p.relative_to(d)) for p in d.rglob("*"))


@pytest.mark.parametrize("argv", IMAGE_COMMANDS, ids=lambda a: a[0])
def test_cli_a_directory_as_image_is_refused_before_the_backend_line(cli_dir, capsys, argv):
    (cli_dir / "adir").mkdir()
    before = _listing(cli_dir)
    code, out, err = _run(capsys, [argv[0], "adir", *argv[1:], "-o", _out_path(argv[0], cli_dir),
                                   "--backend", "numpy"])
    _refused(code, out, err, "adir")
    assert _listing(cli_dir) == before


@pytest.mark.parametrize("argv", IMAGE_COMMANDS, ids=lambda a: a[0])
def test_cli_a_broken_symlink_is_named(cli_dir, capsys, argv):
    os.symlink("nowhere.png", cli_dir / "broken.png")
    before = _listing(cli_dir)
    code, out, err = _run(capsys, [argv[0], "broken.png", *argv[1:], "-o", _out_path(argv[0], cli_dir),
                                   "--backend", "numpy"])
    _refused(code, out, err, "IMAGE", "broken.png")
    assert _listing(cli_dir) == before


@pytest.mark.parametrize("name", ["with space.png", "b\u00e9b\u00e9 \u65e5\u672c.png", "sub/../nosuch.png"])
@pytest.mark.parametrize("argv", IMAGE_COMMANDS, ids=lambda a: a[0])
def test_cli_missing_paths_with_spaces_unicode_relative(cli_dir, capsys, argv, name):
    (cli_dir / "sub").mkdir()
    before = _listing(cli_dir)
    code, out, err = _run(capsys, [argv[0], name, *argv[1:], "-o", _out_path(argv[0], cli_dir), "--backend", "numpy"])
    _refused(code, out, err, "IMAGE", name)
    assert err.strip().endswith(f"IMAGE {name}: no such file"), err
    assert _listing(cli_dir) == before


@pytest.mark.parametrize("argv", [a for a in IMAGE_COMMANDS if a[0] != "depth"], ids=lambda a: a[0])
def test_cli_example_with_a_missing_file(cli_dir, capsys, argv):
    code, out, err = _run(capsys, [argv[0], "nosuch.png", "--example", "camera", *argv[1:], "-o",
                                   _out_path(argv[0], cli_dir), "--backend", "numpy"])
    _refused(code, out, err, "nosuch.png", "--example")
    assert _listing(cli_dir) == []


@pytest.mark.parametrize("argv", [a for a in IMAGE_COMMANDS if a[0] != "frames"], ids=lambda a: a[0])
def test_cli_missing_input_equal_to_output(cli_dir, capsys, argv):
    code, out, err = _run(capsys, [argv[0], "same.png", *argv[1:], "-o", "same.png", "--backend", "numpy"])
    _refused(code, out, err, "same.png")
    assert _listing(cli_dir) == []


@pytest.mark.parametrize("which", ["left", "right"])
@pytest.mark.parametrize("kind", ["missing", "directory", "broken"])
def test_cli_disparity_left_right(cli_dir, capsys, which, kind):
    from gfgpu import io
    io.write_image(str(cli_dir / "img.png"), (np.arange(600) % 251).astype(np.uint8).reshape(20, 30))
    bad = "bad thing.png"
    if kind == "directory":
        (cli_dir / bad).mkdir()
    elif kind == "broken":
        os.symlink("nowhere.png", cli_dir / bad)
    before = _listing(cli_dir)
    pair = [bad, "img.png"] if which == "left" else ["img.png", bad]
    code, out, err = _run(capsys, ["disparity", *pair, "-o", "o.png", "--backend", "numpy"])
    _refused(code, out, err, bad)
    if kind != "directory":
        assert which.upper() in err, err
    assert _listing(cli_dir) == before


def test_cli_batch_a_missing_literal_input_fails_as_its_own_file(cli_dir, capsys):
    """``gfgpu batch shift nosuch.png`` (a typo, no wildcard): batch's documented rule (its
    epilog) is that a file that fails is reported with its reason and the others go on, exit 1;
    a pattern that matches nothing and an empty directory are usage errors (below).  Nothing is
    written for the missing file."""
    code, out, err = _run(capsys, ["batch", "shift", "nosuch.png", "--dx", "1", "-o", "outd", "--backend", "numpy"])
    assert code == 1, (out, err)
    failed = [line for line in out.splitlines() if line.strip().startswith("failed:")]
    assert len(failed) == 1 and "nosuch.png" in failed[0] and "FileNotFoundError" in failed[0], out
    assert not (cli_dir / "outd").exists() or not any((cli_dir / "outd").iterdir())


def test_cli_batch_unreadable_pattern_and_directory_are_usage_errors(cli_dir, capsys):
    (cli_dir / "adir").mkdir()
    for item in ("adir", "nomatch*.png"):
        code, out, err = _run(capsys, ["batch", "shift", item, "--dx", "1", "-o", "outd", "--backend", "numpy"])
        _refused(code, out, err, item)
    assert _listing(cli_dir) == ["adir"]


# ---------------------------------------------------------------------------------------------
# 3fa88f0: the LRU
# ---------------------------------------------------------------------------------------------
class _Maker:
    def __init__(self):
        self.calls = []

    def __call__(self, key, value=None):
        def make():
            self.calls.append(key)
            return key * 10 if value is None else value
        return make


def test_lru_eviction_order_follows_use():
    lru, mk = LRU(3), _Maker()
    for k in (1, 2, 3):
        assert lru.get(k, mk(k)) == 10 * k
    assert lru.get(1, mk(1)) == 10          # 1 is now the most recent
    assert lru.get(4, mk(4)) == 40          # drops 2
    assert len(lru) == 3
    assert mk.calls == [1, 2, 3, 4]
    for k in (1, 3, 4):
        lru.get(k, mk(k))
    assert mk.calls == [1, 2, 3, 4]
    lru.get(2, mk(2))
    assert mk.calls == [1, 2, 3, 4, 2]      # 2 was gone; now 1 (least recent) is
    lru.get(3, mk(3))
    lru.get(4, mk(4))
    lru.get(2, mk(2))
    assert mk.calls == [1, 2, 3, 4, 2]
    lru.get(1, mk(1))
    assert mk.calls == [1, 2, 3, 4, 2, 1]


@pytest.mark.parametrize("most", [0, 1])
def test_lru_tiny_bounds(most):
    lru, mk = LRU(most), _Maker()
    assert lru.get("a", mk("a")) == "a" * 10
    assert len(lru) == most
    assert lru.get("a", mk("a")) == "a" * 10
    assert mk.calls == (["a", "a"] if most == 0 else ["a"])
    lru.get("b", mk("b"))
    assert len(lru) == most
    lru.get("a", mk("a"))
    assert mk.calls[-1] == "a"


def test_lru_negative_bound_is_refused_at_construction():
    """LRU(-1) was accepted and every get() then raised KeyError from popitem of an empty table."""
    with pytest.raises(ValueError, match="most"):
        lru = LRU(-1)
        lru.get("a", lambda: 1)


def test_lru_a_failing_make_stores_nothing():
    lru, mk = LRU(2), _Maker()
    lru.get(1, mk(1))
    lru.get(2, mk(2))

    def boom():
        raise RuntimeError("no")

    with pytest.raises(RuntimeError):
        lru.get(3, boom)
    assert len(lru) == 2
    lru.get(1, mk(1))
    lru.get(2, mk(2))
    assert mk.calls == [1, 2]
    assert lru.get(3, mk(3)) == 30


@pytest.mark.parametrize("value", [0, 0.0, False, "", (), np.zeros(0), np.float32(0)], ids=repr)
def test_lru_falsy_values_are_kept(value):
    lru, mk = LRU(4), _Maker()
    for _ in range(3):
        got = lru.get("k", mk("k", value))
        assert got is value
    assert mk.calls == ["k"]


def test_lru_a_none_value_is_kept_too():
    """get() tests ``hit is not None``: a ``make()`` that returns None is made again at every call
    (and re-inserted, evicting the least recent entry each time)."""
    lru, calls = LRU(2), []
    lru.get("other", lambda: 1)

    def make():
        calls.append(1)
        return None

    for _ in range(3):
        assert lru.get("none", make) is None
    assert len(calls) == 1, f"make() ran {len(calls)} times for one key"


def test_lru_concurrent_get_of_one_key():
    lru, made = LRU(4), []
    gate = threading.Barrier(8)

    def make():
        made.append(1)
        time.sleep(0.05)
        return np.arange(5)

    out = [None] * 8

    def work(i):
        gate.wait()
        out[i] = lru.get("k", make)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(o is not None and np.array_equal(o, np.arange(5)) for o in out)
    assert len(lru) == 1
    assert 1 <= len(made) <= 8
    after = lru.get("k", lambda: pytest.fail("made again after every thread stored it"))
    assert np.array_equal(after, np.arange(5))


def test_lru_many_threads_many_keys_stay_bounded_and_correct():
    lru = LRU(16)
    bad = []

    def work(seed):
        rng = np.random.default_rng(seed)
        for k in rng.integers(0, 40, 2000):
            k = int(k)
            v = lru.get(k, lambda k=k: (k, k * k))
            if v != (k, k * k):
                bad.append((k, v))

    threads = [threading.Thread(target=work, args=(s,)) for s in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not bad, bad[:3]
    assert len(lru) <= 16


def _forget_plans():
    from tests.backends.test_first_call import _forget_plans as forget
    forget()
    from gfgpu.motion.polar_kernels import _opencl as polar
    polar._KEPT.clear()
    polar._SMALL.clear()


def _host(be, a):
    return be.to_host(a) if not isinstance(a, np.ndarray) else a


def test_green_filter_past_the_window_bound_then_back_is_bit_identical(backend):
    """mirror mode keys each line length's window by its corner weight: > 1024 lengths evict the
    first; back at the first length the window is made again and the result keeps its bits."""
    from gfgpu._core import recursion
    dtype = np.float64 if backend.supports_float64 else np.float32
    kernel = greens.UniformGreen(10.0)        # |lam| 0.905: lines from 400 lie beyond its reach in float64
    x = np.random.default_rng(3).standard_normal((2, 1600)).astype(dtype)
    n0 = 400

    def run(n):
        return _host(backend, gfgpu.green_filter(x[:, :n], kernel, axis=1, mode="mirror", backend=backend))

    first = run(n0)
    for n in range(n0 + 1, n0 + 1 + 1100):
        run(n)
    assert len(recursion._windows) == 1024      # full: more distinct windows were made than it keeps
    again = run(n0)
    _forget_plans()
    fresh = run(n0)
    np.testing.assert_array_equal(again, first)
    np.testing.assert_array_equal(fresh, first)
    want = gfgpu.green_filter(x[:, :n0].astype(np.float64), kernel, axis=1, mode="mirror", backend="numpy")
    scale = max(1.0, float(np.abs(want).max()))
    assert np.abs(first - want).max() / scale < (1e-10 if dtype == np.float64 else 2e-5)


def test_shift_after_flooding_the_plan_tables_is_bit_identical(backend):
    """Every entry of the windows/weights tables evicted by unrelated keys: shift and
    green_filter at a seen size give the bits of the first call."""
    from gfgpu._core import recursion
    x = np.random.default_rng(4).random((37, 45)).astype(np.float32)
    k = greens.UniformGreen(3.0)
    calls = [lambda m=m: gfgpu.shift(x, (0.3, -1.7), mode=m, backend=backend) for m in ("reflect", "mirror", "nearest")]
    calls += [lambda: gfgpu.green_filter(x, k, axis=0, mode="mirror", backend=backend)]
    first = [_host(backend, c()) for c in calls]
    for table in (recursion._weights, recursion._windows):
        for i in range(1100):
            table.get(("flood", i), lambda i=i: ("junk", i))
        assert len(table) <= 1024
    for f, c in zip(first, calls):
        np.testing.assert_array_equal(_host(backend, c()), f)
    _forget_plans()
    for f, c in zip(first, calls):
        np.testing.assert_array_equal(_host(backend, c()), f)


def test_rotation_blur_past_the_kept_device_arrays_then_back(cpu_opencl):
    """The polar launcher keeps 6 (context, key) device arrays: 9 centres evict the first;
    back at it, the result has the first call's bits and equals a call with every cache cleared."""
    be = cpu_opencl
    img = np.random.default_rng(5).random((48, 56)).astype(np.float32)
    centres = [(20.0 + i, 25.0 - 0.5 * i) for i in range(9)]
    first = _host(be, gfgpu.motion_blur(img, 0.3, kind="rotation", center=centres[0], backend=be))
    for c in centres[1:]:
        gfgpu.motion_blur(img, 0.3, kind="rotation", center=c, backend=be)
    from gfgpu.motion.polar_kernels import _opencl as polar
    assert len(polar._KEPT) <= 6 and len(polar._SMALL) <= 64
    again = _host(be, gfgpu.motion_blur(img, 0.3, kind="rotation", center=centres[0], backend=be))
    _forget_plans()
    fresh = _host(be, gfgpu.motion_blur(img, 0.3, kind="rotation", center=centres[0], backend=be))
    np.testing.assert_array_equal(again, first)
    np.testing.assert_array_equal(fresh, first)
    want = gfgpu.motion_blur(img.astype(np.float64), 0.3, kind="rotation", center=centres[0], backend="numpy")
    assert np.abs(first - want).max() / max(1.0, float(np.abs(want).max())) < 2e-4


# ---------------------------------------------------------------------------------------------
# f74ad48: two-sided column steps declined where their scratch exceeds inputs + outputs
# ---------------------------------------------------------------------------------------------
WIDTHS = [1, 15, 16, 21, 22, 31, 32, 33, 42, 43, 63, 64, 65]
TOL = {np.float32: 2e-5, np.float64: 1e-11}


def _close(got, want, dtype, what=""):
    err = max_relerr(got, want)
    assert err < TOL[dtype], f"{what}: relative error {err:.3g}"


@pytest.fixture
def empty_spy(cpu_opencl, monkeypatch):
    be = cpu_opencl
    sizes = []
    empty = be.empty

    def spy(shape, dtype, *args, **kwargs):
        sizes.append(int(np.prod(shape)) * np.dtype(dtype).itemsize)
        return empty(shape, dtype, *args, **kwargs)

    monkeypatch.setattr(be, "empty", spy)
    return be, sizes


def _all_three(be, x, want_x, **kw):
    axis_kw = {k: v for k, v in kw.items() if k != "axes"}
    out = []
    for fn in (gfgpu.derivative, gfgpu.projection):
        for axis in range(x.ndim - (1 if kw.get("channel_axis") is not None else 0)):
            got = fn(x, 1.7, axis=axis, backend=be, **axis_kw)
            want = fn(want_x, 1.7, axis=axis, backend="numpy", **axis_kw)
            out.append((f"{fn.__name__} axis={axis}", got, want))
    for i, (g, w) in enumerate(zip(gfgpu.gradient(x, 1.7, backend=be, **kw),
                                   gfgpu.gradient(want_x, 1.7, backend="numpy", **kw))):
        out.append((f"gradient[{i}]", g, w))
    return out


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("m", WIDTHS)
def test_twosided_widths_at_the_scratch_boundary(empty_spy, dtype, m):
    be, sizes = empty_spy
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("no float64")
    for n in (1, 37, 1500):
        x = np.random.default_rng(n * 100 + m).standard_normal((n, m)).astype(dtype)
        sizes.clear()
        for mode in ("reflect", "constant"):
            for what, g, w in _all_three(be, x, x.astype(np.float64), mode=mode, cval=0.4):
                _close(g, w, dtype, f"({n}, {m}) {dtype.__name__} {mode} {what}")
        assert max(sizes) <= 4 * x.nbytes, f"({n}, {m}): a temporary of {max(sizes) / x.nbytes:.1f}x the image"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(3, 200, 21), (3, 200, 43), (5, 300, 1), (2, 1, 64), (4, 2000, 2)], ids=str)
def test_twosided_stacks(empty_spy, dtype, shape):
    be, sizes = empty_spy
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("no float64")
    x = np.random.default_rng(sum(shape)).standard_normal(shape).astype(dtype)
    for what, g, w in _all_three(be, x, x.astype(np.float64), mode="nearest"):
        _close(g, w, dtype, f"{shape} {what}")
    assert max(sizes) <= 4 * x.nbytes, f"{shape}: a temporary of {max(sizes) / x.nbytes:.1f}x the image"


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(900, 7, 3), (900, 11, 4), (300, 22, 2), (64, 43, 3)], ids=str)
def test_twosided_channel_axis(empty_spy, dtype, shape):
    be, sizes = empty_spy
    if dtype == np.float64 and not be.supports_float64:
        pytest.skip("no float64")
    x = np.random.default_rng(sum(shape) + 1).standard_normal(shape).astype(dtype)
    for what, g, w in _all_three(be, x, x.astype(np.float64), mode="wrap", channel_axis=-1):
        _close(g, w, dtype, f"{shape} {what}")
    assert max(sizes) <= 4 * x.nbytes, f"{shape}: a temporary of {max(sizes) / x.nbytes:.1f}x the image"


def test_twosided_takes_agrees_with_the_scratch_run_two_sided_allocates(empty_spy, monkeypatch):
    """Where takes() says yes, the scratch that run_two_sided then allocates is within inputs +
    outputs (the decision and the allocation use one layout)."""
    from gfgpu.backends.opencl import twosided
    be, sizes = empty_spy
    seen = []
    run = twosided.run_two_sided

    def spy(be_, srcs, dsts, axis, plan, *a, **k):
        before = len(sizes)
        res = run(be_, srcs, dsts, axis, plan, *a, **k)
        image = srcs[0].nbytes
        scratch = max(sizes[before:], default=0)
        seen.append((srcs[0].shape, axis, len(srcs), len(dsts), scratch / image))
        return res

    monkeypatch.setattr(twosided, "run_two_sided", spy)
    import gfgpu.filters as filters
    monkeypatch.setattr(filters, "_two_sided_runner", lambda b: spy if twosided.runs_on(b) else None)
    for shape in [(500, 21), (500, 22), (500, 32), (500, 43), (500, 64), (3, 40, 43), (64, 5000)]:
        for dtype in (np.float32, np.float64):
            x = np.random.default_rng(1).standard_normal(shape).astype(dtype)
            gfgpu.gradient(x, 2.0, backend=be)
            for axis in range(x.ndim):
                gfgpu.derivative(x, 2.0, axis=axis, backend=be)
    assert seen, "no two-sided step ran"
    for shape, axis, nin, nout, ratio in seen:
        assert ratio <= nin + nout, (shape, axis, nin, nout, ratio)
