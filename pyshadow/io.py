"""Image files: float EXR for data, Radiance HDR for radiance, 8-bit sRGB PNG/JPEG for viewing.

Everything goes through OpenImageIO. Arrays are ``(H, W)`` or ``(H, W, C)``,
row 0 at the top, as everywhere in pyshadow.

File kinds, chosen by the (case-insensitive) extension
------------------------------------------------------
``.exr``
    32-bit float channels, lossless ZIP compression: a float32 array comes
    back bit for bit, NaN and +-inf included (depth maps with +inf
    background, normals, bent normals, AO). Channels: 1 -> ``Y``;
    3 -> ``R, G, B``; 4 -> ``R, G, B, A`` (array channel k is the k-th name;
    for normals R, G, B hold x, y, z).
``.hdr``
    Radiance RGBE (run-length encoded), for linear RGB radiance that other
    tools read (HDR viewers, environment maps): per pixel three 8-bit
    mantissas share one 8-bit exponent. Each channel is rounded to the
    nearest multiple of ``q = 2^(e - 8)``, where ``2^(e-1) <= m < 2^e`` for
    the pixel's largest channel ``m``: read back with OpenImageIO or
    :func:`read_image` (which decode a stored mantissa ``k`` as ``k q``), the
    largest channel is within a relative ``2^-8`` (0.4 %) of the value
    written and every channel within ``2^-8`` times the pixel's largest
    (read back) channel, so a channel far below the pixel's largest is lost
    (``0.001`` beside ``100`` reads back as 0). Readers that add half a step
    (Radiance's own, ``(k + 0.5) q``) see up to ``2^-7``. A pixel whose largest
    channel is below ``1e-32`` is stored black. Float input only; NaN,
    negative values, +-inf and values from ``255.5 * 2^119`` (about 1.7e38)
    up are refused (ValueError): write an EXR for those. Channels: 3 -> RGB;
    1 -> grey, stored as R = G = B (reads back as (H, W, 3)); 4 are refused
    (RGBE has no alpha: pass ``image[..., :3]``). The header holds no
    ``EXPOSURE=`` line (the values are the radiances themselves) and the
    rows are stored top to bottom (``-Y H +X W``).
``.png``, ``.jpg``, ``.jpeg``
    8 bits per channel, sRGB-encoded. A float array is read as *linear*
    values, clipped to [0, 1], encoded with the sRGB transfer function
    (IEC 61966-2-1, :func:`linear_to_srgb`) and rounded to the nearest of
    0 .. 255; a ``uint8`` array is taken as already encoded and written as
    is. An alpha channel (the 4th) is stored linearly, never encoded, and as
    straight (unassociated) alpha, as PNG defines it. Channels: 1 -> grey,
    3 -> RGB, 4 -> RGBA (PNG only; JPEG has no alpha). JPEG is lossy
    (quality 95). 16-bit PNGs are read (:func:`read_image`) but not written:
    a ``uint16`` array is a TypeError saying how to pass it.

Writes are atomic: the image goes to a hidden temporary file in the target's
directory (same extension, so OpenImageIO picks the same format), which is
flushed to disk (``fsync``) and then replaces the target with
:func:`os.replace`. If anything fails, the temporary file is removed and an
existing target is left untouched.

A PNG, JPEG or HDR is written only where the folder's free space and the
process's file size limit hold a bound on its size (1.01 (PNG) or 3 (JPEG)
bytes per byte of pixels, 5.1 bytes per pixel (HDR), plus 64 KiB), and a PNG or
JPEG that does not end as a complete file does, or an HDR whose last row does
not decode (a disk filled meanwhile, a quota) is an OSError: OpenImageIO's PNG
and HDR writers ignore a failed write of their last bytes (they reported
success and left a truncated file, which replaced the image) and its JPEG
writer ends the process ("Output file write error --- out of disk space?",
exit status 1). EXR writes report such failures themselves.
"""
from __future__ import annotations

import errno
import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ._files import atomic_path

__all__ = ["write_image", "read_image", "linear_to_srgb", "srgb_to_linear", "EXTENSIONS"]

_KIND = {".exr": "exr", ".hdr": "rgbe", ".png": "srgb8", ".jpg": "srgb8", ".jpeg": "srgb8"}
#: File extensions :func:`write_image` accepts.
EXTENSIONS = tuple(_KIND)
_JPEG_QUALITY = 95
_CHANNEL_NAMES = {1: ("Y",), 3: ("R", "G", "B"), 4: ("R", "G", "B", "A")}
_FLOAT32_EXACT = 2 ** 24        # float32 holds every integer up to here
#: Bytes an 8-bit file may take per byte of pixels (free space asked before a write): PNG, deflate's worst
#: case (stored blocks) and chunk headers; JPEG (quality 95), measured up to 1.22 (binary noise), 3 kept;
#: HDR per float of (H, W, 3): RGBE's run-length coding at worst, 4 bytes a pixel, a count byte per 128 and
#: 4 + 4 bytes a row, (4 W + 4 ceil(W / 128) + 4) / 3 W <= 1.68 (W >= 8; flat rows below, 4 / 3).
_SIZE_BOUND = {".png": 1.01, ".jpg": 3.0, ".jpeg": 3.0, ".hdr": 1.7}
#: RGBE's largest value is 255 * 2**119; values from half a step above it round beyond the 8-bit exponent.
_RGBE_LIMIT = 255.5 * 2.0 ** 119
_RGBE_BLACK = 1e-32             # a pixel whose largest channel is below it is stored black
_METADATA_BYTES = 1 << 16       # row filter bytes aside: headers, EXIF, colour chunks and a margin
#: The bytes a complete 8-bit file ends with (PNG's IEND chunk, JPEG's EOI marker).
_END = {".png": b"IEND\xaeB`\x82", ".jpg": b"\xff\xd9", ".jpeg": b"\xff\xd9"}


def _real(x, name: str) -> np.ndarray:
    """``x`` as float64 for the sRGB functions; wider floats are clipped to [0, 1] first (no overflow)."""
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected real numbers (got dtype {a.dtype})")
    if a.dtype.kind == "f" and a.dtype.itemsize > 8:      # long double beyond float64's range
        a = np.clip(a, 0.0, 1.0)
    return a.astype(np.float64)


def linear_to_srgb(x) -> np.ndarray:
    """sRGB transfer function (IEC 61966-2-1): linear [0, 1] -> encoded [0, 1].

    ``12.92 x`` for ``x <= 0.0031308``, else ``1.055 x^(1/2.4) - 0.055``.
    Input is clipped to [0, 1]; float64 out. Real numbers only (TypeError otherwise).
    """
    x = np.clip(_real(x, "x"), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(c) -> np.ndarray:
    """Inverse of :func:`linear_to_srgb`: encoded [0, 1] -> linear [0, 1].

    ``c / 12.92`` for ``c <= 0.04045``, else ``((c + 0.055) / 1.055)^2.4``.
    Input is clipped to [0, 1]; float64 out. Real numbers only (TypeError otherwise).
    """
    c = np.clip(_real(c, "c"), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


def _kind(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in _KIND:
        raise ValueError(f"cannot tell the image format of {str(path)!r} from its extension "
                         f"{ext!r}; use one of {', '.join(EXTENSIONS)}")
    return _KIND[ext]


def _wide_int(a: np.ndarray, png: bool = False) -> str:
    """The end of a dtype error for 16-bit image data (a 16-bit PNG read as integers): none is written."""
    if a.dtype != np.uint16:
        return ""
    if png:
        return ("; no 16-bit PNG is written: pass linear floats (srgb_to_linear(array / 65535) for sRGB-encoded "
                "data), or write an EXR")
    return "; uint16 data in [0, 1]: pass array / 65535"


def _pixels(array, kind: str, path: Path) -> np.ndarray:
    """Validate ``array``; return the (H, W, C) C-contiguous data to store."""
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in _CHANNEL_NAMES:
        raise ValueError(f"image must have shape (H, W) or (H, W, C) with C in 1, 3, 4 "
                         f"(got shape {np.shape(array)})")
    if a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(f"image is empty (shape {np.shape(array)})")
    if kind == "exr":
        if not np.issubdtype(a.dtype, np.floating):
            raise TypeError(f"EXR files store float images (expected a float array vs got dtype "
                            f"{a.dtype}); for 8-bit data divide by 255 or write a PNG{_wide_int(a)}")
        with np.errstate(over="ignore"):     # beyond float32's range -> +-inf, as documented
            return np.ascontiguousarray(a, dtype=np.float32)
    if kind == "rgbe":
        return _rgbe_pixels(a, path)
    if path.suffix.lower() != ".png" and a.shape[2] == 4:
        raise ValueError(f"JPEG has no alpha channel: cannot write a 4-channel image to {path}")
    if a.dtype == np.uint8:
        return np.ascontiguousarray(a)
    if not np.issubdtype(a.dtype, np.floating):
        raise TypeError(f"8-bit images are written from linear float arrays in [0, 1] or from "
                        f"uint8 arrays (got dtype {a.dtype}){_wide_int(a, png=True)}")
    if np.isnan(a).any():
        raise ValueError(f"image holds {int(np.isnan(a).sum())} NaN value(s), which 8-bit "
                         f"{path.suffix} cannot store")
    return encode_8bit(a, slice(0, 3) if a.shape[2] == 4 else slice(None))


def encode_8bit(a, colour=slice(None)) -> np.ndarray:
    """The uint8 values an 8-bit PNG or JPEG holds of linear float values ``a`` (..., C): clipped to [0, 1], the
    channels ``colour`` (a slice of the last axis; not alpha) sRGB-encoded, rounded half up; no NaN."""
    enc = np.clip(a, 0.0, 1.0).astype(np.float64)       # clipped first: a long double may overflow float64
    enc[..., colour] = linear_to_srgb(enc[..., colour])
    return np.floor(enc * 255.0 + 0.5).astype(np.uint8)


def _rgbe_pixels(a: np.ndarray, path: Path) -> np.ndarray:
    """(H, W, 1 or 3) float -> (H, W, 3) float32 that RGBE stores exactly: each channel rounded to the nearest
    multiple of its pixel's step (module docstring); OpenImageIO's encoder truncates, which on its own lost up
    to 2^-7 of a value (0.3 % on average, always downwards)."""
    if not np.issubdtype(a.dtype, np.floating):
        raise TypeError(f"Radiance HDR files store float images (expected a float array vs got dtype {a.dtype}); "
                        f"for 8-bit data write a PNG{_wide_int(a)}")
    if a.shape[2] == 4:
        raise ValueError(f"Radiance HDR has no alpha channel: cannot write a 4-channel image to {path} "
                         "(pass image[..., :3], or write an EXR)")
    with np.errstate(invalid="ignore", over="ignore"):     # (a long double beyond float64 is caught here)
        bad = {"NaN value(s)": np.isnan(a), "negative value(s)": a < 0,
               "value(s) +inf or >= 255.5 * 2**119 (~1.7e38)": a >= _RGBE_LIMIT}
    for what, mask in bad.items():
        if mask.any():
            raise ValueError(f"image holds {int(mask.sum())} {what}, which a Radiance HDR file (RGBE) cannot "
                             "store; write an EXR for those")
    x = np.broadcast_to(a, a.shape[:2] + (3,)).astype(np.float64)     # grey -> R = G = B
    top = x.max(axis=2, keepdims=True)
    x = np.where(top < _RGBE_BLACK, 0.0, x)         # as OpenImageIO's encoder does (no subnormal steps here)
    top = np.maximum(top, _RGBE_BLACK)
    step = np.ldexp(1.0, np.frexp(top)[1] - 8)      # 2^(e - 8), 2^(e-1) <= top < 2^e
    step = np.where(np.rint(top / step) >= 256, 2 * step, step)      # top rounds up to 2^e: the next exponent
    return np.ascontiguousarray(np.rint(x / step) * step, dtype=np.float32)      # k * 2^n, k <= 256: exact


def _write_oiio(tmp: Path, data: np.ndarray, kind: str):
    """Write (H, W, C) ``data`` to ``tmp`` with OpenImageIO; raise OSError on failure."""
    H, W, C = data.shape
    fmt = oiio.TypeUInt8 if kind == "srgb8" else oiio.TypeFloat
    spec = oiio.ImageSpec(W, H, C, fmt)
    spec.channelnames = _CHANNEL_NAMES[C]
    spec.alpha_channel = 3 if C == 4 else -1
    if kind == "exr":
        spec.attribute("compression", "zip")
        spec.attribute("DateTime", "")      # else the time of writing: equal images gave other bytes
    elif kind == "srgb8":
        spec.attribute("oiio:UnassociatedAlpha", 1)
        spec.attribute("oiio:ColorSpace", "sRGB")
        spec.attribute("Compression", f"jpeg:{_JPEG_QUALITY}")
    # rgbe: OpenImageIO's own header, with no EXPOSURE= line and the rows top down (-Y H +X W)
    out = oiio.ImageOutput.create(str(tmp))
    if out is None:
        _write_error(tmp, "OpenImageIO has no writer for it", oiio.geterror())
    if not out.open(str(tmp), spec):
        reason = out.geterror() or oiio.geterror()
        _os_error(tmp)
        _write_error(tmp, "OpenImageIO could not open it for writing", reason)
    ok = out.write_image(data)
    err = out.geterror() if not ok else ""
    closed = out.close()
    if not ok or not closed:
        _write_error(tmp, "OpenImageIO could not write it", err or out.geterror() or oiio.geterror())


def _os_error(tmp: Path):
    """Raise the system's own error where ``tmp`` cannot be created (a folder without write permission, a
    read-only file system: PermissionError or OSError EROFS) rather than OpenImageIO's "Could not open file"."""
    try:
        with open(tmp, "xb"):
            pass
    except FileExistsError:
        return
    os.unlink(tmp)


def _free_bytes(folder: Path):
    """Bytes this process may still write in ``folder``'s file system (root: the reserved blocks too), or None
    where it is not told (a file system of no size, as some network mounts report)."""
    try:
        st = os.statvfs(folder)
    except (AttributeError, OSError):       # no statvfs (Windows)
        try:
            return shutil.disk_usage(folder).free
        except OSError:
            return None
    if st.f_blocks == 0:
        return None
    root = hasattr(os, "geteuid") and os.geteuid() == 0
    return (st.f_bfree if root else st.f_bavail) * st.f_frsize


def _size_limit():
    """The process's limit on a file's size in bytes (``ulimit -f``), or None."""
    try:
        import resource
    except ImportError:                     # Windows
        return None
    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    return None if soft == resource.RLIM_INFINITY or soft < 0 else soft


def _check_room(tmp: Path, data: np.ndarray, ext: str):
    """OSError about ``tmp`` where an 8-bit file of ``data`` may not fit: OpenImageIO's PNG writer would
    leave a truncated file reported written, its JPEG writer end the process."""
    need = int(data.size * _SIZE_BOUND[ext]) + data.shape[0] + _METADATA_BYTES
    free, limit = _free_bytes(tmp.parent), _size_limit()
    if free is not None and free < need:
        raise OSError(errno.ENOSPC, f"not enough free space to write it ({free} bytes free, up to {need} "
                                    "needed)", str(tmp))
    if limit is not None and limit < need:
        raise OSError(errno.EFBIG, f"the process's file size limit (ulimit -f: {limit} bytes) may not hold it "
                                   f"(up to {need} bytes)", str(tmp))


def _check_complete(tmp: Path, ext: str):
    """OSError about ``tmp`` unless the 8-bit file OpenImageIO wrote ends as a complete file does; an HDR file
    unless its last row decodes (OpenImageIO's HDR writer, too, reported success for a file cut short)."""
    if ext == ".hdr":
        inp = oiio.ImageInput.open(str(tmp))
        if inp is None:
            _write_error(tmp, "OpenImageIO left it unreadable", oiio.geterror())
        try:
            row = inp.read_scanline(inp.spec().height - 1, 0, oiio.TypeFloat)
            reason = inp.geterror()
        finally:
            inp.close()
        if row is None:
            _write_error(tmp, "OpenImageIO left it incomplete", f"{reason.strip()}; a full disk or a quota?")
        return
    end = _END[ext]
    with open(tmp, "rb") as f:
        size = f.seek(0, os.SEEK_END)
        f.seek(max(0, size - len(end)))
        complete = f.read() == end
    if not complete:
        _write_error(tmp, "OpenImageIO left it incomplete", f"{size} bytes, not ending as a {ext} file does; "
                     "a full disk or a quota?")


def _write_error(tmp: Path, what: str, reason: str):
    """Raise an OSError about the temporary file ``tmp``: ``atomic_path`` names the target instead."""
    raise OSError(errno.EIO, f"{what} ({reason.strip() or 'no reason given'})", str(tmp))


def write_image(path, array) -> None:
    """Write an image file atomically; the format follows the extension.

    Parameters
    ----------
    path : str or os.PathLike
        Ends in ``.exr``, ``.hdr``, ``.png``, ``.jpg`` or ``.jpeg`` (any case). Its
        directory must exist; an existing file is replaced.
    array : ndarray, shape (H, W) or (H, W, C), C in {1, 3, 4}
        EXR: any float dtype, stored as float32 (float64 is rounded to
        nearest; magnitudes beyond float32's range become +-inf).
        HDR: float, 1 or 3 channels, finite, >= 0 and below about 1.7e38;
        stored as RGBE, within 2^-8 of each pixel's largest channel.
        PNG/JPEG: linear float in [0, 1] (clipped, sRGB-encoded, rounded to
        8 bits; no NaN) or ``uint8`` (sRGB-encoded, written as is). See the module
        docstring for channel names and the alpha channel.
        :func:`pyshadow.viz.image_panel` draws an RGB array as its PNG holds it;
        a 2-D array it colour-maps instead (``'gray'`` draws 0.5 as 128, the PNG holds 188).

    Raises
    ------
    ValueError
        Unknown extension, wrong shape, NaN for an 8-bit file, 4 channels
        for JPEG or HDR; NaN, negative, infinite or too large values for HDR.
    TypeError
        Non-float array for EXR or HDR; neither float nor uint8 for PNG/JPEG
        (no 16-bit PNG is written).
    FileNotFoundError
        The directory does not exist.
    PermissionError
        No permission to write in the directory, or to write the existing
        file (a read-only file is left as it was; OSError ``EROFS``: a
        read-only file system).
    OSError
        OpenImageIO failed to write (no file is left behind); a PNG, JPEG or
        HDR that the folder's free space or the file size limit may not hold
        (``ENOSPC``, ``EFBIG``, before writing) or that came out incomplete.

    Examples
    --------
    >>> import tempfile
    >>> depth = np.array([[1.5, np.inf]], np.float32)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_image(os.path.join(d, "depth.exr"), depth)
    ...     print(read_image(os.path.join(d, "depth.exr")).tolist())
    [[1.5, inf]]
    """
    path = Path(os.fspath(path))
    kind = _kind(path)
    data = _pixels(array, kind, path)
    parent = path.parent
    if not parent.is_dir():
        raise FileNotFoundError(errno.ENOENT, "directory does not exist", str(parent))
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "cannot write an image over a directory", str(path))
    with atomic_path(path) as tmp:
        if kind != "exr":
            _check_room(tmp, data, path.suffix.lower())
        _write_oiio(tmp, data, kind)
        if kind != "exr":
            _check_complete(tmp, path.suffix.lower())


#: EXIF orientation code -> the (H, W, C) transform that turns the stored pixels upright (as
#: ``ImageBufAlgo.reorient``): Radiance HDR files stored bottom-up ("+Y H +X W") or column-wise,
#: TIFF and JPEG orientation tags.
_ORIENT = {1: lambda x: x, 2: lambda x: x[:, ::-1], 3: lambda x: x[::-1, ::-1], 4: lambda x: x[::-1],
           5: lambda x: x.transpose(1, 0, 2), 6: lambda x: x.transpose(1, 0, 2)[:, ::-1],
           7: lambda x: x.transpose(1, 0, 2)[::-1, ::-1], 8: lambda x: x.transpose(1, 0, 2)[::-1]}
#: A Radiance HDR resolution line (major axis first) -> its EXIF orientation code. OpenImageIO swaps
#: 6 and 8 (``+X W +Y H``, whose scanline x is column x from the bottom up, is 8, not 6).
_RADIANCE_ORIENT = {b"-Y+X": 1, b"-Y-X": 2, b"+Y-X": 3, b"+Y+X": 4,
                    b"+X-Y": 5, b"-X-Y": 6, b"-X+Y": 7, b"+X+Y": 8}
_RADIANCE_RESOLUTION = re.compile(rb"\n\n([-+][XY]) +\d+ +([-+][XY]) +\d+ *\r?\n")
#: Radiance header lines giving multipliers applied to the pixels (cumulative; Radiance's header.c and color.h).
_RADIANCE_EXPOSURE = re.compile(rb"^EXPOSURE=[ \t]*(\S+)", re.M)
_RADIANCE_COLORCORR = re.compile(rb"^COLORCORR=[ \t]*(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.M)


def _radiance_header(inp, path: Path):
    """The first 64 KiB of a Radiance HDR file (its header and resolution line), or None for other formats."""
    if inp.format_name() != "hdr":
        return None
    with open(path, "rb") as f:
        return f.read(1 << 16)


def _radiance_with_format(path: Path):
    """A temporary copy of the Radiance HDR file ``path`` with a ``FORMAT=32-bit_rle_rgbe`` line added, where
    its header has none (the line is optional, that its default; OpenImageIO refuses such files), else None:
    not a Radiance file (``#?`` first), or its header ends past 64 KiB or names the format; ValueError where it
    names another (XYZE). The caller removes it."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
        end = head.find(b"\n\n")
        fmt = re.search(rb"^FORMAT=(.*)$", head[:max(end, 0)], re.M)
        named = fmt.group(1).strip().decode(errors="replace") if fmt and head.startswith(b"#?") else None
        if named not in (None, "32-bit_rle_rgbe"):             # OpenImageIO: "no FORMAT specifier found"
            raise ValueError(f"cannot read image {path}: a Radiance HDR of FORMAT={named!r}; OpenImageIO reads "
                             "only 32-bit_rle_rgbe (convert it: Radiance's ra_xyze -r)")
        if not head.startswith(b"#?") or end < 0 or fmt:
            return None
        first = head.index(b"\n") + 1                  # after the magic line, as Radiance's writers put it
        fd, tmp = tempfile.mkstemp(suffix=".hdr", prefix="pyshadow-")
        try:
            with os.fdopen(fd, "wb") as out:
                out.write(head[:first] + b"FORMAT=32-bit_rle_rgbe\n" + head[first:])
                shutil.copyfileobj(f, out)
        except BaseException:
            os.unlink(tmp)
            raise
    return Path(tmp)


def _orientation(spec, head) -> int:
    """The EXIF orientation code of the open file; a Radiance HDR's from its own resolution line."""
    code = spec.get_int_attribute("Orientation", 1)
    m = _RADIANCE_RESOLUTION.search(head) if head is not None else None
    if m:
        code = _RADIANCE_ORIENT.get(m.group(1) + m.group(2), code)
    return code


def _radiance_multiplier(head, C: int):
    """The (C,) multiplier a Radiance HDR's pixels hold (the product of its EXPOSURE and COLORCORR lines), or
    None where it is 1: stored values are the original radiances times it. A value that is not a positive
    finite number (a line of no meaning) is passed over."""
    if head is None or C != 3:
        return None
    head = re.split(rb"\n\r?\n", head, maxsplit=1)[0]     # the header ends at its first empty line
    mult = np.ones(3)
    for m in list(_RADIANCE_EXPOSURE.finditer(head)) + list(_RADIANCE_COLORCORR.finditer(head)):
        try:
            v = np.array([float(g) for g in m.groups()])
        except ValueError:
            continue
        if np.all(np.isfinite(v) & (v > 0)):
            mult *= v
    return None if np.all(mult == 1.0) else mult


def _display_window(data: np.ndarray, spec) -> np.ndarray:
    """The data window's pixels placed in the display window (zeros where no pixel is stored)."""
    full = (spec.full_x, spec.full_y, spec.full_width, spec.full_height)
    if full == (spec.x, spec.y, spec.width, spec.height) or spec.full_width < 1 or spec.full_height < 1:
        return data
    out = np.zeros((spec.full_height, spec.full_width, data.shape[2]), data.dtype)
    y0, x0 = max(spec.y, spec.full_y), max(spec.x, spec.full_x)
    y1 = min(spec.y + spec.height, spec.full_y + spec.full_height)
    x1 = min(spec.x + spec.width, spec.full_x + spec.full_width)
    if y1 > y0 and x1 > x0:
        out[y0 - spec.full_y:y1 - spec.full_y, x0 - spec.full_x:x1 - spec.full_x] = \
            data[y0 - spec.y:y1 - spec.y, x0 - spec.x:x1 - spec.x]
    return out


def _exr_with_uint(inp, spec, path: Path) -> np.ndarray:
    """An EXR holding UINT channels (ids), channel by channel: the integers as they are, float
    channels as floats (OpenImageIO alone would scale the integers to [0, 1])."""
    planes = []
    for c in range(spec.nchannels):
        uint = spec.channelformat(c).basetype == oiio.UINT
        px = inp.read_image(0, 0, c, c + 1, oiio.TypeUInt32 if uint else oiio.TypeFloat)
        if px is None:
            raise ValueError(f"cannot read image {path}: {inp.geterror() or oiio.geterror()}")
        px = np.asarray(px).reshape(spec.height, spec.width)
        if uint and px.size and int(px.max()) > _FLOAT32_EXACT:
            raise ValueError(f"cannot read image {path}: its uint channel {spec.channelnames[c]!r} holds "
                             f"{int(px.max())}, beyond 2**24, which float32 cannot hold exactly")
        planes.append(px.astype(np.float32))
    return np.stack(planes, axis=-1)


def read_image(path) -> np.ndarray:
    """Read an image file as float32.

    Parameters
    ----------
    path : str or os.PathLike
        Any format OpenImageIO reads; the first subimage is read.

    Returns
    -------
    image : ndarray, float32, shape (H, W) for one channel, else (H, W, C)
        Float files (EXR, HDR, float TIFF) come back as stored (half is
        widened exactly), except that a Radiance HDR's values are divided by
        the product of its ``EXPOSURE=`` and ``COLORCORR=`` header lines
        (multipliers its writer applied, which Radiance's own readers
        divide out; one not a positive finite number is passed over), to
        give the radiances the file was made from; an EXR's uint channels
        (ids) as their integers (ValueError beyond 2**24, which float32
        cannot hold). Integer
        files (8-bit PNG/JPEG, 16-bit PNG) are taken as sRGB-encoded:
        value ``v`` of ``2^b - 1`` decodes to
        ``srgb_to_linear(v / (2^b - 1))``, linear in [0, 1]; an alpha channel
        is only scaled to [0, 1] (straight alpha, as stored). Signed integer
        files are refused (ValueError).

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    PermissionError
        No permission to read the file.
    ValueError
        ``path`` is not a file or OpenImageIO cannot read it (the message
        names the path and OpenImageIO's reason), or it is a truncated JPEG
        (whose decoder would fill the missing part with grey).

    Notes
    -----
    A (H, W, 1) array written to EXR reads back as (H, W), with the same bits.

    The image comes back upright, row 0 at the top: a file's orientation
    (a Radiance HDR stored bottom-up, ``+Y H +X W``, or column-wise; a TIFF
    or JPEG orientation tag) is applied. It covers the file's display window:
    an EXR whose data window is smaller or offset has its pixels placed
    there, zeros where none is stored (overscan outside the display window
    is dropped).

    A Radiance HDR whose header has no ``FORMAT=`` line (optional in the
    format, whose default is ``32-bit_rle_rgbe``; OpenImageIO refuses such
    files) is read as that format, through a temporary copy with the line.
    """
    path = Path(os.fspath(path))
    if not path.exists():
        raise FileNotFoundError(errno.ENOENT, "no such image file", str(path))
    if not path.is_file():
        raise ValueError(f"cannot read image {path}: not a file")
    with open(path, "rb"):      # the system's PermissionError, not OpenImageIO's "Could not open" as a ValueError
        pass
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp, copy = oiio.ImageInput.open(str(path), config), None
    if inp is None:
        reason = oiio.geterror()
        copy = _radiance_with_format(path)          # a Radiance HDR without its optional FORMAT= line
        inp = None if copy is None else oiio.ImageInput.open(str(copy), config)
        if inp is None:
            if copy is not None:
                copy.unlink()
                reason = oiio.geterror()
            raise ValueError(f"cannot read image {path}: {reason}")
    try:
        spec = inp.spec()
        C, alpha = spec.nchannels, spec.alpha_channel
        fmt = spec.format
        if inp.format_name() == "openexr" and any(spec.channelformat(c).basetype == oiio.UINT
                                                  for c in range(C)):
            native, top = _exr_with_uint(inp, spec, path), None
        elif fmt == oiio.TypeUInt8 or fmt == oiio.TypeUInt16:
            native = inp.read_image(fmt)
            top = 255.0 if fmt == oiio.TypeUInt8 else 65535.0
        elif fmt.basetype in (oiio.INT8, oiio.INT16, oiio.INT32, oiio.INT64):
            raise ValueError(f"cannot read image {path}: its channels are signed integers ({fmt}), which have no "
                             "colour encoding (OpenImageIO maps them to [-1, 1]; the negative half would be lost); "
                             "store them as float (EXR, float TIFF) or as unsigned integers")
        elif fmt.basetype in (oiio.HALF, oiio.FLOAT, oiio.DOUBLE):
            native, top = inp.read_image(oiio.TypeFloat), None
        else:  # other integer types: OpenImageIO maps them to [0, 1]
            native, top = inp.read_image(oiio.TypeFloat), 1.0
        if native is None:
            raise ValueError(f"cannot read image {path}: {inp.geterror() or oiio.geterror()}")
        warning = inp.geterror()        # a non-fatal decoder complaint, the pixels returned all the same
        if "premature end" in warning.lower():      # libjpeg: data missing, the rest filled with grey
            raise ValueError(f"cannot read image {path}: it is truncated ({warning.strip()})")
        head = _radiance_header(inp, path)
        orientation, multiplier = _orientation(spec, head), _radiance_multiplier(head, C)
    finally:
        inp.close()
        if copy is not None:
            copy.unlink()
    data = _display_window(np.asarray(native).reshape(spec.height, spec.width, C), spec)
    data = _ORIENT.get(orientation, _ORIENT[1])(data)
    if multiplier is not None:      # the radiances the file was made from (Radiance's own readers divide too)
        data = data.astype(np.float64) / multiplier
    if top is not None:
        enc = data.astype(np.float64) / top
        colour = [c for c in range(C) if c != alpha]
        enc[:, :, colour] = srgb_to_linear(enc[:, :, colour])
        data = enc
    data = np.ascontiguousarray(data, dtype=np.float32)
    return data[:, :, 0] if C == 1 else data
