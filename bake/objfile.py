"""A small, strict Wavefront OBJ reader: positions, texture coordinates and faces.

Written for the bake rather than taken from trimesh because relative (negative)
indices must count back from the elements defined *so far* (trimesh 5.2 counts from the
end of the file, which is wrong when ``v`` and ``f`` lines interleave), every index must
be range-checked, and it is several times faster on large files. Polygons are split
into triangle fans. Materials, normals, groups and smoothing are not needed by a bake
and are skipped; ``mtllib`` names and the texture maps of the MTL files are checked by
the caller through ``check_reference``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import MeshError


def read_obj(data: bytes, path: Path, check_reference) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Parse OBJ bytes into ``(vertices (n, 3) float64, faces (m, 3) int64, uv)``.

    Vertices are one per distinct (position, texture coordinate) pair used by a face
    corner, so UV seams survive; ``uv`` is ``(n, 2)`` float64, or None when some face
    corner has no texture coordinate. ``check_reference(name, what)`` is called for each
    ``mtllib`` file name.

    The lines are sorted by kind at once and each kind's numbers converted in one call
    (``_numbers``; rows of other lengths take a line at a time).
    """
    where = str(path)
    lines = data.decode("utf-8", errors="replace").replace("\t", " ").splitlines()
    head = np.array([line[:2] for line in lines], dtype="U2")
    if np.char.startswith(head, " ").any():  # indented lines
        lines = [line.lstrip() for line in lines]
        head = np.array([line[:2] for line in lines], dtype="U2")
    v_at, vt_at, f_at = (np.flatnonzero(head == key) for key in ("v ", "vt", "f "))
    for i in np.flatnonzero(head == "mt"):
        parts = lines[i].split()
        if parts[0] == "mtllib":
            for name in parts[1:]:
                check_reference(name, "mtllib")
    vt_at = vt_at[[lines[i][2:3] in ("", " ") for i in vt_at]]  # "vt", not "vtx"
    v = _numbers(lines, v_at, 3, where, "every 'v' line needs x, y and z")
    vt = _numbers(lines, vt_at, 2, where, None) if len(vt_at) else np.zeros((0, 2))
    if not len(f_at):
        return v, np.zeros((0, 3), dtype=np.int64), None
    corners = " ".join([lines[i][2:] for i in f_at]).split()
    sizes = np.array([len(lines[i].split()) - 1 for i in f_at])
    if (sizes < 3).any():
        raise MeshError(where, f"line {int(f_at[np.argmax(sizes < 3)]) + 1}: a face needs at least 3 corners")
    # per face: positions and texture coordinates defined before its line, and its line number
    counts = np.stack([np.cumsum(head == "v ")[f_at], np.searchsorted(vt_at, f_at), f_at + 1], axis=1)

    vi, ti = _corner_indices(corners, where)
    seen = np.repeat(counts, sizes, axis=0)  # per corner
    vi = _absolute(vi, seen[:, 0], len(v), seen[:, 2], "vertex", where)
    has_uv = bool((ti != 0).all())
    uv_index = _absolute(ti, seen[:, 1], len(vt), seen[:, 2], "texture coordinate", where) if has_uv else None

    # Fan-triangulate polygons: corner k of a polygon starting at s gives (s, s+k, s+k+1).
    starts = np.repeat(np.cumsum(sizes) - sizes, sizes - 2)
    k = _fan_offsets(sizes)
    tri_corners = np.stack([starts, starts + k, starts + k + 1], axis=1)

    # One vertex per distinct (position, texcoord) pair, in order of first use.
    pair = vi if uv_index is None else vi * (len(vt) + 1) + uv_index
    unique, first, inverse = np.unique(pair, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    faces = rank[inverse.ravel()][tri_corners]
    used = first[order]
    return v[vi[used]], faces, None if uv_index is None else vt[uv_index[used]]


def _numbers(lines: list[str], at: np.ndarray, columns: int, where: str, short: str | None) -> np.ndarray:
    """``(len(at), columns)`` float64: the first ``columns`` numbers after the keyword of
    each line ``lines[i]`` for ``i`` in ``at``; a line with fewer raises ``MeshError`` with
    the words ``short``, or, with ``short`` None, takes zeros for the missing ones."""
    try:
        if all(len(lines[i].split()) == columns + 1 for i in at):  # every line alike: all at once
            return np.array(" ".join([lines[i][2:] for i in at]).split(), dtype=np.float64).reshape(-1, columns)
        rows = [lines[i].split()[1 : columns + 1] for i in at]
        if short is None:
            rows = [(r + ["0"] * columns)[:columns] for r in rows]
        elif any(len(r) < columns for r in rows):
            raise MeshError(where, short)
        return np.array(rows, dtype=np.float64).reshape(-1, columns)
    except ValueError as exc:
        raise MeshError(where, f"bad coordinate: {exc}") from None


def _corner_indices(corners: list[str], where: str) -> tuple[np.ndarray, np.ndarray]:
    """Position and texcoord indices (0 where absent) of "v", "v/vt", "v//vn", "v/vt/vn".

    Files write every corner alike: then the whole list is converted at once.
    """
    joined = " ".join(corners)
    slashes = corners[0].count("/")
    double = "//" in corners[0]
    if joined.count("/") == slashes * len(corners) and joined.count("//") == (len(corners) if double else 0):
        columns = 1 if slashes == 0 else (2 if slashes == 1 or double else 3)
        try:  # numpy's C parser: 6x faster than int() on each field
            flat = np.fromstring(joined.replace("//", " ").replace("/", " "), dtype=np.int64, sep=" ")
        except ValueError:  # a field that is not a whole number: the slow way names it
            flat = None
        if flat is not None and flat.size == columns * len(corners) and (flat.size == 0 or np.abs(flat).max() < 2**62):
            flat = flat.reshape(-1, columns)
            has_vt = columns == 3 or (columns == 2 and not double)
            return flat[:, 0], flat[:, 1] if has_vt else np.zeros(len(flat), dtype=np.int64)
    try:
        fields = [c.split("/") for c in corners]
        vi = np.array([f[0] for f in fields], dtype=np.int64)
        ti = np.array([int(f[1]) if len(f) > 1 and f[1] else 0 for f in fields], dtype=np.int64)
    except (ValueError, OverflowError):
        bad = next((c for c in corners if not _is_index(c)), corners[0])
        raise MeshError(where, f"bad face index {bad!r}") from None
    return vi, ti


def _is_index(corner: str) -> bool:
    """A corner whose fields are whole numbers within int64, the first one present."""
    fields = corner.split("/")
    try:
        return bool(fields[0]) and all(abs(int(x)) < 2**62 for x in fields if x)
    except ValueError:
        return False


def _fan_offsets(sizes: np.ndarray) -> np.ndarray:
    """For polygons of ``sizes`` corners: 1, 2, ..., n - 2 for each polygon, concatenated."""
    n_tris = sizes - 2
    total = int(n_tris.sum())
    ends = np.cumsum(n_tris)
    return np.arange(total) - np.repeat(ends - n_tris, n_tris) + 1


def _absolute(index, defined, total, line, what, where) -> np.ndarray:
    """0-based indices from 1-based or negative OBJ indices, checked against the file.

    A negative index counts back from the ``defined`` elements before its line.
    """
    out = np.where(index < 0, defined + index, index - 1)
    bad = (index == 0) | (out < 0) | (out >= total)
    if bad.any():
        i = int(np.argmax(bad))
        raise MeshError(where, f"line {int(line[i])}: {what} index {int(index[i])} out of range ({total} defined)")
    return out
