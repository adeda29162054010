"""A small, strict Wavefront OBJ reader: positions, texture coordinates, faces, and each
face's group and material.

Written for the bake rather than taken from trimesh because relative (negative)
indices must count back from the elements defined *so far* (trimesh 5.2 counts from the
end of the file, which is wrong when ``v`` and ``f`` lines interleave), every index must
be range-checked, and it is several times faster on large files. Polygons are split
into triangle fans. Each face has the part its last ``g`` or ``o`` line names and the
material its last ``usemtl`` names (``default`` before any); faces with texture
coordinates keep them where others have none. Normals and smoothing are not needed by a
bake and are skipped; ``mtllib`` names and the texture maps of the MTL files are checked
by the caller through ``check_reference``.

Two readers, one result. ``_read_fast`` reads the bytes in bulk with numpy: a table of
line starts sorts the lines by kind, each kind's lines are cut out in runs of consecutive
lines, their numbers are converted in one call each (plain decimals as integers divided
by a power of ten, which rounds exactly as float() does) and the indices are checked at
once; what each face's line follows is counted only when an index is negative. It gives
up (returns None) wherever ``_read_lines``, the reader of one line at a time, might read
differently: whitespace other than spaces, tabs and line ends (str.split() and
str.splitlines() break at it), a field that does not convert at once, corners not all
written alike, and every error, so that the messages are that reader's.
"""

from __future__ import annotations

import mmap
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import _native
from ..errors import MeshError

# Whitespace other than space, tab, CR and LF (the rest of what str.isspace() accepts):
# str.split() and str.splitlines() break at these, bytes do not.
_ODD_SPACE = "\v\f\x1c\x1d\x1e\x1f\x85\xa0\u1680" + "".join(map(chr, range(0x2000, 0x200B))) + "\u2028\u2029\u202f\u205f\u3000"
_ODD_SPACE_ASCII = [c.encode() for c in _ODD_SPACE if c.isascii()]
_ODD_SPACE_UTF8 = {c.encode() for c in _ODD_SPACE if not c.isascii()}  # 2 bytes from \xc2, 3 from \xe1-\xe3
_FLOAT_CHARS = b"0123456789+-.eE \n"  # all a line of plain decimal numbers has
_INDEX_CHARS = b"0123456789+-/ \n"
_SLASH_TO_SPACE = bytes.maketrans(b"/", b" ")
_OTHER, _V, _VT, _F, _MT, _INDENTED, _US, _GROUP = range(8)  # line kinds
DEFAULT = "default"  # the part and the material of faces before any g/o or usemtl line


class ObjMesh(NamedTuple):
    """What :func:`read_obj` reads.

    ``vertices`` (n, 3) float64, ``faces`` (m, 3) int64; ``uv`` (n, 2) float64 (NaN on the
    vertices of faces without texture coordinates) or None when no face has any;
    ``has_uv`` (m,) bool when only some faces have them, else None; ``part`` and
    ``material`` (m,) int64, each face's index into ``part_names`` (its ``g``/``o`` line's
    name) and ``material_names`` (its ``usemtl`` line's), both in order of first use.
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None
    has_uv: np.ndarray | None
    part: np.ndarray
    part_names: list[str]
    material: np.ndarray
    material_names: list[str]


def read_obj(data: bytes | mmap.mmap, path: Path, check_reference) -> ObjMesh:
    """Parse OBJ bytes (or a mapped file) into an :class:`ObjMesh`.

    Vertices are one per distinct (position, texture coordinate) pair used by a face
    corner, so UV seams survive; a face whose corners do not all have a texture coordinate
    has none (its vertices' ``uv`` rows are NaN). ``check_reference(name, what)`` is called
    for each ``mtllib`` file name.

    Read in one compiled pass (``native/objfile.cpp``) where it takes the file (plain
    ASCII, plain decimals, corners all written alike: what both readers here read alike),
    else in bulk (``_read_fast``) when that reader takes it, else a line at a time
    (``_read_lines``), which also raises every ``MeshError``.
    """
    view = np.frombuffer(data, dtype=np.uint8)
    try:
        compiled = _native.read_obj(view)
    finally:
        del view  # a mapped file can be closed only once no view holds it
    if compiled is not None:
        names, vertices, faces, uv, marks = compiled
        for name in names:
            check_reference(name, "mtllib")
        return ObjMesh(vertices, faces, uv, None, *_marked(marks, len(faces)))
    data = bytes(data)  # the readers here take bytes (a mapped file is copied only for them)
    fast = _read_fast(data)
    if fast is None:
        return _read_lines(data, str(path), check_reference)
    mtllibs, mesh = fast
    for name in mtllibs:
        check_reference(name, "mtllib")
    return mesh


def _read_fast(data: bytes) -> tuple[list[str], ObjMesh] | None:
    """``(mtllib names, mesh)`` as ``_read_lines`` gives them, or None."""
    if _odd_space(data):
        return None
    if b"\r" in data:  # CRLF or CR alone ends a line, as in str.splitlines()
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    if b"\t" in data:
        data = data.replace(b"\t", b" ")
    text = b"\n" + data if not data or data.endswith(b"\n") else b"\n" + data + b"\n"
    starts, ends, kind = _line_kinds(text)
    if (kind == _INDENTED).any():  # _read_lines then strips every line
        text = re.sub(rb"\n +", b"\n", text)
        starts, ends, kind = _line_kinds(text)

    words = {int(i): text[starts[i] : ends[i]].decode("utf-8", errors="replace").split()
             for i in np.flatnonzero((kind == _MT) | (kind == _US) | (kind == _GROUP))}
    mtllibs = [name for i in np.flatnonzero(kind == _MT).tolist() if words[i][0] == "mtllib" for name in words[i][1:]]
    v_lines, vt_lines, f_lines = (np.flatnonzero(kind == k) for k in (_V, _VT, _F))
    v = _floats(_cut(text, starts, ends, v_lines), len(v_lines), b"v", 3, pad=False)
    vt = _floats(_cut(text, starts, ends, vt_lines), len(vt_lines), b"vt", 2, pad=True)
    if v is None or vt is None:
        return None
    if not len(f_lines):
        return mtllibs, _no_faces(v)
    corners = _corners(_cut(text, starts, ends, f_lines), len(f_lines))
    if corners is None:
        return None
    sizes, vi, ti = corners
    has_uv = bool((ti != 0).all())
    defined_v: np.ndarray | None = None  # per corner, the elements its line follows: for relative indices
    defined_vt: np.ndarray | None = None
    if (vi < 0).any() or (has_uv and (ti < 0).any()):
        defined_v = np.repeat(np.cumsum(kind == _V)[f_lines], sizes)
        defined_vt = np.repeat(np.searchsorted(vt_lines, f_lines), sizes)
    position = _resolve(vi, defined_v, len(v))
    texcoord = _resolve(ti, defined_vt, len(vt)) if has_uv else None
    if position is None or (has_uv and texcoord is None):
        return None
    vertices, faces, uv = _mesh(v, vt, position, texcoord, sizes)
    return mtllibs, ObjMesh(vertices, faces, uv, None, *_groups(f_lines, sizes, words))


def _no_faces(v: np.ndarray) -> ObjMesh:
    """The mesh of a file without faces (the caller rejects it, naming the file)."""
    none = np.zeros(0, dtype=np.int64)
    return ObjMesh(v, np.zeros((0, 3), dtype=np.int64), None, None, none, [DEFAULT], none, [DEFAULT])


def _groups(f_lines: np.ndarray, sizes: np.ndarray, words: dict[int, list[str]]) -> tuple[np.ndarray, list[str], np.ndarray, list[str]]:
    """``(part, part_names, material, material_names)`` of the triangles of the face lines
    ``f_lines`` (``sizes`` corners each): the ``g``/``o`` and ``usemtl`` lines (``words``:
    line number -> its words) that last precede each."""
    marks = sorted(words)
    groups = [i for i in marks if words[i][0] in ("g", "o")]
    materials = [i for i in marks if words[i][0] == "usemtl"]
    part, part_names = _labels(f_lines, groups, [" ".join(words[i][1:]) for i in groups], sizes)
    material, material_names = _labels(f_lines, materials, [" ".join(words[i][1:]) for i in materials], sizes)
    return part, part_names, material, material_names


def _marked(marks: list[tuple[int, str, int]], m: int) -> tuple[np.ndarray, list[str], np.ndarray, list[str]]:
    """``(part, part_names, material, material_names)`` of ``m`` triangles from the compiled
    reader's marks (``(0: g/o or 1: usemtl, name, triangles before it)``), as
    :func:`_groups` labels face lines: triangle ``t`` as the line ``2 t + 1`` of size 3, a
    mark before it as the line ``2 * before``."""
    if not m:  # as _no_faces
        none = np.zeros(0, dtype=np.int64)
        return none, [DEFAULT], none, [DEFAULT]
    out: list = []
    for kind in (0, 1):
        at = [before for k, _, before in marks if k == kind]
        names = [name for k, name, _ in marks if k == kind]
        if not at or at[-1] == 0:  # none, or all before the first face (a file of one object): one name, no sort
            out += [np.zeros(m, dtype=np.int64), [names[-1] or DEFAULT if names else DEFAULT]]
        else:
            lines, sizes = 2 * np.arange(m, dtype=np.int64) + 1, np.full(m, 3, dtype=np.int64)
            out += _labels(lines, [2 * a for a in at], names, sizes)
    return out[0], out[1], out[2], out[3]


def _labels(f_lines: np.ndarray, marks: list[int], names: list[str], sizes: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Each triangle's index into the names of the lines ``marks`` (line numbers, sorted;
    ``names``: theirs, ``DEFAULT`` where empty) that last precede its face line (``DEFAULT``
    before the first), numbered in order of first use; and those names."""
    ids: dict[str, int] = {}
    code = np.array([ids.setdefault(name or DEFAULT, len(ids)) for name in [DEFAULT, *names]], dtype=np.int64)
    label = code[np.searchsorted(np.asarray(marks, dtype=np.int64), f_lines)]  # marks before each line: 0 is DEFAULT
    used, first, inverse = np.unique(label, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(used), dtype=np.int64)
    rank[order] = np.arange(len(used))
    known = list(ids)
    return np.repeat(rank[inverse.ravel()], sizes - 2), [known[used[k]] for k in order]


def _odd_space(data: bytes) -> bool:
    """Whether ``data`` decoded as UTF-8 has a character of ``_ODD_SPACE``. Other
    characters above ASCII only matter to the bytes path in ``mtllib`` names (decoded
    there) and number fields (not taken)."""
    if any(c in data for c in _ODD_SPACE_ASCII):
        return True
    if data.isascii():
        return False
    a = np.frombuffer(data + b"\0\0", dtype=np.uint8)
    at = np.flatnonzero((a == 0xC2) | ((a >= 0xE1) & (a <= 0xE3)))  # where those start
    two = a[at].astype(np.int32) << 8 | a[at + 1]
    three = two << 8 | a[at + 2]  # a complete sequence decodes as itself, whatever precedes it
    wanted = [int.from_bytes(c, "big") for c in _ODD_SPACE_UTF8]
    return bool(np.isin(two, wanted).any() or np.isin(three, wanted).any())


def _line_kinds(text: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each line's first byte and the newline after it (offsets into ``text``, which starts
    and ends with a newline), and its kind by its first bytes, as ``_read_lines`` sorts them:
    ``_V`` "v ", ``_VT`` "vt" alone or before a space, ``_F`` "f ", ``_MT`` "mt", ``_US``
    "us", ``_GROUP`` "g" or "o" alone or before a space, ``_INDENTED`` a space, ``_OTHER``."""
    a = np.frombuffer(text, dtype=np.uint8)
    breaks = np.flatnonzero(a == 10)
    starts, ends = breaks[:-1] + 1, breaks[1:]
    c0, c1, c2 = (a[np.minimum(starts + k, len(a) - 1)] for k in range(3))  # c1, c2 only where the line is long enough
    kind = np.zeros(len(starts), dtype=np.int8)
    kind[(c0 == ord("v")) & (c1 == ord(" "))] = _V
    kind[(c0 == ord("v")) & (c1 == ord("t")) & ((c2 == ord(" ")) | (c2 == 10))] = _VT
    kind[(c0 == ord("f")) & (c1 == ord(" "))] = _F
    kind[(c0 == ord("m")) & (c1 == ord("t"))] = _MT
    kind[(c0 == ord("u")) & (c1 == ord("s"))] = _US
    kind[((c0 == ord("g")) | (c0 == ord("o"))) & ((c1 == ord(" ")) | (c1 == 10))] = _GROUP
    kind[c0 == ord(" ")] = _INDENTED
    return starts, ends, kind


def _cut(text: bytes, starts: np.ndarray, ends: np.ndarray, lines: np.ndarray) -> bytes:
    """The ``lines`` (sorted line numbers) as one bytes with a newline before and after
    each: runs of consecutive lines are sliced whole."""
    if not len(lines):
        return b"\n"
    cut = np.flatnonzero(np.diff(lines) != 1) + 1
    first, last = lines[np.r_[0, cut]], lines[np.r_[cut - 1, len(lines) - 1]]
    return b"\n" + b"".join([text[a:b] for a, b in zip(starts[first].tolist(), (ends[last] + 1).tolist(), strict=True)])


def _blank(content: bytes, lines: int, keyword: bytes, allowed: bytes) -> bytes | None:
    """``content`` (``lines`` lines, each starting with ``keyword``) with the keyword's
    letters turned into spaces; None when a byte is neither ``allowed`` nor one of those
    letters, or a letter occurs elsewhere than in the keywords."""
    if content.translate(None, allowed + keyword) or any(content.count(keyword[i : i + 1]) != lines for i in range(len(keyword))):
        return None
    return content.translate(bytes.maketrans(keyword, b" " * len(keyword)))


def _fields(content: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fields per line of ``content`` (a newline before and after each line, only spaces
    between fields), and where each field starts and ends."""
    a = np.frombuffer(content, dtype=np.uint8)
    solid = a > ord(" ")
    edges = np.flatnonzero(solid[1:] != solid[:-1]) + 1
    starts, ends = edges[::2], edges[1::2]
    return np.diff(np.searchsorted(starts, np.flatnonzero(a == 10))), starts, ends


def _floats(content: bytes, lines: int, keyword: bytes, columns: int, pad: bool) -> np.ndarray | None:
    """``(lines, columns)`` float64: the first ``columns`` numbers after the keyword on each
    line of ``content``, zeros for missing ones when ``pad``; None when a line is short
    (without ``pad``) or a field is not a decimal number that float() and numpy agree on."""
    blank = _blank(content, lines, keyword, _FLOAT_CHARS)  # "nan", "1_0", "0x1p3": float() alone decides
    if blank is None:
        return None
    counts, starts, ends = _fields(blank)
    if not lines:
        return np.zeros((0, columns))
    if not pad and counts.min() < columns:
        return None
    flat = None if b"e" in blank or b"E" in blank else _plain_decimals(blank, starts, ends)
    if flat is None:
        try:  # numpy's parser rounds as float() does and raises on a field it cannot take whole
            flat = np.fromstring(blank, dtype=np.float64, sep=" ")
        except ValueError:
            return None
        if flat.size != len(starts):  # also where there are no fields: numpy then gives [-1.0]
            return None
    if counts.min() == counts.max() >= columns:
        return np.ascontiguousarray(flat.reshape(-1, counts[0])[:, :columns])
    take = (np.cumsum(counts) - counts)[:, None] + np.arange(columns)
    have = np.arange(columns) < counts[:, None]
    return np.append(flat, 0.0)[np.where(have, take, flat.size)]


_POWERS_OF_TEN = np.array([float(10**k) for k in range(23)])  # all exact in float64


def _plain_decimals(content: bytes, starts: np.ndarray, ends: np.ndarray) -> np.ndarray | None:
    """float() of each field of ``content`` (``starts``, ``ends``: its fields), each a sign,
    digits and at most one ".", or None. The digits without the point are read as one
    integer (numpy's integer parser is much faster than its float parser) and divided by a
    power of ten: both are exact below 2**53 and 10**22, so the quotient is the correctly
    rounded value that float() gives."""
    if not len(starts):
        return np.zeros(0)
    a = np.frombuffer(content, dtype=np.uint8)
    points = np.flatnonzero(a == ord("."))
    field = np.searchsorted(starts, points, side="right") - 1
    if (np.diff(field) == 0).any() or ((ends - starts == 1) & (a[starts] == ord("."))).any():
        return None  # "1.2.3", or a field "." that would vanish
    digits = content.replace(b".", b"")
    d = np.frombuffer(digits, dtype=np.uint8)
    signs = np.flatnonzero((d == ord("-")) | (d == ord("+")))
    if len(signs) and ((d[signs + 1] - ord("0")) > 9).any():  # a sign alone parses as 0 ("-." too)
        return None
    try:  # now every field has a digit
        mantissa = np.fromstring(digits, dtype=np.int64, sep=" ")
    except ValueError:
        return None
    if mantissa.size != len(starts) or (mantissa > 2**53).any() or (mantissa < -(2**53)).any():
        return None  # too many digits for this exact path
    places = np.zeros(len(starts), dtype=np.int64)
    places[field] = ends[field] - points - 1
    if places.max() >= len(_POWERS_OF_TEN):
        return None
    value = np.abs(mantissa) / _POWERS_OF_TEN[places]
    return np.where(a[starts] == ord("-"), -value, value)  # "-0.0" is -0.0, as float() has it


def _corners(content: bytes, lines: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(sizes, vi, ti)`` from the face lines in ``content``: corners per face, and each
    corner's position and texcoord index as written (ti 0 where absent); None unless every
    corner has the form of the first and all convert at once, as in ``_corner_indices``."""
    blank = _blank(content, lines, b"f", _INDEX_CHARS)
    if blank is None:
        return None
    sizes, starts, ends = _fields(blank)
    if sizes.min() < 3:
        return None
    n = len(starts)
    first = blank[starts[0] : ends[0]]
    slashes, double = first.count(b"/"), b"//" in first
    if blank.count(b"/") != slashes * n or blank.count(b"//") != (n if double else 0):
        return None
    columns = 1 if slashes == 0 else (2 if slashes == 1 or double else 3)
    try:
        flat = np.fromstring(blank.translate(_SLASH_TO_SPACE), dtype=np.int64, sep=" ")
    except ValueError:
        return None
    if flat.size != columns * n:
        return None
    flat = flat.reshape(-1, columns)
    has_vt = columns == 3 or (columns == 2 and not double)
    return sizes, flat[:, 0], flat[:, 1] if has_vt else np.zeros(n, dtype=np.int64)


def _resolve(index: np.ndarray, defined: np.ndarray | None, total: int) -> np.ndarray | None:
    """0-based indices (``_absolute`` without the message), or None when one is out of range.
    ``defined`` is None when no index is negative."""
    out = index - 1 if defined is None else np.where(index < 0, defined + index, index - 1)
    if out.min() < 0 or out.max() >= total:
        return None
    return out


def _mesh(v, vt, vi, uv_index, sizes) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Fan triangles over the corners (``sizes`` per polygon) and one vertex per distinct
    (position ``vi``, texcoord ``uv_index``) pair, numbered in order of first use."""
    # Fan-triangulate polygons: corner k of a polygon starting at s gives (s, s+k, s+k+1).
    if sizes.min() == sizes.max() == 3:
        tri_corners = np.arange(3 * len(sizes)).reshape(-1, 3)
    else:
        starts = np.repeat(np.cumsum(sizes) - sizes, sizes - 2)
        k = _fan_offsets(sizes)
        tri_corners = np.stack([starts, starts + k, starts + k + 1], axis=1)

    # A key per corner, 0 <= key < size, equal where the pair is: the texcoord index alone
    # when each goes with one position (then a table replaces a sort), else pairs ranked.
    if uv_index is None:
        key, size = vi, len(v)
    else:
        position = np.full(len(vt), -1)
        position[uv_index] = vi
        if (position[uv_index] == vi).all():
            key, size = uv_index, len(vt)
        else:
            distinct, key = np.unique(vi * (len(vt) + 1) + uv_index, return_inverse=True)
            size = len(distinct)
    first_use = np.full(size, len(key))
    np.minimum.at(first_use, key, np.arange(len(key)))
    is_first = np.zeros(len(key), dtype=bool)
    is_first[first_use[first_use < len(key)]] = True
    number = np.cumsum(is_first) - 1  # at a first use: that vertex's number
    used = np.flatnonzero(is_first)
    faces = number[first_use[key]][tri_corners]
    return v[vi[used]], faces, None if uv_index is None else vt[uv_index[used]]


def _read_lines(data: bytes, where: str, check_reference) -> ObjMesh:
    """``read_obj`` a line at a time: every file, every error.

    The lines are sorted by kind at once and each kind's numbers converted in one call
    (``_numbers``; rows of other lengths take a line at a time).
    """
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
        return _no_faces(v)
    corners = " ".join([lines[i][2:] for i in f_at]).split()
    sizes = np.array([len(lines[i].split()) - 1 for i in f_at])
    if (sizes < 3).any():
        raise MeshError(where, f"line {int(f_at[np.argmax(sizes < 3)]) + 1}: a face needs at least 3 corners")
    # per face: positions and texture coordinates defined before its line, and its line number
    counts = np.stack([np.cumsum(head == "v ")[f_at], np.searchsorted(vt_at, f_at), f_at + 1], axis=1)

    vi, ti = _corner_indices(corners, where)
    seen = np.repeat(counts, sizes, axis=0)  # per corner
    vi = _absolute(vi, seen[:, 0], len(v), seen[:, 2], "vertex", where)
    textured = np.logical_and.reduceat(ti != 0, np.cumsum(sizes) - sizes)  # per polygon: every corner has a texcoord
    uv_index = None
    if textured.all():
        uv_index = _absolute(ti, seen[:, 1], len(vt), seen[:, 2], "texture coordinate", where)
    elif textured.any():  # the corners of faces without: a NaN row after the file's texcoords
        given = np.repeat(textured, sizes)
        uv_index = np.full(len(ti), len(vt), dtype=np.int64)
        uv_index[given] = _absolute(ti[given], seen[given, 1], len(vt), seen[given, 2], "texture coordinate", where)
        vt = np.vstack([vt, np.full((1, 2), np.nan)])
    vertices, faces, uv = _mesh(v, vt, vi, uv_index, sizes)
    has_uv = np.repeat(textured, sizes - 2) if textured.any() and not textured.all() else None
    words = {int(i): lines[i].split() for i in np.flatnonzero(np.isin(head, ("us", "g ", "o ", "g", "o")))}
    return ObjMesh(vertices, faces, uv, has_uv, *_groups(f_at, sizes, {i: w for i, w in words.items() if w}))


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
        try:  # numpy's C parser, not int() on each field
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
