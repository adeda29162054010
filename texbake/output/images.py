"""Image maps in and out, written atomically and checked: EXR and TIFF through OpenImageIO,
PNG by texbake itself (OpenImageIO's chunks, the pixel stream deflated on two threads; see
``_write_png``), every format read through OpenImageIO.

Pixels come in as ``(h, w, c)`` float values, row 0 at the top, c = 1, 2, 3 or 4 (the
last channel of 2 or 4 is alpha, never colour-encoded). Colour policy by format:

========  =========  =====================================  ==========================
format    bits       stored as                              ``oiio:ColorSpace``
========  =========  =====================================  ==========================
png       8, 16      sRGB-encoded integers                  ``srgb_rec709_scene``
tif       8, 16      sRGB-encoded integers                  ``srgb_rec709_scene``
tif       32         linear float                           ``lin_rec709_scene``
exr       16, 32     linear half / float, zip compression   ``lin_rec709_scene``
========  =========  =====================================  ==========================

``colorspace`` says what the given pixels are: ``"linear"`` (the default: scene-linear
Rec.709 colour), ``"srgb"`` (already sRGB-encoded: stored as they are in integer files,
decoded to linear for float files) or ``"data"`` (non-colour values such as normals or
masks: stored as they are everywhere, tagged ``data``/``Raw``).

OpenImageIO 3.2 names (its built-in config): ``srgb_rec709_scene`` and
``lin_rec709_scene`` are canonical; ``"sRGB"`` and ``"linear"`` are accepted aliases, but
``"scene_linear"`` is the ACEScg *role* (it is stored as ``lin_ap1_scene``: wrong
primaries) and ``"Raw"`` is stored as ``data`` in EXR. PNG has no way to say "data": such
a PNG is written as linear (a ``gAMA`` chunk of 1.0, no ``sRGB`` or ``cHRM`` chunk, so
that an image viewer does not decode it as sRGB) with a ``texbake:ColorSpace`` text field
saying ``data``, which ``read_image`` looks at (glTF ignores a PNG's colour chunks: the slot
says how it is read).

A file is written under a temporary name beside its final one (same folder, so the
rename is atomic), flushed to the disk, checked against what was meant to be written
(OpenImageIO reports success on a PNG truncated by a full disk), and only then renamed
into place. A PNG is checked without decoding it: every chunk whole with its CRC, the
end at the end of the file, and the checksum that closes its compressed stream (the
Adler-32 of the rows as filtered) equal to that of the rows given to the encoder. EXR
and TIFF files are read back and compared band by band. On any failure the temporary file is removed and
:class:`OutputError` names the path and the reason; nothing is ever left under the final
name.
"""

from __future__ import annotations

import functools
import struct
import tempfile
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from zlib_ng import zlib_ng

from .. import _native
from ..errors import OutputError, ParameterError
from ..formats import DEFAULT_BITS, bits_problem, image_format
from .atomic import replacing
from .atomic import sync as _sync  # a module global: tests put a failure in it

SRGB = "srgb_rec709_scene"
LINEAR = "lin_rec709_scene"
DATA = "data"
_EXTENSION = {"png": ".png", "exr": ".exr", "tif": ".tif"}
_COLORSPACES = {"linear": "linear", "lin_rec709_scene": "linear", "srgb": "srgb", "srgb_rec709_scene": "srgb",
                "data": "data", "raw": "data"}
_BAND_TEXELS = 1 << 20  # texels encoded (and checked) at a time: bounded memory, some 50 MB
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_FILTER_UP = 0x20  # png.h's PNG_FILTER_UP
_PNG_UP = 2  # the "up" filter's byte in a row
_EXIF_SRGB, _EXIF_UNCALIBRATED = 1, 0xFFFF


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of values clipped to [0, 1]."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`srgb_encode`."""
    x = np.asarray(encoded, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


# -- exact 8-bit sRGB encoding, fast ------------------------------------------------------
# A table over 2**20 linear levels gives round(255 * oetf(x)) off by one level for about
# 1e-4 of the values (those close to a rounding threshold); each value is then moved to
# the exact code by comparing it with the thresholds on either side of the table's code
# (compiled: ``native/images.cpp``, one pass, rows on the cores, no GIL; numpy's version
# made five temporaries and took as long as the compression).

_LUT_LEVELS = 1 << 20


@functools.cache
def _srgb8_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    table = np.rint(srgb_encode(np.arange(_LUT_LEVELS) / (_LUT_LEVELS - 1)) * 255).astype(np.uint8)
    # code(x) > k  <=>  x >= decode((k + 0.5) / 255); as the smallest float32 at or above it
    t = srgb_decode((np.arange(255) + 0.5) / 255)
    t32 = t.astype(np.float32)
    low = t32.astype(np.float64) < t
    t32[low] = np.nextafter(t32[low], np.float32(np.inf))
    above = np.append(t32, np.float32(np.inf))  # threshold to reach code + 1
    below = np.insert(t32, 0, np.float32(-np.inf))  # threshold of the code itself
    return table, above, below


# what encode8 takes for tables where no channel is sRGB-encoded: read by no code
_NO_SRGB8 = (np.zeros(2, dtype=np.uint8), np.full(256, np.inf, dtype=np.float32), np.full(256, -np.inf, dtype=np.float32))


def _band_rows(width: int) -> int:
    """Rows of a band of an image ``width`` texels wide (write and check use the same)."""
    return max(8, _BAND_TEXELS // max(width, 1))


def _stored(fmt: str, bits: int, given: str) -> tuple[type, str]:
    """The file's pixel type and colour space for pixels that hold ``given``."""
    if fmt == "exr" or bits == 32:
        return (np.float16 if bits == 16 else np.float32), DATA if given == "data" else LINEAR
    return (np.uint8 if bits == 8 else np.uint16), DATA if given == "data" else SRGB


def _encode(pixels: np.ndarray, fmt: str, bits: int, given: str) -> np.ndarray:
    """Rows of ``pixels`` as the file stores them (:func:`_stored`)."""
    colour = 1 if pixels.shape[2] <= 2 else 3  # channels after these are alpha
    dtype, _ = _stored(fmt, bits, given)
    if dtype in (np.float16, np.float32):
        data = pixels.astype(dtype)
        if given == "srgb":
            data[..., :colour] = srgb_decode(pixels[..., :colour])
        return data
    top = 255 if bits == 8 else 65535
    out: np.ndarray = np.empty(pixels.shape, dtype=dtype)
    # NaN is written as 0 and infinities clipped: integer files have no room for them
    if bits == 8:
        if pixels.dtype == np.bool_:
            pixels = pixels.view(np.uint8)
        elif pixels.dtype not in (np.float32, np.float64):  # float16 (maps of 8192² and more): widened here
            pixels = pixels.astype(np.float32)  # a band: bounded
        # the tables (2**20 levels: 10 ms to make) only for a map with channels to sRGB-encode
        _native.encode8(pixels, colour if given == "linear" else 0, *(_srgb8_tables() if given == "linear" else _NO_SRGB8), out)
        return out
    if given != "linear":  # no channel sRGB-encoded: compiled, one pass
        if pixels.dtype not in (np.float32, np.float64):
            pixels = pixels.astype(np.float32)
        _native.encode16(pixels, out)
        return out
    band = np.clip(np.nan_to_num(pixels.astype(np.float32), nan=0.0), 0.0, 1.0)
    if given == "linear":
        out[..., :colour] = np.rint(srgb_encode(band[..., :colour].astype(np.float64)) * top)
    else:
        out[..., :colour] = np.rint(band[..., :colour] * np.float32(top))
    out[..., colour:] = np.rint(band[..., colour:] * np.float32(top))
    return out


def _typedesc(dtype):
    import OpenImageIO as oiio

    return {np.uint8: oiio.UINT8, np.uint16: oiio.UINT16, np.float16: oiio.HALF, np.float32: oiio.FLOAT}[np.dtype(dtype).type]


def write_image(path, pixels, *, fmt: str | None = None, bits: int | None = None, colorspace: str = "linear") -> dict:
    """Write an image map to ``path``, atomically, and check it was written whole.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its folder must exist. An older file of that name is replaced only
        once the new one is complete.
    pixels : (h, w, c) or (h, w) array_like of float or bool
        Row 0 at the top; c = 1, 2, 3 or 4 (the last of 2 or 4 is alpha, never
        colour-encoded). float16, float32, float64 or bool (the coverage mask). Integer
        files clip values to ``[0, 1]`` and write NaN as 0; float files keep every value.
    fmt : {"png", "exr", "tif", "tiff"}, optional
        Default: from the suffix of ``path``.
    bits : int, optional
        8 or 16 for PNG (default 8); 16 (half, default) or 32 (float) for EXR; 8, 16
        (default) or 32 (float) for TIFF.
    colorspace : {"linear", "srgb", "data"}, optional
        What ``pixels`` hold (see the module's table): scene-linear colour (default),
        sRGB-encoded colour, or non-colour data stored as given.

    Returns
    -------
    dict
        What was written: ``path`` (str), ``format``, ``bits``, ``colorspace`` (the
        file's), ``width``, ``height``, ``channels`` and ``bytes`` (the file's size).

    Raises
    ------
    ParameterError
        A bad format, bit depth, colour space, or pixel array (shape or dtype).
    OutputError
        The file could not be written or read back whole (a full disk, a missing or
        read-only folder); nothing is left under ``path``'s name, nor a temporary file.
    """
    path = Path(path)
    fmt = image_format(fmt or path.suffix)
    bits = DEFAULT_BITS[fmt] if bits is None else bits
    if problem := bits_problem(fmt, bits):
        raise ParameterError("bits", problem)
    given = _COLORSPACES.get(str(colorspace).lower())
    if given is None:
        raise ParameterError("colorspace", f"expected linear, srgb or data, got {colorspace!r}")
    pixels = _pixels(pixels)
    dtype, stored = _stored(fmt, bits, given)
    h, w, c = pixels.shape
    # one transaction: write to a temporary name, flush, read back and compare, rename
    with replacing(path, _EXTENSION[fmt]) as tmp:
        if fmt == "png":
            digests = _write_png(tmp, pixels, _png_header(w, h, c, bits, stored), (fmt, bits, given))
        else:
            digests = _write_bands(path, tmp, pixels, _spec(pixels.shape, dtype, fmt, stored), (fmt, bits, given))
        _sync(tmp)
        _verify(tmp, digests, (h, w, c), dtype, fmt)
    return {
        "path": str(path), "format": fmt, "bits": bits, "colorspace": stored,
        "width": w, "height": h, "channels": c, "bytes": path.stat().st_size,
    }


def _pixels(pixels) -> np.ndarray:
    """``pixels`` as an ``(h, w, c)`` array, c = 1 to 4, of floats or bools; a 2D array is one channel."""
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 2, 3, 4) or 0 in pixels.shape:
        raise ParameterError("pixels", f"expected (h, w, 1-4) values, got shape {pixels.shape}")
    if not (np.issubdtype(pixels.dtype, np.floating) or pixels.dtype == np.bool_):
        raise ParameterError("pixels", f"expected float (or bool) values, got {pixels.dtype}")
    return pixels


def _spec(shape: tuple[int, ...], dtype, fmt: str, stored: str):
    """The OpenImageIO ``ImageSpec`` of a file of ``(h, w, c)`` pixels of ``dtype`` whose colour space is ``stored``."""
    import OpenImageIO as oiio  # pip install OpenImageIO

    h, w, c = shape
    spec = oiio.ImageSpec(w, h, c, _typedesc(dtype))
    # PNG data: OpenImageIO writes gAMA 1.0 for a linear PNG and no colour chunk for Raw
    spec.attribute("oiio:ColorSpace", (LINEAR if fmt == "png" else "Raw") if stored == DATA else stored)
    spec.attribute("Software", "texbake")
    if stored == DATA:
        spec.attribute("texbake:ColorSpace", DATA)  # PNG, TIFF cannot say it otherwise
    if c in (2, 4):
        spec.attribute("oiio:UnassociatedAlpha", 1)  # alpha is coverage, not premultiplied
    spec.attribute("compression", "zip")
    # one row filter, "up", not libpng's trial of all five on every row, and zlib's level 4
    # (its first with lazy matching): baked maps are smooth fields, which "up" predicts well
    spec.attribute("png:compressionLevel", 4)
    spec.attribute("png:filter", _PNG_FILTER_UP)
    if fmt == "tif":
        # libtiff fails ("TIFFWriteCustomDirectory() of the Exif data") on the Exif
        # directory OIIO writes unless it holds a tag: the colour space is one.
        spec.attribute("Exif:ColorSpace", _EXIF_SRGB if stored == SRGB else _EXIF_UNCALIBRATED)
    return spec


def _write_bands(path: Path, tmp: Path, pixels: np.ndarray, spec, encoding: tuple[str, int, str]) -> list[int]:
    """Write ``pixels`` to ``tmp`` a band at a time (memory stays bounded), the next band
    encoded (:func:`_encode` with ``encoding``: format, bits, colour space given) while
    this one is compressed; return what to check the file against: the CRC-32 of each
    band as written, or for a PNG the Adler-32 its stream must close with
    (:class:`_PngRows`). :class:`OutputError` names ``path`` if OpenImageIO fails."""
    import OpenImageIO as oiio

    fmt = encoding[0]
    out = oiio.ImageOutput.create(str(tmp))
    if out is None:
        raise OutputError(f"{path}: cannot create a {fmt} writer: {oiio.geterror() or 'unknown error'}")
    ok = bool(out.open(str(tmp), spec))
    error = out.geterror()
    digests: list[int] = []
    rows = _PngRows() if fmt == "png" else None
    h, band = len(pixels), _band_rows(pixels.shape[1])
    with ThreadPoolExecutor(1, thread_name_prefix="texbake-encode") as encoder:
        pending = encoder.submit(_encode, pixels[:band], *encoding)
        for r in range(0, h, band) if ok else ():
            data = pending.result()
            if r + band < h:
                pending = encoder.submit(_encode, pixels[r + band : r + 2 * band], *encoding)
            if rows is not None:
                rows.add(data)
            else:
                digests.append(zlib.crc32(data.data))
            if not out.write_scanlines(r, r + len(data), 0, data):
                ok, error = False, out.geterror()
                break
    ok = bool(out.close()) and ok
    error = error or out.geterror() or oiio.geterror()
    if not ok or error:
        raise OutputError(f"{path}: write failed: {error or 'unknown OpenImageIO error'}")
    return rows.adlers() if rows is not None else digests


# -- PNG: OpenImageIO's chunks, texbake's stream compressed on both cores -----------------
# OpenImageIO (libpng) compresses a PNG's one zlib stream on one core: 90 ms of a 1024² 16-bit
# normal map, more than its bake. The pixel stream is written here instead, as pigz writes
# one: pieces of the filtered rows deflated at once on two threads (the GIL released),
# each but the last ended by a sync flush (a byte-aligned empty stored block), so that their
# concatenation is one valid deflate stream; the Adler-32 of the whole closes it. The chunks
# before it (colour chunks, eXIf, text) are the ones OpenImageIO writes for the same spec.
# The deflate is zlib-ng's (python-zlib-ng): on a 1024² 16-bit normal map at level 4 it took
# 49 ms for 2.01 MB where zlib took 80 ms for 2.06 MB (one core; zlib-ng's level 1 is a
# different, much larger, kind of stream).

_PNG_PIECE = 1 << 19  # filtered bytes deflated at a time: two threads busy, memory bounded
_ZLIB_HEADER = b"\x78\x5e"  # deflate, 32K window, "fast" (levels 2-5): what zlib writes at level 4
_PNG_LEVEL = 4


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


# What OpenImageIO 3.x writes before a PNG's pixels for texbake's spec (_spec), chunk for
# chunk: colour chunks (data: gAMA 1.0 alone; sRGB: sRGB, gAMA 1/2.2, cHRM), its Exif block
# (the Software tag), a zero offset, the Software text and, for data, texbake's colour-space
# text. tests/texbake/output/test_images.py holds them equal to what OpenImageIO writes.
_PNG_COLOUR_CHUNKS = {
    DATA: ((b"gAMA", bytes.fromhex("000186a0")),),
    SRGB: ((b"sRGB", b"\x03"), (b"gAMA", bytes.fromhex("0000b18f")),
           (b"cHRM", bytes.fromhex("00007a26000080840000fa00000080e8000075300000ea6000003a9800001770"))),
}
_PNG_TEXT_CHUNKS = ((b"eXIf", bytes.fromhex("4d4d002a0000001074657862616b6500000101310002000000080000000800000000")),
                    (b"oFFs", bytes(9)), (b"tEXt", b"Software\x00texbake"))
_PNG_COLOUR_TYPE = {1: 0, 2: 4, 3: 2, 4: 6}  # grey, grey + alpha, RGB, RGBA


def _png_header(width: int, height: int, channels: int, bits: int, stored: str) -> bytes:
    """The signature and the chunks before a PNG's pixel data, as OpenImageIO writes them
    (:data:`_PNG_COLOUR_CHUNKS`), for ``channels`` of ``bits`` in colour space ``stored``."""
    ihdr = struct.pack(">IIBBBBB", width, height, bits, _PNG_COLOUR_TYPE[channels], 0, 0, 0)
    text = _PNG_TEXT_CHUNKS + (((b"tEXt", b"texbake:ColorSpace\x00data"),) if stored == DATA else ())
    return PNG_SIGNATURE + b"".join(_png_chunk(kind, body) for kind, body in ((b"IHDR", ihdr), *_PNG_COLOUR_CHUNKS[stored], *text))


def _deflated(piece: memoryview, last: bool) -> tuple[bytes, int]:
    """``(raw deflate of piece, its Adler-32)``; a sync flush ends it unless ``last``."""
    z = zlib_ng.compressobj(_PNG_LEVEL, zlib_ng.DEFLATED, -15)
    return z.compress(piece) + z.flush(zlib_ng.Z_FINISH if last else zlib_ng.Z_SYNC_FLUSH), zlib.adler32(piece)


def _write_png(tmp: Path, pixels: np.ndarray, header: bytes, encoding: tuple[str, int, str]) -> list[int]:
    """Write ``pixels`` as a PNG to ``tmp``: ``header`` (:func:`_png_header`), then its rows
    filtered "up", deflated a piece at a time on two threads, a band encoded at a time
    (:func:`_encode` with ``encoding``); return the Adler-32 values the stream may close
    with (:class:`_PngRows`, for the check)."""
    h, w, _ = pixels.shape
    rows, band = _PngRows(), _band_rows(w)
    adler = 1
    with open(tmp, "wb") as f, ThreadPoolExecutor(2, thread_name_prefix="texbake-deflate") as pool:
        f.write(header)
        prefix = _ZLIB_HEADER
        for r in range(0, h, band):
            filtered = rows.add(_encode(pixels[r : r + band], *encoding))
            flat = memoryview(filtered.data).cast("B")
            step = max(1, _PNG_PIECE // filtered.shape[1]) * filtered.shape[1]  # whole rows
            last = r + band >= h
            starts = range(0, len(flat), step)
            pieces = [pool.submit(_deflated, flat[i : i + step], last and i + step >= len(flat)) for i in starts]
            for i, piece in zip(starts, pieces, strict=True):  # in order: the stream's pieces follow each other
                data, a = piece.result()
                adler = _adler32_combine(adler, a, min(step, len(flat) - i))
                f.write(_png_chunk(b"IDAT", prefix + data))
                prefix = b""
        f.write(_png_chunk(b"IDAT", struct.pack(">I", adler)) + _png_chunk(b"IEND", b""))
    return rows.adlers()


class _PngRows:
    """The Adler-32 of a PNG's rows as they are compressed: each row's filter byte, then
    its bytes (big-endian samples) less those of the row above ("up", the filter
    ``_spec`` sets; the first row has none above it, and libpng may mark it "none")."""

    def __init__(self) -> None:
        self._first: bytes | None = None  # the first row's bytes
        self._rest = zlib.adler32(b"")  # the rows after it, filtered
        self._rest_bytes = 0
        self._above = np.zeros(0, dtype=np.uint8)  # the last row added

    def add(self, band: np.ndarray) -> np.ndarray:
        """The next ``(rows, w, c)`` uint8 or uint16 rows; returns them filtered, ``(rows, 1 +
        row bytes)`` uint8, each marked "up" (the image's first row too: the row above it
        is zero)."""
        big_endian = band if band.dtype.itemsize == 1 else band.astype(band.dtype.newbyteorder(">"))
        raw = np.ascontiguousarray(big_endian).view(np.uint8).reshape(len(band), -1)
        filtered = np.empty((len(raw), raw.shape[1] + 1), dtype=np.uint8)
        filtered[:, 0] = _PNG_UP
        start = 0
        if self._first is None:
            self._first = raw[0].tobytes()
            filtered[0, 1:] = raw[0]
            start = 1
        else:
            np.subtract(raw[:1], self._above, out=filtered[:1, 1:])  # uint8: modulo 256, as the filter
        np.subtract(raw[1:], raw[:-1], out=filtered[1:, 1:])
        rest = filtered[start:]
        self._rest = zlib.adler32(rest.data, self._rest)
        self._rest_bytes += rest.size
        self._above = raw[-1]
        return filtered

    def adlers(self) -> list[int]:
        """The stream's Adler-32 with the first row marked "none" and marked "up"."""
        assert self._first is not None
        return [_adler32_combine(zlib.adler32(bytes([kind]) + self._first), self._rest, self._rest_bytes)
                for kind in (0, _PNG_UP)]


def _adler32_combine(first: int, second: int, second_bytes: int) -> int:
    """The Adler-32 of two pieces from theirs (zlib's ``adler32_combine``)."""
    base = 65521
    rem = second_bytes % base
    low = (first & 0xFFFF) + (second & 0xFFFF) + base - 1
    high = (rem * (first & 0xFFFF)) % base + (first >> 16) + (second >> 16) + base - rem
    return (low % base) | ((high % base) << 16)


def encode_png_bytes(pixels, bits: int = 8, *, colorspace: str = "linear") -> bytes:
    """The bytes of a PNG of ``pixels`` (as :func:`write_image` writes it, checked)."""
    with tempfile.TemporaryDirectory(prefix="texbake-png-") as folder:
        target = Path(folder) / "image.png"
        write_image(target, pixels, fmt="png", bits=bits, colorspace=colorspace)
        return target.read_bytes()


def _verify(tmp: Path, digests: list[int], shape: tuple[int, int, int], dtype, fmt: str) -> None:
    """Check a written file; raise OutputError unless it is whole.

    A PNG by its chunks (:func:`_check_png_chunks`: ``digests`` are the Adler-32 values
    its stream may close with), without decoding it. Others read back a band at a time:
    each band of ``shape`` pixels of ``dtype`` must have the CRC-32 in ``digests`` it was
    written with."""
    h, w, c = shape
    if fmt == "png":
        _check_png_chunks(tmp, (w, h), digests)
        return
    import OpenImageIO as oiio
    if fmt == "tif":
        _check_tiff_layout(tmp)
    inp = _open(tmp)
    if inp is None:
        raise OutputError(f"{tmp}: cannot be read back: {oiio.geterror() or 'unknown error'}")
    try:
        spec = inp.spec()
        if (spec.height, spec.width, spec.nchannels) != shape:
            raise OutputError(f"{tmp}: reads back as {spec.width}x{spec.height}x{spec.nchannels}, not {w}x{h}x{c} (disk full?)")
        rows = _band_rows(w)
        for band, r in enumerate(range(0, h, rows)):
            back = inp.read_scanlines(0, 0, r, min(h, r + rows), 0, 0, c, _typedesc(dtype))
            error = inp.geterror()
            if back is None or error:
                raise OutputError(f"{tmp}: cannot be read back: {error or 'no data'}")
            if zlib.crc32(np.ascontiguousarray(back, dtype=dtype).data) != digests[band]:
                raise OutputError(f"{tmp}: the written pixels do not read back intact (disk full?)")
    finally:
        inp.close()


def _check_png_chunks(path: Path, size: tuple[int, int], adlers: list[int]) -> None:
    """Walk a PNG's chunks: each whole with a right CRC, IHDR of ``size`` (width, height)
    first, IEND last at the end of the file, and the IDAT stream closing with one of
    ``adlers`` (zlib's trailer: the Adler-32 of every row as it was filtered). The
    pixels are not decoded: the checksums prove the bytes the encoder made are on the
    disk, whole, and that it was given every row.

    libpng reads the pixels of a PNG cut short after its last IDAT without an error.
    """
    data = path.read_bytes()
    if not data.startswith(PNG_SIGNATURE):
        raise OutputError(f"{path}: not a PNG file (truncated?)")
    p, tail, header = len(PNG_SIGNATURE), b"", None
    while True:
        if p + 12 > len(data):
            raise OutputError(f"{path}: truncated PNG (chunk header at byte {p}, disk full?)")
        length, kind = struct.unpack_from(">I4s", data, p)
        end = p + 12 + length
        if end > len(data):
            raise OutputError(f"{path}: truncated PNG ({kind.decode('latin-1')} chunk, disk full?)")
        if zlib.crc32(data[p + 4 : end - 4]) != struct.unpack_from(">I", data, end - 4)[0]:
            raise OutputError(f"{path}: corrupt PNG ({kind.decode('latin-1')} chunk CRC)")
        if header is None:
            header = struct.unpack_from(">II", data, p + 8) if kind == b"IHDR" and length >= 8 else ()
        if kind == b"IDAT":
            tail = (tail + data[max(p + 8, end - 8) : end - 4])[-4:]
        p = end
        if kind == b"IEND":
            break
    if p != len(data):
        raise OutputError(f"{path}: {len(data) - p} stray bytes after the PNG's end")
    if header != size:
        raise OutputError(f"{path}: the PNG's header says {header}, not {size} (width, height)")
    if len(tail) < 4 or struct.unpack(">I", tail)[0] not in adlers:
        raise OutputError(f"{path}: the PNG's pixel data is not the rows written (disk full?)")


_TIFF_TYPE_SIZE = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 13: 4}
_TIFF_IFD_POINTERS = (34665, 34853, 40965, 330)  # Exif, GPS, interoperability, SubIFDs
_TIFF_DATA = ((273, 279), (324, 325))  # strip / tile offsets and byte counts


def _check_tiff_layout(path: Path) -> None:
    """Every directory, tag value, strip and tile of a (classic) TIFF inside the file.

    libtiff reads the pixels of a TIFF cut short in its trailing metadata without an
    error. BigTIFF files (only written beyond 4 GB) are left to the pixel check.
    """
    data = path.read_bytes()
    size = len(data)
    if size < 8 or data[:2] not in (b"II", b"MM"):
        raise OutputError(f"{path}: not a TIFF file (truncated?)")
    e = "<" if data[:2] == b"II" else ">"
    if struct.unpack_from(e + "H", data, 2)[0] != 42:
        return  # BigTIFF
    todo, seen = [struct.unpack_from(e + "I", data, 4)[0]], set()
    while todo:
        ifd = todo.pop()
        if ifd == 0 or ifd in seen:
            continue
        seen.add(ifd)
        if ifd + 2 > size:
            raise OutputError(f"{path}: truncated TIFF (directory at byte {ifd}, disk full?)")
        n = struct.unpack_from(e + "H", data, ifd)[0]
        if ifd + 2 + 12 * n + 4 > size:
            raise OutputError(f"{path}: truncated TIFF (directory at byte {ifd}, disk full?)")
        tags = {}
        for i in range(n):
            tag, kind, count, value = struct.unpack_from(e + "HHII", data, ifd + 2 + 12 * i)
            length = _TIFF_TYPE_SIZE.get(kind, 1) * count
            if length > 4 and value + length > size:
                raise OutputError(f"{path}: truncated TIFF (tag {tag} value, disk full?)")
            if kind in (3, 4, 13) and count:
                fmt = e + ("H" if kind == 3 else "I") * count
                tags[tag] = struct.unpack_from(fmt, data, value if length > 4 else ifd + 2 + 12 * i + 8)
        for tag in _TIFF_IFD_POINTERS:
            todo.extend(tags.get(tag, ()))
        for offsets, counts in _TIFF_DATA:
            for offset, count in zip(tags.get(offsets, ()), tags.get(counts, ()), strict=False):
                if offset + count > size:
                    raise OutputError(f"{path}: truncated TIFF (pixel data, disk full?)")
        todo.append(struct.unpack_from(e + "I", data, ifd + 2 + 12 * n)[0])


def _open(path: Path):
    """An ImageInput that keeps alpha as stored (not premultiplied), or None."""
    import OpenImageIO as oiio

    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    return oiio.ImageInput.open(str(path), config)


def read_image(path) -> np.ndarray:
    """``(h, w, c)`` float32 pixels of an image file, row 0 at the top.

    Colour channels of an sRGB file (by its ``oiio:ColorSpace``; an integer file that says
    nothing counts as sRGB) are decoded to linear; linear and data files are returned as
    stored (integers scaled to [0, 1]). Raises :class:`OutputError` if it cannot be read.
    """
    import OpenImageIO as oiio

    inp = _open(path)
    if inp is None:
        raise OutputError(f"{path}: cannot read: {oiio.geterror() or 'unknown error'}")
    try:
        spec = inp.spec()
        data = inp.read_image(oiio.FLOAT)
        error = inp.geterror()
        colorspace = str(spec.getattribute("oiio:ColorSpace") or "").lower()
        ours = str(spec.getattribute("texbake:ColorSpace") or "").lower()
        exif = spec.getattribute("Exif:ColorSpace")
        integer = spec.format.basetype in (oiio.UINT8, oiio.UINT16)
    finally:
        inp.close()
    if data is None or error:
        raise OutputError(f"{path}: cannot read: {error or 'no data'}")
    data = np.asarray(data, dtype=np.float32)
    data = data if data.ndim == 3 else data[:, :, None]
    if ours == DATA:
        srgb = False
    elif colorspace:
        srgb = "srgb" in colorspace
    else:  # e.g. TIFF: Exif says sRGB (1) or uncalibrated (65535)
        srgb = integer and exif != _EXIF_UNCALIBRATED
    if srgb:
        colour = 1 if data.shape[2] <= 2 else 3
        data[..., :colour] = srgb_decode(data[..., :colour])
    return data
