"""Equal keys and equal rows grouped in time close to linear.

Meshes of millions of faces group corners, edges and vertices by integer keys or by the
bits of their coordinates. ``np.unique(..., return_inverse=True)`` and ``np.argsort``
sort indices, several times slower than ``np.sort`` of the values (vectorised), and
``np.unique(rows, axis=0)`` compares rows byte by byte. Here every sort is ``np.sort`` of
int64 values that carry their index in the low bits: sorting them sorts the keys, ties
in index order (stable), and several keys are sorted least significant first (a radix
sort by whole keys), each pass one such sort. Rows go through a compiled hash table instead
(linear).
"""

from __future__ import annotations

import numpy as np

from .. import _native


def stable_order(*keys: np.ndarray) -> np.ndarray:
    """``(n,)`` int64 indices that sort by ``keys[0]``, then ``keys[1]``, ...: what
    ``np.lexsort(keys[::-1])`` gives (ties keep their order), for ``(n,)`` integer keys."""
    n = len(keys[0])
    bits = max(1, (n - 1).bit_length())
    order = np.arange(n, dtype=np.int64)
    if n < 2:
        return order
    for key in reversed(keys):
        k = np.asarray(key)[order]
        lo, hi = int(k.min()), int(k.max())
        if hi - lo >= 1 << (63 - bits):  # too wide to carry an index: numpy's own stable sort
            order = order[np.argsort(k, kind="stable")]
            continue
        packed = (k.astype(np.int64) - lo) << bits
        packed |= np.arange(n, dtype=np.int64)
        packed.sort()
        order = order[packed & ((1 << bits) - 1)]
    return order


def groups(*keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first (g,) int64, inverse (n,) int64)`` of the ``(n,)`` integer keys taken
    together: groups numbered in the order of their keys (as ``np.unique``), ``first`` the
    index of each group's first member, ``inverse`` each member's group."""
    n = len(keys[0])
    bits = max(1, (n - 1).bit_length())
    one = _mixed_radix(keys, 63 - bits) if n else None
    if one is not None:  # one sort of the keys as one number, each carrying its index
        packed = (one << bits) | np.arange(n, dtype=np.int64)
        packed.sort()
        order, ordered = packed & ((1 << bits) - 1), packed >> bits
        new = np.empty(n, dtype=bool)
        new[:1] = True
        np.not_equal(ordered[1:], ordered[:-1], out=new[1:])
    else:
        order = stable_order(*keys)
        new = np.zeros(n, dtype=bool)
        new[:1] = True
        for key in keys:
            k = np.asarray(key)[order]
            new[1:] |= k[1:] != k[:-1]
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return order[new], inverse


def _mixed_radix(keys: tuple[np.ndarray, ...], room: int) -> np.ndarray | None:
    """The keys as one int64 number each, ordered as the keys are (``keys[0]`` most
    significant), or None when their ranges need more than ``room`` bits."""
    spans = []
    for key in keys:
        lo, hi = int(np.min(key)), int(np.max(key))
        spans.append((lo, hi - lo + 1))
    total = 1
    for _, span in spans:
        total *= span
    if total >= 1 << room:
        return None
    out = np.zeros(len(keys[0]), dtype=np.int64)
    for key, (lo, span) in zip(keys, spans, strict=True):
        out *= span
        out += np.asarray(key).astype(np.int64) - lo
    return out


def group_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)`` as :func:`groups` of the ``(n, d)`` rows, equal where their
    values are (-0.0 equals 0.0; NaN rows by their bits), numbered in the order of their
    first row (``first`` ascending).

    One pass through a hash table of the rows' bits, compiled (``native/grouping.cpp``):
    linear time, where sorting the rows is n log n."""
    rows = np.ascontiguousarray(rows)
    if rows.ndim != 2:
        raise ValueError(f"group_rows: expected (n, d) rows, got shape {rows.shape}")
    if rows.dtype.kind == "f":
        rows = np.ascontiguousarray(rows, dtype=np.float64) + 0.0  # -0.0 is 0.0
    elif rows.dtype != np.int64:
        rows = rows.astype(np.int64)
    return _native.group_rows(rows.view(np.uint64))


def unique_inverse(values: np.ndarray, n: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(values, return_inverse=True)`` of non-negative int ``values`` (indices
    below ``n``, by default their maximum + 1), the inverse flat: ``(used (u,) int64
    ascending, inverse (values.size,) int64)``, with ``used[inverse] == values.ravel()``.

    A mask and a running count, linear in ``n`` and the values, where np.unique sorts the
    values (the unwrap's chart vertices: several times a bake, 250,000 corners on a CAD
    part)."""
    flat = np.asarray(values, dtype=np.int64).reshape(-1)
    if n is None:
        n = int(flat.max()) + 1 if len(flat) else 0
    if len(flat) and (flat.min() < 0 or flat.max() >= n):
        raise ValueError(f"unique_inverse: values outside [0, {n})")
    mask = np.zeros(n, dtype=bool)
    mask[flat] = True
    rank = np.cumsum(mask, dtype=np.int64) - 1
    return np.flatnonzero(mask), rank[flat]
