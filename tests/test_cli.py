"""The ``gfgpu`` command as a user meets it: version, ``python -m gfgpu``, the backend line,
one-line errors, the devices table, and no stray Warp warning."""

import os
import subprocess
import sys

import numpy as np
import pytest

import gfgpu
from gfgpu.cli import main


def run(*argv, env=None):
    return subprocess.run([sys.executable, "-m", "gfgpu", *map(str, argv)], capture_output=True, text=True,
                          env=env, timeout=300)


def test_version_and_python_dash_m():
    res = run("--version")
    assert res.returncode == 0 and res.stdout.strip() == f"gfgpu {gfgpu.__version__}"
    assert gfgpu.__version__.count(".") == 2


@pytest.mark.parametrize("argv", [["--version"], ["--help"], ["blur", "--help"], ["devices"]])
def test_the_command_runs_without_docstrings(argv):
    """``python -OO`` drops every docstring: the command line must not read one."""
    res = subprocess.run([sys.executable, "-OO", "-m", "gfgpu", *argv], capture_output=True, text=True)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr[-2000:]


@pytest.mark.parametrize("backend", ["numpy", "opencl", "warp"])
def test_every_command_says_which_backend_ran(tmp_path, capsys, require_backend, backend):
    be = require_backend(backend)
    out = tmp_path / "g.png"
    code = main(["gradient", "--example", "camera", "-o", str(out), "--backend", backend])
    text = capsys.readouterr()
    assert code == 0, text.err
    assert f"on {be.device}" in text.out
    first = text.out.splitlines()[0]
    assert first.startswith(f"gfgpu gradient: backend {backend} on ")
    assert main(["gradient", "--example", "camera", "-o", str(out), "--backend", backend, "--quiet"]) == 0
    assert "backend" not in capsys.readouterr().out


def test_errors_are_one_line_without_traceback(tmp_path):
    cases = [
        ("shift", tmp_path / "missing.png", "-o", tmp_path / "o.png", "--dx", 1),
        ("gradient", "--example", "camera", "-o", tmp_path / "o.png", "-u", -1, "--backend", "numpy"),
        ("blur", "--example", "camera", "-o", tmp_path / "o.png", "--zoom", 5, "--backend", "numpy"),
        ("gradient", "--example", "camera", "-o", tmp_path / "o.png", "--device", "cuda:0"),
    ]
    for argv in cases:
        res = run(*argv)
        assert res.returncode == 2, (argv, res.stderr)
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith(f"gfgpu {argv[0]}: "), (argv, res.stderr)
        assert "Traceback" not in res.stderr


def test_refuses_to_overwrite_its_input(tmp_path):
    import imageio.v3 as iio
    src = tmp_path / "in.png"
    iio.imwrite(src, np.zeros((8, 8), np.uint8))
    before = src.read_bytes()
    res = run("shift", src, "-o", src, "--dx", 1, "--backend", "numpy")
    assert res.returncode == 2 and "refusing to overwrite" in res.stderr
    assert src.read_bytes() == before


def test_devices_table_columns_align():
    res = run("devices")
    assert res.returncode == 0
    rows = res.stdout.splitlines()
    assert rows[0].split()[:4] == ["backend", "device", "kind", "state"]
    starts = {rows[0].index(h) for h in ("device", "kind", "state")}
    for row in rows[1:]:
        # every column starts where its header does
        assert all(row[i - 2:i] == "  " and row[i] != " " for i in starts), row


def test_no_warp_warning_unless_warp_runs():
    """Automatic resolution decides without initialising Warp where no CUDA driver exists."""
    from gfgpu.backends.warp import cuda_driver_present
    if cuda_driver_present():
        pytest.skip("a CUDA driver is present: Warp is the automatic choice here")
    code = ("import numpy as np, gfgpu, sys; gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5)); "
            "print('warp' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, GFGPU_BACKEND=""))
    assert "CUDA" not in res.stderr
    code = "import numpy as np, gfgpu; gfgpu.shift(np.ones((8, 8), np.float32), (0, 1.5), backend='warp')"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if res.returncode == 0:
        assert "Could not find or load the NVIDIA CUDA driver" not in res.stderr


@pytest.fixture
def small_png(tmp_path):
    import imageio.v3 as iio
    rng = np.random.default_rng(3)
    path = tmp_path / "small.png"
    iio.imwrite(path, (rng.random((40, 48)) * 255).astype(np.uint8))
    return path


@pytest.mark.parametrize("argv", [
    ("shift", "{img}", "-o", "{out}.png", "--dx", 1.5),
    ("blur", "{img}", "-o", "{out}.png", "--dx", 6, "--dy", -2),
    ("frames", "{img}", "-o", "{out}", "--dy", 4, "-n", 3),
    ("disparity", "{img}", "{img}", "-o", "{out}.png", "--max-disparity", 4),
    ("depth", "{img}", "-o", "{out}.png", "--light", 1, 0, 1),
    ("batch", "gradient", "{img}", "-o", "{out}"),
])
def test_each_command_names_its_backend(argv, small_png, tmp_path, capsys):
    if argv[0] == "depth":
        # shape from shading needs shading: white noise is all flat background (no depth to fit)
        import imageio.v3 as iio

        from gfgpu.shading import lambertian_shading
        yy, xx = np.mgrid[-20:20, -24:24] + 0.5
        shaded = lambertian_shading(6 * np.exp(-(xx**2 + yy**2) / 120), (1, 0, 1))
        small_png = tmp_path / "shaded.png"
        iio.imwrite(small_png, np.clip(shaded * 255, 0, 255).astype(np.uint8))
    args = [str(a).format(img=small_png, out=tmp_path / "result") for a in argv]
    assert main([*args, "--backend", "numpy"]) == 0, capsys.readouterr().err
    name = argv[0] if argv[0] != "batch" else "batch"
    assert f"gfgpu {name}: backend numpy on host" in capsys.readouterr().out


@pytest.fixture
def wide_png16(tmp_path):
    import imageio.v3 as iio
    path = tmp_path / "wide16.png"
    iio.imwrite(path, (np.random.default_rng(4).random((40, 52)) * 65535).astype(np.uint16))
    return path


@pytest.mark.parametrize("argv, pattern", [
    (("blur", "{img}", "-o", "{out}.png", "--zoom", 5), r"--zoom must lie in .*got 5\.0"),
    (("blur", "{img}", "-o", "{out}.png", "--zoom", -0.9), r"--zoom must lie in .*got -0\.9"),
    (("blur", "{img}", "-o", "{out}.png", "--rotate", 400), r"--rotate must lie in \[-360, 360\].*got 400"),
    (("frames", "{img}", "-o", "{out}", "--zoom", 2, "-n", 3), r"--zoom must lie in"),
    (("frames", "{img}", "-o", "{out}", "--rotate", -361, "-n", 3), r"--rotate must lie in"),
    (("shift", "{img16}", "-o", "{out}.jpg", "--dx", 1), r"-o .*\.jpg: JPEG holds 8-bit samples.*16-bit"),
    (("blur", "{img16}", "-o", "{out}.jpg", "--dx", 3), r"-o .*\.jpg: JPEG holds 8-bit samples"),
    (("frames", "{img16}", "-o", "{out}", "--dx", 3, "-n", 3), None),
    (("disparity", "{img}", "{img16}", "-o", "{out}.png", "--max-disparity", 4),
     r"LEFT and RIGHT must have one size, got 40 x 48 and 40 x 52 \(rows x cols\)"),
])
def test_a_refused_command_never_says_a_backend_ran(tmp_path, capsys, small_png, wide_png16, argv, pattern):
    """Every check of the input and the options comes before the backend line (which says work started):
    out-of-range motion values, an output format that would lose the input's depth, a pair of two sizes."""
    args = [str(a).format(img=small_png, img16=wide_png16, out=tmp_path / "result") for a in argv]
    code = cli([*args, "--backend", "numpy"])
    if pattern is None:         # frames are PNGs (16-bit kept): this one runs, and says its backend
        assert code == 0, capsys.readouterr().err
        assert "frames: backend numpy on host" in capsys.readouterr().out
        return
    import re
    out = capsys.readouterr()
    err = out.err.strip()
    assert "backend" not in out.out, out.out
    assert code == 2 and "\n" not in err and err.startswith(f"gfgpu {argv[0]}: ") and re.search(pattern, err), err
    assert sorted(os.listdir(tmp_path)) == ["small.png", "wide16.png"]


# --------------------------------------------------------------------------------------
# files and the command line (issue 16, items 9-11)
# --------------------------------------------------------------------------------------
def cli(argv):
    """``main`` with every argument as a string, as the shell passes them."""
    return main([str(a) for a in argv])


def one_line_error(capsys, code, expect_code, command, pattern):
    """The command returned ``expect_code`` with one line ``gfgpu COMMAND: ...`` matching ``pattern``."""
    import re
    err = capsys.readouterr().err.strip()
    assert code == expect_code, err
    assert "\n" not in err and err.startswith(f"gfgpu {command}: ") and re.search(pattern, err), err
    return err


@pytest.mark.parametrize("argv, option", [
    (("shift", "{img}", "-o", "{link}", "--dx", 1), "-o"),
    (("shift", "{img}", "-o", "{hard}", "--dx", 1), "-o"),
    (("shift", "{link}", "-o", "{img}", "--dx", 1), "-o"),
    (("shift", "{img}", "-o", "{out}/o.png", "--npy", "{npy}", "--dx", 1), "--npy"),
    (("gradient", "{img}", "-o", "{img}"), "-o"),
    (("gradient", "{img}", "-o", "{out}/o.png", "--npy", "{npy}"), "--npy"),
    (("blur", "{img}", "-o", "{hard}", "--dx", 2), "-o"),
    (("depth", "{img}", "-o", "{out}/o.png", "--relief", "{link}"), "--relief"),
    (("depth", "{img}", "-o", "{out}/o.png", "--npy", "{npy}"), "--npy"),
    (("disparity", "{img}", "{img2}", "-o", "{hard}", "--max-disparity", 4), "-o"),
])
def test_no_command_writes_an_input(tmp_path, capsys, argv, option):
    """Also through a symbolic or a hard link, and for every extra output."""
    import imageio.v3 as iio
    src = tmp_path / "in.png"
    iio.imwrite(src, (np.random.default_rng(1).random((16, 20)) * 255).astype(np.uint8))
    src2 = tmp_path / "in2.png"
    src2.write_bytes(src.read_bytes())
    (tmp_path / "link.png").symlink_to(src)
    os.link(src, tmp_path / "hard.png")
    data = np.save(tmp_path / "data.npy", np.zeros(3)) or tmp_path / "data.npy"
    os.link(data, tmp_path / "in.npy")   # --npy names an input (a hard link of it)
    names = dict(img=src, img2=src2, link=tmp_path / "link.png", hard=tmp_path / "hard.png", out=tmp_path,
                 npy=tmp_path / "in.npy")
    before = {n: (tmp_path / n).read_bytes() for n in ("in.png", "in2.png", "in.npy")}
    args = [str(a).format(**names) for a in argv]
    if option == "--npy":   # --npy names an input file: make it one
        args = [str(a).format(**names) for a in argv[:1]] + [str(tmp_path / "in.npy")] + \
               [str(a).format(**names) for a in argv[2:]]
    code = cli([*args, "--backend", "numpy"])
    one_line_error(capsys, code, 2, argv[0], rf"{option} .*(refusing to overwrite|would overwrite) the input")
    assert {n: (tmp_path / n).read_bytes() for n in before} == before
    assert (tmp_path / "link.png").is_symlink() and os.path.samefile(tmp_path / "hard.png", src)


def test_frames_never_write_an_input(tmp_path, capsys, small_png):
    folder = tmp_path / "f"
    folder.mkdir()
    src = folder / "frame_001.png"
    src.write_bytes(small_png.read_bytes())
    code = cli(["frames", str(src), "-o", str(folder), "--dx", 2, "-n", 3, "--backend", "numpy"])
    one_line_error(capsys, code, 2, "frames", "would overwrite the input")
    assert src.read_bytes() == small_png.read_bytes() and sorted(os.listdir(folder)) == ["frame_001.png"]


@pytest.mark.parametrize("argv, pattern", [
    (("gradient", "{img}", "-o", "{out}.png", "-u", 0), r"argument -u: must be > 0, got '0'"),
    (("gradient", "{img}", "-o", "{out}.png", "-u", "nan"), r"argument -u: must be a finite number, got 'nan'"),
    (("depth", "{img}", "-o", "{out}.png", "-u", "-2"), r"argument -u: must be > 0"),
    (("shift", "{img}", "-o", "{out}.png", "--dx", "nan"), r"argument --dx: must be a finite number"),
    (("shift", "{img}", "-o", "{out}.png", "--dy", "1e400"), r"argument --dy: must be a finite number, got '1e400'"),
    (("blur", "{img}", "-o", "{out}.png", "--zoom", "inf"), r"argument --zoom: must be a finite number"),
    (("frames", "{img}", "-o", "{out}", "--dx", 2, "--fps", "nan"), r"argument --fps: must be a finite number"),
    (("frames", "{img}", "-o", "{out}", "--dx", 2, "-n", 0), r"argument -n/--frames: must be >= 1"),
    (("shift", "{img}", "-o", "{out}.png", "--dx", "one"), r"argument --dx: expected a number, got 'one'"),
    (("disparity", "{img}", "{img}", "-o", "{out}.png", "--max-disparity", 0),
     r"argument --max-disparity: must be >= 1"),
])
def test_bad_option_values_are_one_line_usage_errors(tmp_path, capsys, small_png, argv, pattern):
    args = [str(a).format(img=small_png, out=tmp_path / "result") for a in argv]
    with pytest.raises(SystemExit) as info:
        cli([*args, "--backend", "numpy"])
    one_line_error(capsys, info.value.code, 2, argv[0], pattern)
    assert sorted(os.listdir(tmp_path)) == ["small.png"]


def test_an_unknown_device_names_the_option(tmp_path, capsys, small_png):
    code = cli(["shift", str(small_png), "-o", str(tmp_path / "o.png"), "--dx", 1, "--backend", "numpy",
                 "--device", "gpu7"])
    one_line_error(capsys, code, 2, "shift", r"--device gpu7: .*host")
    code = cli(["shift", str(small_png), "-o", str(tmp_path / "o.png"), "--dx", 1, "--device", "gpu7"])
    one_line_error(capsys, code, 2, "shift", r"--device gpu7: ")
    assert not (tmp_path / "o.png").exists()


@pytest.mark.parametrize("output, pattern", [
    ("{tmp}/missing/x.png", r"-o .*missing/x\.png: the folder .*missing does not exist \(it is not created\)"),
    ("{img}/x.png", r"small\.png is not a directory"),
    ("/proc/x.png", r"-o /proc/x\.png: cannot create a file in /proc"),
    ("{tmp}", r"is a directory"),
    ("{tmp}/x.txt", r"-o .*x\.txt: the extension must be \.png or \.tif or \.tiff or \.jpg or \.jpeg or \.bmp"),
    ("{tmp}/x", r"the extension must be .*, got none"),
])
def test_output_paths_are_checked_before_any_work(tmp_path, capsys, small_png, monkeypatch, output, pattern):
    import gfgpu.cli.shift as shift_command
    monkeypatch.setattr(shift_command, "shift", lambda *a, **k: pytest.fail("computed before checking -o"))
    out = output.format(tmp=tmp_path, img=small_png)
    code = cli(["shift", str(small_png), "-o", out, "--dx", 1, "--backend", "numpy"])
    one_line_error(capsys, code, 2, "shift", pattern)
    assert not (tmp_path / "missing").exists() and sorted(os.listdir(tmp_path)) == ["small.png"]


def test_npy_must_end_in_npy_and_differ_from_the_output(tmp_path, capsys, small_png):
    code = cli(["shift", str(small_png), "-o", str(tmp_path / "x.png"), "--npy", str(tmp_path / "x.png"),
                 "--dx", 1, "--backend", "numpy"])
    one_line_error(capsys, code, 2, "shift", r"--npy and -o name the same file")
    code = cli(["gradient", str(small_png), "-o", str(tmp_path / "x.png"), "--npy", str(tmp_path / "raw.png"),
                 "--backend", "numpy"])
    one_line_error(capsys, code, 2, "gradient", r"--npy .*raw\.png: the extension must be \.npy, got \.png")
    assert sorted(os.listdir(tmp_path)) == ["small.png"]


def test_disparity_output_in_proc_fails_at_once(capsys, monkeypatch):
    import gfgpu.cli.disparity as command

    def must_not_run(*args, **kwargs):
        raise AssertionError("the disparity was computed before the output path was checked")
    monkeypatch.setattr(command, "disparity", must_not_run)      # the work (37 s before) never starts
    code = cli(["disparity", "--example", "motorcycle", "--method", "uniform", "-o", "/proc/d.png",
                "--backend", "numpy"])
    one_line_error(capsys, code, 2, "disparity", r"-o /proc/d\.png: ")


def test_a_full_disk_is_failed_work(tmp_path, capsys, small_png, monkeypatch):
    """Exit status 1 (the work was done, its output could not be written), one line naming the output."""
    import errno

    def full(tmp, data):                       # every encoded image goes through this one write
        with open(tmp, "wb") as f:
            f.write(bytes(data[:10]))
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(gfgpu.io, "_write_bytes", full)
    code = cli(["shift", str(small_png), "-o", str(tmp_path / "o.png"), "--dx", 1, "--backend", "numpy", "-q"])
    one_line_error(capsys, code, 1, "shift", rf"cannot write {tmp_path / 'o.png'}: No space left on device$")
    assert sorted(os.listdir(tmp_path)) == ["small.png"]          # no temporary file left


@pytest.mark.parametrize("content, pattern", [
    (b"", r"the file is empty \(0 bytes\)"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", r"(?i)not a readable image|truncated|broken"),
    (b"GIF89a nonsense", r"not a readable image|truncated"),
])
def test_corrupt_inputs_are_one_line(tmp_path, content, pattern):
    bad = tmp_path / "bad.png"
    bad.write_bytes(content)
    res = run("shift", bad, "-o", tmp_path / "o.png", "--dx", 1, "--backend", "numpy", "-q")
    assert res.returncode == 2 and "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"gfgpu shift: cannot read image {str(bad)!r}: "), res.stderr
    import re
    assert re.search(pattern, lines[0]) and "plugin" not in lines[0], lines[0]


def test_decompression_bomb_is_one_line(tmp_path, capsys, small_png, monkeypatch):
    from PIL import Image
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 100)
    code = cli(["gradient", str(small_png), "-o", str(tmp_path / "o.png"), "--backend", "numpy", "-q"])
    one_line_error(capsys, code, 2, "gradient", r"small\.png.*decompression bomb")


def test_output_format_follows_the_extension(tmp_path, small_png):
    from test_io import magic_of
    for name, fmt in (("o.png", "PNG"), ("o.tif", "TIFF"), ("o.jpg", "JPEG"), ("o.bmp", "BMP")):
        for argv in (("shift", "--dx", 1), ("gradient",), ("blur", "--dx", 3)):
            out = tmp_path / f"{argv[0]}-{name}"
            assert cli([argv[0], str(small_png), "-o", str(out), *map(str, argv[1:]), "--backend", "numpy",
                         "-q"]) == 0
            assert magic_of(out) == fmt, out


def test_sixteen_bit_and_float_inputs_keep_their_depth(tmp_path):
    import imageio.v3 as iio
    import tifffile
    flat = np.full((20, 24), 30000, np.uint16)
    iio.imwrite(tmp_path / "flat16.png", flat)
    assert cli(["shift", str(tmp_path / "flat16.png"), "-o", str(tmp_path / "o16.png"), "--dx", 1.5,
                 "--backend", "numpy", "-q"]) == 0
    out = iio.imread(tmp_path / "o16.png")
    assert out.dtype == np.uint16 and (out == 30000).all()          # not black, not 8-bit
    ramp = np.linspace(0, 1, 20 * 24, dtype=np.float32).reshape(20, 24)
    tifffile.imwrite(tmp_path / "f.tif", ramp)
    assert cli(["blur", str(tmp_path / "f.tif"), "-o", str(tmp_path / "b.tif"), "--dx", 4, "--backend", "numpy",
                 "-q"]) == 0
    raw = tifffile.imread(tmp_path / "b.tif")
    ref = gfgpu.motion_blur(ramp, (0.0, 4.0), backend="numpy")
    assert raw.dtype == np.float32
    np.testing.assert_array_equal(raw, ref)
    assert cli(["blur", str(tmp_path / "f.tif"), "-o", str(tmp_path / "b.png"), "--dx", 4, "--backend", "numpy",
                 "-q"]) == 0
    np.testing.assert_array_equal(iio.imread(tmp_path / "b.png"), gfgpu.io.to_display_8bit(ref, ramp))


@pytest.mark.parametrize("command, motion", [("shift", ("--dx", 2.5)), ("blur", ("--dx", 6)),
                                             ("frames", ("--dx", 6, "-n", 3))])
def test_alpha_is_kept_without_dark_fringes(tmp_path, command, motion):
    """An opaque orange square on transparent black: filtered premultiplied, the edge pixels keep the
    square's colour and only their alpha falls (a plain filter would darken them)."""
    import imageio.v3 as iio
    rgba = np.zeros((24, 32, 4), np.uint8)
    rgba[6:18, 10:22] = (230, 120, 20, 255)
    iio.imwrite(tmp_path / "sq.png", rgba)
    out = tmp_path / ("o" if command == "frames" else "o.png")
    assert cli([command, str(tmp_path / "sq.png"), "-o", str(out), *map(str, motion), "--backend", "numpy",
                 "-q"]) == 0
    res = iio.imread(out / "frame_002.png" if command == "frames" else out)
    assert res.shape == (24, 32, 4)
    partly = (res[..., 3] > 20) & (res[..., 3] < 235)
    assert partly.any()
    np.testing.assert_allclose(res[partly][:, :3], np.broadcast_to([230, 120, 20], (partly.sum(), 3)), atol=3)
    assert res[..., 3].min() == 0 and res[..., 3].max() >= 200


def test_cmyk_jpeg_exif_orientation_and_multi_frame_inputs(tmp_path, capsys):
    import imageio.v3 as iio
    from PIL import Image
    Image.new("CMYK", (16, 12), (0, 255, 255, 0)).save(tmp_path / "cmyk.jpg", quality=100)
    assert cli(["shift", str(tmp_path / "cmyk.jpg"), "-o", str(tmp_path / "c.png"), "--dx", 1,
                 "--backend", "numpy", "-q"]) == 0
    np.testing.assert_allclose(iio.imread(tmp_path / "c.png")[6, 8], [255, 0, 0], atol=3)   # RGB, red
    a = (np.arange(12 * 16) % 251).astype(np.uint8).reshape(12, 16)
    im = Image.fromarray(a)
    exif = im.getexif()
    exif[0x0112] = 6                                   # stored sideways: shown rotated 90 degrees clockwise
    im.save(tmp_path / "side.png", exif=exif)
    assert cli(["shift", str(tmp_path / "side.png"), "-o", str(tmp_path / "s.png"), "--dx", 0, "--backend", "numpy",
                 "-q"]) == 0
    np.testing.assert_array_equal(iio.imread(tmp_path / "s.png"), np.rot90(a, -1))
    iio.imwrite(tmp_path / "anim.gif", np.stack([np.full((8, 8, 3), v, np.uint8) for v in (0, 90, 180)]),
                duration=100, loop=0)
    code = cli(["blur", str(tmp_path / "anim.gif"), "-o", str(tmp_path / "b.png"), "--dx", 2, "--backend",
                 "numpy", "-q"])
    one_line_error(capsys, code, 2, "blur", r"anim\.gif'?: it holds 3 frames .*extract the frames first")


def test_shift_without_an_amount_is_refused(tmp_path, capsys, small_png):
    # like blur without a motion: an unshifted copy written with exit 0 hid a forgotten option
    code = cli(["shift", str(small_png), "-o", str(tmp_path / "o.png"), "--backend", "numpy"])
    one_line_error(capsys, code, 2, "shift", r"give a shift: --dx .*--dy")
    assert not (tmp_path / "o.png").exists()


def test_blur_takes_the_box_psf(tmp_path, capsys, small_png):
    import imageio.v3 as iio

    from gfgpu.motion import motion_blur
    for psf in ("box", "green"):
        out = tmp_path / f"{psf}.tif"
        assert cli(["blur", str(small_png), "-o", str(out), "--dx", 7, "--psf", psf, "--backend", "numpy"]) == 0
        assert f"psf {psf}" in capsys.readouterr().out
    ref = motion_blur(iio.imread(small_png).astype(np.float32), (0.0, 7.0), psf="box", backend="numpy")
    np.testing.assert_allclose(iio.imread(tmp_path / "box.tif").astype(np.float32),
                               np.clip(np.rint(ref), 0, 255), atol=1)
    assert not np.array_equal(iio.imread(tmp_path / "box.tif"), iio.imread(tmp_path / "green.tif"))


# --- gfgpu canny: one image's edge map ------------------------------------------------------------
@pytest.mark.parametrize("backend", ["numpy", "opencl", "warp"])
def test_canny_command_writes_the_api_edge_map(tmp_path, capsys, require_backend, backend):
    import imageio.v3 as iio

    be = require_backend(backend)
    out = tmp_path / "edges.png"
    code = cli(["canny", "--example", "camera", "-o", out, "-u", 1.5, "--low", 0.8, "--high", 0.9,
                "--backend", backend])
    text = capsys.readouterr()
    assert code == 0, text.err
    assert text.out.splitlines()[0].startswith(f"gfgpu canny: backend {backend} on {be.device}")
    written = iio.imread(out)
    assert written.dtype == np.uint8 and written.ndim == 2 and set(np.unique(written)) == {0, 255}
    cam = gfgpu.io.example_image("camera")
    expect = gfgpu.canny(cam, 1.5, 0.8, 0.9, use_quantiles=True, backend="numpy")
    np.testing.assert_array_equal(written == 255, expect)
    assert f"{int(expect.sum())} edge pixels" in text.out


def test_canny_command_files_colour_and_defaults(tmp_path, capsys):
    import imageio.v3 as iio

    rgb = np.zeros((40, 48, 3), np.uint8)
    rgb[:, 24:] = (255, 120, 0)
    path = tmp_path / "rgb.png"
    iio.imwrite(path, rgb)
    assert cli(["canny", path, "-o", tmp_path / "e.png", "--backend", "numpy", "-q"]) == 0
    edges = iio.imread(tmp_path / "e.png") == 255
    grey = (rgb / 255.0).astype(np.float32).mean(axis=-1)
    np.testing.assert_array_equal(edges, gfgpu.canny(grey, 1.0, backend="numpy"))
    assert np.unique(np.nonzero(edges)[1]).tolist() == [24]          # one edge, no side lobes
    # a float TIFF in 0..255 (the ghost edges came through a float file)
    tif = tmp_path / "step.tif"
    iio.imwrite(tif, ((np.mgrid[:64, :64][1] >= 32) * 255.0).astype(np.float32))
    assert cli(["canny", tif, "-o", tmp_path / "s.png", "--backend", "numpy", "-q"]) == 0
    assert np.unique(np.nonzero(iio.imread(tmp_path / "s.png"))[1]).tolist() == [32]


@pytest.mark.parametrize("extra,pattern", [
    (["--low", 0.8], r"give --low and --high together"),
    (["--low", 1.5, "--high", 2], r"argument --low: expected a quantile in \[0, 1\], got '1.5'"),
    (["--low", 0.9, "--high", 0.8], r"--low \(0.9\) must not exceed --high \(0.8\)"),
    (["-u", 0], r"-u"),
    (["-u", 1e12], r"-u must lie in"),
    (["--mode", "bogus"], r"--mode"),
])
def test_canny_command_refuses_bad_options_before_work(tmp_path, capsys, extra, pattern):
    out = tmp_path / "e.png"
    try:
        code = cli(["canny", "--example", "camera", "-o", out, "--backend", "numpy", *extra])
    except SystemExit as exc:          # argparse's own checks exit from parse_args
        code = exc.code
    one_line_error(capsys, code, 2, "canny", pattern)
    assert not out.exists()


def test_canny_command_refuses_a_file_with_example(tmp_path, capsys, small_png):
    code = cli(["canny", small_png, "--example", "camera", "-o", tmp_path / "e.png", "--backend", "numpy"])
    one_line_error(capsys, code, 2, "canny", r"example")
    assert not (tmp_path / "e.png").exists()


def test_batch_canny_on_a_float_tiff_has_no_ghost_edges(tmp_path):
    """The issue's second route to the side lobes: ``gfgpu batch canny`` on a float TIFF in 0..255."""
    import imageio.v3 as iio

    src = tmp_path / "in"
    src.mkdir()
    iio.imwrite(src / "step.tif", ((np.mgrid[:64, :64][1] >= 32) * 255.0).astype(np.float32))
    for extra in ([], ["--low", 0.0, "--high", 0.5]):
        out = tmp_path / f"out{len(extra)}"
        assert cli(["batch", "canny", src / "step.tif", "-o", out, "--format", "npy", "--backend", "numpy",
                    "--quiet", *extra]) == 0
        edges = np.load(out / "step.npy")
        assert np.unique(np.nonzero(edges)[1]).tolist() == [32], extra


@pytest.mark.parametrize("argv", [["blur", "--dx", "3"], ["shift", "--dx", "1"], ["canny"], ["gradient"]])
def test_a_missing_input_is_a_usage_error_before_the_backend_starts(tmp_path, capsys, argv):
    """No IMAGE and no --example: exit 2, one line, and no "backend ... on ..." line first (it read
    as if work had started)."""
    assert main([*argv, "-o", str(tmp_path / "out.png")]) == 2
    captured = capsys.readouterr()
    assert "backend" not in captured.out, captured.out
    assert captured.err.strip() == f"gfgpu {argv[0]}: give an IMAGE path or --example camera"
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("argv", [["blur", "--dx", "3"], ["shift", "--dx", "1"], ["canny"], ["gradient"],
                                  ["frames", "--dx", "3"]])
def test_a_missing_input_file_is_named_before_the_backend_starts(tmp_path, capsys, argv):
    """An IMAGE that does not exist: exit 2, one line naming it, no "backend ... on ..." line."""
    missing = tmp_path / "nosuch.png"
    assert main([argv[0], str(missing), *argv[1:], "-o", str(tmp_path / "out.png")]) == 2
    captured = capsys.readouterr()
    assert "backend" not in captured.out, captured.out
    assert captured.err.strip() == f"gfgpu {argv[0]}: IMAGE {missing}: no such file"
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("argv, command, pattern", [
    (["depth", "--example", "camera"], "depth",
     r"unrecognized arguments: --example .*no bundled example"),
    (["shift", "--example", "camera", "--dx", "1", "--bogus"], "shift", r"unrecognized arguments: --bogus"),
    (["batch", "canny", "x.png", "-o", "out", "--bogus", "1"], "batch canny", r"unrecognized arguments: --bogus 1"),
])
def test_unknown_options_are_reported_by_the_command(tmp_path, capsys, argv, command, pattern):
    # argparse's top level used to say "gfgpu: unrecognized arguments" for any command
    with pytest.raises(SystemExit) as info:
        cli([*argv, "-o", str(tmp_path / "out.png")] if command != "batch canny" else argv)
    one_line_error(capsys, info.value.code, 2, command, pattern)
    assert not (tmp_path / "out.png").exists()
