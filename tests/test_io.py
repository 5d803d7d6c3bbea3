"""gfgpu.io, the image-file layer of every command: what is read (depth, orientation, colour space,
one image per file, regular files only), what is written (format from the extension, the input's
depth, alpha), the output checks made before any work, atomic writes and their leftovers."""

import errno
import importlib.util
import os
import signal
import struct
import subprocess
import sys
import textwrap
import threading
import time
import zlib

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile
from PIL import Image

from gfgpu import io

MAGIC = {"PNG": b"\x89PNG", "TIFF": (b"II*\x00", b"MM\x00*"), "JPEG": b"\xff\xd8", "BMP": b"BM"}


def magic_of(path):
    head = open(path, "rb").read(4)
    for fmt, magic in MAGIC.items():
        if head.startswith(magic if isinstance(magic, tuple) else (magic,)):
            return fmt
    return None


# --------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------
def test_reads_at_the_stored_depth(tmp_path, rng):
    grey16 = (rng.random((12, 10)) * 65535).astype(np.uint16)
    iio.imwrite(tmp_path / "g16.png", grey16)
    np.testing.assert_array_equal(io.read_image(tmp_path / "g16.png"), grey16)
    rgba16 = (rng.random((12, 10, 4)) * 65535).astype(np.uint16)
    tifffile.imwrite(tmp_path / "c16.tif", rgba16, photometric="rgb", extrasamples=["unassalpha"])
    np.testing.assert_array_equal(io.read_image(tmp_path / "c16.tif"), rgba16)
    f = rng.random((12, 10)).astype(np.float32)
    tifffile.imwrite(tmp_path / "f.tif", f)
    np.testing.assert_array_equal(io.read_image(tmp_path / "f.tif"), f)


def test_sixteen_bit_colour_png(tmp_path, rng, monkeypatch):
    """Pillow reads a 16-bit colour PNG at 8 bits: OpenCV's plugin reads it, or it is refused."""
    pytest.importorskip("cv2")
    rgb16 = (rng.random((6, 5, 3)) * 65535).astype(np.uint16)
    io.write_image(tmp_path / "c16.png", rgb16)
    assert open(tmp_path / "c16.png", "rb").read(26)[24:26] == b"\x10\x02"   # IHDR: 16 bits, RGB
    np.testing.assert_array_equal(io.read_image(tmp_path / "c16.png"), rgb16)
    monkeypatch.setitem(sys.modules, "cv2", None)                            # OpenCV not installed
    with pytest.raises(ValueError, match="16-bit colour PNG, which Pillow reads at 8 bits only"):
        io.read_image(tmp_path / "c16.png")
    with pytest.raises(ValueError, match="16-bit colour PNG needs opencv"):
        io.write_image(tmp_path / "again.png", rgb16)


def png_bytes(samples, colour_type, bit_depth, trns=None, plte=None):
    """A PNG written here byte by byte (no encoder in between): ``samples`` (H, W[, C]) at
    ``bit_depth``, optional ``tRNS`` and ``PLTE`` chunk contents, no filtering, not interlaced."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    a = np.asarray(samples)
    h, w = a.shape[:2]
    flat = a.reshape(h, -1)
    if bit_depth == 16:
        rows = flat.astype(">u2").view(np.uint8).reshape(h, -1)
    elif bit_depth == 8:
        rows = flat.astype(np.uint8)
    else:
        bits = np.unpackbits(flat.astype(np.uint8)[..., None], axis=-1)[..., 8 - bit_depth:]
        rows = np.packbits(bits.reshape(h, -1), axis=-1)
    raw = b"".join(b"\0" + r.tobytes() for r in rows)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bit_depth, colour_type, 0, 0, 0))
    if plte is not None:
        out += chunk(b"PLTE", bytes(np.asarray(plte, np.uint8).ravel()))
    if trns is not None:
        out += chunk(b"tRNS", trns)
    return out + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


#: EXIF/TIFF orientation -> where the stored image's rows and columns go (TIFF 6.0, tag 274), written
#: out per value: 1 as stored, 2 mirrored left-right, 3 turned 180 degrees, 4 mirrored top-bottom,
#: 5 transposed (row r -> column r), 6 turned 90 degrees clockwise, 7 transverse (row r -> column
#: W-1-r, column c -> row H-1-c), 8 turned 90 degrees counter-clockwise
def upright_of(a, tag):
    h, w = a.shape
    out = np.empty((h, w) if tag <= 4 else (w, h), a.dtype)
    for r in range(h):
        for c in range(w):
            rr, cc = {1: (r, c), 2: (r, w - 1 - c), 3: (h - 1 - r, w - 1 - c), 4: (h - 1 - r, c),
                      5: (c, r), 6: (c, h - 1 - r), 7: (w - 1 - c, h - 1 - r), 8: (w - 1 - c, r)}[tag]
            out[rr, cc] = a[r, c]
    return out


def test_exif_and_tiff_orientation_are_applied(tmp_path):
    a = np.arange(48, dtype=np.uint8).reshape(6, 8)
    upright = {tag: upright_of(a, tag) for tag in range(1, 9)}
    assert np.array_equal(upright[7], a[::-1, ::-1].T) and not np.array_equal(upright[7], upright[5])
    for tag, expect in upright.items():
        im = Image.fromarray(a)
        exif = im.getexif()
        exif[0x0112] = tag
        im.save(tmp_path / f"o{tag}.png", exif=exif)
        np.testing.assert_array_equal(io.read_image(tmp_path / f"o{tag}.png"), expect)
        tifffile.imwrite(tmp_path / f"o{tag}.tif", a, extratags=[(274, "H", 1, tag, True)])
        np.testing.assert_array_equal(io.read_image(tmp_path / f"o{tag}.tif"), expect)


def test_png_transparency_chunk_becomes_alpha(tmp_path):
    """tRNS (a palette's transparent entries, one transparent grey or RGB colour) is read as an alpha
    channel at the image's depth, not dropped."""
    palette = [(0, 0, 0), (255, 0, 0), (0, 255, 0)]
    index = np.array([[0, 1, 2], [2, 1, 0]], np.uint8)
    cases = {
        "palette": (png_bytes(index, 3, 8, plte=palette, trns=bytes([0, 128])),      # entry 2: opaque
                    np.concatenate([np.array(palette, np.uint8)[index], np.array([0, 128, 255], np.uint8)[index,
                                    None]], axis=-1)),
        "grey8": (png_bytes(np.array([[7, 9], [9, 7]]), 0, 8, trns=struct.pack(">H", 7)),
                  np.array([[[7, 0], [9, 255]], [[9, 255], [7, 0]]], np.uint8)),
        "grey16": (png_bytes(np.array([[1000, 9]]), 0, 16, trns=struct.pack(">H", 1000)),
                   np.array([[[1000, 0], [9, 65535]]], np.uint16)),
        "grey2": (png_bytes(np.array([[0, 1, 2, 3]]), 0, 2, trns=struct.pack(">H", 1)),   # samples x 85
                  np.array([[[0, 255], [85, 0], [170, 255], [255, 255]]], np.uint8)),
        "grey1": (png_bytes(np.array([[0, 1, 1]]), 0, 1, trns=struct.pack(">H", 1)),
                  np.array([[[0, 255], [255, 0], [255, 0]]], np.uint8)),
        "rgb8": (png_bytes(np.array([[[1, 2, 3], [1, 2, 4]]]), 2, 8, trns=struct.pack(">HHH", 1, 2, 3)),
                 np.array([[[1, 2, 3, 0], [1, 2, 4, 255]]], np.uint8)),
    }
    if importlib.util.find_spec("cv2") is not None:
        cases["rgb16"] = (png_bytes(np.array([[[1000, 2, 3], [1000, 2, 4]]]), 2, 16,
                                    trns=struct.pack(">HHH", 1000, 2, 3)),
                          np.array([[[1000, 2, 3, 0], [1000, 2, 4, 65535]]], np.uint16))
    for name, (data, expect) in cases.items():
        (tmp_path / f"{name}.png").write_bytes(data)
        got = io.read_image(tmp_path / f"{name}.png")
        assert got.dtype == expect.dtype, name
        np.testing.assert_array_equal(got, expect, err_msg=name)


def test_truncated_16_bit_colour_png_is_one_line_from_gfgpu(tmp_path, rng):
    """OpenCV decodes 16-bit colour PNGs: a damaged one must not reach libpng (which prints its own
    line on stderr) and must not say "Could not read index"."""
    pytest.importorskip("cv2")
    data = png_bytes((rng.random((40, 40, 3)) * 65535).astype(np.uint16), 2, 16)
    cut = data[: len(data) // 2]
    damaged = data[:100] + bytes([data[100] ^ 0xFF]) + data[101:]
    for name, content, why in (("cut.png", cut, "truncated PNG: the file ends inside its IDAT chunk"),
                               ("crc.png", damaged, "corrupt PNG: the checksum of its IDAT chunk is wrong")):
        (tmp_path / name).write_bytes(content)
        code = f"from gfgpu import io\ntry:\n    io.read_image({str(tmp_path / name)!r})\n" \
               f"except ValueError as e:\n    print(e)\n"
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert res.stdout.strip() == f"cannot read image {str(tmp_path / name)!r}: {why}", res
        assert res.stderr == "", res.stderr


def test_cmyk_jpeg_is_read_as_rgb(tmp_path):
    Image.new("CMYK", (8, 6), (0, 255, 255, 0)).save(tmp_path / "red.jpg", quality=100)   # no cyan, full magenta
    img = io.read_image(tmp_path / "red.jpg")
    assert img.shape == (6, 8, 3) and img.dtype == np.uint8
    np.testing.assert_allclose(img[3, 4], [255, 0, 0], atol=2)
    cmyk = np.zeros((4, 4, 4), np.uint8)
    cmyk[..., 1] = cmyk[..., 2] = 255
    tifffile.imwrite(tmp_path / "red.tif", cmyk, photometric="separated")
    np.testing.assert_array_equal(io.read_image(tmp_path / "red.tif")[0, 0], [255, 0, 0])


@pytest.mark.parametrize("make, message", [
    (lambda p: iio.imwrite(p / "x.gif", np.stack([np.full((8, 8, 3), v, np.uint8) for v in (0, 90, 180)]),
                           duration=100, loop=0), "holds 3 frames"),
    (lambda p: tifffile.imwrite(p / "x.tif", np.zeros((3, 8, 8), np.uint8), photometric="minisblack"),
     "holds 3 images \\(a multi-page TIFF\\)"),
    (lambda p: tifffile.imwrite(p / "x.tif", np.ones((8, 8), np.complex64)), "complex samples \\(complex64\\)"),
    (lambda p: (p / "x.png").write_bytes(b""), "the file is empty"),
    (lambda p: (p / "x.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40), "not a readable image"),
    (lambda p: (p / "x.png").write_bytes(b"hello, world"), "not a readable image"),
])
def test_files_that_are_refused_with_one_line(tmp_path, make, message):
    make(tmp_path)
    (path,) = [tmp_path / n for n in os.listdir(tmp_path)]
    with pytest.raises(ValueError, match=message) as info:
        io.read_image(path)
    assert str(info.value).startswith(f"cannot read image {str(path)!r}: ") and "\n" not in str(info.value)


def test_truncated_png_names_the_file(tmp_path, rng):
    iio.imwrite(tmp_path / "full.png", (rng.random((40, 40)) * 255).astype(np.uint8))
    data = (tmp_path / "full.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cannot read image .*cut\.png'.*truncated"):
        io.read_image(tmp_path / "cut.png")


def test_decompression_bomb_is_one_line(tmp_path, monkeypatch):
    iio.imwrite(tmp_path / "big.png", np.zeros((40, 40), np.uint8))
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 100)          # 1600 pixels > 2 x the limit
    with pytest.raises(ValueError, match=r"big\.png.*decompression bomb.*MAX_IMAGE_PIXELS") as info:
        io.read_image(tmp_path / "big.png")
    assert "\n" not in str(info.value)


def test_a_fifo_is_refused_without_being_opened(tmp_path):
    os.mkfifo(tmp_path / "pipe.png")
    outcome = []

    def read():
        try:
            io.read_image(tmp_path / "pipe.png")
        except ValueError as exc:
            outcome.append(str(exc))

    t = threading.Thread(target=read, daemon=True)
    t.start()
    t.join(20)
    assert not t.is_alive(), "read_image opened the FIFO and blocks"
    assert outcome and "a FIFO (named pipe), not a regular file" in outcome[0]
    assert io.regular_file_problem(tmp_path / "pipe.png") == "a FIFO (named pipe)"
    assert io.regular_file_problem(tmp_path) == "a directory"
    assert io.regular_file_problem(tmp_path / "missing.png") is None
    with pytest.raises(FileNotFoundError):
        io.read_image(tmp_path / "missing.png")


# --------------------------------------------------------------------------------------
# writing: format from the extension, the input's depth, alpha
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, fmt", [("a.png", "PNG"), ("a.tif", "TIFF"), ("a.TIFF", "TIFF"), ("a.jpg", "JPEG"),
                                       ("a.jpeg", "JPEG"), ("a.bmp", "BMP")])
def test_format_follows_the_extension(tmp_path, name, fmt, rng):
    img = (rng.random((8, 9, 3)) * 255).astype(np.uint8)
    io.write_image(tmp_path / name, img)
    assert magic_of(tmp_path / name) == fmt
    back = io.read_image(tmp_path / name)
    assert back.shape == img.shape
    if fmt != "JPEG":
        np.testing.assert_array_equal(back, img)


@pytest.mark.parametrize("name", ["a.txt", "a", "a.gif", "a.npy"])
def test_other_extensions_are_refused(tmp_path, name):
    with pytest.raises(ValueError, match="unknown image format"):
        io.write_image(tmp_path / name, np.zeros((4, 4), np.uint8))
    assert not os.listdir(tmp_path)


def test_alpha_is_kept_where_the_format_has_it(tmp_path, rng):
    rgba = (rng.random((8, 9, 4)) * 255).astype(np.uint8)
    for name in ("a.png", "a.tif"):
        io.write_image(tmp_path / name, rgba)
        np.testing.assert_array_equal(io.read_image(tmp_path / name), rgba)
    for name, image in (("a.bmp", rgba), ("la.jpg", rgba[..., [0, 3]]), ("a.jpeg", rgba)):   # no alpha there:
        with pytest.raises(ValueError, match=r"holds no alpha channel; write a \.png or \.tif to keep it"):
            io.write_image(tmp_path / name, image)                 # refused, never dropped
        with pytest.raises(ValueError, match=r"-o .*: (JPEG|BMP) holds 8-bit samples without alpha and the "
                                             r"input has an alpha channel; write a \.png or \.tif"):
            io.check_keeps(image, tmp_path / name, "-o")
        with pytest.raises(ValueError, match="alpha"):
            io.save_image(tmp_path / name, image.astype(np.float32), image)
    assert sorted(os.listdir(tmp_path)) == ["a.png", "a.tif"]


def test_to_output_writes_what_was_read_at_its_depth():
    res = np.array([[-3.2, 0.4], [100.6, 70000.0]])
    u8, u16, f32, f64, i16 = (np.zeros((2, 2), t) for t in (np.uint8, np.uint16, np.float32, np.float64, np.int16))
    np.testing.assert_array_equal(io.to_output(res, u8, "o.png"), [[0, 0], [101, 255]])
    np.testing.assert_array_equal(io.to_output(res, u8, "o.tif"), [[0, 0], [101, 255]])
    out = io.to_output(res, u16, "o.png")
    assert out.dtype == np.uint16 and out.tolist() == [[0, 0], [101, 65535]]
    assert io.to_output(res, u16, "o.tiff").dtype == np.uint16
    for name in ("o.jpg", "o.bmp"):                                                 # 16 bits: refused
        with pytest.raises(ValueError, match=r"16-bit samples; write a \.png or \.tif to keep it"):
            io.to_output(res * 257, u16, name)
    assert io.to_display_8bit(res * 257, u16).tolist() == [[0, 0], [101, 255]]       # v / 257 (GIF, display)
    assert io.to_output(res, f32, "o.tif").dtype == np.float32
    assert io.to_output(res, f64, "o.tif").dtype == np.float64
    np.testing.assert_array_equal(io.to_output(res, f32, "o.tif"), res.astype(np.float32))
    assert io.to_output(res, i16, "o.tif").tolist() == [[-3, 0], [101, 32767]]
    grad = np.array([[0.0, 0.5], [1.0, 2.0]])
    np.testing.assert_array_equal(io.to_output(grad, grad, "o.png"), io.to_display_8bit(grad, grad))
    assert io.to_output(grad, grad, "o.png").tolist() == [[0, 64], [128, 255]]


def test_float_into_8_bit_formats_follows_a_stated_rule(tmp_path):
    """Float input in [0, 1] is v * 255 (0.031..0.973 stays 8..248, not stretched to 0..255); any other
    range is stretched, and conversion_note says which, with the numbers."""
    unit = np.array([[0.031, 0.5], [0.973, 0.25]], np.float32)
    for name in ("o.png", "o.jpg", "o.bmp"):
        assert io.to_output(unit, unit, name).tolist() == [[8, 128], [248, 64]]
        note = io.conversion_note(unit, name)
        assert "float32 input in [0, 1] (here 0.031..0.973)" in note and "round(v * 255)" in note
        assert "write a .tif to keep the float32 values" in note
    wide = np.array([[-2.0, 0.0], [2.0, 1.0]])
    assert io.to_output(wide, wide, "o.png").tolist() == [[0, 128], [255, 191]]
    assert "stretched from its range -2..2 to 0..255" in io.conversion_note(wide, "o.png")
    i16 = np.array([[-100, 100]], np.int16)
    assert "int16 input written as 8-bit PNG stretched" in io.conversion_note(i16, "o.png")
    for img, name in ((unit, "o.tif"), (unit.astype(np.uint8), "o.jpg"), (unit.astype(np.uint16), "o.png")):
        assert io.conversion_note(img, name) is None             # written as they are
    nan = np.array([[np.nan, 0.5]])
    assert io.to_display_8bit(nan, nan).tolist() == [[0, 128]]


def test_a_flat_16_bit_image_is_not_black(tmp_path):
    flat = np.full((6, 7), 30000, np.uint16)
    io.save_image(tmp_path / "a.png", flat.astype(np.float32), flat)
    back = io.read_image(tmp_path / "a.png")
    assert back.dtype == np.uint16 and (back == 30000).all()
    assert (io.to_display_8bit(flat, flat) == round(30000 / 257)).all()


def test_premultiplied_alpha_round_trip_and_no_fringes():
    rgba = np.zeros((1, 6, 4), np.uint8)
    rgba[0, 3:] = (200, 40, 10, 255)                  # opaque colour beside transparent black
    work = io.premultiply(rgba)
    blurred = (work + np.roll(work, 1, axis=1)) / 2   # any linear filter of all channels
    out = io.unpremultiply(blurred, rgba.dtype)
    edge = out[0, 3]                                  # half covered: alpha 127.5, colour unchanged
    np.testing.assert_allclose(edge, [200, 40, 10, 127.5], rtol=1e-6)
    np.testing.assert_allclose(io.unpremultiply(work, rgba.dtype)[0, 3:], rgba[0, 3:])
    assert (out[0, 1:3] == 0).all()                   # fully transparent: colour 0


# --------------------------------------------------------------------------------------
# output checks before any work; atomic writes
# --------------------------------------------------------------------------------------
def test_check_output_before_any_work(tmp_path):
    assert io.check_output(tmp_path / "a.png", name="-o") == str(tmp_path / "a.png")
    with pytest.raises(FileNotFoundError, match=r"-o .*: the folder .*missing does not exist"):
        io.check_output(tmp_path / "missing" / "a.png", name="-o")
    assert not (tmp_path / "missing").exists()
    (tmp_path / "file.png").write_bytes(b"x")
    with pytest.raises(NotADirectoryError, match="file.png is not a directory"):
        io.check_output(tmp_path / "file.png" / "a.png")
    with pytest.raises(IsADirectoryError):
        io.check_output(tmp_path)
    with pytest.raises(ValueError, match=r"--npy .*a\.png: the extension must be \.npy, got \.png"):
        io.check_output(tmp_path / "a.png", name="--npy", extensions=(".npy",))
    with pytest.raises(OSError, match="/proc"):
        io.check_output("/proc/d.png")
    assert sorted(os.listdir(tmp_path)) == ["file.png"]     # the probe file is gone


def test_read_only_folder(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes into a read-only folder anyway")
    ro = tmp_path / "ro"
    ro.mkdir()
    os.chmod(ro, 0o555)
    try:
        with pytest.raises(PermissionError, match="cannot create a file in"):
            io.check_output(ro / "a.png", name="-o")
        with pytest.raises(io.OutputError, match=r"cannot write .*ro/a\.png"):
            io.write_image(ro / "a.png", np.zeros((4, 4), np.uint8))
    finally:
        os.chmod(ro, 0o755)


def test_a_full_disk_names_the_output_not_the_temporary(tmp_path, monkeypatch):
    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io, "_write_bytes", full)        # the one write of every encoded PNG, JPEG, BMP
    monkeypatch.setattr(tifffile, "imwrite", full)
    for name in ("a.png", "a.jpg", "a.bmp", "a.tif"):
        with pytest.raises(io.OutputError) as info:
            io.write_image(tmp_path / name, np.zeros((4, 4), np.uint8))
        assert str(info.value) == f"cannot write {tmp_path / name}: No space left on device"
        assert info.value.errno == errno.ENOSPC and isinstance(info.value, OSError)
    assert not os.listdir(tmp_path)
    with pytest.raises(io.OutputError, match="does-not-exist"):
        io.save_npy(tmp_path / "does-not-exist" / "a.npy", np.zeros(3))
    assert not (tmp_path / "does-not-exist").exists()          # a missing folder is not created


def test_stale_temporaries_of_killed_runs_are_removed(tmp_path):
    """A SIGKILLed writer leaves its .gfgpu-HOST-PID-* file; only dead or old ones are removed."""
    code = textwrap.dedent(f"""
        import time, gfgpu.io as io
        def write(tmp):
            open(tmp, "wb").write(b"partial")
            print("writing", flush=True)
            time.sleep(60)
        io.write_atomic({str(tmp_path / "out.png")!r}, write)
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "writing"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    (left,) = [n for n in os.listdir(tmp_path) if n.startswith(".gfgpu-")]
    assert f"-{proc.pid}-" in left and left.endswith(".png")
    mine = tmp_path / f"{io._temp_prefix()}abcdefgh.png"      # this process runs: kept, whatever its age
    mine.write_bytes(b"")
    legacy_old, legacy_new = tmp_path / ".gfgpu-k3j4h5g6.png", tmp_path / ".gfgpu-a1b2c3d4.npy"
    for p in (legacy_old, legacy_new):
        p.write_bytes(b"")
    os.utime(legacy_old, (time.time() - 3 * 86400,) * 2)
    os.utime(mine, (time.time() - 3 * 86400,) * 2)
    others = [tmp_path / ".gfgpu-notes", tmp_path / "x.gfgpu-12345678.png", tmp_path / ".gfgpu-k3j4h5g6.png.keep"]
    for p in others:
        p.write_bytes(b"")
        os.utime(p, (time.time() - 3 * 86400,) * 2)
    removed = io.remove_stale_temporaries(tmp_path)
    assert sorted(removed) == sorted([str(tmp_path / left), str(legacy_old)])
    assert mine.exists() and legacy_new.exists() and all(p.exists() for p in others)
    assert io.remove_stale_temporaries(tmp_path / "nowhere") == []


@pytest.mark.parametrize("colour", [False, True])
def test_animated_gif_reads_back_frame_by_frame(tmp_path, colour):
    # grey frames that differ a lot: Pillow wrote the first as L and the rest as P, and
    # imageio.v3 could not read the file ("No packer found from P to L")
    from gfgpu.io import save_gif
    # later frames with fewer grey levels than the first (a fade, a blur) are where it broke
    ramp = np.tile(np.arange(256, dtype=np.uint8), (8, 1))
    frames = np.stack([ramp // (k + 1) for k in range(5)])
    if colour:
        frames = np.stack([frames, 255 - frames, frames // 2], axis=-1)
    save_gif(tmp_path / "a.gif", frames, fps=10)
    back = iio.imread(tmp_path / "a.gif", index=None)
    assert len(list(iio.imiter(tmp_path / "a.gif"))) == 5
    if colour:
        assert back.shape == frames.shape
    else:
        if back.ndim == 4:                        # a reader may expand the grey palette to RGB
            assert (back == back[..., :1]).all()
            back = back[..., 0]
        assert np.array_equal(back, frames)       # grey: every level kept exactly
