"""``gfgpu batch`` (gfgpu.batch, gfgpu.cli.batch): outputs, resume, atomicity, bad files, Dask."""

import hashlib
import os
import re

import imageio.v3 as iio
import numpy as np
import pytest

import gfgpu
from gfgpu import batch
from gfgpu.cli import main
from gfgpu.io import gradient_to_rgb as _gradient_png
from gfgpu.io import to_display_8bit


def run_cli(*argv):
    """``gfgpu batch ...`` as the command runs it; the exit code."""
    return main(["batch", *map(str, argv), "--quiet"])


def fails_with(capsys, message, *argv):
    """The command exits with status 2 and the one-line message ``gfgpu batch OP: ...``."""
    assert run_cli(*argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gfgpu batch ") and "\n" not in err and re.search(message, err), err


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def tree_digest(folder):
    return {name: sha256(os.path.join(folder, name)) for name in sorted(os.listdir(folder))
            if os.path.isfile(os.path.join(folder, name))}


@pytest.fixture
def images(tmp_path, rng):
    """A folder with two colour PNGs and one grey PNG (small: 24 x 32)."""
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("c1", "c2"):
        iio.imwrite(folder / f"{name}.png", (rng.random((24, 32, 3)) * 255).astype(np.uint8))
    iio.imwrite(folder / "g.png", (rng.random((24, 32)) * 255).astype(np.uint8))
    return folder


def leftovers(folder):
    """Temporary files of write_atomic left in ``folder`` (there must be none)."""
    return [n for n in os.listdir(folder) if n.startswith(".gfgpu-")]


# --------------------------------------------------------------------------------------
# outputs equal the direct API call
# --------------------------------------------------------------------------------------
def test_shift_npy_equals_api(images, tmp_path, backend):
    out = tmp_path / "out"
    assert run_cli("shift", images, "-o", out, "--dx", 2.5, "--dy", -1.25, "--format", "npy",
                   "--backend", backend.name) == 0
    for name in ("c1", "c2", "g"):
        img = iio.imread(images / f"{name}.png").astype(np.float32)
        ref = gfgpu.shift(img, (-1.25, 2.5), axes=(0, 1), backend=backend.name)
        got = np.load(out / f"{name}.npy")
        assert got.dtype == np.float32 and got.shape == img.shape
        np.testing.assert_array_equal(got, ref)


def test_png_and_tiff_outputs(images, tmp_path):
    for fmt in ("png", "tiff", "npy"):
        assert run_cli("shift", images / "c1.png", "-o", tmp_path / fmt, "--dx", 1, "--dy", 3, "--format", fmt,
                       "--backend", "numpy", "--mode", "nearest") == 0
    img = iio.imread(images / "c1.png")
    raw = gfgpu.shift(img.astype(np.float32), (3, 1), mode="nearest", axes=(0, 1), backend="numpy")
    np.testing.assert_array_equal(np.load(tmp_path / "npy" / "c1.npy"), raw)
    np.testing.assert_array_equal(iio.imread(tmp_path / "tiff" / "c1.tiff"), raw)
    np.testing.assert_array_equal(iio.imread(tmp_path / "png" / "c1.png"), to_display_8bit(raw, img))


def test_gradient_outputs_equal_api(images, tmp_path):
    assert run_cli("gradient", images, "-o", tmp_path / "npy", "-u", 1.5, "--format", "npy",
                   "--backend", "numpy") == 0
    assert run_cli("gradient", images / "c2.png", "-o", tmp_path / "png", "-u", 1.5, "--backend", "numpy") == 0
    img = iio.imread(images / "c2.png").astype(np.float32).mean(axis=-1)
    gy, gx = gfgpu.gradient(img, 1.5, backend="numpy")
    np.testing.assert_array_equal(np.load(tmp_path / "npy" / "c2.npy"), np.stack([gy, gx]))
    np.testing.assert_array_equal(iio.imread(tmp_path / "png" / "c2.png"), _gradient_png(gy, gx))
    grey = iio.imread(images / "g.png").astype(np.float32)
    np.testing.assert_array_equal(np.load(tmp_path / "npy" / "g.npy"), np.stack(gfgpu.gradient(grey, 1.5,
                                                                                                backend="numpy")))


def test_canny_outputs_equal_api(images, tmp_path):
    assert run_cli("canny", images / "g.png", "-o", tmp_path, "-u", 1, "--low", 0.7, "--high", 0.9,
                   "--format", "npy", "--backend", "numpy") == 0
    grey = iio.imread(images / "g.png")
    ref = gfgpu.canny(grey, 1.0, 0.7, 0.9, use_quantiles=True, backend="numpy")
    got = np.load(tmp_path / "g.npy")
    assert got.dtype == bool and got.any()
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("how, expect", [
    (("--dx", 6, "--dy", -2), dict(velocity=(-2, 6))),                       # (vy, vx)
    (("--dx", 4, "--keep-position"), dict(velocity=(0, 4), displace=False)),
    (("--dy", 5), dict(velocity=(5, 0))),
    (("--zoom", 0.3, "--center-x", 10, "--center-y", 12), dict(velocity=0.3, kind="zoom", center=(12, 10))),
    (("--zoom", 0.3, "--center-x", 10), dict(velocity=0.3, kind="zoom", center=(11.5, 10))),   # row: middle
])
def test_blur_outputs_equal_api(images, tmp_path, how, expect):
    """--dx/--dy map onto velocity=(dy, dx) and --center-x/--center-y onto center=(row, col)."""
    assert run_cli("blur", images / "c1.png", "-o", tmp_path, *how, "--format", "npy", "--backend", "numpy") == 0
    img = iio.imread(images / "c1.png").astype(np.float32)
    ref = gfgpu.motion_blur(img, channel_axis=-1, backend="numpy", **expect)
    np.testing.assert_array_equal(np.load(tmp_path / "c1.npy"), ref)


def test_parameters_are_rows_then_cols_and_old_keys_are_refused(images, tmp_path):
    """The library's parameter dicts: shift=(dy, dx), velocity=(vy, vx), center=(row, col);
    the old keys fail before any work (check_parameters) and per file (process_file)."""
    img = iio.imread(images / "c1.png")
    jobs = [batch.Job(str(images / "c1.png"), str(tmp_path / f"{name}.npy"), op, params, "npy", backend="numpy")
            for name, op, params in (("shift", "shift", {"shift": (-1.25, 2.5)}),
                                     ("blur", "blur", {"velocity": (-2.0, 6.0)}),
                                     ("zoom", "blur", {"zoom": 0.3, "center": (12, 10)}))]
    assert [batch.process_file(j).status for j in jobs] == ["ok"] * 3
    work = img.astype(np.float32)
    np.testing.assert_array_equal(np.load(tmp_path / "shift.npy"),
                                  gfgpu.shift(work, (-1.25, 2.5), channel_axis=-1, backend="numpy"))
    # the same job with the old (dx, dy) convention would differ
    assert not np.allclose(np.load(tmp_path / "shift.npy"),
                           gfgpu.shift(work, (2.5, -1.25), channel_axis=-1, backend="numpy"))
    np.testing.assert_array_equal(np.load(tmp_path / "blur.npy"),
                                  gfgpu.motion_blur(work, (-2.0, 6.0), channel_axis=-1, backend="numpy"))
    np.testing.assert_array_equal(np.load(tmp_path / "zoom.npy"),
                                  gfgpu.motion_blur(work, (0.3, 0.3), kind="zoom", center=(12, 10),
                                                    channel_axis=-1, backend="numpy"))
    for op, params, match in (("shift", {"by": (1, 1)}, "unknown 'by'"),
                              ("shift", {}, r"shift=\(dy, dx\)"),
                              ("blur", {"velocity": (1, 1), "zoom": 0.2}, "exactly one"),
                              ("blur", {"velocity": (1, 1), "center": (3, 3)}, "zoom only"),
                              ("blur", {"zoom": 0.2, "center": (1, 2, 3)}, r"pair \(row, col\)")):
        with pytest.raises(ValueError, match=match):
            batch.check_parameters(op, params)
    old = batch.process_file(batch.Job(str(images / "c1.png"), str(tmp_path / "old.npy"), "shift", {"by": (1, 1)},
                                       "npy", backend="numpy"))
    assert old.status == "failed" and "unknown 'by'" in old.message
    outside = batch.process_file(batch.Job(str(images / "c1.png"), str(tmp_path / "out.npy"), "blur",
                                           {"zoom": 0.3, "center": (30, 10)}, "npy", backend="numpy"))
    assert outside.status == "failed" and "inside the image" in outside.message   # row 30 of 24 rows


# --------------------------------------------------------------------------------------
# resume and atomic writes
# --------------------------------------------------------------------------------------
def test_resume_skips_and_overwrite_recomputes(images, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "c1.npy").write_bytes(b"stale")          # an output from an earlier run
    args = ("shift", images, "-o", out, "--dx", 1, "--dy", 1, "--format", "npy", "--backend", "numpy")
    assert run_cli(*args) == 0
    assert "2 ok, 1 skipped, 0 failed" in capsys.readouterr().out
    assert (out / "c1.npy").read_bytes() == b"stale"
    done = {n: os.stat(out / f"{n}.npy").st_mtime_ns for n in ("c2", "g")}
    digests = tree_digest(out)

    assert run_cli(*args) == 0                      # everything there: nothing recomputed
    assert "0 ok, 3 skipped, 0 failed" in capsys.readouterr().out
    assert tree_digest(out) == digests
    assert {n: os.stat(out / f"{n}.npy").st_mtime_ns for n in ("c2", "g")} == done

    past = 1_000_000_000
    for n in ("c2", "g"):
        os.utime(out / f"{n}.npy", ns=(past, past))
    assert run_cli(*args, "--overwrite") == 0
    assert "3 ok, 0 skipped, 0 failed" in capsys.readouterr().out
    ref = gfgpu.shift(iio.imread(images / "c1.png").astype(np.float32), (1, 1), axes=(0, 1), backend="numpy")
    np.testing.assert_array_equal(np.load(out / "c1.npy"), ref)
    assert all(os.stat(out / f"{n}.npy").st_mtime_ns > past for n in ("c2", "g"))
    assert not leftovers(out)


@pytest.mark.parametrize("fmt", ["npy", "png"])
def test_interrupted_write_leaves_no_partial_output(images, tmp_path, monkeypatch, capsys, fmt):
    """A writer that dies half-way through the second file: no partial output, no temp file."""
    import gfgpu.io

    calls = []
    real = np.save if fmt == "npy" else gfgpu.io._write_bytes

    def dying_writer(target, *args, **kwargs):
        calls.append(target)
        if len(calls) == 2:
            if hasattr(target, "write"):
                target.write(b"\x93NUMPY garbage")
            else:
                with open(target, "wb") as f:
                    f.write(b"\x89PNG garbage")
            raise OSError("disk full (simulated)")
        return real(target, *args, **kwargs)

    if fmt == "npy":
        monkeypatch.setattr(np, "save", dying_writer)
    else:
        monkeypatch.setattr(gfgpu.io, "_write_bytes", dying_writer)
    out = tmp_path / "out"
    before = tree_digest(images)
    assert run_cli("shift", images, "-o", out, "--dx", 1, "--format", fmt, "--backend", "numpy") == 1
    text = capsys.readouterr().out
    assert "2 ok, 0 skipped, 1 failed" in text and "disk full (simulated)" in text
    assert sorted(os.listdir(out)) == sorted(f"{n}.{fmt}" for n in ("c1", "g"))   # c2 died: absent
    assert not leftovers(out)
    assert tree_digest(images) == before
    monkeypatch.undo()
    assert run_cli("shift", images, "-o", out, "--dx", 1, "--format", fmt, "--backend", "numpy") == 0
    assert "1 ok, 2 skipped, 0 failed" in capsys.readouterr().out   # the rerun completes the batch


# --------------------------------------------------------------------------------------
# bad files: reported, the others processed, inputs untouched
# --------------------------------------------------------------------------------------
def test_bad_files_are_reported_and_the_rest_processed(images, tmp_path, capsys):
    import tifffile
    good = (images / "c1.png").read_bytes()
    (images / "truncated.png").write_bytes(good[: len(good) // 2])
    tifffile.imwrite(images / "complex.tif", (np.ones((8, 8)) + 2j).astype(np.complex64))
    (images / "dangling.png").symlink_to(tmp_path / "nowhere.png")    # unreadable entry of the folder
    (images / "notes.txt").write_text("not an image")                  # not an image extension: ignored
    unreadable = os.geteuid() != 0                                     # root reads 0o000 files anyway
    if unreadable:
        (images / "locked.png").write_bytes(good)
        os.chmod(images / "locked.png", 0)
    missing = tmp_path / "missing.png"
    before = {n: sha256(images / n) for n in os.listdir(images)
              if n not in ("dangling.png", "locked.png")}
    out = tmp_path / "out"
    try:
        code = run_cli("shift", images, missing, "-o", out, "--dx", 0.5, "--dy", 0.5, "--format", "npy",
                       "--backend", "numpy")
    finally:
        if unreadable:
            os.chmod(images / "locked.png", 0o644)
    text = capsys.readouterr().out
    n_bad = 4 + unreadable
    assert code == 1
    assert f"3 ok, 0 skipped, {n_bad} failed" in text
    reasons = {line.split(": ")[1]: line for line in text.splitlines() if line.strip().startswith("failed:")}
    assert set(reasons) == {str(images / "truncated.png"), str(images / "complex.tif"), str(images / "dangling.png"),
                            str(missing)} | ({str(images / "locked.png")} if unreadable else set())
    assert "complex64" in reasons[str(images / "complex.tif")]
    assert "FileNotFoundError" in reasons[str(missing)]
    if unreadable:
        assert "PermissionError" in reasons[str(images / "locked.png")]
    assert sorted(os.listdir(out)) == ["c1.npy", "c2.npy", "g.npy"]
    assert not leftovers(out)
    assert {n: sha256(images / n) for n in before} == before


def test_process_file_never_raises(tmp_path):
    jobs = [batch.Job(str(tmp_path / "none.png"), str(tmp_path / "o.npy"), "shift", {"shift": (1, 1)}, "npy"),
            batch.Job(str(tmp_path / "none.png"), str(tmp_path / "o.npy"), "rotate", {}, "npy"),
            batch.Job(str(tmp_path), str(tmp_path / "o.npy"), "shift", {"shift": (1, 1)}, "npy")]
    iio.imwrite(tmp_path / "nan.tiff", np.full((8, 8), np.nan, np.float32))
    jobs.append(batch.Job(str(tmp_path / "nan.tiff"), str(tmp_path / "o.npy"), "gradient", {"u": 1.0}, "npy",
                          backend="numpy"))
    results = [batch.process_file(j) for j in jobs]
    assert [r.status for r in results] == ["failed"] * 4
    assert all(r.message and r.seconds >= 0 for r in results)
    assert "rotate" in results[1].message
    assert not os.path.exists(tmp_path / "o.npy")


# --------------------------------------------------------------------------------------
# planning errors: before any work
# --------------------------------------------------------------------------------------
def test_refuses_to_overwrite_an_input(images, capsys):
    before = tree_digest(images)
    fails_with(capsys, "overwrite an input", "shift", images, "-o", images, "--dx", 1, "--dy", 1, "--backend", "numpy")
    os.link(images / "g.png", images.parent / "g.npy")       # a hard link is the same file
    with pytest.raises(ValueError, match="overwrite an input"):
        batch.plan_jobs([str(images / "g.png")], str(images.parent), "shift", {"shift": (1, 1)}, fmt="npy")
    assert tree_digest(images) == before
    # the task itself refuses too, whatever its job says
    job = batch.Job(str(images / "g.png"), str(images / "g.png"), "shift", {"shift": (1, 1)}, overwrite=True)
    assert batch.process_file(job).status == "failed"
    assert tree_digest(images) == before


def test_same_stem_is_an_error_before_any_work(images, tmp_path, capsys):
    (images / "sub").mkdir()
    (images / "sub" / "g.jpg").write_bytes((images / "g.png").read_bytes())
    fails_with(capsys, "same name stem 'g'", "shift", images, images / "sub", "-o", tmp_path / "out", "--dx", 1,
               "--dy", 1)
    assert not (tmp_path / "out").exists()


def test_discovery(images, tmp_path, capsys):
    (images / "UPPER.PNG").write_bytes((images / "g.png").read_bytes())
    (images / "x.JpEg").write_bytes(b"")
    (images / "readme.txt").write_text("")
    (images / ".hidden.png").write_bytes(b"")
    (images / "deep").mkdir()
    (images / "deep" / "d.tif").write_bytes(b"")
    names = lambda paths: [os.path.relpath(p, images) for p in paths]
    assert names(batch.discover_inputs([images])) == ["UPPER.PNG", "c1.png", "c2.png", "g.png", "x.JpEg"]
    assert names(batch.discover_inputs([str(images / "**" / "*.tif"), images / "g.png",
                                        str(images / "g.png")])) == ["deep/d.tif", "g.png"]
    assert all(os.path.isabs(p) for p in batch.discover_inputs([os.path.relpath(images)]))
    with pytest.raises(ValueError, match=r"\*\.bmp.*matches no file"):
        batch.discover_inputs([str(images / "*.bmp")])
    (tmp_path / "empty").mkdir()
    fails_with(capsys, "holds no image file", "gradient", tmp_path / "empty", "-o", tmp_path / "out")


@pytest.mark.parametrize("argv, message", [
    (("gradient", "-u", 0), "u must be > 0"),
    (("canny", "--low", 0.9, "--high", 0.2), r"low quantile \(0.9\) must not exceed"),
    (("canny", "--low", 1.5), "low_threshold"),
    (("blur", "--zoom", 3), "u1.* got 3"),
    (("blur", "--dx", 1, "--dy", 1, "--center-x", 3, "--center-y", 3), "--center"),
    (("blur", "--dx", 1, "--zoom", 0.2), "give one motion"),
    (("blur",), "give one motion"),
    (("shift",), "--dx"),
    (("shift", "--dx", "nan"), "shift must be finite"),
])
def test_bad_parameters_fail_once_before_any_work(images, tmp_path, capsys, argv, message):
    fails_with(capsys, message, argv[0], images, "-o", tmp_path / "out", *argv[1:], "--backend", "numpy")
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------------------
# Dask: a LocalCluster of two worker processes, end to end through --workers
# --------------------------------------------------------------------------------------
def test_local_cluster_two_workers(images, tmp_path, capsys):
    pytest.importorskip("dask.distributed")
    (images / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    before = tree_digest(images)
    code = run_cli("shift", images, "-o", tmp_path / "dask", "--dx", 2, "--dy", 1, "--format", "npy",
                   "--backend", "numpy", "--workers", 2)
    captured = capsys.readouterr()
    assert code == 1
    assert "3 ok, 0 skipped, 1 failed" in captured.out and "broken.png" in captured.out
    assert "2 worker(s)" in captured.err
    assert run_cli("shift", images, "-o", tmp_path / "here", "--dx", 2, "--dy", 1, "--format", "npy",
                   "--backend", "numpy") == 1
    for name in ("c1", "c2", "g"):
        np.testing.assert_array_equal(np.load(tmp_path / "dask" / f"{name}.npy"),
                                      np.load(tmp_path / "here" / f"{name}.npy"))
    assert not leftovers(tmp_path / "dask")
    assert tree_digest(images) == before


# --------------------------------------------------------------------------------------
# files (issue 16, items 9, 10, 12): own outputs, special files, leftovers, depth and alpha
# --------------------------------------------------------------------------------------
def test_output_folder_inside_the_input_pattern_is_skipped_on_rerun(images, capsys):
    """``gfgpu batch shift 'imgs/**/*.png' -o imgs/out`` twice: the rerun does not take its own
    outputs as inputs (before: "would overwrite an input")."""
    pattern, out = str(images / "**" / "*.png"), images / "out"
    before = tree_digest(images)
    assert run_cli("shift", pattern, "-o", out, "--dx", 1, "--backend", "numpy") == 0
    assert "3 ok, 0 skipped, 0 failed" in capsys.readouterr().out
    outputs = tree_digest(out)
    assert run_cli("shift", pattern, "-o", out, "--dx", 1, "--backend", "numpy") == 0
    text = capsys.readouterr().out
    assert "left out 3 file(s) inside the output folder" in text and "0 ok, 3 skipped, 0 failed" in text
    assert tree_digest(out) == outputs and tree_digest(images) == before
    # a pattern rooted in the output folder itself names its files: still refused, not skipped
    fails_with(capsys, "overwrite an input", "shift", str(images / "*.png"), "-o", images, "--dx", 1)


def test_a_fifo_named_like_an_image_is_skipped_and_reported(images, tmp_path):
    """Run as a separate process with a timeout: opening the FIFO would block forever."""
    import subprocess
    import sys
    os.mkfifo(images / "pipe.png")
    res = subprocess.run([sys.executable, "-m", "gfgpu", "batch", "shift", str(images), str(images / "*.png"),
                          "-o", str(tmp_path / "out"), "--dx", "1", "--backend", "numpy", "-q"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "4 file(s): 3 ok, 1 skipped, 0 failed" in res.stdout, res.stdout    # the FIFO: reported once
    assert f"skipped: {images / 'pipe.png'}: not a regular file (a FIFO (named pipe)): not read" in res.stdout
    assert sorted(os.listdir(tmp_path / "out")) == ["c1.png", "c2.png", "g.png"]
    job = batch.Job(str(images / "pipe.png"), str(tmp_path / "p.npy"), "shift", {"shift": (1, 1)}, "npy")
    r = batch.process_file(job)                                          # never opened here either
    assert r.status == "failed" and "FIFO" in r.message


def test_temporaries_of_a_killed_batch_are_removed_on_the_next_run(images, tmp_path, capsys):
    """SIGKILL a batch while it writes: its .gfgpu-HOST-PID-* temporary stays; the next run removes
    it (its process is gone), and keeps what is not a gfgpu temporary."""
    import signal
    import subprocess
    import sys
    import textwrap
    out = tmp_path / "out"
    code = textwrap.dedent(f"""
        import time, numpy as np, gfgpu.io, gfgpu.cli
        real = np.save
        def slow(f, arr, **kw):
            real(f, arr, **kw)
            print("writing", flush=True)
            time.sleep(60)
        np.save = slow
        gfgpu.cli.main(["batch", "shift", {str(images)!r}, "-o", {str(out)!r}, "--dx", "1", "--format", "npy",
                        "--backend", "numpy", "-q"])
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "writing"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    stale = leftovers(out)
    assert len(stale) == 1 and f"-{proc.pid}-" in stale[0]
    (out / ".gfgpu-notes.txt").write_text("not ours")
    assert run_cli("shift", images, "-o", out, "--dx", 1, "--format", "npy", "--backend", "numpy") == 0
    captured = capsys.readouterr()
    assert "removed 1 temporary file(s) of an interrupted run" in captured.err
    assert "3 ok, 0 skipped, 0 failed" in captured.out
    assert leftovers(out) == [".gfgpu-notes.txt"]


def test_batch_keeps_depth_and_alpha(tmp_path, rng):
    folder = tmp_path / "in"
    folder.mkdir()
    flat16 = np.full((12, 16), 40000, np.uint16)
    iio.imwrite(folder / "flat16.png", flat16)
    rgba = np.zeros((12, 16, 4), np.uint8)
    rgba[3:9, 4:12] = (200, 100, 50, 255)
    iio.imwrite(folder / "rgba.png", rgba)
    assert run_cli("blur", folder, "-o", tmp_path / "out", "--dx", 3, "--backend", "numpy") == 0
    out16 = iio.imread(tmp_path / "out" / "flat16.png")
    assert out16.dtype == np.uint16 and (out16 == 40000).all()        # not stretched to black
    res = iio.imread(tmp_path / "out" / "rgba.png")
    assert res.shape == (12, 16, 4)
    partly = (res[..., 3] > 20) & (res[..., 3] < 235)
    assert partly.any()
    np.testing.assert_allclose(res[partly][:, :3], np.broadcast_to([200, 100, 50], (partly.sum(), 3)), atol=3)
    assert run_cli("shift", folder / "rgba.png", "-o", tmp_path / "npy", "--dx", 1, "--format", "npy",
                   "--backend", "numpy") == 0
    assert np.load(tmp_path / "npy" / "rgba.npy").shape == (12, 16, 4)


# --------------------------------------------------------------------------------------
# wide integers (int32, uint32, int64) keep their values; float -> 8-bit PNG is stated
# --------------------------------------------------------------------------------------
WIDE = 2_000_000_003          # float32 holds it as 2,000,000,000


@pytest.mark.parametrize("dtype", [np.int32, np.uint32, np.int64])
def test_wide_integers_are_filtered_in_float64_as_in_the_api(tmp_path, backend, dtype):
    """issue 31: batch cast every integer image to float32 (``shift`` by (0, 0) of 2,000,000,003 gave
    2,000,000,000); now the API's dtype policy: the same values as ``gfgpu.shift``/``gfgpu.motion_blur``."""
    import tifffile
    img = np.full((12, 16), WIDE, dtype)
    img[:, 8:] -= 1000
    tifffile.imwrite(tmp_path / "w.tif", img)
    assert run_cli("shift", tmp_path / "w.tif", "-o", tmp_path / "s", "--dx", 0, "--format", "npy",
                   "--backend", backend.name) == 0
    got = np.load(tmp_path / "s" / "w.npy")
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, img.astype(np.float64))
    assert run_cli("blur", tmp_path / "w.tif", "-o", tmp_path / "b", "--dx", 3.5, "--format", "npy",
                   "--backend", backend.name) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "b" / "w.npy"), gfgpu.motion_blur(img, (0.0, 3.5),
                                                                                      backend=backend.name))


def test_canny_scales_wide_integers_in_float64(tmp_path):
    """A step of one count at 2**24 (int32): batch canny divided in float32, where 2**24 + 1 rounds to
    2**24, and found no edge; now it equals ``gfgpu.canny`` of the integer image."""
    import tifffile
    img = np.full((24, 32), 2 ** 24, np.int32)
    img[:, 16:] += 1
    tifffile.imwrite(tmp_path / "step.tif", img)
    assert run_cli("canny", tmp_path / "step.tif", "-o", tmp_path / "e", "--low", 0.7, "--high", 0.9,
                   "--format", "npy", "--backend", "numpy") == 0
    got = np.load(tmp_path / "e" / "step.npy")
    ref = gfgpu.canny(img, 1.0, 0.7, 0.9, use_quantiles=True, backend="numpy")
    assert ref.any() and set(np.nonzero(ref.any(axis=0))[0]) == {16}
    np.testing.assert_array_equal(got, ref)


def test_float_and_wide_integer_png_outputs_are_stated(tmp_path, capsys, rng):
    """The single-image commands print gfgpu.io.conversion_note; batch did not (float TIFF -> PNG was
    rescaled silently).  Now each such file has a note line, in the command's options."""
    import tifffile
    inputs = tmp_path / "in"
    inputs.mkdir()
    tifffile.imwrite(inputs / "unit.tif", (0.031 + 0.942 * rng.random((12, 16))).astype(np.float32))
    tifffile.imwrite(inputs / "wide.tif", (rng.random((12, 16)) * 1e9).astype(np.int32))
    iio.imwrite(inputs / "u8.png", (rng.random((12, 16)) * 255).astype(np.uint8))
    iio.imwrite(inputs / "u16.png", (rng.random((12, 16)) * 65535).astype(np.uint16))
    for op in (("shift", "--dx", 1), ("blur", "--dx", 2)):
        assert run_cli(*op, inputs, "-o", tmp_path / op[0], "--backend", "numpy") == 0
        out = capsys.readouterr().out
        notes = [line for line in out.splitlines() if line.startswith("  note: ")]
        assert len(notes) == 2, out
        assert f"{inputs / 'unit.tif'}: float32 input in [0, 1]" in notes[0] and "round(v * 255)" in notes[0]
        assert f"{inputs / 'wide.tif'}: int32 input written as 8-bit PNG stretched" in notes[1]
        assert all(line.endswith("values") and "--format tiff keeps" in line for line in notes)
        assert run_cli(*op, inputs, "-o", tmp_path / f"{op[0]}_tiff", "--format", "tiff", "--backend",
                       "numpy") == 0
        assert "note:" not in capsys.readouterr().out
    for op in (("gradient",), ("canny",)):      # renderings (colour-coded, 0/255), not the values
        assert run_cli(*op, inputs, "-o", tmp_path / op[0], "--backend", "numpy") == 0
        assert "note:" not in capsys.readouterr().out


_SPAWN_IN_GUARD = """
import multiprocessing as mp, time
from gfgpu.batch import _sigint_ignored
if __name__ == "__main__":
    with _sigint_ignored():
        child = mp.get_context("spawn").Process(target=time.sleep, args=(20,))
        child.start()                   # the first spawn of the process: it starts the resource tracker
        for _ in range(200):            # until the child's interpreter runs (its mask is set by then)
            with open(f"/proc/{child.pid}/status") as f:
                status = dict(line.split(":", 1) for line in f if ":" in line)
            if "SigBlk" in status and int(status.get("SigCgt", "0").strip(), 16):
                break
            time.sleep(0.05)
        child.kill()
        child.join()
    print(status["SigBlk"].strip())
"""


@pytest.mark.skipif(not (hasattr(__import__("signal"), "pthread_sigmask") and os.path.exists("/proc/self/status")),
                    reason="no signal masks, or no /proc to read them, here")
def test_workers_spawned_in_the_guard_keep_sigint_blocked(tmp_path):
    """Dask's workers are multiprocessing 'spawn' children, and the first spawn starts multiprocessing's
    resource tracker, which unblocks SIGINT in the spawning thread: in a fresh process (no tracker
    yet) the workers then acted on Ctrl-C (each printed a traceback)."""
    import signal
    import subprocess
    import sys
    script = tmp_path / "spawn_in_guard.py"
    script.write_text(_SPAWN_IN_GUARD)
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, check=True)
    assert int(res.stdout.split()[-1], 16) & (1 << (signal.SIGINT - 1)), res.stdout


@pytest.mark.skipif(not (hasattr(__import__("signal"), "pthread_sigmask") and os.path.exists("/proc/self/status")),
                    reason="no signal masks, or no /proc to read them, here")
def test_ctrl_c_while_the_local_cluster_starts_is_kept_and_its_processes_never_see_it():
    """The workers must not act on a Ctrl-C (each printed a traceback), and the batch must: a
    Ctrl-C during the cluster's start-up was ignored and the batch ran to the end (exit 0).  Inside
    the guard SIGINT is pending, not lost; processes started there have it blocked."""
    import signal
    import subprocess
    import sys
    import threading

    from gfgpu.batch import _sigint_ignored
    with pytest.raises(KeyboardInterrupt):
        with _sigint_ignored():
            child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
            try:
                # sent to this (main) thread, not the process: a process-directed signal may be taken
                # by another thread whose mask lets it through (pytest's, a runtime's) and raised
                # whenever that thread runs, after this test on a loaded machine
                signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
                with open(f"/proc/{child.pid}/status") as f:
                    blocked = int(next(line for line in f if line.startswith("SigBlk:")).split()[1], 16)
                assert blocked & (1 << (signal.SIGINT - 1)), "the child would act on a Ctrl-C"
            finally:
                child.kill()
                child.wait()
