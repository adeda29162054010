"""Image maps in and out with OpenImageIO, written atomically and checked.

Dtype policy: pixels come in as ``(h, w, c)`` float linear values, row 0 at the top,
c = 1, 3 or 4 (the 4th channel is alpha, never colour-encoded). PNG and 8/16-bit TIFF are
written sRGB-encoded (colour space ``srgb_rec709_scene``); EXR (half or float) and 32-bit
TIFF linear (``lin_rec709_scene``). ``read_image`` returns float32 linear values.

A file is written under a temporary name beside its final one, read back in full and
compared with what was meant to be written (OpenImageIO reports success on a PNG
truncated by a full disk), and only then renamed into place.
"""

from __future__ import annotations

import functools
import os
import uuid
from pathlib import Path

import numpy as np

from .errors import OutputError, ParameterError

SRGB = "srgb_rec709_scene"
LINEAR = "lin_rec709_scene"
BITS = {"png": (8, 16), "exr": (16, 32), "tif": (8, 16, 32)}
_DEFAULT_BITS = {"png": 8, "exr": 16, "tif": 16}
_BAND = 512  # rows encoded at a time (bounded memory)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of values clipped to [0, 1]."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`srgb_encode`."""
    x = np.asarray(encoded, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def _format(path: Path, fmt: str | None) -> str:
    f = (fmt or path.suffix).lower().lstrip(".")
    f = "tif" if f == "tiff" else f
    if f not in BITS:
        raise ParameterError("format", f"expected one of {', '.join(BITS)}, got {f!r}")
    return f


_LUT_LEVELS = 1 << 20  # linear levels of the 8-bit sRGB table: off by one level < 1e-4 of the time


@functools.cache
def _srgb8_table() -> np.ndarray:
    return np.rint(srgb_encode(np.arange(_LUT_LEVELS) / (_LUT_LEVELS - 1)) * 255).astype(np.uint8)


def _encode(pixels: np.ndarray, fmt: str, bits: int) -> tuple[np.ndarray, str]:
    """The array to store (its dtype is the file's) and its colour space."""
    if fmt == "exr" or bits == 32:
        return pixels.astype(np.float16 if bits == 16 else np.float32), LINEAR
    dtype, top = (np.uint8, 255) if bits == 8 else (np.uint16, 65535)
    out = np.empty(pixels.shape, dtype=dtype)
    colour = min(pixels.shape[2], 3) if pixels.shape[2] != 2 else 1
    for r in range(0, pixels.shape[0], _BAND):
        band = np.clip(pixels[r : r + _BAND], 0.0, 1.0)
        if bits == 8:  # table lookup: ten times faster than the power function
            index = (band[..., :colour] * (_LUT_LEVELS - 1) + 0.5).astype(np.int32)
            out[r : r + _BAND, :, :colour] = _srgb8_table()[index]
        else:
            out[r : r + _BAND, :, :colour] = np.rint(srgb_encode(band[..., :colour].astype(np.float64)) * top)
        out[r : r + _BAND, :, colour:] = np.rint(band[..., colour:] * top)
    return out, SRGB


def write_image(path, pixels, *, fmt: str | None = None, bits: int | None = None) -> dict:
    """Write ``(h, w, c)`` float linear ``pixels`` to ``path``; returns what was written.

    ``fmt``: "png", "exr" or "tif" (default: from the extension); ``bits``: 8 or 16 for
    PNG, 16 (half) or 32 (float) for EXR, 8, 16 or 32 (float) for TIFF.
    Raises :class:`OutputError` if the file cannot be written completely.
    """
    import OpenImageIO as oiio  # pip install OpenImageIO

    path = Path(path)
    fmt = _format(path, fmt)
    bits = _DEFAULT_BITS[fmt] if bits is None else bits
    if bits not in BITS[fmt]:
        raise ParameterError("bits", f"{fmt} takes {' or '.join(map(str, BITS[fmt]))} bits, got {bits}")
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 2, 3, 4) or 0 in pixels.shape:
        raise ParameterError("pixels", f"expected (h, w, 1-4) values, got shape {pixels.shape}")
    data, colorspace = _encode(pixels, fmt, bits)
    h, w, c = data.shape
    typedesc = {np.uint8: oiio.UINT8, np.uint16: oiio.UINT16, np.float16: oiio.HALF, np.float32: oiio.FLOAT}[data.dtype.type]

    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{path.suffix or '.' + fmt}")
    try:
        spec = oiio.ImageSpec(w, h, c, typedesc)
        spec.attribute("oiio:ColorSpace", colorspace)
        spec.attribute("Software", "texbake")
        spec.attribute("oiio:UnassociatedAlpha", 1)  # alpha is coverage, not premultiplied
        spec.attribute("compression", "zip")
        spec.attribute("png:compressionLevel", 3)  # most of the size for half the time
        if fmt == "tif":
            spec.attribute("tiff:write_exif", 0)  # libtiff fails on OIIO's Exif directory
        out = oiio.ImageOutput.create(str(tmp))
        if out is None:
            raise OutputError(f"{path}: cannot create a {fmt} writer: {oiio.geterror()}")
        ok = out.open(str(tmp), spec) and out.write_image(data)
        error = out.geterror()
        ok = out.close() and ok
        error = error or out.geterror()
        if not ok or error:
            raise OutputError(f"{path}: write failed: {error or 'unknown OpenImageIO error'}")
        back = _read_raw(tmp, data.dtype)
        if back.shape != data.shape or not np.array_equal(back, data):
            raise OutputError(f"{path}: the written file does not read back intact (disk full?)")
        os.replace(tmp, path)
    except OutputError:
        tmp.unlink(missing_ok=True)
        raise
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(f"{path}: {exc.strerror or exc}") from None
    return {
        "path": str(path), "format": fmt, "bits": bits, "colorspace": colorspace,
        "width": w, "height": h, "channels": c, "bytes": path.stat().st_size,
    }


def _open(path: Path):
    """An ImageInput that keeps alpha as stored (not premultiplied), or None."""
    import OpenImageIO as oiio

    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    return oiio.ImageInput.open(str(path), config)


def _read_raw(path: Path, dtype) -> np.ndarray:
    import OpenImageIO as oiio

    inp = _open(path)
    if inp is None:
        raise OutputError(f"{path}: cannot be read back: {oiio.geterror()}")
    try:
        want = {np.uint8: oiio.UINT8, np.uint16: oiio.UINT16, np.float16: oiio.HALF, np.float32: oiio.FLOAT}[np.dtype(dtype).type]
        data = inp.read_image(want)
        error = inp.geterror()
    finally:
        inp.close()
    if data is None or error:
        raise OutputError(f"{path}: cannot be read back: {error or 'no data'}")
    data = np.asarray(data)
    return data if data.ndim == 3 else data[:, :, None]


def read_image(path) -> np.ndarray:
    """``(h, w, c)`` float32 linear pixels of an image file (sRGB decoded where tagged)."""
    import OpenImageIO as oiio

    inp = _open(path)
    if inp is None:
        raise OutputError(f"{path}: cannot read: {oiio.geterror()}")
    try:
        spec = inp.spec()
        data = inp.read_image(oiio.FLOAT)
        colorspace = str(spec.getattribute("oiio:ColorSpace") or "")
        integer = spec.format.basetype in (oiio.UINT8, oiio.UINT16)
    finally:
        inp.close()
    data = np.asarray(data, dtype=np.float32)
    data = data if data.ndim == 3 else data[:, :, None]
    if "srgb" in colorspace.lower() or (integer and not colorspace):
        colour = min(data.shape[2], 3) if data.shape[2] != 2 else 1
        data[..., :colour] = srgb_decode(data[..., :colour])
    return data
