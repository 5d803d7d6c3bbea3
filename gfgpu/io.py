"""Image files: reading (with bundled examples), writing at the input's bit depth, display
conversions and atomic writes.

Reading (:func:`read_image`): imageio's Pillow plugin and tifffile, the image upright (EXIF
orientation), CMYK converted to RGB, PNG transparency (``tRNS``) as an alpha channel, one image
per file (animations, multi-page TIFFs and complex samples are refused), never opening anything
but a regular file.  Writing (:func:`write_image`, :func:`save_image`): the format named by the
extension (:data:`IMAGE_FORMATS`; any other is refused), at the input's depth (:func:`to_output`);
what a format cannot hold is refused (16 bits or alpha in a JPEG or BMP, :func:`check_keeps`) or
converted by a stated rule (float into 8 bits, :func:`to_display_8bit`, :func:`conversion_note`),
never silently.

Every output is written to a temporary file in the destination's directory and renamed into
place, so an interrupted run never leaves a partial file; inputs are never written.  Errors are
``OSError`` (unreadable or unwritable files; :class:`OutputError` when an output could not be
written) or ``ValueError`` (bad names or contents); the command line turns them into one-line
messages.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import socket
import stat
import tempfile
import time
from importlib import resources

import numpy as np

__all__ = ["EXAMPLES", "IMAGE_FORMATS", "OutputError", "example_image", "read_image", "regular_file_problem",
           "image_format", "check_output", "write_atomic", "remove_stale_temporaries", "write_image",
           "to_output", "check_keeps", "conversion_note", "save_image", "save_png", "save_gif", "save_npy",
           "has_alpha", "alpha_scale", "premultiply",
           "unpremultiply", "to_display_8bit", "gradient_to_rgb", "colourise_disparity", "write_pfm", "read_pfm",
           "write_ply", "disparity_to_png16", "colour_bar"]

#: bundled example images (gfgpu/data/NAME.png)
EXAMPLES = ("camera",)


def example_image(name):
    """A bundled example image (``gfgpu/data/NAME.png``) as an array; ``ValueError`` if unknown."""
    import imageio.v3 as iio
    if name not in EXAMPLES:
        raise ValueError(f"example must be one of {', '.join(EXAMPLES)}; got {name!r}")
    with resources.as_file(resources.files("gfgpu.data").joinpath(f"{name}.png")) as p:
        return iio.imread(p)


#: extensions of the image formats read and written (compared case-insensitively) and the format
#: each names; an output's format is chosen from its extension, any other extension is refused
IMAGE_FORMATS = {".png": "PNG", ".tif": "TIFF", ".tiff": "TIFF", ".jpg": "JPEG", ".jpeg": "JPEG", ".bmp": "BMP"}

#: zlib level of the PNGs written: lossless like every level; on a 2000 x 3000 colour image 1.5 s
#: and 9.7 MB where Pillow's default (6) takes 4.5-5.7 s for 8.6 MB
PNG_COMPRESS_LEVEL = 1

_TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
#: Pillow modes read as RGB (colour spaces that are not RGB samples)
_TO_RGB = ("CMYK", "YCbCr", "LAB", "HSV")
#: TIFF/EXIF orientation (tag 274) -> the numpy operation that shows the image upright (TIFF 6.0
#: and EXIF 2.3: 5 transpose, 7 transverse = transpose then a 180-degree turn; colour axes untouched)
_ORIENT = {2: lambda a: a[:, ::-1], 3: lambda a: a[::-1, ::-1], 4: lambda a: a[::-1],
           5: lambda a: a.swapaxes(0, 1), 6: lambda a: np.rot90(a, -1),
           7: lambda a: a.swapaxes(0, 1)[::-1, ::-1], 8: lambda a: np.rot90(a, 1)}


class OutputError(OSError):
    """An output could not be written (the work was done): a full disk, an I/O error, ...

    Raised by :func:`write_atomic` (and so by every writer here) with the output's own path in
    the message, never the temporary file's; the command line exits with status 1 for it.
    """


def _file_kind(mode):
    for test, kind in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            return kind
    return "not a regular file"


def regular_file_problem(path):
    """``None`` if ``path`` is a regular file (or names nothing), else what it is ("a FIFO
    (named pipe)", "a directory", ...).  Only ``stat``: a FIFO is never opened (that would block)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    return None if stat.S_ISREG(mode) else _file_kind(mode)


def read_image(path):
    """The image file ``path`` as an array, upright, at the bit depth it was stored in.

    Samples keep their type (uint8, uint16, float32, ...) and channels (grey ``(H, W)``, grey +
    alpha ``(H, W, 2)``, RGB ``(H, W, 3)``, RGBA ``(H, W, 4)``).  The EXIF orientation (JPEG,
    PNG, ...; TIFF's Orientation tag, all eight values) is applied; CMYK, YCbCr and LAB images
    are converted to RGB (palette images too).  PNG transparency given by a ``tRNS`` chunk
    becomes an alpha channel at the image's depth: a palette's transparent entries (RGBA), one
    transparent grey or RGB colour (alpha 0 there, opaque elsewhere; 1-bit grey becomes 8-bit
    0/255).  TIFF is read with tifffile, the other formats with imageio's Pillow plugin; a
    16-bit colour PNG, which Pillow reads at 8 bits only, with imageio's OpenCV plugin
    (``opencv-python-headless``) or not at all; its chunks and image data are checked first, so
    a truncated or corrupt one is refused in gfgpu's one line, not libpng's.

    Raises
    ------
    OSError
        The file cannot be opened (``FileNotFoundError``, ``PermissionError``, ...).
    ValueError
        Not a regular file (a FIFO, a directory, a device: never opened), an empty file, contents
        that cannot be decoded (corrupt, truncated, an unknown format, a decompression bomb), a
        file of several images (an animated GIF or PNG, a multi-page TIFF: gfgpu processes one
        image per file) or complex samples.  The message names the file and says why, in one line.
    """
    import imageio.v3 as iio
    name = os.fspath(path)
    st = os.stat(name)                                  # FileNotFoundError, PermissionError
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"cannot read image {name!r}: it is {_file_kind(st.st_mode)}, not a regular file "
                         f"(not opened)")
    if st.st_size == 0:
        raise ValueError(f"cannot read image {name!r}: the file is empty (0 bytes)")
    with open(name, "rb") as f:                         # PermissionError
        head = f.read(32)
    try:
        if head[:4] in _TIFF_MAGIC:
            return _read_tiff(name)
        return _read_pillow(iio, name, head)
    except _Refused as exc:
        raise ValueError(f"cannot read image {name!r}: {exc}") from None
    except Exception as exc:    # Pillow raises OSError, ValueError, SyntaxError, DecompressionBombError, ...
        cause = _root_cause(exc)
        if not isinstance(cause, (OSError, ValueError, SyntaxError, EOFError, MemoryError, IndexError, KeyError)) \
                and type(cause).__name__ != "DecompressionBombError":
            raise
        raise ValueError(f"cannot read image {name!r}: {_reason(cause)}") from None


def _root_cause(exc):
    """The error a plugin wrapped (imageio re-raises Pillow's errors as its own)."""
    seen = {id(exc)}
    while True:
        inner = exc.__cause__ or exc.__context__
        if inner is None or id(inner) in seen or "unknown error occurred" not in str(exc):
            return exc
        seen.add(id(inner))
        exc = inner


class _Refused(Exception):
    """A readable file gfgpu does not process (several frames, complex samples, ...)."""


def _reason(exc):
    """One line saying why a decoder failed (imageio appends lines of plugin hints)."""
    if type(exc).__name__ == "DecompressionBombError":
        return f"{exc} (Pillow's limit PIL.Image.MAX_IMAGE_PIXELS; raise it only for a file you trust)"
    if isinstance(exc, MemoryError):
        return "not enough memory to decode it"
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    unknown = ("Could not find a backend", "cannot identify image file", "can not handle the given uri")
    if not lines or any(text in lines[0] for text in unknown):
        return "not a readable image (corrupt, or an unsupported format)"
    return lines[0]


def _read_pillow(iio, name, head):
    props = iio.improps(name, plugin="pillow", index=None)
    if props.is_batch and props.n_images != 1:
        raise _Refused(f"it holds {props.n_images} frames (an animation or a multi-page file); gfgpu "
                       f"processes one image per file: extract the frames first")
    png = head[:8] == _PNG_MAGIC and head[12:16] == b"IHDR"
    if png and head[24] == 16 and head[25] in (2, 4, 6):
        return _read_png16_colour(iio, name, head[25])
    meta = iio.immeta(name, plugin="pillow")
    mode, key = meta.get("mode"), meta.get("transparency")
    if mode == "P" and key is not None:
        # a palette with transparent entries (PNG tRNS, GIF): Pillow's RGBA conversion applies them
        return np.asarray(iio.imread(name, plugin="pillow", index=0, rotate=True, mode="RGBA"))
    image = np.asarray(iio.imread(name, plugin="pillow", index=0, rotate=True,
                                  mode="RGB" if mode in _TO_RGB else None))
    if key is not None and mode in ("1", "L", "I;16", "I", "RGB") and image.ndim == (3 if mode == "RGB" else 2):
        image = _colour_key_alpha(image, mode, key, head[24] if png and head[25] == 0 else 8)
    return image


def _colour_key_alpha(image, mode, key, bit_depth):
    """Grey or RGB with one transparent colour (PNG tRNS): an alpha channel, 0 where the pixel is that
    colour, opaque elsewhere.  Pillow gives the key at the file's bit depth but scales 2- and 4-bit
    grey samples to 0..255, so the key is scaled alike; 1-bit grey becomes 0/255 8-bit grey + alpha."""
    if image.dtype == bool:
        grey = image.astype(np.uint8) * np.uint8(255)
        return np.stack([grey, np.where(grey == (255 if key else 0), 0, 255).astype(np.uint8)], axis=-1)
    if mode in ("L",) and bit_depth < 8:
        key = int(key) * (255 // (2 ** bit_depth - 1))
    key = np.asarray(key, np.int64).reshape(-1)
    opaque = np.iinfo(image.dtype).max if image.dtype.kind in "iu" else 1
    clear = np.all(image.reshape(image.shape[:2] + (-1,)) == key, axis=-1)
    alpha = np.where(clear, 0, opaque).astype(image.dtype)
    return np.concatenate([image.reshape(image.shape[:2] + (-1,)), alpha[..., None]], axis=-1)


def _check_png(name, data=None):
    """Refuse (one line) a PNG that libpng would fail on with its own message on stderr: truncated,
    a chunk's checksum wrong, or image data that does not decompress to the size the header gives."""
    import struct
    import zlib
    data = open(name, "rb").read() if data is None else data
    pos, idat, header = 8, [], None
    while True:
        if pos + 8 > len(data):
            raise _Refused("truncated PNG: the file ends before its last chunk (IEND)")
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        if pos + 12 + length > len(data):
            raise _Refused(f"truncated PNG: the file ends inside its {kind.decode('latin-1')} chunk")
        body = data[pos + 8:pos + 8 + length]
        if zlib.crc32(kind + body) & 0xFFFFFFFF != struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0]:
            raise _Refused(f"corrupt PNG: the checksum of its {kind.decode('latin-1')} chunk is wrong")
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body[:13])
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    w, h, depth, colour, _, _, interlace = header
    bits = depth * {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(colour, 1)
    passes = [((h - y0 + dy - 1) // dy, (w - x0 + dx - 1) // dx) for y0, x0, dy, dx in
              ((0, 0, 8, 8), (0, 4, 8, 8), (4, 0, 8, 4), (0, 2, 4, 4), (2, 0, 4, 2), (0, 1, 2, 2), (1, 0, 2, 1))] \
        if interlace else [(h, w)]
    expected = sum(ph * (1 + (pw * bits + 7) // 8) for ph, pw in passes if ph and pw)
    try:
        size = len(zlib.decompress(b"".join(idat)))
    except zlib.error:
        raise _Refused("corrupt or truncated PNG: its image data does not decompress") from None
    if size < expected:
        raise _Refused(f"truncated PNG: its image data holds {size} of {expected} bytes")


def _read_png16_colour(iio, name, colour_type):
    try:
        import cv2
    except ImportError:
        raise _Refused("a 16-bit colour PNG, which Pillow reads at 8 bits only: install "
                       "opencv-python-headless to read it at 16 bits, or convert it to a 16-bit TIFF") from None
    _check_png(name)            # OpenCV would print libpng's and its own lines on stderr first
    # OpenCV applies tRNS (one transparent RGB colour) as a 16-bit alpha channel itself
    image = np.asarray(iio.imread(name, plugin="opencv", flags=cv2.IMREAD_UNCHANGED))
    if colour_type == 4 and image.ndim == 3 and image.shape[-1] == 4:   # grey + alpha, expanded by OpenCV
        image = image[..., [0, 3]]
    return image


def _read_tiff(name):
    import tifffile
    with tifffile.TiffFile(name) as tif:
        series = tif.series
        frames = sum(len(s.pages) for s in series) if series else len(tif.pages)
        if frames != 1:
            raise _Refused(f"it holds {frames} images (a multi-page TIFF); gfgpu processes one image per "
                           f"file: split the pages first")
        page = series[0].pages[0] if series else tif.pages[0]
        image = page.asarray()
        if image.dtype.kind == "c":
            raise _Refused(f"complex samples ({image.dtype}); gfgpu filters real images: write the real and "
                           f"imaginary parts as two files")
        if page.axes.startswith("S") and image.ndim == 3:        # planar configuration: samples first
            image = np.moveaxis(image, 0, -1)
        if page.photometric == tifffile.PHOTOMETRIC.SEPARATED and image.ndim == 3 and image.shape[-1] >= 4:
            top = np.iinfo(image.dtype).max if image.dtype.kind in "iu" else 1.0   # CMYK -> RGB
            ink = image[..., :4].astype(np.float64) / top
            rgb = (1 - ink[..., :3]) * (1 - ink[..., 3:4]) * top
            image = (np.rint(rgb) if image.dtype.kind in "iu" else rgb).astype(image.dtype)
        tag = page.tags.get("Orientation")
    if tag is not None and tag.value in _ORIENT:
        image = np.ascontiguousarray(_ORIENT[tag.value](image))
    return image


def image_format(path, name="output"):
    """The format (``'PNG'``, ``'TIFF'``, ``'JPEG'``, ``'BMP'``) that ``path``'s extension names;
    ``ValueError`` naming ``name`` and the path for any other extension."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in IMAGE_FORMATS:
        raise ValueError(f"{name} {os.fspath(path)}: unknown image format {ext or '(no extension)'!r}; use "
                         f"{', '.join(IMAGE_FORMATS)}")
    return IMAGE_FORMATS[ext]


def _temp_prefix():
    """``.gfgpu-HOST-PID-``: whose temporary file it is, so a later run can tell a stale one."""
    host = re.sub(r"[^A-Za-z0-9.]", "_", socket.gethostname())[:40] or "host"
    return f".gfgpu-{host}-{os.getpid()}-"


_TEMP_NAME = re.compile(r"^\.gfgpu-(?:(?P<host>[A-Za-z0-9._]+)-(?P<pid>\d+)-)?[A-Za-z0-9_]{8}(?:\.[^.]*)?$")


def check_output(path, *, name="output", extensions=None):
    """Fail at once (before any work) if ``path`` cannot be written; returns it.

    Checks that its extension is one of ``extensions`` (if given), that it is not a directory,
    that its folder exists (it is not created), is a directory, and that a file can be created
    there: a hidden temporary file is created and removed at once, which also catches read-only
    file systems and pseudo file systems such as ``/proc``.

    Raises
    ------
    ValueError
        Another extension.
    OSError
        ``IsADirectoryError``, ``FileNotFoundError`` (a missing folder), ``NotADirectoryError``,
        ``PermissionError`` or another error creating a file there; the message names ``name``
        and the path.
    """
    p = os.fspath(path)
    if os.path.isdir(p):
        raise IsADirectoryError(f"{name} {p}: is a directory, not a file name")
    if extensions is not None:
        ext = os.path.splitext(p)[1].lower()
        if ext not in extensions:
            raise ValueError(f"{name} {p}: the extension must be {' or '.join(extensions)}, got "
                             f"{ext or 'none'}")
    folder = os.path.dirname(os.path.abspath(p))
    if not os.path.exists(folder):
        raise FileNotFoundError(f"{name} {p}: the folder {folder} does not exist (it is not created)")
    if not os.path.isdir(folder):
        raise NotADirectoryError(f"{name} {p}: {_nearest_file(folder)} is not a directory")
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=_temp_prefix())
    except OSError as exc:
        raise type(exc)(f"{name} {p}: cannot create a file in {folder} "
                        f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(tmp)
    return p


def _nearest_file(folder):
    while folder and not os.path.exists(folder):
        folder = os.path.dirname(folder)
    return folder


def write_atomic(path, write):
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``.

    The temporary file is ``.gfgpu-HOST-PID-XXXXXXXX<ext>`` in ``path``'s folder (which must
    exist: it is not created) and is removed if ``write`` fails; only a hard kill can leave one,
    and :func:`remove_stale_temporaries` removes those.  An ``OSError`` while creating, writing
    or renaming (a missing or read-only folder, a full disk) becomes an :class:`OutputError`
    naming ``path``, not the temporary file; other exceptions of ``write`` pass unchanged.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path)) or "."
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=os.path.splitext(path)[1], prefix=_temp_prefix())
    except OSError as exc:
        raise _output_error(path, exc) from None
    os.close(fd)
    try:
        write(tmp)
        # mkstemp creates 0600 files; outputs get the usual permissions (0666 minus the umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise _output_error(path, exc) from None
        raise


def _output_error(path, exc):
    reason, code = exc.strerror or str(exc), exc.errno
    short = re.search(r"(\d+) requested and (\d+) written", str(exc))
    if short:       # numpy's tofile (np.save, tifffile) reports a short write without an errno
        written = f"{short[2]} of {short[1]} bytes written"
        if _free_bytes(path) < int(short[1]) - int(short[2]):
            reason, code = f"No space left on device ({written})", errno.ENOSPC
        else:
            reason = f"short write ({written})"
    err = OutputError(f"cannot write {path}: {reason}")
    err.errno = code
    return err


def _free_bytes(path):
    try:
        st = os.statvfs(os.path.dirname(os.path.abspath(path)) or ".")
    except OSError:
        return 0
    return st.f_bavail * st.f_frsize


def remove_stale_temporaries(folder, *, max_age=86400.0):
    """Remove the temporary files that killed runs of gfgpu left in ``folder``; their paths.

    Only files named as :func:`write_atomic` names them (``.gfgpu-HOST-PID-XXXXXXXX<ext>``, or
    ``.gfgpu-XXXXXXXX<ext>`` of earlier versions), and only stale ones: written by a process of
    this host that no longer runs, or (another host's, or no process id) last modified more than
    ``max_age`` seconds ago.  A process of this host that still runs keeps its files, whatever
    their age.  Nothing else is touched; a missing folder has none.
    """
    folder = os.fspath(folder)
    try:
        names = os.listdir(folder)
    except (FileNotFoundError, NotADirectoryError):
        return []
    host = _temp_prefix().split("-")[1]
    now, removed = time.time(), []
    for entry in names:
        m = _TEMP_NAME.match(entry)
        if m is None:
            continue
        path = os.path.join(folder, entry)
        try:
            st = os.lstat(path)
        except OSError:
            continue
        if not stat.S_ISREG(st.st_mode):
            continue
        if m["pid"] is not None and m["host"] == host:
            stale = not _process_alive(int(m["pid"]))
        else:
            stale = now - st.st_mtime > max_age
        if stale:
            with contextlib.suppress(OSError):
                os.unlink(path)
                removed.append(path)
    return removed


def _process_alive(pid):
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:       # PermissionError: someone else's live process
        return True
    return True


def write_image(path, image):
    """Write the array ``image`` in the format of ``path``'s extension, atomically.

    ``.png``: uint8 or uint16, grey, grey + alpha, RGB or RGBA (a 16-bit colour PNG needs
    ``opencv-python-headless``; Pillow writes 16-bit grey only).  ``.tif``/``.tiff`` (tifffile):
    any real sample type, alpha as an unassociated extra sample.  ``.jpg``/``.jpeg`` and
    ``.bmp``: uint8 grey or RGB only (neither keeps an alpha channel, so one is refused, never
    dropped).  PNG is written at zlib level 1 (``compress_level``): lossless like any other level,
    several times faster on photographs and 10-20 % larger.

    Raises
    ------
    ValueError
        Another extension, or samples the format cannot hold (float in a PNG, alpha in a JPEG or
        BMP, ...): nothing is converted here (see :func:`to_output`).
    OutputError
        The file could not be written (see :func:`write_atomic`).
    """
    fmt = image_format(path)
    arr = np.asarray(image)
    channels = 1 if arr.ndim == 2 else arr.shape[-1]
    if arr.ndim not in (2, 3) or channels not in (1, 2, 3, 4):
        raise ValueError(f"cannot write an array of shape {arr.shape} as an image (grey, grey + alpha, RGB "
                         f"or RGBA)")
    if fmt == "TIFF":
        import tifffile
        if arr.dtype.kind not in "biuf":
            raise ValueError(f"cannot write {arr.dtype} samples as TIFF")
        kw = dict(photometric="rgb" if channels in (3, 4) else "minisblack")
        if channels in (2, 4):
            kw["extrasamples"] = ["unassalpha"]
        write_atomic(path, lambda tmp: tifffile.imwrite(tmp, arr, **kw))
        return
    import imageio.v3 as iio
    if fmt in ("JPEG", "BMP") and channels in (2, 4):
        raise ValueError(f"{os.fspath(path)}: {fmt} holds no alpha channel; write a .png or .tif to keep it "
                         f"(or drop the alpha channel first)")
    if arr.ndim == 3 and channels == 1:
        arr = arr[..., 0]
    allowed = (np.uint8, np.uint16) if fmt == "PNG" else (np.uint8,)
    if arr.dtype not in allowed:
        raise ValueError(f"{fmt} holds {' or '.join(np.dtype(t).name for t in allowed)} samples, not "
                         f"{arr.dtype}; write a .tif for other sample types")
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if arr.dtype == np.uint16 and arr.ndim == 3:
        try:
            import cv2
        except ImportError:
            raise ValueError("a 16-bit colour PNG needs opencv-python-headless (Pillow writes 16-bit grey "
                             "only); write a .tif instead") from None
        if channels == 2:
            write_atomic(path, lambda tmp: iio.imwrite(tmp, arr, plugin="opencv", extension=ext))
            return
        bgr = arr[..., [2, 1, 0, 3][:channels]]          # OpenCV's channel order
        ok, data = cv2.imencode(ext, np.ascontiguousarray(bgr), [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESS_LEVEL])
        if not ok:
            raise ValueError(f"{os.fspath(path)}: OpenCV could not encode a 16-bit colour PNG")
        write_atomic(path, lambda tmp: _write_bytes(tmp, data.tobytes()))
        return
    kw = {"compress_level": PNG_COMPRESS_LEVEL} if fmt == "PNG" else {}
    write_atomic(path, lambda tmp: _pillow_save(tmp, arr, fmt, **kw))


def _write_bytes(tmp, data):
    with open(tmp, "wb") as f:
        f.write(data)


def _pillow_save(tmp, arr, fmt, **kw):
    """Pillow encoding into memory, then one write we check: a full disk raises here, once.
    (Given a file, Pillow's encoders write to its descriptor and a JPEG's short write went unseen,
    leaving a truncated file; imageio's plugin objects repeat errors from their destructor.)"""
    import io as _io

    from PIL import Image
    buffer = _io.BytesIO()
    Image.fromarray(np.ascontiguousarray(arr)).save(buffer, format=fmt, **kw)
    _write_bytes(tmp, buffer.getbuffer())


def _round_clip(values, dtype):
    info = np.iinfo(dtype)
    return np.clip(np.rint(np.nan_to_num(values, nan=0.0)), info.min, info.max).astype(dtype)


def check_keeps(original, path, name="output"):
    """Refuse (``ValueError``) to write an image like ``original`` to ``path`` where the format
    would lose something without a rule to state: 16-bit samples or an alpha channel into a JPEG
    or BMP (8-bit, no alpha).  The message names ``name``, the path and the formats that keep it.
    Float and other integer input written to 8-bit formats is converted by a stated rule instead
    (:func:`to_display_8bit`, :func:`conversion_note`)."""
    fmt = image_format(path, name)
    img = np.asarray(original)
    if fmt not in ("JPEG", "BMP"):
        return
    lost = []
    if img.dtype == np.uint16:
        lost.append("16-bit samples")
    if has_alpha(img):
        lost.append("an alpha channel")
    if lost:
        raise ValueError(f"{name} {os.fspath(path)}: {fmt} holds 8-bit samples without alpha and the input has "
                         f"{' and '.join(lost)}; write a .png or .tif to keep {'them' if len(lost) > 1 else 'it'}")


def conversion_note(original, path):
    """What writing an image like ``original`` to ``path`` does to its values, in one line, or
    ``None`` where they are written as they are (uint8 anywhere, uint16 in a PNG or TIFF, every
    type in a TIFF).  Commands print it: no conversion is silent."""
    fmt = image_format(path)
    img = np.asarray(original)
    if fmt == "TIFF" or img.dtype == np.uint8 or (img.dtype == np.uint16 and fmt == "PNG"):
        return None
    lo, hi = _value_range(img)
    keep = f"write a .tif to keep the {img.dtype} values"
    if _unit_range(img):
        return (f"{img.dtype} input in [0, 1] (here {lo:.4g}..{hi:.4g}) written as 8-bit {fmt}: "
                f"round(v * 255); {keep}")
    return (f"{img.dtype} input written as 8-bit {fmt} stretched from its range {lo:.4g}..{hi:.4g} to 0..255; "
            f"{keep}")


def _value_range(img):
    finite = img[np.isfinite(img)] if img.dtype.kind == "f" else img
    if finite.size == 0:
        return 0.0, 0.0
    return float(np.min(finite)), float(np.max(finite))


def _unit_range(img):
    """Whether float (or bool) samples follow the [0, 1] convention: every finite value in [0, 1]."""
    if img.dtype == bool:
        return True
    if img.dtype.kind != "f":
        return False
    lo, hi = _value_range(img)
    return lo >= 0.0 and hi <= 1.0


def to_output(result, original, path):
    """The filtered ``result`` of the image ``original``, in the samples written to ``path``.

    What was read is written at its depth: uint8 input gives uint8 (rounded, clipped);
    uint16 input gives uint16 in a PNG or TIFF; other integer input keeps its type in a TIFF;
    float input gives float32 in a TIFF (float64 input, float64); float and other integers into
    a PNG, JPEG or BMP get the 8-bit conversion :func:`to_display_8bit` (stated by
    :func:`conversion_note`).  16-bit or alpha input into a JPEG or BMP is refused
    (:func:`check_keeps`).
    """
    fmt = image_format(path)
    check_keeps(original, path)
    src = np.asarray(original).dtype
    res = np.asarray(result)
    if src == np.uint8:
        return _round_clip(res, np.uint8)
    if src == np.uint16 and fmt in ("PNG", "TIFF"):
        return _round_clip(res, np.uint16)
    if fmt == "TIFF" and src.kind in "iu":
        return _round_clip(res, src)
    if fmt == "TIFF" and src.kind == "f":
        return res.astype(np.float64 if src == np.float64 else np.float32)
    return to_display_8bit(res, original)


def save_image(path, result, original):
    """Write ``result``, the filtered ``original``, to ``path`` at the original's depth
    (:func:`to_output`, :func:`write_image`)."""
    write_image(path, to_output(result, original, path))


def save_png(path, image):
    """Write an 8-bit (or 16-bit grey) image as PNG, atomically (whatever ``path``'s extension),
    at zlib level :data:`PNG_COMPRESS_LEVEL`."""
    write_atomic(path, lambda tmp: _pillow_save(tmp, np.asarray(image), "PNG", compress_level=PNG_COMPRESS_LEVEL))


def save_gif(path, frames, fps):
    """Write 8-bit frames ``(n, H, W)`` or ``(n, H, W, 3)`` as an endlessly looping animated GIF at
    ``fps`` frames per second, atomically.  Every frame is written whole, so a reader gets ``n``
    frames back.  Grey frames are written exactly, in palette mode with the grey ramp as their
    palette; colour frames get Pillow's adaptive palette per frame."""
    from PIL import GifImagePlugin, Image

    grey = bytes(np.repeat(np.arange(256, dtype=np.uint8), 3))

    def image(f):
        f = np.ascontiguousarray(f)
        if f.ndim == 3:
            return Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE)   # as Pillow's GIF writer
        # one mode and one grey palette for every frame: Pillow wrote the first as L and later
        # ones as P, which imageio (Pillow 13) cannot read back ("No packer found from P to L")
        im = Image.frombytes("P", (f.shape[1], f.shape[0]), f.tobytes())
        im.putpalette(grey)
        return im

    def write(tmp):
        images = [image(f) for f in frames]
        # frame by frame, not Pillow's save_all: that drops a frame equal to the one before it
        # (adding its duration to that one), so a still stretch read back fewer frames than
        # written; optimize=False: a palette trimmed to a frame's levels is no grey ramp
        header, _ = GifImagePlugin.getheader(images[0].copy(), info={"loop": 0, "optimize": False})
        parts = list(header)
        for im in images:
            parts += GifImagePlugin.getdata(im, duration=1000.0 / fps, include_color_table=True)
        parts.append(b";")
        _write_bytes(tmp, b"".join(parts))
    write_atomic(path, write)


def save_npy(path, array):
    """Write the raw array as ``.npy``, atomically (whatever ``path``'s extension)."""
    def write(tmp):
        with open(tmp, "wb") as f:
            np.save(f, array)
    write_atomic(path, write)


def has_alpha(image):
    """Whether ``image`` (channels last) is grey + alpha ``(H, W, 2)`` or RGBA ``(H, W, 4)``."""
    return np.ndim(image) == 3 and np.shape(image)[-1] in (2, 4)


def alpha_scale(dtype):
    """The alpha value of an opaque pixel: the integer type's maximum, 1 for floats and bool."""
    dtype = np.dtype(dtype)
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else 1.0


def premultiply(image, dtype=np.float32):
    """``(colour * a, alpha)`` of an image with alpha last, as ``dtype`` (``a`` = alpha / its
    opaque value), so that a linear filter of all channels gives no dark fringes at edges."""
    x = np.asarray(image).astype(dtype)
    a = x[..., -1:] / alpha_scale(np.asarray(image).dtype)
    return np.concatenate([x[..., :-1] * a, x[..., -1:]], axis=-1)


def unpremultiply(result, original_dtype):
    """Inverse of :func:`premultiply` on filtered channels: colour divided by the filtered alpha
    where it is > 0 (colour 0 where the result is transparent); alpha as filtered."""
    res = np.asarray(result)
    a = res[..., -1:] / alpha_scale(original_dtype)
    colour = np.divide(res[..., :-1], a, out=np.zeros_like(res[..., :-1]), where=a > 0)
    return np.concatenate([colour, res[..., -1:]], axis=-1)


def to_display_8bit(result, original):
    """Display conversion of a filtered image to uint8, by the type and values of ``original``:

    - uint8: rounded and clipped;
    - uint16: ``round(v / 257)`` (its full range, so a flat image keeps its grey level);
    - float (or bool) whose finite values all lie in [0, 1], the usual convention for float
      images: ``round(v * 255)``, clipped (0.031..0.973 gives 8..248, not 0..255);
    - anything else (float beyond [0, 1], other integer types): ``original``'s finite value range
      stretched to 0..255 (a flat one to 0).

    :func:`conversion_note` states which rule applied; NaN becomes 0."""
    img = np.asarray(original)
    if img.dtype == np.uint8:
        return _round_clip(result, np.uint8)
    if img.dtype == np.uint16:
        return _round_clip(np.asarray(result) / 257.0, np.uint8)
    if _unit_range(img):
        return _round_clip(np.asarray(result, np.float64) * 255.0, np.uint8)
    lo, hi = _value_range(img)
    scale = 255.0 / (hi - lo) if hi > lo else 1.0
    return _round_clip((np.asarray(result, np.float64) - lo) * scale, np.uint8)


def gradient_to_rgb(gy, gx):
    """Colour-coded gradient (H, W, 3) uint8: hue = orientation ``atan2(gy, gx)``, saturation 0.8,
    value = magnitude (robustly normalised to its 99.5th percentile).

    The HSV -> RGB conversion is the closed form ``c_n = v (1 - s clip(min(k, 4 - k), 0, 1))``,
    ``k = (n + 6 h) mod 6`` with n = 5, 3, 1 for red, green, blue, in float32 without ``%`` or
    boolean indexing (slow on large images): skimage's ``hsv2rgb`` to +-1 of 255, 4-5x faster."""
    gy = np.asarray(gy, np.float32)
    gx = np.asarray(gx, np.float32)
    mag = np.hypot(gx, gy)
    top = np.float32(np.percentile(mag, 99.5) or 1.0)
    h6 = np.arctan2(gy, gx) * np.float32(3 / np.pi)          # 6 x hue, in [-3, 3]
    np.add(h6, np.float32(6), out=h6, where=h6 < 0)
    value = np.clip(mag / top, 0, 1) * np.float32(255)
    out = np.empty(mag.shape + (3,), np.uint8)
    k = np.empty_like(h6)
    for c, n in enumerate((5, 3, 1)):
        np.add(h6, np.float32(n), out=k)
        np.subtract(k, np.float32(6), out=k, where=k >= 6)
        w = np.clip(np.minimum(k, 4 - k), 0, 1)
        w *= np.float32(-0.8)
        w += 1
        w *= value
        out[..., c] = np.rint(w)
    return out


# Turbo colour map (A. Mikhailov, Google, 2019), polynomial approximation: no matplotlib needed
_TURBO = np.array([
    [0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943],
    [0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604],
    [0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973]])


def colourise_disparity(disp, d_min, d_max):
    """(H, W, 3) uint8 Turbo image of ``disp`` scaled from ``d_min`` (blue) to ``d_max`` (red);
    NaN (rejected) pixels are black."""
    t = np.clip((np.nan_to_num(disp, nan=d_min) - d_min) / max(d_max - d_min, 1e-9), 0, 1)
    powers = t[..., None] ** np.arange(6)
    rgb = np.clip(powers @ _TURBO.T, 0, 1)
    rgb[~np.isfinite(disp)] = 0
    return (rgb * 255).round().astype(np.uint8)


def write_pfm(path, disp):
    """Write a greyscale PFM (little-endian float32, rows bottom to top; NaN kept, as Middlebury)."""
    data = np.asarray(disp, np.float32)
    with open(path, "wb") as f:
        f.write(f"Pf\n{data.shape[1]} {data.shape[0]}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(data[::-1]).astype("<f4").tobytes())


def read_pfm(path):
    """Read a greyscale PFM written by :func:`write_pfm` (or Middlebury's tools); ``ValueError``
    if the file is not one."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"Pf":
            raise ValueError(f"{path}: not a greyscale PFM")
        w, h = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(4 * w * h), "<f4" if scale < 0 else ">f4")
    if data.size != w * h:
        raise ValueError(f"{path}: truncated PFM ({data.size} of {w * h} samples)")
    return data.reshape(h, w)[::-1].astype(np.float32)


def write_ply(path, points, colors=None, *, binary=True):
    """Write a point cloud as a PLY file (vertices ``x, y, z`` float32, optional ``red, green,
    blue`` uchar), through the ``plyfile`` package; points with a NaN coordinate are dropped.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (written atomically).
    points : (..., 3) array_like
        Coordinates, e.g. the (H, W, 3) output of :func:`gfgpu.stereo.reproject_to_3d`.
    colors : (..., 3) or (...) array_like, optional
        Colour per point, same leading shape (grey is repeated); uint8, or floats in [0, 1]
        if float.
    binary : bool, optional
        Binary little-endian (default) or ASCII PLY.

    Returns
    -------
    int
        The number of points written.

    Raises
    ------
    ValueError
        ``points`` not of shape (..., 3), or ``colors`` of another leading shape.
    OSError
        The file cannot be written.

    Examples
    --------
    >>> import numpy as np, os, tempfile
    >>> pts = np.array([[[0, 0, 1], [np.nan, 0, 1]], [[1, 2, 3], [4, 5, 6]]], np.float32)
    >>> path = os.path.join(tempfile.mkdtemp(), "cloud.ply")
    >>> write_ply(path, pts, np.full((2, 2), 200, np.uint8))
    3
    """
    from plyfile import PlyData, PlyElement
    pts = np.asarray(points, np.float32)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise ValueError(f"points must have shape (..., 3), got {pts.shape}")
    keep = np.isfinite(pts).all(axis=-1)
    fields = [("x", "f4"), ("y", "f4"), ("z", "f4")]
    cols = None
    if colors is not None:
        c = np.asarray(colors)
        if c.shape == pts.shape[:-1]:
            c = np.repeat(c[..., None], 3, axis=-1)
        if c.shape[:-1] != pts.shape[:-1] or c.shape[-1] not in (3, 4):
            raise ValueError(f"colors must have shape {pts.shape[:-1]} or {pts.shape[:-1] + (3,)}, got {c.shape}")
        c = c[..., :3]
        if c.dtype.kind == "f":
            c = np.clip(np.rint(c * 255), 0, 255)
        cols = c.astype(np.uint8)[keep]
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    vert = np.empty(int(keep.sum()), dtype=fields)
    for i, name in enumerate("xyz"):
        vert[name] = pts[keep][:, i]
    if cols is not None:
        for i, name in enumerate(("red", "green", "blue")):
            vert[name] = cols[:, i]
    data = PlyData([PlyElement.describe(vert, "vertex")], text=not binary, byte_order="<")
    write_atomic(path, lambda tmp: data.write(tmp))
    return int(vert.size)


def disparity_to_png16(disp):
    """A disparity map as a 16-bit image in the KITTI convention: ``round(d * 256)``, 0 = invalid.

    NaN, non-positive and too large disparities (``d * 256 > 65535``) become 0 (KITTI has no
    negative disparities; a disparity of exactly 0 is indistinguishable from invalid there).

    Examples
    --------
    >>> import numpy as np
    >>> disparity_to_png16(np.array([[1.5, np.nan, 0.0, 300.0]], np.float32))
    array([[384,   0,   0,   0]], dtype=uint16)
    """
    d = np.asarray(disp, np.float64)
    v = np.rint(np.nan_to_num(d, nan=0.0) * 256)
    return np.where((v > 0) & (v <= 65535), v, 0).astype(np.uint16)


def colour_bar(height, d_min, d_max, width=48):
    """(height, width, 3) uint8 vertical Turbo bar from ``d_max`` (top) to ``d_min`` (bottom),
    with tick marks and the two end values written in a 3x5 pixel font (digits, '-', '.')."""
    t = np.linspace(1, 0, height)[:, None].repeat(width // 2, axis=1)
    bar = colourise_disparity(d_min + t * (d_max - d_min), d_min, d_max)
    out = np.zeros((height, width, 3), np.uint8)
    out[:, :width // 2] = bar
    for frac in (0, 0.25, 0.5, 0.75, 1):
        y = int(round(frac * (height - 1)))
        out[y, width // 2:width // 2 + 4] = 255
    _draw_text(out, f"{d_max:g}", 2, width // 2 + 6)
    _draw_text(out, f"{d_min:g}", height - 8, width // 2 + 6)
    return out


_FONT = {"0": "111101101101111", "1": "010110010010111", "2": "111001111100111", "3": "111001111001111",
         "4": "101101111001001", "5": "111100111001111", "6": "111100111101111", "7": "111001001001001",
         "8": "111101111101111", "9": "111101111001111", "-": "000000111000000", ".": "000000000000010"}


def _draw_text(img, text, top, left):
    for i, ch in enumerate(text):
        glyph = _FONT.get(ch)
        if glyph is None:
            continue
        g = np.array([int(b) for b in glyph], bool).reshape(5, 3)
        y0, x0 = top, left + 4 * i
        if y0 < 0 or y0 + 5 > img.shape[0] or x0 + 3 > img.shape[1]:
            return
        img[y0:y0 + 5, x0:x0 + 3][g] = 255
