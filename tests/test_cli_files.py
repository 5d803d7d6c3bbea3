"""The ``gfgpu`` command's files as a new user meets them: an input file and ``--example``
together, outputs that would lose depth or alpha, stated conversions, float64 input, stale
frames, ``--keep-position`` with ``--zoom``, messages in the options' names and units, sizes in
(rows, cols), ``disparity``'s raw outputs and early ``--ply``/``--png16`` checks, Ctrl-C and a
full disk."""

import errno
import os
import struct
import subprocess
import sys
import time
import zlib

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile

import gfgpu
from gfgpu.cli import main


def cli(argv):
    return main([str(a) for a in argv])


def one_line(capsys, code, expect, command):
    err = capsys.readouterr().err.strip()
    assert code == expect, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"gfgpu {command}: "), err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture
def grey(tmp_path, rng):
    path = tmp_path / "grey.png"
    iio.imwrite(path, (rng.random((24, 32)) * 255).astype(np.uint8))
    return path


@pytest.mark.parametrize("argv", [
    ["shift", "{f}", "--example", "camera", "--dx", 3, "-o", "{o}.png"],
    ["blur", "{f}", "--example", "camera", "--dx", 3, "-o", "{o}.png"],
    ["gradient", "{f}", "--example", "camera", "-o", "{o}.png"],
    ["frames", "{f}", "--example", "camera", "--dx", 3, "-n", 2, "-o", "{o}"],
    ["disparity", "{f}", "{f}", "--example", "motorcycle", "-o", "{o}.png"],
])
def test_a_file_and_example_together_are_refused(tmp_path, capsys, grey, argv):
    out = tmp_path / "out"
    argv = [str(a).format(f=grey, o=out) for a in argv] + ["--backend", "numpy", "-q"]
    line = one_line(capsys, cli(argv), 2, argv[0])
    assert "not both" in line and str(grey) in line and "--example" in line
    assert sorted(os.listdir(tmp_path)) == ["grey.png"]


@pytest.mark.parametrize("make, output, words", [
    (lambda: np.full((8, 9), 40000, np.uint16), "o.jpg", "16-bit samples"),
    (lambda: np.full((8, 9, 4), 200, np.uint8), "o.jpg", "an alpha channel"),
    (lambda: np.full((8, 9, 4), 200, np.uint8), "o.bmp", "an alpha channel"),
    (lambda: np.full((8, 9, 2), 20000, np.uint16), "o.bmp", "16-bit samples and an alpha channel"),
])
def test_outputs_that_would_lose_depth_or_alpha_are_refused_before_work(tmp_path, capsys, make, output, words):
    src = tmp_path / "in.tif"
    gfgpu.io.write_image(src, make())
    for command in (["shift", src, "--dx", 1], ["blur", src, "--dx", 2]):
        code = cli([*command, "-o", tmp_path / output, "--backend", "numpy", "-q"])
        line = one_line(capsys, code, 2, command[0])
        assert words in line and "write a .png or .tif" in line and f"-o {tmp_path / output}" in line
        assert not (tmp_path / output).exists()


def test_float_tiff_into_png_is_not_stretched_and_says_so(tmp_path, capsys):
    img = np.linspace(0.031, 0.973, 30 * 40, dtype=np.float32).reshape(30, 40)
    tifffile.imwrite(tmp_path / "f.tif", img)
    assert cli(["shift", tmp_path / "f.tif", "-o", tmp_path / "o.png", "--dx", 0, "--backend", "numpy", "-q"]) == 0
    err = capsys.readouterr().err
    assert "note: float32 input in [0, 1] (here 0.031..0.973) written as 8-bit PNG: round(v * 255)" in err
    out = iio.imread(tmp_path / "o.png")
    np.testing.assert_array_equal(out, np.rint(img.astype(np.float64) * 255).astype(np.uint8))
    assert out.min() == 8 and out.max() == 248                  # not stretched to 0..255


def test_float64_beyond_float32_range_is_computed_in_float64(tmp_path, capsys):
    img = np.full((16, 20), 1e300)
    img[:, 10:] = -2e300
    tifffile.imwrite(tmp_path / "big.tif", img)
    res = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "gfgpu", "shift",
                          str(tmp_path / "big.tif"), "-o", str(tmp_path / "o.tif"), "--dx", "0.5",
                          "--backend", "numpy", "-q"], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stderr == "", res.stderr
    out = tifffile.imread(tmp_path / "o.tif")
    assert out.dtype == np.float64 and np.isfinite(out).all()
    np.testing.assert_allclose(out, gfgpu.shift(img, (0, 0.5), backend="numpy"), rtol=1e-12)


def test_png_transparency_survives_blur(tmp_path, capsys):
    """A palette PNG with a transparent entry: the blurred output keeps the transparent background."""
    index = np.zeros((20, 24), np.uint8)
    index[6:14, 8:16] = 1
    palette = bytes([0, 0, 0, 250, 30, 10])

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    raw = b"".join(b"\0" + row.tobytes() for row in index)
    header = struct.pack(">IIBBBBB", 24, 20, 8, 3, 0, 0, 0)
    (tmp_path / "p.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"PLTE", palette)
                                     + chunk(b"tRNS", b"\0") + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    assert cli(["blur", tmp_path / "p.png", "-o", tmp_path / "o.png", "--dx", 2, "--psf", "box",
                "--keep-position", "--backend", "numpy", "-q"]) == 0
    out = iio.imread(tmp_path / "o.png")
    assert out.shape == (20, 24, 4)
    assert (out[:3, :, 3] == 0).all() and (out[10, 11:13, 3] == 255).all()
    np.testing.assert_array_equal(out[10, 12, :3], [250, 30, 10])


def test_frames_removes_only_its_own_stale_frames(tmp_path, capsys, grey):
    folder = tmp_path / "fr"
    base = [grey, "--dx", 3, "--backend", "numpy", "-q", "-o", folder]
    assert cli(["frames", *base, "-n", 6]) == 0
    (folder / "notes.txt").write_text("mine")
    (folder / "frame_1234.png").write_bytes(b"x")              # a frame of a run with more digits
    capsys.readouterr()
    assert cli(["frames", *base, "-n", 3]) == 0
    out = capsys.readouterr().out
    assert sorted(os.listdir(folder)) == ["frame_000.png", "frame_001.png", "frame_002.png", "frames.gif",
                                          "notes.txt"]
    assert "removed 4 frame(s) of an earlier run" in out
    assert len(iio.imread(folder / "frames.gif", index=None)) == 3


def test_keep_position_with_the_green_zoom_is_an_error(tmp_path, capsys, grey):
    for command in (["blur", grey, "-o", tmp_path / "o.png"], ["frames", grey, "-o", tmp_path / "fr"]):
        line = one_line(capsys, cli([*command, "--zoom", 0.2, "--keep-position", "--backend", "numpy", "-q"]), 2,
                        command[0])
        assert "--keep-position" in line and "--psf box" in line
    line = one_line(capsys, cli(["batch", "blur", grey, "-o", tmp_path / "b", "--zoom", 0.2, "--keep-position"]), 2,
                    "batch blur")
    assert "--keep-position" in line
    assert cli(["blur", grey, "-o", tmp_path / "o.png", "--zoom", 0.2, "--keep-position", "--psf", "box",
                "--backend", "numpy", "-q"]) == 0


@pytest.mark.parametrize("argv, present, absent", [
    (["blur", "{g}", "-o", "{t}/o.png", "--zoom", 5], "--zoom must lie in", "velocity"),
    (["blur", "{g}", "-o", "{t}/o.png", "--rotate", 400], "--rotate", "velocity"),
    (["disparity", "{g}", "{g}", "-o", "{t}/o.png", "--max-disparity", 5, "--min-disparity", 7],
     "--max-disparity must satisfy --min-disparity (7)", "max_disparity"),
])
def test_messages_name_the_options(tmp_path, capsys, grey, argv, present, absent):
    argv = [str(a).format(g=grey, t=tmp_path) for a in argv] + ["--backend", "numpy", "-q"]
    line = one_line(capsys, cli(argv), 2, argv[0])
    assert present in line and absent not in line, line


def test_depth_names_direction_in_degrees(tmp_path, capsys):
    y, x = np.mgrid[:48, :64]
    sphere = np.clip(1 - ((x - 32) ** 2 + (y - 24) ** 2) / 400, 0, 1) ** 0.5 * 200 + 20
    iio.imwrite(tmp_path / "s.png", sphere.astype(np.uint8))
    line = one_line(capsys, cli(["depth", tmp_path / "s.png", "-o", tmp_path / "d.png", "--light", 0, 0, 1,
                                 "--backend", "numpy", "-q"]), 2, "depth")
    assert "--direction DEGREES" in line and "--method photometric-motion" in line
    assert "direction=" not in line and "radians" not in line


def test_sizes_are_rows_by_cols(tmp_path, capsys, grey):
    assert cli(["shift", grey, "-o", tmp_path / "o.png", "--dx", 1, "--backend", "numpy", "-q"]) == 0
    assert "24 x 32 (rows x cols)" in capsys.readouterr().out


@pytest.fixture
def pair(tmp_path, rng):
    texture = (rng.random((40, 80)) * 255).astype(np.uint8)
    left = texture
    right = np.roll(texture, -4, axis=1)
    iio.imwrite(tmp_path / "l.png", left)
    iio.imwrite(tmp_path / "r.png", right)
    return tmp_path / "l.png", tmp_path / "r.png"


def test_disparity_fill_keeps_the_raw_npy(tmp_path, capsys, pair):
    base = ["disparity", *pair, "--max-disparity", 15, "--backend", "numpy", "-q"]
    assert cli([*base, "-o", tmp_path / "a.png", "--npy", tmp_path / "raw.npy", "--pfm", tmp_path / "raw.pfm"]) == 0
    assert cli([*base, "-o", tmp_path / "b.png", "--npy", tmp_path / "fill.npy", "--pfm", tmp_path / "fill.pfm",
                "--fill"]) == 0
    raw, filled = np.load(tmp_path / "raw.npy"), np.load(tmp_path / "fill.npy")
    assert np.isnan(raw).any()                                   # rejected pixels (the left band at least)
    np.testing.assert_array_equal(filled, raw)
    np.testing.assert_array_equal(gfgpu.io.read_pfm(tmp_path / "fill.pfm"), raw)
    assert not np.array_equal(iio.imread(tmp_path / "a.png"), iio.imread(tmp_path / "b.png"))


@pytest.mark.parametrize("extra, words", [
    (["--ply", "{t}/c.ply"], "--ply needs --focal and --baseline, or --q"),
    (["--ply", "{t}/c.ply", "--q", "{t}/missing.txt"], "--q"),
    (["--ply", "{t}/c.ply", "--q", "{t}/q.txt", "--focal", 100, "--baseline", 1], "not both"),
    (["--png16", "{t}/d16.png", "--max-disparity", 300], "--max-disparity is 300"),
    (["--png16", "{t}/d16.png", "--max-disparity", 15, "--min-disparity", -4], "--min-disparity is -4"),
])
def test_disparity_options_are_checked_before_any_file_is_written(tmp_path, capsys, pair, extra, words):
    np.savetxt(tmp_path / "q.txt", np.eye(4))
    extra = [str(a).format(t=tmp_path) for a in extra]
    argv = ["disparity", *pair, "-o", tmp_path / "o.png", "--npy", tmp_path / "o.npy", *extra]
    if "--max-disparity" not in extra:
        argv += ["--max-disparity", 15]
    line = one_line(capsys, cli([*argv, "--backend", "numpy", "-q"]), 2, "disparity")
    assert words in line
    assert sorted(os.listdir(tmp_path)) == ["l.png", "q.txt", "r.png"]


def test_ctrl_c_is_exit_130_without_traceback(tmp_path, capsys, grey, monkeypatch):
    import gfgpu.cli.shift as shift_cli

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(shift_cli, "shift", interrupted)
    line = one_line(capsys, cli(["shift", grey, "-o", tmp_path / "o.png", "--dx", 1, "--backend", "numpy", "-q"]),
                    130, "shift")
    assert line == "gfgpu shift: interrupted"
    assert sorted(os.listdir(tmp_path)) == ["grey.png"]


_FSIZE = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)           # writes past the limit fail (EFBIG), as on a full disk
limit = int(sys.argv[1])
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
from gfgpu.cli import main
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("output", ["o.png", "o.jpg", "o.bmp", "o.tif", "npy"])
def test_a_failing_write_is_one_line_and_leaves_nothing(tmp_path, grey, output):
    """Writes that fail part-way (a file-size limit stands in for a full disk): exit 1, one line naming
    the output, no destructor traceback, no partial file, and no truncated JPEG reported as written."""
    big = tmp_path / "big.png"
    iio.imwrite(big, (np.random.default_rng(1).random((120, 160, 3)) * 255).astype(np.uint8))
    target = tmp_path / "out"
    target.mkdir()
    argv = ["shift", big, "--dx", 1, "--backend", "numpy", "-q"]
    argv += ["-o", target / "o.png", "--npy", target / "o.npy"] if output == "npy" else ["-o", target / output]
    limit = 120_000 if output == "npy" else 4096        # the PNG (about 58 kB) fits, the .npy (230 kB) does not
    res = subprocess.run([sys.executable, "-c", _FSIZE, str(limit), *map(str, argv)], capture_output=True, text=True,
                         timeout=300)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 1 and len(lines) == 1, res.stderr
    name = "o.npy" if output == "npy" else output
    assert lines[0].startswith(f"gfgpu shift: cannot write {target / name}: "), res.stderr
    assert name not in os.listdir(target) and not [n for n in os.listdir(target) if n.startswith(".gfgpu")]


def test_short_writes_say_no_space_left(tmp_path, monkeypatch):
    """numpy's tofile (np.save, tifffile) says "N requested and M written": on a full folder that is
    ENOSPC, named so."""
    def short(tmp, *args, **kwargs):
        raise OSError("1440000 requested and 65504 written")
    monkeypatch.setattr(tifffile, "imwrite", short)
    monkeypatch.setattr(gfgpu.io, "_free_bytes", lambda path: 0)
    with pytest.raises(gfgpu.io.OutputError) as info:
        gfgpu.io.write_image(tmp_path / "a.tif", np.zeros((4, 4), np.float32))
    assert str(info.value) == f"cannot write {tmp_path / 'a.tif'}: No space left on device (65504 of 1440000 bytes " \
                              f"written)"
    assert info.value.errno == errno.ENOSPC


def test_gradient_colours_match_skimage_hsv(rng):
    from skimage.color import hsv2rgb
    gy, gx = rng.normal(size=(2, 64, 80)).astype(np.float32)
    mag = np.hypot(gx, gy)
    hsv = np.stack([(np.arctan2(gy, gx) / (2 * np.pi)) % 1.0, np.full(mag.shape, 0.8),
                    np.clip(mag / np.percentile(mag, 99.5), 0, 1)], axis=-1)
    ref = (hsv2rgb(hsv) * 255).round().astype(int)
    got = gfgpu.io.gradient_to_rgb(gy, gx).astype(int)
    assert np.abs(got - ref).max() <= 1 and (got != ref).mean() < 1e-3


def test_batch_on_local_workers_prints_no_dask_log_lines_on_ctrl_c(tmp_path, rng):
    """Ctrl-C during ``gfgpu batch --workers 2``: exit 130, one line, none of Dask's own log lines
    ("Worker process still alive after 4.0 seconds, killing") or worker tracebacks."""
    import signal
    inputs = tmp_path / "in"
    inputs.mkdir()
    n = 48
    for i in range(n):
        iio.imwrite(inputs / f"b{i}.png", (rng.random((600, 800)) * 255).astype(np.uint8))
    out_dir = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "gfgpu", "batch", "blur", str(inputs), "-o", str(out_dir),
                             "--dx", "30", "--workers", "2", "--backend", "numpy"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    first = proc.stderr.readline()
    assert first.startswith("dask: 2 worker(s)"), first
    # interrupt while the work runs: once the first output exists (a fixed sleep let a fast machine
    # finish first, and a Ctrl-C during the interpreter's exit is Python's, not ours: killed by SIGINT)
    deadline = time.monotonic() + 120
    while not any(out_dir.glob("*.png")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)                # what Ctrl-C does: the whole process group
    out, err = proc.communicate(timeout=300)
    assert "distributed." not in err and "Traceback" not in err, err
    done = len(list(out_dir.glob("*.png")))
    if proc.returncode in (0, -signal.SIGINT):        # the batch had finished (exiting): every output, no lines
        assert done == n and err == "", (proc.returncode, done, err)
    else:
        assert proc.returncode == 130 and err.strip() == "gfgpu batch blur: interrupted", (proc.returncode, err)
        assert done < n, done


# a module that sends the process a real SIGINT (what Ctrl-C does) while it is being imported
_CTRL_C_ON_IMPORT = """
import os, signal, time
os.kill(os.getpid(), signal.SIGINT)
time.sleep(60)
"""
#: the ``gfgpu`` script's own lines (pip's console-script wrapper for ``gfgpu.cli:main``)
_SCRIPT = "import sys; from gfgpu.cli import main; sys.exit(main())"


@pytest.mark.parametrize("entry", ["python -m gfgpu", "gfgpu script"])
@pytest.mark.parametrize("module", ["numpy", "argparse"])   # loaded by the commands / by the parser
def test_ctrl_c_during_start_up_is_exit_130_in_one_line(tmp_path, entry, module):
    """Ctrl-C while the command is still importing (issue 31: a KeyboardInterrupt traceback and exit
    status -2): one line, exit status 130, from ``python -m gfgpu`` and from the ``gfgpu`` script."""
    import signal
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / f"{module}.py").write_text(_CTRL_C_ON_IMPORT)
    argv = ["-m", "gfgpu"] if entry == "python -m gfgpu" else ["-c", _SCRIPT]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(fake), *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.run([sys.executable, *argv, "shift", "x.png", "-o", "y.png", "--dx", "1"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=120,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert (proc.returncode, proc.stderr) == (130, "gfgpu: interrupted\n"), (proc.returncode, proc.stderr)
    assert sorted(os.listdir(tmp_path)) == ["fake"]


_HELP_MODULES = """
import contextlib, io, sys
from gfgpu.cli import main
script = sorted(m for m in sys.modules if m.split(".")[0] in ("gfgpu", "numpy", "argparse"))
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main(sys.argv[1:])
    except SystemExit:
        pass
print(" ".join(script))
print(" ".join(sorted(sys.modules)))
"""


@pytest.mark.parametrize("argv", [["--help"], ["depth", "--help"], ["disparity", "--help"], ["batch", "--help"]])
def test_help_does_not_load_the_operators(tmp_path, argv):
    """``gfgpu --help`` took ~4 s importing every operator (issue 31): the script's first line loads
    only ``gfgpu.cli``, and help loads no shape-from-shading (scipy.optimize) or stereo matcher."""
    out = subprocess.run([sys.executable, "-c", _HELP_MODULES, *argv], capture_output=True, text=True,
                         check=True, timeout=120, cwd=tmp_path).stdout.splitlines()
    assert out[0].split() == ["gfgpu", "gfgpu._version", "gfgpu.cli"]
    loaded = set(out[1].split())
    assert not loaded & {"gfgpu.shading", "gfgpu.stereo", "scipy.optimize", "warp", "pyopencl", "dask"}, loaded


@pytest.mark.parametrize("u, words", [("1e10", "must lie in (0, 1e+09] pixels"), ("1e300", "must lie in (0, 1e+09]"),
                                      ("0", "must be > 0"), ("nan", "finite")])
def test_depth_u_is_refused_with_its_range_before_reading(tmp_path, capsys, u, words):
    """``-u`` beyond the library's kernel-scale range (1e9 px, as every other ``-u``; beyond it GSFS
    is its integrator limit, and a float32 image's kernel overflowed past 3.4e38 into "the shape
    estimate is flat") is an option error naming ``-u``, before the (missing) image is read."""
    with pytest.raises(SystemExit) as exit_:
        cli(["depth", tmp_path / "missing.png", "-o", tmp_path / "d.png", "-u", u])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith("gfgpu depth: argument -u: ") and words in err and "missing" not in err, err
    assert sorted(os.listdir(tmp_path)) == []


def _shading(tmp_path, name, image):
    iio.imwrite(tmp_path / name, np.clip(image, 0, 255).astype(np.uint8))
    return tmp_path / name


def test_depth_light_and_u_messages_name_the_options(tmp_path, capsys, rng):
    """The light estimate's refusals said "pass light=" and the lower limit of u "u must", the API's
    names: now ``--light`` and ``-u``."""
    from scipy import ndimage
    texture = _shading(tmp_path, "t.png", 128 + 60 * ndimage.gaussian_filter(rng.standard_normal((48, 64)), 3)
                       / 0.1)                        # fills the frame: no flat background to fix the slant
    line = one_line(capsys, cli(["depth", texture, "-o", tmp_path / "d.png", "--backend", "numpy", "-q"]), 2,
                    "depth")
    assert "pass --light L1 L2 L3 (or TILT SLANT)" in line and "light=" not in line and "mask=" not in line, line
    y, x = np.mgrid[:48, :64]
    sphere = _shading(tmp_path, "s.png", np.clip(1 - ((x - 32) ** 2 + (y - 24) ** 2) / 400, 0, 1) ** 0.5 * 200 + 20)
    line = one_line(capsys, cli(["depth", sphere, "-o", tmp_path / "d.png", "--light", 1, 0, 1, "-u", 1,
                                 "--backend", "numpy", "-q"]), 2, "depth")
    assert line.startswith("gfgpu depth: -u must be at least "), line
    assert cli(["depth", sphere, "-o", tmp_path / "d.png", "--light", 1, 0, 1, "-u", "1e9", "--backend", "numpy",
                "-q"]) == 0
    assert sorted(os.listdir(tmp_path)) == ["d.png", "s.png", "t.png"]


def test_depth_light_help_names_the_default_estimator(capsys):
    """The --light help named Zheng & Chellappa (1991), no longer the default estimator."""
    with pytest.raises(SystemExit):
        cli(["depth", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    start = text.index("--light L [L ...]", text.index("options:"))
    light = text[start:text.index("-u U", start)]
    assert "Zheng" not in light and "'background' method" in light and "flat frontal background" in light
