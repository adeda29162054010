"""The image formats texbake writes and the bit depths each takes: one rule for the
settings, the image writer and the save step."""

from __future__ import annotations

from .errors import ParameterError

BITS = {"png": (8, 16), "exr": (16, 32), "tif": (8, 16, 32)}  # the bit depths each format takes
DEFAULT_BITS = {"png": 8, "exr": 16, "tif": 16}


def format_name(name: str) -> str:
    """An image format as texbake names it: lower case, no leading dot, "tiff" as "tif"."""
    name = name.lower().lstrip(".")
    return "tif" if name == "tiff" else name


def image_format(name: str) -> str:
    """:func:`format_name` of ``name`` (a format or an extension); :class:`ParameterError`
    (``format``) unless it is one of :data:`BITS`."""
    fmt = format_name(name)
    if fmt not in BITS:
        raise ParameterError("format", f"expected png, exr, tif or tiff, got {fmt!r}")
    return fmt


def bits_problem(fmt: str, bits) -> str | None:
    """Why ``bits`` is not a bit depth the image format ``fmt`` takes, or None."""
    if bits in BITS[fmt]:
        return None
    return f"{fmt} takes {' or '.join(map(str, BITS[fmt]))} bits, got {bits!r}"
