"""A small PLY reader: positions, per-vertex texture coordinates, polygons and triangle strips.

Written for the bake rather than left to trimesh because trimesh 4 reads neither
``element tristrips`` (a scanner's usual output: one list of vertex indices, ``-1`` between
strips) nor a binary file whose faces have different corner counts (triangles beside
quads). Faces are split into triangle fans (a quad, an n-gon); strips into triangles of
alternating winding, the stitching triangles (two corners the same) left out. Colours,
normals and other properties are skipped. Faces with texture coordinates of their own
(a ``texcoord`` list) are left to trimesh, which splits the vertices by them:
:func:`read_ply` then returns None.
"""

from __future__ import annotations

import numpy as np

_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_UV_NAMES = (("texture_u", "texture_v"), ("u", "v"), ("s", "t"), ("texture_s", "texture_t"))
_INDEX_NAMES = ("vertex_indices", "vertex_index")


def read_ply(data: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | None:
    """``(vertices (n, 3), faces (m, 3) int64, uv (n, 2) or None)`` of PLY bytes, or None
    for a file this reader leaves to trimesh (faces with texture coordinates of their own).
    Raises ValueError on a malformed file; indices are not range-checked
    here (the caller does, naming the file)."""
    fmt, elements, body = _header(data)
    if any(name == "texcoord" for _, _, props in elements for name, _ in props):
        return None
    read = _ascii_elements if fmt == "ascii" else _binary_elements
    values = read(body, elements, "<" if fmt == "binary_little_endian" else ">")
    vertex = values.get("vertex", {})
    if not all(k in vertex for k in "xyz"):  # no vertices: no faces (the caller says so)
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), None
    vertices = np.column_stack([vertex[k] for k in "xyz"]).astype(np.float64)
    uv = next((np.column_stack([vertex[a], vertex[b]]).astype(np.float64) for a, b in _UV_NAMES if a in vertex and b in vertex), None)
    triangles = [np.zeros((0, 3), dtype=np.int64)]
    for name, rows in values.items():
        lists = next((rows[k] for k in _INDEX_NAMES if k in rows), None)
        if lists is None or name == "vertex":
            continue
        triangles.append(_strips(lists) if name == "tristrips" else _fans(lists))
    return vertices, np.concatenate(triangles), uv


def _header(data: bytes) -> tuple[str, list, bytes]:
    """``(format, [(element, count, [(property, type)])], the bytes after the header)``; a
    list property's type is ``("list", count type, item type)``."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError("no PLY header")
    newline = data.find(b"\n", end)
    body = data[newline + 1:] if newline >= 0 else b""
    fmt, elements = "", []  # type: tuple[str, list[tuple[str, int, list]]]
    for line in data[:end].decode("ascii", errors="replace").splitlines()[1:]:
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and words[1] == "list":
            elements[-1][2].append((words[4], ("list", _TYPES[words[2]], _TYPES[words[3]])))
        elif words[0] == "property" and elements:
            elements[-1][2].append((words[2], _TYPES[words[1]]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"unknown PLY format {fmt!r}")
    if any(count < 0 for _, count, _ in elements):
        raise ValueError("a negative element count")
    return fmt, elements, body


def _ascii_elements(body: bytes, elements: list, _order: str) -> dict[str, dict]:
    """Each element's properties (arrays; a list property: a list of arrays) from ASCII rows."""
    numbers = np.array(body.split(), dtype=np.float64)  # integers up to 2**53 exactly
    out: dict[str, dict] = {}
    at = 0
    for name, count, props in elements:
        if all(not isinstance(t, tuple) for _, t in props):
            block = numbers[at:at + count * len(props)].reshape(count, len(props))
            out[name] = {p: block[:, i].astype(t) for i, (p, t) in enumerate(props)}
            at += count * len(props)
            continue
        same = _same_lengths_ascii(numbers, at, count, props)
        if same is not None:
            out[name], at = same[0], at + same[1]
            continue
        rows: dict[str, list] = {p: [] for p, _ in props}
        for _ in range(count):
            for p, t in props:
                n = int(numbers[at]) if isinstance(t, tuple) else 0
                rows[p].append(numbers[at + 1:at + 1 + n].astype(np.int64) if isinstance(t, tuple) else numbers[at])
                at += n + 1
        if at > len(numbers):
            raise ValueError(f"the file ends inside element {name!r}")
        out[name] = rows
    return out


def _binary_elements(body: bytes, elements: list, order: str) -> dict[str, dict]:
    """Each element's properties from binary rows: fixed rows read at once, rows with lists
    one at a time."""
    out: dict[str, dict] = {}
    at = 0
    for name, count, props in elements:
        if all(not isinstance(t, tuple) for _, t in props):
            dtype = np.dtype([(p, order + t) for p, t in props])
            block = np.frombuffer(body, dtype=dtype, count=count, offset=at)
            out[name] = {p: block[p].astype(t) for p, t in props}
            at += count * dtype.itemsize
            continue
        same = _same_lengths_binary(body, at, count, props, order)
        if same is not None:
            out[name], at = same[0], at + same[1]
            continue
        rows: dict[str, list] = {p: [] for p, _ in props}
        for _ in range(count):
            for p, t in props:
                if isinstance(t, tuple):
                    n = int(np.frombuffer(body, dtype=order + t[1], count=1, offset=at)[0])
                    at += np.dtype(t[1]).itemsize
                    rows[p].append(np.frombuffer(body, dtype=order + t[2], count=n, offset=at).astype(np.int64))
                    at += n * np.dtype(t[2]).itemsize
                else:
                    rows[p].append(np.frombuffer(body, dtype=order + t, count=1, offset=at)[0])
                    at += np.dtype(t).itemsize
        out[name] = rows
    return out


def _one_list(props: list) -> int | None:
    """The position of an element's only list property, or None (none, or several)."""
    lists = [i for i, (_, t) in enumerate(props) if isinstance(t, tuple)]
    return lists[0] if len(lists) == 1 else None


def _same_lengths_ascii(numbers: np.ndarray, at: int, count: int, props: list) -> tuple[dict, int] | None:
    """``(properties, numbers read)`` of an element of one list property (beside scalars)
    whose lists all have one length, read at once (the list ``(count, n)`` int64), else None."""
    i = _one_list(props)
    if i is None or count == 0 or at + i >= len(numbers):
        return None
    n = int(numbers[at + i])
    width = len(props) + n
    block = numbers[at:at + count * width]
    if n < 0 or len(block) != count * width:
        return None
    block = block.reshape(count, width)
    if not (block[:, i] == n).all():
        return None
    columns = [*range(i), *range(i + 1 + n, width)]
    out = {p: block[:, c].astype(t) for (p, t), c in zip([q for j, q in enumerate(props) if j != i], columns, strict=True)}
    out[props[i][0]] = block[:, i + 1:i + 1 + n].astype(np.int64)
    return out, count * width


def _same_lengths_binary(body: bytes, at: int, count: int, props: list, order: str) -> tuple[dict, int] | None:
    """``(properties, bytes read)`` of an element of one list property (beside scalars)
    whose lists all have one length, read at once (the list ``(count, n)`` int64), else None."""
    i = _one_list(props)
    if i is None or count == 0:
        return None
    before = sum(np.dtype(t).itemsize for _, t in props[:i])
    _, size_type, item_type = props[i][1]
    if at + before + np.dtype(size_type).itemsize > len(body):
        return None
    n = int(np.frombuffer(body, dtype=order + size_type, count=1, offset=at + before)[0])
    fields = [(f"p{j}", order + t) for j, (_, t) in enumerate(props) if j != i]
    dtype = np.dtype([*fields[:i], ("n", order + size_type), ("i", order + item_type, (max(n, 0),)), *fields[i:]])
    if n < 0 or at + count * dtype.itemsize > len(body):
        return None
    block = np.frombuffer(body, dtype=dtype, count=count, offset=at)
    if not (block["n"] == n).all():
        return None
    out = {p: block[f"p{j}"].astype(t) for j, (p, t) in enumerate(props) if j != i}
    out[props[i][0]] = block["i"].astype(np.int64).reshape(count, n)
    return out, count * dtype.itemsize


def _fans(lists) -> np.ndarray:
    """``(t, 3)`` int64 triangle fans of polygons (a ``(count, n)`` array, or a list of
    arrays of corner indices; fewer than three corners: no triangle)."""
    if isinstance(lists, np.ndarray):  # polygons of one size: fans at once
        k = np.arange(1, lists.shape[1] - 1)
        return np.stack([np.repeat(lists[:, :1], len(k), axis=1), lists[:, k], lists[:, k + 1]], axis=2).reshape(-1, 3)
    polygons = list(lists)
    sizes = np.array([len(p) for p in polygons], dtype=np.int64)
    if not len(polygons) or sizes.max(initial=0) < 3:
        return np.zeros((0, 3), dtype=np.int64)
    corners = np.concatenate([np.asarray(p, dtype=np.int64) for p in polygons])
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    fans = np.maximum(sizes - 2, 0)
    first = np.repeat(start, fans)
    k = np.arange(fans.sum()) - np.repeat(np.cumsum(fans) - fans, fans) + 1  # 1 .. n-2 per polygon
    return np.column_stack([corners[first], corners[first + k], corners[first + k + 1]])


def _strips(lists) -> np.ndarray:
    """``(t, 3)`` int64 triangles of triangle strips (lists of vertex indices, ``-1`` between
    strips): triangle ``j`` of a strip is its corners ``j, j+1, j+2``, every other one
    turned so that all face one way; those with two corners the same (stitches) left out."""
    s = np.concatenate([np.append(np.asarray(x, dtype=np.int64), -1) for x in lists] or [np.zeros(0, np.int64)])
    if len(s) < 3:
        return np.zeros((0, 3), dtype=np.int64)
    restart = s < 0
    begin = np.maximum.accumulate(np.where(restart, np.arange(len(s)) + 1, 0))  # each corner's strip start
    j = np.arange(2, len(s))
    ok = ~restart[j] & ~restart[j - 1] & ~restart[j - 2] & (j - begin[j] >= 2)
    j = j[ok]
    odd = (j - begin[j]) % 2 == 1
    a, b, c = s[j - 2], s[j - 1], s[j]
    tri = np.column_stack([np.where(odd, b, a), np.where(odd, a, b), c])
    return tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
