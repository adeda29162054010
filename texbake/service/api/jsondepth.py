"""How deep the JSON a client sends may nest, checked before anything parses it.

Python's ``json`` (which FastAPI parses request bodies with) recurses, so a body nested
100,000 deep ends in a RecursionError (FastAPI's bare 400) after a deep walk, and
pydantic's parser (the multipart ``settings`` field) has a limit of its own. One limit
for all, the texture specs' (:data:`texbake.textures.spec.MAX_NESTING`), counted without
parsing: each ``[`` or ``{`` outside strings is one level, the outermost included.
"""

from __future__ import annotations

from texbake.textures.spec import MAX_NESTING

MAX_DEPTH = MAX_NESTING
MAX_BYTES = 1 << 20  # of a JSON request body: far more than a swatch's, little to scan

def depth(data: bytes | str) -> int:
    """The deepest nesting of ``[`` and ``{`` in JSON ``data``, outside strings (no parse).

    Vectorised, in time linear in the length: a quote is a string's end or start unless
    an odd run of backslashes comes before it, a bracket is inside a string after an odd
    number of those quotes, the depth is the brackets' running sum. (A regular expression
    for strings backtracks: quadratic on a quote and many escaped quotes.)
    """
    import numpy as np

    raw = np.frombuffer(data.encode() if isinstance(data, str) else data, np.uint8)
    if not len(raw):
        return 0
    at = np.arange(len(raw), dtype=np.int64)
    plain = np.maximum.accumulate(np.where(raw == ord("\\"), -1, at))  # the last byte at or before each that is no backslash
    backslashes_before = np.concatenate([[0], at[:-1] - plain[:-1]])
    quotes = (raw == ord('"')) & (backslashes_before % 2 == 0)
    outside = np.cumsum(quotes) % 2 == 0
    opens = ((raw == ord("[")) | (raw == ord("{"))) & outside
    closes = ((raw == ord("]")) | (raw == ord("}"))) & outside
    return max(0, int(np.cumsum(opens.astype(np.int64) - closes).max()))


def too_deep(data: bytes | str) -> str | None:
    """Why ``data`` is refused (nested deeper than :data:`MAX_DEPTH`), or None."""
    found = depth(data)
    return f"JSON nested {found:,} deep: the limit is {MAX_DEPTH}" if found > MAX_DEPTH else None


def shallow(value):
    """A pydantic before-validator of a ``Json`` field: its text refused past the limit."""
    if isinstance(value, (str, bytes)) and (why := too_deep(value)):
        raise ValueError(why)
    return value
